"""``dynaeval score MODEL`` on a 3DGS-family render folder, and ``--3dgs-json``."""

from __future__ import annotations

import json

import pytest

from dynaeval.cli import main

from ..io.test_layout_3dgs import _iteration


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


FAST = ("--no-lpips", "-q", "--focus", "none", "--no-masked", "--no-presence", "--no-temporal")


@pytest.fixture
def model(tmp_path):
    m = tmp_path / "bicycle"
    for n in (7000, 30000):
        _iteration(m, "test", n)
    return m


def test_score_model_exits_0_and_names_the_iteration(model, capsys):
    code, out, err = run(capsys, "score", model, "--protocol", "3dgs", *FAST)
    assert code == 0, err
    assert "3dgs render folder: scored" in err and "ours_30000" in err
    assert "also rendered: ours_7000" in err
    assert "the numbers of its own metrics.py are --protocol 3dgs" not in err
    code, _, err = run(capsys, "score", model, "--iteration", "7000", *FAST)
    assert code == 0, err
    assert "the numbers of its own metrics.py are --protocol 3dgs" in err


def test_bad_model_exits_2_with_a_clear_message(model, tmp_path, capsys):
    code, _, err = run(capsys, "score", model, "--iteration", "123", *FAST)
    assert code == 2 and "no iteration 123 rendered" in err and "7000, 30000" in err
    broken = tmp_path / "broken"
    (broken / "test" / "ours_1" / "renders").mkdir(parents=True)  # render.py stopped before gt/
    code, _, err = run(capsys, "score", broken, *FAST)
    assert code == 2 and "ours_1 has renders/ but no gt/" in err
    (tmp_path / "empty").mkdir()
    code, _, err = run(capsys, "score", tmp_path / "empty", *FAST)
    assert code == 2 and "holds no known render layout" in err and "3dgs: MODEL" in err
    assert "Traceback" not in err


def test_3dgs_json_shape_and_no_clobber(model, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    code, _, err = run(capsys, "score", model, "--protocol", "3dgs", "--3dgs-json", out,
                       "-o", tmp_path / "r.json", *FAST)
    assert code == 0, err
    results = json.loads((out / "results.json").read_text())
    per_view = json.loads((out / "per_view.json").read_text())
    doc = json.loads((tmp_path / "r.json").read_text())
    assert list(results) == ["ours_30000"] and list(results["ours_30000"]) == ["SSIM", "PSNR"]
    assert results["ours_30000"]["PSNR"] == pytest.approx(doc["summary"]["psnr"])
    assert list(per_view["ours_30000"]["PSNR"]) == ["00000.png", "00001.png", "00002.png"]
    assert per_view["ours_30000"]["SSIM"]["00001.png"] == pytest.approx(doc["frames"][1]["ssim"])
    before = (out / "results.json").read_text()
    code, _, err = run(capsys, "score", model, "--3dgs-json", out, *FAST)
    assert code == 2 and "3DGS results file exists" in err
    assert (out / "results.json").read_text() == before
    code, _, err = run(capsys, "score", model, "--3dgs-json", out, "--overwrite", *FAST)
    assert code == 0 and "not the 3DGS family's own" in err
