"""The optional packages dynaeval can use: which are installed, found once at import, and the one
place that imports them.

``AVAILABLE`` is filled when this module is imported, with ``importlib.util.find_spec`` (it finds
a package without importing it: microseconds, where importing torch takes seconds), so every
metric's availability is known before a run starts. :func:`load` imports a package on first use
and turns a missing or broken install into :class:`MissingDependency`, which carries the line that
installs it; callers decide what to do with that (a default metric is reported unavailable, a
metric asked for by name is refused). No other module of dynaeval imports these packages itself
(``tests/dynaeval/test_architecture.py``).

Ground floor: imports nothing of dynaeval, so every layer may use it.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from dataclasses import dataclass
from types import ModuleType


@dataclass(frozen=True)
class Dependency:
    """One optional package."""

    module: str
    """Top-level import name (``flip_evaluator``)."""
    distribution: str
    """Its name on PyPI (``flip-evaluator``)."""
    install: str
    """The command that installs it for dynaeval."""
    needed_for: str
    """What of dynaeval needs it, for messages and ``dynaeval`` docs."""


_LPIPS = "pip install 'dynaeval[lpips]'"
_VIDEO = "pip install 'dynaeval[video]'"

DEPENDENCIES: dict[str, Dependency] = {d.module: d for d in (
    Dependency("torch", "torch", _LPIPS, "LPIPS, tLP and JOD"),
    Dependency("torchvision", "torchvision", _LPIPS, "LPIPS' backbone; detector export"),
    Dependency("lpips", "lpips", _LPIPS, "LPIPS and tLP"),
    Dependency("flip_evaluator", "flip-evaluator", _VIDEO, "FLIP (--flip)"),
    Dependency("pycvvdp", "cvvdp", _VIDEO, "JOD with ColorVideoVDP (--jod)"),
    Dependency("pyfvvdp", "pyfvvdp", "pip install 'dynaeval[fvvdp]'",
               "JOD with FovVideoVDP (jod.model=fvvdp)"),
    Dependency("distributed", "dask[distributed]", "pip install 'dynaeval[dist]'",
               "scoring on a Dask cluster (dynaeval.run.distributed)"),
    Dependency("jsonschema", "jsonschema", "pip install jsonschema",
               "the JSON-schema check of results files, on top of dynaeval's own"),
    Dependency("tomli", "tomli", "pip install tomli", "reading SUITE.toml on Python 3.10"),
    Dependency("onnx", "onnx", "pip install onnx", "exporting detectors (dynaeval detector fetch)"),
    Dependency("ultralytics", "ultralytics",
               "pip install --no-deps ultralytics && pip install torch torchvision pyyaml "
               "requests onnx", "YOLO detectors (dynaeval detector fetch yolov8n)"),
)}
# Not a plain ``pip install ultralytics``: that pulls ``opencv-python``, whose files overwrite
# dynaeval's ``opencv-contrib-python-headless`` in the shared ``cv2`` folder and take ``--flow
# tvl1`` away. Of ultralytics' other requirements, loading a ``.pt`` and
# ``YOLO.export(format="onnx")`` need only pyyaml (its import), requests (the weights download)
# and onnx (the export); tried with ultralytics 8.4.190 (docs/regions.md).
"""Every optional package, by import name."""


def _found(module: str) -> bool:
    """Whether ``module`` can be found, without importing it (a blocking finder, or a module set
    to None in ``sys.modules``, counts as absent)."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a finder that refuses; sys.modules[name] without a spec
        return False


AVAILABLE: dict[str, bool] = {name: _found(name) for name in DEPENDENCIES}
"""Import name -> whether the package is installed, found when dynaeval was imported. Installed
is not always importable (torchvision beside a torch it was not built for): :func:`load` says."""


class MissingDependency(ImportError):
    """An optional package is not installed, or is installed but does not import.

    ``module``, ``install`` (the command that installs it) and ``installed`` (True: found, but its
    import failed; the cause is chained) are attributes, so no caller reads the message.
    """

    def __init__(self, module: str, *, installed: bool = False,
                 cause: BaseException | None = None, message: str | None = None):
        dep = DEPENDENCIES.get(module.split(".")[0])
        self.install = dep.install if dep else f"pip install {module.split('.')[0]}"
        self.installed = installed
        what = (f"is installed but does not import ({type(cause).__name__}: {cause})"
                if installed else "is not installed")
        if installed and cause is not None and (mismatch := _torchvision_mismatch(cause)):
            what, self.install = mismatch
        super().__init__(message or f"{dep.needed_for + ' needs ' if dep else ''}the "
                         f"{dep.distribution if dep else module} package, which {what}: "
                         f"{self.install}",
                         name=cause.name if installed and isinstance(cause, ImportError)
                         and cause.name else module)
        self.module = module

    def saying(self, message: str) -> MissingDependency:
        """The same failure with the caller's own message (which names the install line)."""
        return MissingDependency(self.module, installed=self.installed, message=message)


def _torchvision_mismatch(cause: BaseException) -> tuple[str, str] | None:
    """(what is wrong, the install that fixes it) when ``cause`` is torchvision built for another
    torch ("operator torchvision::nms does not exist"), which reinstalling dynaeval's extra cannot
    fix; else None. torchvision 0.(N + 15) is the release for torch 2.N."""
    if "torchvision::" not in str(cause) or "does not exist" not in str(cause):
        return None
    from importlib.metadata import PackageNotFoundError, version

    try:
        torch, vision = version("torch"), version("torchvision")
    except PackageNotFoundError:
        return None
    major_minor = torch.split("+")[0].split(".")[:2]
    if len(major_minor) != 2 or major_minor[0] != "2" or not major_minor[1].isdigit():
        return None
    want = f"0.{int(major_minor[1]) + 15}"
    return (f"is installed but built for another torch: torchvision {vision} beside torch {torch} "
            f"({type(cause).__name__}: {cause})",
            f"pip install 'torchvision=={want}.*' (the release for torch {'.'.join(major_minor)}; "
            f"or the torch that torchvision {vision} was built for)")


def available(*modules: str) -> bool:
    """Whether every one of ``modules`` (import names, e.g. ``"torch"``) is installed: the flags
    found at import, and no module blocked since (set to None in ``sys.modules``)."""
    return not missing(*modules)


def missing(*modules: str) -> list[str]:
    """Those of ``modules`` that are not installed (see :func:`available`), in the order given.
    A module already in ``sys.modules`` counts as installed, and one set to None there (Python's
    way of blocking an import) as not installed, whatever was found at import."""
    def absent(m: str) -> bool:
        if m in sys.modules:
            return sys.modules[m] is None
        top = m.split(".")[0]
        return not (AVAILABLE[top] if top in AVAILABLE else _found(top))
    return [m for m in modules if absent(m)]


def load(module: str) -> ModuleType:
    """Import ``module`` (a package of ``DEPENDENCIES`` or one of its submodules, e.g.
    ``"torchvision.models.detection"``) and return it.

    Raises:
        MissingDependency: the package is not installed, or its import fails; the original
            error is chained as ``__cause__``.
    """
    top = module.split(".")[0]
    if missing(top):
        raise MissingDependency(module)
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:  # a dependency of the package (or the package) is gone
        if err.name is not None and err.name.split(".")[0] != top:
            raise MissingDependency(module, installed=True, cause=err) from err
        raise MissingDependency(module) from err
    except Exception as err:  # noqa: BLE001 - a broken install raises anything (OSError, RuntimeError)
        raise MissingDependency(module, installed=True, cause=err) from err
