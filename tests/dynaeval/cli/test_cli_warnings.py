"""Console warnings: what the user needs is on the console when no results file is written
(issue 32, item 7: "N warning(s) ... listed in the results JSON" pointed at a file that did not
exist)."""

from __future__ import annotations

from dynaeval.cli import main


def test_without_o_the_reason_is_on_the_console(scene, capsys):
    pred, gt = scene  # 64 px frames: MS-SSIM needs 176x176
    assert main(["score", str(pred), str(gt), "--no-lpips", "--msssim", "--no-temporal", "-q",
                 "--focus", "none"]) == 0
    err = capsys.readouterr().err
    assert "msssim: MS-SSIM needs images of at least 176x176 pixels" in err
    assert "(8 frame(s) in 2 camera(s))" in err
    assert "results JSON" not in err


def test_many_kinds_are_summarised_with_a_count_pointing_where_they_are(capsys):
    from dynaeval.cli import _print_frame_warnings

    warnings = [{"camera": f"c{i % 2}", "frame": f"{i:04d}", "metric": "ssim",
                 "status": "undefined", "reason": f"reason {i % 7}"} for i in range(21)]
    warnings.append({"camera": "c0", "metric": "tlp", "status": "no-region",
                     "reason": "no pair has boxes"})
    _print_frame_warnings(warnings, None)
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 6, err  # the 5 commonest reasons, then one line for the rest
    assert err[0] == "dynaeval: warning: ssim: reason 0 (3 frame(s) in 2 camera(s))"
    assert err[-1] == ("dynaeval: 7 more warning(s) about single frames or cameras, of 3 other "
                       "kind(s) (pass -o results.json to keep them all)")
    _print_frame_warnings(warnings, "out/r.json")
    assert capsys.readouterr().err.splitlines()[-1].endswith("(all listed in out/r.json)")
    _print_frame_warnings(warnings[-1:], None)
    assert capsys.readouterr().err == "dynaeval: warning: tlp: no pair has boxes (1 camera(s))\n"
