"""dynaeval.core.deps: optional packages found once at import, imported in one place."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from dynaeval.core import deps
from dynaeval.core.deps import DEPENDENCIES, MissingDependency, available, load, missing

_BLOCKED = textwrap.dedent("""
    import importlib.abc, sys

    class Blocked(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] == "flip_evaluator":
                raise ImportError("blocked by the test")
            return None

    sys.meta_path.insert(0, Blocked())
    from dynaeval.core import deps
    print(deps.AVAILABLE["flip_evaluator"], deps.AVAILABLE["torch"])
    try:
        deps.load("flip_evaluator")
    except deps.MissingDependency as err:
        print(err.module, err.installed, err.install, isinstance(err, ImportError))
""")


def test_the_flags_are_found_at_import_without_importing_anything():
    """In an interpreter where flip_evaluator cannot be found, AVAILABLE says so from the start,
    torch is found but not imported, and load names the install line."""
    code = _BLOCKED + "print('torch' in sys.modules, 'lpips' in sys.modules)\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.split("\n")
    assert lines[0] == f"False {deps._found('torch')}"
    assert lines[1] == "flip_evaluator False pip install 'dynaeval[video]' True"
    assert lines[2] == "False False"


def test_every_flag_agrees_with_find_spec():
    """In a fresh interpreter (in this one, other tests change ``sys.path`` after the flags
    were found: setuptools puts its vendored tomli on it)."""
    code = ("import importlib.util\nfrom dynaeval.core import deps\n"
            "print([n for n in deps.DEPENDENCIES\n"
            "       if deps.AVAILABLE[n] != (importlib.util.find_spec(n) is not None)])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_a_module_blocked_in_sys_modules_is_missing(monkeypatch):
    monkeypatch.setitem(sys.modules, "jsonschema", None)
    assert missing("torch", "jsonschema") == (["jsonschema"] if deps.AVAILABLE["torch"]
                                              else ["torch", "jsonschema"])
    assert not available("jsonschema")
    with pytest.raises(MissingDependency) as err:
        load("jsonschema")
    assert err.value.install == "pip install jsonschema" and not err.value.installed
    assert "is not installed: pip install jsonschema" in str(err.value)


def test_an_installed_package_that_does_not_import_says_so(tmp_path, monkeypatch):
    """A package that is found but whose import fails (a broken install) is MissingDependency
    with installed=True and the cause chained, not the package's own exception."""
    pkg = tmp_path / "dynaeval_broken_dep"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("raise OSError('libfoo.so: cannot open shared object file')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(DEPENDENCIES, "dynaeval_broken_dep", deps.Dependency(
        "dynaeval_broken_dep", "broken-dep", "pip install --force-reinstall broken-dep", "a test"))
    monkeypatch.setitem(deps.AVAILABLE, "dynaeval_broken_dep", True)
    with pytest.raises(MissingDependency) as err:
        load("dynaeval_broken_dep")
    assert err.value.installed and isinstance(err.value.__cause__, OSError)
    assert str(err.value) == ("a test needs the broken-dep package, which is installed but does "
                              "not import (OSError: libfoo.so: cannot open shared object file): "
                              "pip install --force-reinstall broken-dep")


def test_a_missing_dependency_of_a_package_is_named(tmp_path, monkeypatch):
    """ultralytics installed without requests: the error's name is the absent dependency."""
    pkg = tmp_path / "dynaeval_needs_absent"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("import dynaeval_absent_module_xyz\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(deps.AVAILABLE, "dynaeval_needs_absent", True)
    with pytest.raises(MissingDependency) as err:
        load("dynaeval_needs_absent")
    assert err.value.installed and err.value.name == "dynaeval_absent_module_xyz"
    assert err.value.module == "dynaeval_needs_absent"


def test_a_default_metric_whose_package_is_absent_names_the_install_line_once(monkeypatch):
    """The registry adds the extra's install line only to an ImportError that has none: a
    MissingDependency carries its own (typed, not found in the message text)."""
    from dynaeval.metrics import flip

    monkeypatch.setitem(sys.modules, "flip_evaluator", None)
    with pytest.raises(MissingDependency) as err:
        flip._package()
    assert str(err.value).count("pip install") == 1
    assert "NVIDIA's flip-evaluator package, which is not installed" in str(err.value)


def test_a_torchvision_built_for_another_torch_names_the_mismatch_and_the_matching_install(
        monkeypatch):
    """Issue 43 item 5: with torch and torchvision builds that do not match ("operator
    torchvision::nms does not exist") the fix given was pip install 'dynaeval[lpips]', which
    cannot help: the mismatch and the matching install are named."""
    import importlib.metadata

    from dynaeval.core import deps

    versions = {"torch": "2.13.0", "torchvision": "0.29.1"}
    monkeypatch.setattr(importlib.metadata, "version", versions.__getitem__)
    err = deps.MissingDependency("lpips", installed=True,
                                 cause=RuntimeError("operator torchvision::nms does not exist"))
    assert "built for another torch: torchvision 0.29.1 beside torch 2.13.0" in str(err)
    assert err.install.startswith("pip install 'torchvision==0.28.*'")
    assert "dynaeval[lpips]" not in str(err)
    other = deps.MissingDependency("lpips", installed=True, cause=OSError("libc10.so: not found"))
    assert "dynaeval[lpips]" in other.install  # any other broken import keeps the extra's line
