"""Runtime plumbing shared by every layer: devices, onnxruntime providers and sessions, OpenCV's
threads and build (contrib or not), file hashes.

**One meaning of** ``device="auto"``: *the GPU when the engine that will run can use one, else
the CPU* — never an error. For torch that is ``"cuda"`` when ``torch.cuda.is_available()`` (and
``"cpu"`` when torch is not installed); for onnxruntime it is the ``CUDAExecutionProvider`` when the
installed onnxruntime offers it (``onnxruntime-gpu``). An explicit ``"cuda"`` that cannot be
honoured is an :class:`~dynaeval.core.errors.InputError` naming the fix.

Ground floor: numpy-free even; onnxruntime and cv2 are imported inside the functions, torch through
``dynaeval.core.deps``.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from dynaeval.core.deps import available, load
from dynaeval.core.errors import InputError

CPU_PROVIDERS: tuple[str, ...] = ("CPUExecutionProvider",)
CUDA_PROVIDERS: tuple[str, ...] = ("CUDAExecutionProvider", "CPUExecutionProvider")


def resolve_device(device: object = None) -> str:
    """The torch device name for ``device``, as a string.

    ``None``/``"cpu"`` -> ``"cpu"``; ``"auto"`` -> ``"cuda"`` when torch sees a GPU, else ``"cpu"``
    (also without torch). Other strings (``"cuda"``, ``"cuda:1"``) and torch devices are returned
    as strings unchanged (torch itself rejects a bad one when the model is moved).
    """
    if device is None:
        return "cpu"
    text = str(device)
    if text == "auto":
        if not available("torch"):  # no torch: nothing could run on a GPU anyway
            return "cpu"
        return "cuda" if load("torch").cuda.is_available() else "cpu"
    return text


def torch_device(device: object = None) -> Any:
    """``torch.device`` for ``device`` (see :func:`resolve_device`; imports torch)."""
    torch = load("torch")

    return torch.device(resolve_device(device))


def onnx_providers(device: object = None) -> tuple[str, ...]:
    """onnxruntime execution providers for ``device``: ``None``/``"cpu"``, ``"cuda[:i]"`` or ``"auto"``.

    Returns ``("CPUExecutionProvider",)`` or ``("CUDAExecutionProvider", "CPUExecutionProvider")``
    (CUDA first, the CPU for operators CUDA lacks). ``"auto"`` takes CUDA when this onnxruntime
    offers it, else the CPU. Raises InputError when ``"cuda"`` is asked for but this onnxruntime
    has no ``CUDAExecutionProvider``, and for a device onnxruntime cannot use (e.g. ``"mps"``).
    """
    import onnxruntime as ort

    text = "cpu" if device is None else str(device)
    available = ort.get_available_providers()
    if text == "cpu":
        return CPU_PROVIDERS
    if text == "auto":
        return CUDA_PROVIDERS if "CUDAExecutionProvider" in available else CPU_PROVIDERS
    if text != "cuda" and not text.startswith("cuda:"):
        raise InputError(
            f"onnxruntime runs on device 'cpu', 'cuda' or 'auto', got {text!r}; "
            "pass one of those (or use a torch backend for other devices)"
        )
    if "CUDAExecutionProvider" not in available:
        raise InputError(
            f"device {text!r} asked for, but onnxruntime {ort.__version__} has no "
            f"CUDAExecutionProvider (available: {', '.join(available)}); install onnxruntime-gpu, "
            "or use device 'cpu' (or 'auto', which falls back to the CPU)"
        )
    return CUDA_PROVIDERS


def new_session(model: str | Path | bytes, providers: tuple[str, ...] = CPU_PROVIDERS, *,
                threads: int | None = None) -> Any:
    """A new (uncached) ``onnxruntime.InferenceSession`` on a model file or serialized bytes.

    Only errors are logged (no warnings about unused initialisers on stderr). ``threads``: None
    keeps onnxruntime's default thread pools; an int sets the intra-op threads, one inter-op
    thread and no spinning (a thread waiting for a busy core sleeps instead of burning it).
    A file onnxruntime cannot load is an InputError naming it.
    """
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.log_severity_level = 3
    if threads is not None:
        opts.intra_op_num_threads = max(1, int(threads))
        opts.inter_op_num_threads = 1
        opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
    if isinstance(model, bytes):  # built by dynaeval itself: a failure is a bug, not bad input
        return ort.InferenceSession(model, sess_options=opts, providers=list(providers))
    try:
        return ort.InferenceSession(str(model), sess_options=opts, providers=list(providers))
    except Exception as exc:  # onnxruntime raises its own (non-standard) exception types
        raise InputError(f"not a valid ONNX model onnxruntime can load: {exc}", path=model) from exc


@functools.lru_cache(maxsize=8)
def _cached_session(path: str, mtime_ns: int, size: int, providers: tuple[str, ...]) -> Any:
    return new_session(path, providers)


def load_session(path: str | Path, providers: tuple[str, ...] = CPU_PROVIDERS) -> Any:
    """An ``onnxruntime.InferenceSession`` on a model file, created once per (file, its mtime and
    size, providers): a file rewritten in place gets a new session."""
    p = Path(path).resolve()
    st = p.stat()
    return _cached_session(str(p), st.st_mtime_ns, st.st_size, tuple(providers))


@contextlib.contextmanager
def opencv_threads(threads: int | None) -> Iterator[None]:
    """OpenCV's thread count (``cv2.setNumThreads``) set to ``threads`` inside the block and
    restored after it; None leaves it as it is.

    Process-wide: every thread's OpenCV calls see it while the block runs. A scoring run with
    ``workers`` > 1 sets 1, so each worker's OpenCV calls (DIS flow above all) run on that worker's
    thread: OpenCV's own threads on top of the workers' contend for the same cores and cost CPU
    time in their hand-offs (docs/benchmarks.md, "Two workers on a 1080p job", measures it).
    The numbers do not change: DIS, Farneback, TV-L1 and remap give the same bits on 1, 2 and 4
    threads, and whole runs the same results for 1, 2 and 3 workers (both tested).
    """
    if threads is None:
        yield
        return
    import cv2

    before = cv2.getNumThreads()
    cv2.setNumThreads(max(1, int(threads)))
    try:
        yield
    finally:
        cv2.setNumThreads(before)


def worker_opencv_threads(workers: int) -> contextlib.AbstractContextManager[None]:
    """``opencv_threads`` for a run on ``workers`` threads: 1 when there are several, else
    OpenCV's own count (one worker's DIS flows then use the other cores)."""
    return opencv_threads(1 if workers > 1 else None)


def compiled(fn):  # noqa: ANN001, ANN202
    """``fn`` compiled for the CPU by numba (nopython), IEEE semantics (a division by 0 gives
    inf/NaN as in numpy, which also lets the loops vectorise; no ``fastmath``: no operation is
    reordered or fused), the GIL released. Kept in numba's on-disk cache where a cache folder is
    writable (compiling takes ~1 s; a process's first call of a cached loop ~0.25 s, numba's
    import ~0.2 s), else compiled once per process. numba is imported here, when a module of
    compiled loops is, not with dynaeval."""
    import numba

    options = {"nogil": True, "error_model": "numpy"}
    try:
        return numba.njit(cache=True, **options)(fn)
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return numba.njit(**options)(fn)


MMAP_THRESHOLD = 32 << 20
"""Allocations up to this many bytes (a 1080p float32 RGB frame is 24.9 MB) come from the heap,
not from a fresh ``mmap`` each (glibc's upper limit for the setting)."""
TRIM_THRESHOLD = 1 << 30
"""Free memory at the top of the heap that glibc keeps for the next allocations instead of
returning it to the system."""
_MALLOC_ENV = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_ARENA_MAX",
               "GLIBC_TUNABLES")


