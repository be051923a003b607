"""The ``dynaeval`` command checks its OpenCV at start-up (``dynaeval.core.runtime.check_opencv``)."""

from __future__ import annotations

from dynaeval.cli import main

from ..opencv_fakes import MIXED, install, shadowed_cv2


def test_tvl1_with_two_opencv_builds_is_exit_2_before_the_work(tmp_path, scene, capsys,
                                                               monkeypatch):
    pred, gt = scene
    out = tmp_path / "r.json"
    install(monkeypatch, MIXED, shadowed_cv2())
    code = main(["score", str(pred), str(gt), "--flow", "tvl1", "--no-lpips", "-q", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "error: flow 'tvl1' (--flow tvl1) needs cv2.optflow" in err
    assert "installed: opencv-python 5.1.0.95, opencv-contrib-python-headless 5.1.0.95" in err
    assert ("repair: pip uninstall -y opencv-python opencv-python-headless && pip install "
            "--force-reinstall --no-deps opencv-contrib-python-headless") in err
    assert "Traceback" not in err


def test_two_opencv_builds_without_tvl1_warn_once_and_run(tmp_path, capsys, monkeypatch):
    install(monkeypatch, MIXED, shadowed_cv2())
    monkeypatch.setenv("DYNAEVAL_DETECTORS", str(tmp_path))
    code = main(["detector", "list"])
    err = capsys.readouterr().err
    assert code == 0
    assert err.count("dynaeval: warning: several OpenCV builds share one cv2 folder") == 1
