"""Runtime plumbing: one meaning of ``device="auto"``, providers, cached sessions, file hashes."""

from __future__ import annotations

import hashlib
import os
import sys

import numpy as np
import pytest

from dynaeval.core import runtime
from dynaeval.core.runtime import (
    CPU_PROVIDERS,
    CUDA_PROVIDERS,
    file_sha256,
    load_session,
    new_session,
    onnx_providers,
    opencv_threads,
    resolve_device,
    worker_opencv_threads,
)
from dynaeval.errors import InputError

from ..opencv_fakes import MIXED, install, shadowed_cv2

ort = pytest.importorskip("onnxruntime")


@pytest.mark.parametrize(("device", "expected"), [(None, "cpu"), ("cpu", "cpu"), ("cuda", "cuda"),
                                                  ("cuda:1", "cuda:1")])
def test_resolve_device_keeps_explicit_devices(device, expected):
    assert resolve_device(device) == expected


@pytest.mark.parametrize("gpu", [False, True])
def test_auto_is_cuda_exactly_when_torch_sees_a_gpu(monkeypatch, gpu):
    torch = pytest.importorskip("torch")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: gpu)
    assert resolve_device("auto") == ("cuda" if gpu else "cpu")


def test_auto_is_cpu_without_torch(monkeypatch):
    monkeypatch.setitem(sys.modules, "torch", None)  # makes ``import torch`` raise ImportError
    assert resolve_device("auto") == "cpu"


def test_torch_device():
    torch = pytest.importorskip("torch")
    assert runtime.torch_device(None) == torch.device("cpu")
    assert runtime.torch_device("cuda:1") == torch.device("cuda", 1)


def _providers(monkeypatch, cuda: bool) -> None:
    names = list(CUDA_PROVIDERS if cuda else CPU_PROVIDERS)
    monkeypatch.setattr(ort, "get_available_providers", lambda: names)


@pytest.mark.parametrize("device", [None, "cpu", "auto"])
def test_onnx_without_cuda_runs_on_the_cpu(monkeypatch, device):
    _providers(monkeypatch, cuda=False)
    assert onnx_providers(device) == ("CPUExecutionProvider",)


@pytest.mark.parametrize(("device", "expected"), [("cpu", CPU_PROVIDERS), ("auto", CUDA_PROVIDERS),
                                                  ("cuda", CUDA_PROVIDERS), ("cuda:0", CUDA_PROVIDERS)])
def test_onnx_with_cuda(monkeypatch, device, expected):
    _providers(monkeypatch, cuda=True)
    assert onnx_providers(device) == expected


@pytest.mark.parametrize("device", ["cuda", "cuda:1"])
def test_cuda_without_provider_names_the_fix(monkeypatch, device):
    _providers(monkeypatch, cuda=False)
    with pytest.raises(InputError, match=r"no CUDAExecutionProvider.*install onnxruntime-gpu"):
        onnx_providers(device)


def test_onnx_refuses_devices_it_cannot_use():
    with pytest.raises(InputError, match=r"onnxruntime runs on device 'cpu', 'cuda' or 'auto', got 'mps'"):
        onnx_providers("mps")


def test_cuda_without_provider_on_this_machine():
    if "CUDAExecutionProvider" in ort.get_available_providers():
        pytest.skip("this machine has CUDA: the error path cannot happen")
    with pytest.raises(InputError, match="onnxruntime-gpu"):
        onnx_providers("cuda")
    assert onnx_providers("auto") == ("CPUExecutionProvider",)


def _identity_model() -> bytes:
    pytest.importorskip("onnx")
    from onnx import TensorProto, helper

    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [None])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, [None])
    graph = helper.make_graph([helper.make_node("Identity", ["x"], ["y"])], "id", [x], [y])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    return model.SerializeToString()


def test_session_cached_per_file_and_renewed_when_rewritten(tmp_path):
    path = tmp_path / "id.onnx"
    path.write_bytes(_identity_model())
    a = load_session(path)
    assert load_session(path) is a
    assert load_session(str(path), ("CPUExecutionProvider",)) is a
    st = path.stat()  # rewritten in place: same bytes, a new mtime
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    b = load_session(path)
    assert b is not a
    x = np.arange(3, dtype=np.float32)
    np.testing.assert_array_equal(b.run(["y"], {"x": x})[0], x)


def test_not_an_onnx_file_is_an_input_error(tmp_path):
    path = tmp_path / "bad.onnx"
    path.write_bytes(b"not a model")
    with pytest.raises(InputError, match=r"bad\.onnx: not a valid ONNX model onnxruntime can load"):
        load_session(path)


def test_new_session_from_bytes_with_threads():
    session = new_session(_identity_model(), threads=2)
    x = np.ones(2, dtype=np.float32)
    np.testing.assert_array_equal(session.run(["y"], {"x": x})[0], x)


def test_file_sha256_streams_large_files(tmp_path):
    data = np.random.default_rng(1).integers(0, 256, 3 * (1 << 20) + 17, dtype=np.uint8).tobytes()
    p = tmp_path / "blob.bin"
    p.write_bytes(data)
    assert file_sha256(p) == hashlib.sha256(data).hexdigest()


def test_opencv_threads_sets_the_count_inside_the_block_and_restores_it():
    cv2 = pytest.importorskip("cv2")
    before = cv2.getNumThreads()
    with opencv_threads(1):
        assert cv2.getNumThreads() == 1
    assert cv2.getNumThreads() == before
    with pytest.raises(RuntimeError), opencv_threads(1):
        raise RuntimeError("a failing run")
    assert cv2.getNumThreads() == before
    with opencv_threads(None):
        assert cv2.getNumThreads() == before
    with worker_opencv_threads(1):  # one worker keeps OpenCV's threads, several get one each
        assert cv2.getNumThreads() == before
    with worker_opencv_threads(3):
        assert cv2.getNumThreads() == 1
    assert cv2.getNumThreads() == before