def keep_freed_memory(workers: int = 1, largest: int = MMAP_THRESHOLD) -> bool:
    """Let glibc reuse the memory of freed frame-sized arrays instead of unmapping it; True when
    set. The ``dynaeval`` command calls it once at start, before any thread; the reference
    models' training with ``largest`` = 1 GiB (a 768 x 768 x 16 plane's gradient is 37.7 MB,
    above ``MMAP_THRESHOLD``), falling back to ``MMAP_THRESHOLD`` where glibc refuses more.

    A run allocates and frees arrays of 6-50 MB per frame (decoded images, float32 frames,
    flows). glibc serves such sizes with ``mmap`` and returns them on ``free``, so every frame
    page-faults its memory in afresh: on a VM, a third of a 1080p run's CPU time went to the
    kernel (docs/performance.md, "Allocator"). Here the two thresholds are set
    (``mallopt``): freed arrays stay in the heap and the next frame reuses them. The heap is
    the main arena's: other threads' arenas grow in 64 MB heaps that frame-sized arrays
    fragment, so with ``workers`` > 1 every thread allocates from the main one (measured: with
    the thresholds alone, 2 workers faulted ~5x more than one). One worker keeps its arenas
    (OpenCV's own threads allocate in parallel there). Process-wide, so the library never calls
    it on its own (it would change its host's allocator); a host program may. Nothing is done
    where the C library is not glibc or where the user chose (``MALLOC_MMAP_THRESHOLD_``,
    ``MALLOC_TRIM_THRESHOLD_``, ``MALLOC_ARENA_MAX`` or ``GLIBC_TUNABLES`` set).
    """
    import ctypes
    import os
    import sys

    if not sys.platform.startswith("linux") or any(k in os.environ for k in _MALLOC_ENV):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl, ...)
        return False
    m_trim_threshold, m_mmap_threshold, m_arena_max = -1, -3, -8  # glibc's <malloc.h>
    below = bool(mallopt(m_mmap_threshold, largest)) or bool(
        mallopt(m_mmap_threshold, min(largest, MMAP_THRESHOLD)))
    ok = below and bool(mallopt(m_trim_threshold, max(TRIM_THRESHOLD, 2 * largest)))
    return ok and (workers <= 1 or bool(mallopt(m_arena_max, 1)))


