"""The `dynaeval` wheel holds the toolkit only; the reference models are their own distribution.

The wheels are built for real (``pip wheel --no-deps --no-build-isolation``, about 2 s each) from a
copy of the files git tracks or would track, so a stale ``build/`` of the checkout cannot leak into
them.
"""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from setuptools import find_packages

from reference_models.common.paths import ENV, RepositoryNotFoundError, docs_dir, repo_root

ROOT = Path(__file__).resolve().parents[1]
REFERENCE_PROJECT = ROOT / "tools" / "reference-models"


def test_the_package_selection_keeps_only_dynaeval():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    everything = set(find_packages(where=ROOT))
    selected = set(find_packages(where=ROOT, include=find["include"], exclude=find.get("exclude", ())))
    # not vacuous: the tree holds the other packages, and the selection holds the toolkit's
    assert {"reference_models", "reference_models.scenes"} <= everything
    assert {"dynaeval", "dynaeval.metrics", "dynaeval.io"} <= selected
    assert all(p == "dynaeval" or p.startswith("dynaeval.") for p in selected), sorted(selected)


def _tracked_copy(dst: Path) -> Path:
    """The checkout's tracked and untracked-but-not-ignored files, copied to ``dst``."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout to know which files belong to the source tree")
    names = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                           cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    for name in filter(None, names):
        src = ROOT / name
        if src.is_file():  # deleted but not yet committed files are listed too
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / name)
    return dst


def _wheel_names(project: Path, out: Path) -> tuple[list[str], str]:
    """File names inside the wheel built from ``project``, and its METADATA."""
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    str(project), "-w", str(out)], check=True, capture_output=True)
    (wheel,) = out.glob("*.whl")
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        metadata = zf.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    return names, metadata


@pytest.fixture(scope="module")
def source_tree(tmp_path_factory) -> Path:
    return _tracked_copy(tmp_path_factory.mktemp("src"))


def test_the_dynaeval_wheel_holds_dynaeval_only(source_tree, tmp_path):
    assert (source_tree / "reference_models" / "__init__.py").is_file()  # present, to be left out
    assert (source_tree / "benchmarks").is_dir()
    names, _ = _wheel_names(source_tree, tmp_path)
    dist_info = re.compile(r"dynaeval-[^/]+\.dist-info/")
    outside = [n for n in names if not (n.startswith("dynaeval/") or dist_info.match(n))]
    assert outside == []
    for needed in ("dynaeval/__init__.py", "dynaeval/cli/__init__.py", "dynaeval/models/detector.onnx",
                   "dynaeval/data/sample/sample.json"):
        assert needed in names
    assert not any(n.startswith("dynaeval/bench") for n in names)  # the benchmark is benchmarks/


def test_the_reference_models_wheel_holds_reference_models_and_needs_torch(source_tree, tmp_path):
    names, metadata = _wheel_names(source_tree / "tools" / "reference-models", tmp_path)
    dist_info = re.compile(r"dynaeval_reference_models-[^/]+\.dist-info/")
    assert [n for n in names if not (n.startswith("reference_models/") or dist_info.match(n))] == []
    tracked = {p.relative_to(source_tree).as_posix() for p in (source_tree / "reference_models").rglob("*.py")}
    assert tracked and tracked <= set(names)
    requires = re.findall(r"^Requires-Dist: (\S+)", metadata, re.MULTILINE)
    assert "dynaeval[lpips]" in requires and any(r.startswith("torch") for r in requires)


def test_dynaeval_never_imports_reference_models_or_benchmarks():
    imported = []
    for path in sorted((ROOT / "dynaeval").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            mods = ([a.name for a in node.names] if isinstance(node, ast.Import)
                    else [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0
                    else [])
            imported += [(path.name, m) for m in mods if m.split(".")[0] in ("reference_models", "benchmarks")]
    assert imported == []
    assert any((ROOT / "dynaeval").rglob("*.py"))


def test_ci_runs_the_readme_test_command_which_installs_the_reference_models():
    readme = (ROOT / "README.md").read_text()
    commands = re.findall(r"^python3 -m venv .*$", readme, re.MULTILINE)
    test_command = next(c for c in commands if "pytest" in c)
    assert test_command in (ROOT / ".ci" / "run").read_text().splitlines()
    assert "-e ./tools/reference-models" in test_command and (REFERENCE_PROJECT / "pyproject.toml").is_file()


def test_the_readme_cpu_only_line_installs_the_torch_packages_of_the_lpips_extra():
    # issue 32: the CUDA build is most of a 6.4 GiB venv; the README's CPU-only line must fetch
    # every torch package the lpips extra needs from the CPU index, or pip takes it from PyPI
    import tomllib

    readme = (ROOT / "README.md").read_text()
    index = "--index-url https://download.pytorch.org/whl/cpu"
    (line,) = [c for c in readme.splitlines() if c.startswith("pip install ") and index in c]
    first, then = line.split(" && ")
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["lpips"]
    torch_family = {re.match(r"[a-z]+", r).group() for r in extra if r.startswith("torch")}
    assert set(first.removeprefix("pip install ").removesuffix(f" {index}").split()) == torch_family
    assert then == 'pip install -e ".[lpips]"'


def _fake_repo(root: Path, name: str = "dynaeval") -> Path:
    (root / "docs").mkdir(parents=True)
    (root / "pyproject.toml").write_text(f'[project]\nname = "{name}"\n')
    return root


def test_repo_root_is_found_from_the_current_directory_or_the_env_var(tmp_path, monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    assert repo_root() == ROOT  # this checkout, from here or from the module's own file
    clone = _fake_repo(tmp_path / "clone")
    (clone / "a" / "b").mkdir(parents=True)
    monkeypatch.chdir(clone / "a" / "b")
    assert repo_root() == clone and docs_dir() == clone / "docs"
    monkeypatch.setenv(ENV, str(ROOT))
    assert repo_root() == ROOT


def test_repo_root_refuses_what_is_not_the_dynaeval_repository(tmp_path, monkeypatch):
    other = _fake_repo(tmp_path / "other", name="dynaeval-reference-models")
    monkeypatch.setenv(ENV, str(other))
    with pytest.raises(RepositoryNotFoundError, match=f"{ENV}=.*not the dynaeval repository"):
        repo_root()
