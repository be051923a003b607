"""The 3DGS results.json / per_view.json writer (library side)."""

from __future__ import annotations

import json

import pytest

from dynaeval.errors import InputError
from dynaeval.report.gaussian_splatting import gs_documents, write_gs_json


def _results(names=("a/00000.png", "a/00001.png"), layout=None):
    frames = [{"camera": "a", "frame": n[-9:-4], "pred": n, "psnr": 30.0 + i, "ssim": None,
               "lpips": 0.1} for i, n in enumerate(names)]
    return {"method": "m", "summary": {"psnr": 30.5, "ssim": None, "lpips": 0.1},
            "frames": frames, "inputs": {"layout": layout}}


def test_documents_follow_their_metrics_py():
    res, per = gs_documents(_results(layout={"name": "3dgs", "iteration": 14000}))
    assert res == {"ours_14000": {"SSIM": None, "PSNR": 30.5, "LPIPS": 0.1}}
    assert per["ours_14000"]["PSNR"] == {"00000.png": 30.0, "00001.png": 31.0}
    assert list(gs_documents(_results())[0]) == ["m"]  # another layout: the method's name


def test_errors_and_atomic_refusal(tmp_path):
    with pytest.raises(InputError, match="share a name"):
        gs_documents(_results(names=("a/0.png", "b/0.png")))
    with pytest.raises(InputError, match="computed none of them"):
        gs_documents({"summary": {"tof": 1.0}, "frames": [], "method": "m"})
    (tmp_path / "per_view.json").write_text("{}")
    with pytest.raises(InputError, match="3DGS results file exists"):
        write_gs_json(_results(), tmp_path)
    assert not (tmp_path / "results.json").exists()  # neither file written
    paths = write_gs_json(_results(), tmp_path, overwrite=True)
    assert json.loads(paths[1].read_text())["m"]["LPIPS"]["00001.png"] == 0.1


def test_4dgaussians_documents_use_its_keys():
    """4DGaussians' metrics.py: SSIM, PSNR, LPIPS-vgg, LPIPS-alex, MS-SSIM, D-SSIM; a run has
    one LPIPS, named by its backbone."""
    res = _results(layout={"name": "3dgs", "iteration": 14000})
    res["summary"].update(msssim=0.95, dssim=0.025)
    res["settings"] = {"protocol": {"name": "4dgaussians"}, "lpips": {"net": "alex"}}
    summary = gs_documents(res)[0]["ours_14000"]
    assert summary == {"SSIM": None, "PSNR": 30.5, "LPIPS-alex": 0.1, "MS-SSIM": 0.95,
                       "D-SSIM": 0.025}
    res["settings"]["lpips"]["net"] = "vgg"
    assert list(gs_documents(res)[0]["ours_14000"])[2] == "LPIPS-vgg"
    res["settings"]["protocol"]["name"] = "3dgs"  # 3DGS' keys, its MS-SSIM not among them
    assert list(gs_documents(res)[0]["ours_14000"]) == ["SSIM", "PSNR", "LPIPS"]
