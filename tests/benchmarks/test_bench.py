"""The benchmark runs end to end on a tiny frame and writes its markdown table."""

from __future__ import annotations

import cv2
import numpy as np

from benchmarks import bench


def test_sample_pair_is_deterministic_and_in_range():
    p1, g1, b1 = bench.sample_pair(60, 100)
    p2, g2, b2 = bench.sample_pair(60, 100)
    assert np.array_equal(p1, p2) and np.array_equal(g1, g2) and np.array_equal(b1, b2)
    assert p1.dtype == np.float32 and 0 <= p1.min() and p1.max() <= 1
    assert b1.shape == (6, 4)


def test_bench_writes_the_table(tmp_path, capsys):
    out = tmp_path / "bench.md"
    assert bench.main(["--sizes", "64x48", "--repeats", "1", "--no-lpips", "--peers", "skimage", "--out", str(out)]) == 0
    text = out.read_text()
    assert "| psnr | 64x48 | dynaeval |" in text
    assert "| ssim | 64x48 | dynaeval |" in text
    assert "python benchmarks/bench.py --sizes 64x48" in text
    assert "| focused_ssim | 64x48 |" in capsys.readouterr().out


def test_bench_sequence_plot_and_peer_ratio(tmp_path):
    out = tmp_path / "bench.md"
    argv = ["--sizes", "96x64", "--repeats", "1", "--no-lpips", "--peers", "skimage", "--out", str(out)]
    assert bench.main(argv) == 0
    text = out.read_text()
    for metric in ("motion_mask (isg)", "optical_flow", "warp", "temporal_metrics (no tLP)"):
        assert f"| {metric} | 96x64 |" in text
    assert "| ssim | 96x64 | dynaeval, 2 threads over bands |" in text
    assert "| ssim | 96x64 |" in text.split("fastest peer at equal accuracy")[1]  # scikit-image within 1e-6
    assert (tmp_path / "img" / "bench_speed_error.png").stat().st_size > 1000
    assert "![CPU time vs deviation](img/bench_speed_error.png)" in text


def test_sample_sequence_moves_a_patch():
    gts, preds = bench.sample_sequence(64, 96, frames=3)
    assert len(gts) == len(preds) == 3
    assert gts[0].shape == (64, 96, 3) and gts[0].dtype == np.float32
    assert not np.array_equal(gts[0], gts[1])
    assert np.array_equal(gts[0][:, :20], gts[1][:, :20])  # the background stays


def test_score_throughput_runs_score_in_a_child(tmp_path):
    from pathlib import Path

    import dynaeval

    sample = Path(dynaeval.__file__).parent / "data" / "sample"
    rows = bench.score_throughput(str(sample / "pred"), str(sample / "gt"), (1, 2),
                                  ["--no-lpips", "--no-temporal", "--focus", "none", "--no-masked"],
                                  rounds=2)
    assert [r["workers"] for r in rows] == [1, 2] and rows[0]["frames"] == 16
    assert all(r["rounds"] == 2 and r["wall_max_s"] >= r["wall_s"] > 0 for r in rows)
    assert rows[0]["max_rss_mb"] > 10 and rows[0]["cpu_s"] > 0 and rows[0]["fps"] > 0
    table = bench._throughput_table(rows).splitlines()
    assert table[2].split(" | ")[3] == "1.00"  # the first count's speed-up over itself


def test_degrade_writes_one_frame_per_png(tmp_path):
    import cv2

    src = tmp_path / "gt" / "cam0"
    src.mkdir(parents=True)
    img = (np.random.default_rng(0).random((20, 30, 3)) * 255).astype(np.uint8)
    cv2.imwrite(str(src / "0000.png"), img)
    assert bench.main(["--degrade", str(tmp_path / "gt"), str(tmp_path / "pred")]) == 0
    out = cv2.imread(str(tmp_path / "pred" / "cam0" / "0000.png"))
    assert out.shape == img.shape and not np.array_equal(out, img)


def _alexnet_macs(h: int, w: int) -> int:
    """AlexNet features' conv MACs by hand: (c_in, c_out, kernel, stride, pad, pool after)."""
    layers = [(3, 64, 11, 4, 2, True), (64, 192, 5, 1, 2, True), (192, 384, 3, 1, 1, False),
              (384, 256, 3, 1, 1, False), (256, 256, 3, 1, 1, False)]
    total = 0
    for cin, cout, k, s, p, pool in layers:
        h, w = (h + 2 * p - k) // s + 1, (w + 2 * p - k) // s + 1
        total += h * w * cout * cin * k * k
        if pool:
            h, w = (h - 3) // 2 + 1, (w - 3) // 2 + 1
    return total


def test_backbone_macs_match_the_layer_arithmetic():
    for h, w in ((64, 64), (540, 960), (1080, 1920)):
        assert bench.backbone_macs("alex", h, w) == _alexnet_macs(h, w)


def test_lpips_floor_table_divides_by_the_measured_rate(monkeypatch):
    monkeypatch.setattr(bench, "sgemm_gflops", lambda: 100.0)
    rows = [{"metric": "lpips", "size": "96x64", "impl": "lpips package, same network", "cpu_ms": 20.0},
            {"metric": "lpips", "size": "96x64", "impl": "dynaeval backend=onnxruntime", "cpu_ms": 10.0}]
    text = bench.lpips_floor(rows)
    floor = 1e3 * 4 * _alexnet_macs(64, 96) / 1e9 / 100.0
    assert "**100 GFLOP/s**" in text
    assert f"| 96x64 | {4 * _alexnet_macs(64, 96) / 1e9:.1f} | {floor:.0f} | dynaeval backend=onnxruntime | 10 |" in text
    assert f"| {20.0 / 10.0:.2f} | {20.0 / floor:.2f} |" in text


def test_make_job_writes_the_1080p_job_once(tmp_path):
    job = tmp_path / "job"
    argv = ["--make-job", str(job), "--sizes", "64x48", "--repeats", "1", "--no-lpips",
            "--no-sequence", "--peers", "skimage", "--out", "-"]
    assert bench.main(argv) == 0
    gts = sorted((job / "gt").rglob("*.png"))
    assert len(gts) == 16 and len(sorted((job / "pred").rglob("*.png"))) == 16
    assert cv2.imread(str(gts[0])).shape == (1080, 1920, 3)
    stamp = gts[0].stat().st_mtime_ns
    assert bench.main(argv) == 0
    assert gts[0].stat().st_mtime_ns == stamp  # an existing job is kept
