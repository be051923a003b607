"""The benchmark runs end to end on a tiny frame and writes its markdown table."""

from __future__ import annotations

import numpy as np

from dynaeval import bench


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
    assert "python -m dynaeval.bench --sizes 64x48" in text
    assert "| focused_ssim | 64x48 |" in capsys.readouterr().out