_FAULTS = """
import resource, sys
import numpy as np
from dynaeval.core.runtime import keep_freed_memory
kept = keep_freed_memory() if sys.argv[1] == "keep" else False
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(10):  # a frame's arrays (25 MB: a 1080p float32 RGB frame), then all freed
    frames = [np.ones(25 << 18, np.float32) for _ in range(4)]
    del frames
print(kept, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(mode: str, **env: str) -> tuple[bool, int]:
    import subprocess

    out = subprocess.run([sys.executable, "-c", _FAULTS, mode], capture_output=True, text=True,
                         check=True, env={**os.environ, **env}).stdout.split()
    return out[0] == "True", int(out[1])


@pytest.mark.skipif(not sys.platform.startswith("linux") or
                    __import__("platform").libc_ver()[0] != "glibc", reason="glibc's mallopt")
def test_keep_freed_memory_reuses_frame_sized_arrays_instead_of_faulting_them_in_again():
    kept, faults = _faults("keep")
    plain_kept, plain = _faults("plain")
    assert kept and not plain_kept
    assert faults * 4 < plain  # 10 x 4 x 6,100 pages of 4 KiB without, 4 x 6,100 with
    chosen, _ = _faults("keep", MALLOC_TRIM_THRESHOLD_="131072")  # the user's setting is kept
    assert not chosen
    import subprocess

    several = subprocess.run([sys.executable, "-c", "from dynaeval.core.runtime import keep_freed_memory"
                              " as k; print(k(workers=3))"], capture_output=True, text=True,
                             check=True).stdout.strip()
    assert several == "True"  # and one arena for the workers' threads


def test_without_a_writable_cache_the_loops_are_compiled_per_process(monkeypatch):
    import numba

    real = numba.njit

    def njit(*args, cache=False, **kw):
        if cache:
            raise RuntimeError("cannot cache function 'f': no locator available for file 'f.py'")
        return real(*args, **kw)

    monkeypatch.setattr(numba, "njit", njit)

    def double(x):
        return 2 * x

    assert runtime.compiled(double)(21) == 42


# ------------------------------------------------------------------ which OpenCV is installed


def test_this_venv_has_the_contrib_build_alone_and_tv_l1():
    import cv2

    assert list(runtime.installed_opencv()) == ["opencv-contrib-python-headless"]
    assert runtime.has_tvl1(cv2)
    assert runtime.opencv_problem(needs_tvl1=True) is None
    assert runtime.check_opencv(needs_tvl1=True) is None


def test_installed_opencv_reads_the_four_distributions_metadata(monkeypatch):
    from importlib import metadata

    def version(name):
        if name in MIXED:
            return MIXED[name]
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "version", version)
    assert runtime.installed_opencv() == MIXED


def test_an_empty_optflow_namespace_is_not_tv_l1():
    # a non-contrib build over the contrib one leaves cv2/optflow/ (stubs): hasattr(cv2, "optflow")
    assert not runtime.has_tvl1(shadowed_cv2()) and hasattr(shadowed_cv2(), "optflow")


def test_tvl1_on_a_shadowed_cv2_is_refused_naming_the_builds_and_the_repair(monkeypatch):
    install(monkeypatch, MIXED, shadowed_cv2())
    with pytest.raises(InputError, match=r"flow 'tvl1' .*needs cv2\.optflow\.DualTVL1OpticalFlow_"
                       r"create.*installed: opencv-python 5\.1\.0\.95, opencv-contrib-python-"
                       r"headless 5\.1\.0\.95.*repair: pip uninstall -y opencv-python "
                       r"opencv-python-headless && pip install --force-reinstall --no-deps "
                       r"opencv-contrib-python-headless"):
        runtime.check_opencv(needs_tvl1=True)


def test_two_builds_without_tvl1_are_a_warning_not_an_error(monkeypatch):
    install(monkeypatch, MIXED, shadowed_cv2())
    note = runtime.check_opencv(needs_tvl1=False)
    assert "several OpenCV builds share one cv2 folder" in note and runtime.OPENCV_REPAIR in note


def test_one_build_without_contrib_is_named_as_such(monkeypatch):
    install(monkeypatch, {"opencv-python-headless": "5.1.0.95"}, shadowed_cv2())
    note = runtime.check_opencv(needs_tvl1=False)
    assert note.startswith("this OpenCV is not the contrib build (--flow tvl1 would be refused)")
    with pytest.raises(InputError, match=r"installed: opencv-python-headless 5\.1\.0\.95; "):
        runtime.check_opencv(needs_tvl1=True)


def test_a_cv2_that_does_not_import_is_refused_even_without_tvl1(monkeypatch):
    install(monkeypatch, {"opencv-python": "5.1.0.95"}, None)  # None in sys.modules: ImportError
    with pytest.raises(InputError, match=r"OpenCV \(cv2\) does not import .*installed: "
                                         r"opencv-python 5\.1\.0\.95.*repair: pip uninstall"):
        runtime.check_opencv(needs_tvl1=False)


def test_a_healthy_install_is_probed_without_importing_cv2(monkeypatch):
    install(monkeypatch, {"opencv-contrib-python-headless": "5.1.0.95"}, None)
    assert runtime.check_opencv(needs_tvl1=False) is None  # cv2 would not import: not tried
