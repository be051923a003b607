"""Benchmark scripts own named sections of docs/benchmarks.md and leave the others alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.sections import blocks, keep_sections, put_section
from benchmarks.temporal_speed import interleaved


def test_put_section_replaces_its_own_block_and_keeps_the_rest(tmp_path):
    doc = tmp_path / "b.md"
    doc.write_text("# Benchmarks\n\nmain table\n")
    put_section(doc, "pairs", "## Pairs\n\n4.3 flows\n")
    put_section(doc, "ssim-floor", "## SSIM\n\n1.6x\n")
    put_section(doc, "pairs", "## Pairs\n\n4.2 flows\n")
    text = doc.read_text()
    assert text.startswith("# Benchmarks\n\nmain table\n")
    assert "4.2 flows" in text and "4.3 flows" not in text and "1.6x" in text
    assert list(blocks(text)) == ["pairs", "ssim-floor"]


def test_a_whole_file_rewrite_keeps_the_sections_it_does_not_own():
    old = "# old\n\n<!-- begin pairs -->\nP\n<!-- end pairs -->\n"
    new = keep_sections(old, "# new table\n")
    assert new.startswith("# new table\n") and blocks(new)["pairs"].count("P\n") == 1
    assert keep_sections(old, old) == old


def test_interleaved_runs_every_path_each_round_and_keeps_the_best():
    calls: list[str] = []
    best = interleaved({"a": lambda: calls.append("a"), "b": lambda: calls.append("b")}, 2)
    assert calls == ["a", "b"] * 3  # warm-up round, then 2 alternating rounds
    assert set(best) == {"a", "b"} and all(v["wall"] >= 0 for v in best.values())
    assert all(len(v["cpu_rounds"]) == len(v["wall_rounds"]) == 2 for v in best.values())
    assert all(v["cpu"] == min(v["cpu_rounds"]) for v in best.values())


def test_round_ratios_divide_round_by_round():
    from benchmarks.temporal_speed import round_ratios

    best = {"a": {"cpu_rounds": [2.0, 6.0], "wall_rounds": [1.0, 1.0]},
            "b": {"cpu_rounds": [1.0, 2.0], "wall_rounds": [4.0, 2.0]}}
    assert round_ratios(best, "a", "b").tolist() == [2.0, 3.0]
    assert round_ratios(best, "b", "a", "wall").tolist() == [4.0, 2.0]


def test_command_line_and_stamp():
    import re

    from benchmarks.sections import command_line, utc_stamp

    assert command_line("python benchmarks/x.py", ["--out", "a b"]) == "python benchmarks/x.py --out 'a b'"
    assert command_line("python benchmarks/x.py", []) == "python benchmarks/x.py"  # no trailing space
    assert re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", utc_stamp())


def test_publish_prints_and_writes_unless_dash(tmp_path, capsys):
    from benchmarks.sections import publish

    publish("-", "x", "body")
    assert capsys.readouterr().out == "body\n" and not list(tmp_path.iterdir())
    publish(str(tmp_path / "d.md"), "x", "body")
    assert "<!-- begin x -->\nbody\n<!-- end x -->" in (tmp_path / "d.md").read_text()


def test_checkout_commit_names_the_commit_and_says_when_outside_git(tmp_path):
    import subprocess

    from benchmarks.sections import checkout_commit

    repo = Path(__file__).resolve().parents[2]
    head = subprocess.run(["git", "-C", str(repo), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()
    if not head:
        pytest.skip("not a git checkout")
    assert checkout_commit(repo).split("+")[0] == head
    assert checkout_commit(tmp_path) == "?"


def test_workers_section_on_a_tiny_job_merges_the_shards_and_states_the_ceiling(tmp_path):
    """The workers benchmark end to end (children, shards at once, merge) on 96x64 frames."""
    from benchmarks.temporal_speed import bench_workers, make_job

    job = make_job(tmp_path / "job", size=(64, 96))
    text = bench_workers(job, rounds=1)
    assert "(the shards merged): yes." in text
    assert "2 processes at once (`--shard i/2`" in text
    assert "**The ceiling.**" in text and "faster than 1 worker" in text


def test_children_name_the_failing_command():
    import subprocess
    import sys

    from benchmarks.temporal_speed import _children

    ok = [sys.executable, "-c", "pass"]
    bad = [sys.executable, "-c", "raise SystemExit(3)"]
    user, system = _children([ok, ok])
    assert user > 0 and system >= 0  # two interpreters started: some user time
    with pytest.raises(subprocess.CalledProcessError, match="returned non-zero exit status 3"):
        _children([ok, bad])