OPENCV_DISTRIBUTIONS: tuple[str, ...] = (
    "opencv-python", "opencv-python-headless", "opencv-contrib-python",
    "opencv-contrib-python-headless")
"""The four pip distributions that each install the same ``cv2`` folder: any two of them
installed together overwrite each other's files (the last one installed wins)."""
OPENCV_REPAIR = ("pip uninstall -y opencv-python opencv-python-headless && pip install "
                 "--force-reinstall --no-deps opencv-contrib-python-headless")
"""The command that leaves the one OpenCV build dynaeval depends on (uninstalling a build removes
the shared files, so the contrib one is reinstalled after)."""


def installed_opencv() -> dict[str, str]:
    """``{distribution: version}`` of the OpenCV pip distributions installed (read from their
    metadata with ``importlib.metadata``; ``cv2`` is not imported)."""
    from importlib import metadata

    found = {}
    for name in OPENCV_DISTRIBUTIONS:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return found


def has_tvl1(cv2: Any) -> bool:
    """True when the imported module ``cv2`` has OpenCV-contrib's TV-L1 optical flow.

    ``hasattr(cv2, "optflow")`` is not enough: a non-contrib build installed over the contrib one
    leaves contrib's ``cv2/optflow/`` stub folder, which imports as an empty namespace package.
    """
    return hasattr(getattr(cv2, "optflow", None), "DualTVL1OpticalFlow_create")


def opencv_problem(needs_tvl1: bool = False) -> tuple[str, bool] | None:
    """What is wrong with the installed OpenCV, as ``(message, fatal)``; None when nothing is.

    Cheap when healthy: only the distributions' metadata is read unless ``needs_tvl1`` or more
    than one OpenCV distribution (or none with contrib) is installed; then ``cv2`` is imported
    and probed with ``hasattr``. Fatal: ``cv2`` does not import, or ``needs_tvl1`` and this
    ``cv2`` has no TV-L1. Not fatal (a warning): several builds share the ``cv2`` folder but
    this run does not need contrib. The message names the installed distributions, ``cv2``'s
    file and the repair command.
    """
    dists = installed_opencv()
    mixed = len(dists) > 1 or (bool(dists) and not any("contrib" in d for d in dists))
    if not (mixed or needs_tvl1):
        return None
    try:
        import cv2
    except ImportError as err:
        return f"OpenCV (cv2) does not import ({err}); {_opencv_state(dists)}", True
    if needs_tvl1 and not has_tvl1(cv2):
        return (f"flow 'tvl1' (--flow tvl1) needs cv2.optflow.DualTVL1OpticalFlow_create from opencv-contrib, "
                f"but the cv2 at {getattr(cv2, '__file__', '?')} has none; "
                f"{_opencv_state(dists)}; or use --flow dis"), True
    if mixed:
        what = ("several OpenCV builds share one cv2 folder" if len(dists) > 1
                else "this OpenCV is not the contrib build")
        return f"{what} (--flow tvl1 would be refused); {_opencv_state(dists)}", False
    return None


def _opencv_state(dists: dict[str, str]) -> str:
    names = ", ".join(f"{d} {v}" for d, v in dists.items()) or "no OpenCV pip distribution"
    return (f"installed: {names}; dynaeval needs opencv-contrib-python-headless alone (e.g. "
            f"'pip install ultralytics' adds opencv-python); repair: {OPENCV_REPAIR}")


def check_opencv(needs_tvl1: bool = False) -> str | None:
    """Raise InputError when the installed OpenCV cannot run this command (see
    :func:`opencv_problem`); return the warning text when it can but is in a fragile state."""
    problem = opencv_problem(needs_tvl1)
    if problem is None:
        return None
    message, fatal = problem
    if fatal:
        raise InputError(message)
    return message


def file_sha256(path: str | Path) -> str:
    """SHA-256 hex digest of a file's bytes, read in 1 MiB chunks (recorded in results so a number
    names its model or boxes file)."""
    h = hashlib.sha256()
    with Path(path).open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()
