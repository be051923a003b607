"""The run's one progress bar (dynaeval.core.progress): every phase, an ETA from measured costs,
100 % only at the end, silent with -q, safe with several workers."""

from __future__ import annotations

import io
import re
import threading

import pytest

import dynaeval
from dynaeval.cli import main, sample_dir
from dynaeval.core.progress import LABELS, PHASES, Progress
from dynaeval.regions.focus import FocusConfig

BAR = re.compile(r"scoring +(\d+)% \|[# ]+\| (.+?) \|")


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _bars(text: str) -> list[tuple[int, str]]:
    """(percent, phase text) of every bar line drawn."""
    return [(int(m.group(1)), m.group(2)) for m in BAR.finditer(text)]


def _phase_index(phase_text: str) -> int:
    if phase_text == "all phases":
        return len(PHASES)
    return next(i for i, p in enumerate(PHASES) if phase_text.startswith(LABELS[p] + " "))


def _run(progress: Progress, clock: FakeClock, costs: dict[str, float], cameras: int,
         frames: int) -> None:
    """A fake run: per camera its regions, then frames, pairs, video metrics, each unit taking
    ``costs[phase]`` seconds of the fake clock."""
    for _ in range(cameras):
        clock.now += costs["regions"] * frames
        progress.advance("regions", frames)
        for phase, units in (("frames", frames), ("pairs", frames - 1), ("video", 1)):
            for _ in range(units):
                clock.now += costs[phase]
                progress.advance(phase)


def test_the_bar_is_drawn_at_once_advances_monotonically_and_reaches_100_only_at_the_end():
    clock, out = FakeClock(), io.StringIO()
    progress = Progress({"regions": 8, "frames": 8, "pairs": 6, "video": 2}, stream=out, tty=False,
                        clock=clock, log_interval=0.0)
    assert _bars(out.getvalue()) == [(0, "regions 0/8")]  # before any region is found
    _run(progress, clock, {"regions": 0.5, "frames": 1.0, "pairs": 4.0, "video": 0.2}, 2, 4)
    before_close = _bars(out.getvalue())
    progress.close()
    bars = _bars(out.getvalue())
    percents = [p for p, _ in bars]
    assert percents == sorted(percents)  # never backwards
    assert max(p for p, _ in before_close) <= 99 and bars[-1] == (100, "all phases")
    assert percents.count(100) == 1
    _assert_phases_advance(bars)


def _assert_phases_advance(bars: list[tuple[int, str]], one_camera_at_a_time: bool = True) -> None:
    """Counts never go back; one camera at a time, each camera goes regions -> frames -> temporal
    pairs -> video metrics (the bar names the phase at work), then the next camera starts again
    at regions."""
    idx = [_phase_index(t) for _, t in bars]
    cameras = [[]]
    for prev, cur in zip([0, *idx], idx, strict=False):
        if cur < prev and one_camera_at_a_time:
            assert (prev, cur) == (PHASES.index("video"), 0), (prev, cur)
            cameras.append([])
        cameras[-1].append(cur)
    assert all(c == sorted(c) for c in cameras) or not one_camera_at_a_time
    counts: dict[str, int] = {}
    for _, text in bars:
        if text != "all phases":
            label, count = text.rsplit(" ", 1)
            done = int(count.split("/")[0])
            assert done >= counts.get(label, 0)
            counts[label] = done


def test_the_eta_is_the_remaining_work_at_the_measured_costs():
    clock, out = FakeClock(), io.StringIO()
    costs = {"regions": 0.5, "frames": 1.0, "pairs": 6.0, "video": 0.0}
    progress = Progress({"regions": 8, "frames": 8, "pairs": 6, "video": 0}, stream=out, tty=False,
                        clock=clock, log_interval=0.0)
    assert progress.eta() is None  # nothing measured yet: no guess presented as a number
    _run(progress, clock, costs, 1, 4)  # first camera: every phase measured
    # second camera left: 4 regions, 4 frames, 3 pairs at the costs seen
    assert progress.eta() == pytest.approx(4 * 0.5 + 4 * 1.0 + 3 * 6.0)
    # the fraction is work-weighted, not unit-counted: half the work is done
    assert progress.fraction() == pytest.approx(0.5)
    assert "ETA 0m24s" in out.getvalue().splitlines()[-1]


def test_an_unmeasured_phase_borrows_the_measured_cost_scaled_by_its_prior():
    clock = FakeClock()
    progress = Progress({"regions": 2, "frames": 2, "pairs": 1}, enabled=False, clock=clock)
    clock.now = 3.0
    progress.advance("regions", 2)  # 1.5 s per region, prior 0.5 -> 3 s per prior unit
    assert progress.cost("frames") == pytest.approx(3.0 * 1.0)
    assert progress.cost("pairs") == pytest.approx(3.0 * 3.0)


def test_setup_time_is_charged_to_no_phase():
    clock = FakeClock()
    progress = Progress({"frames": 2}, enabled=False, clock=clock)
    clock.now = 100.0  # loading the metrics
    progress.restart()
    clock.now = 102.0
    progress.advance("frames")
    assert progress.cost("frames") == pytest.approx(2.0)


def test_disabled_draws_nothing_and_unknown_phases_are_refused():
    out = io.StringIO()
    progress = Progress({"frames": 3}, enabled=False, stream=out)
    progress.advance("frames", 3)
    progress.close()
    assert out.getvalue() == ""
    with pytest.raises(ValueError, match="unknown progress phases"):
        Progress({"frame": 3}, enabled=False)


def test_workers_ticking_from_threads_count_every_unit():
    out = io.StringIO()
    progress = Progress({"frames": 400}, stream=out, tty=True, interval=None)

    def work() -> None:
        for _ in range(100):
            progress.advance("frames")

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert progress.done["frames"] == 400
    progress.close()
    assert out.getvalue().endswith("done\x1b[K\n")


def test_a_terminal_gets_one_line_redrawn_and_a_ticker_that_stops_on_close():
    out = io.StringIO()
    progress = Progress({"frames": 1}, stream=out, tty=True, interval=0.01)
    assert out.getvalue().startswith("\rscoring   0%")
    progress.close()
    assert progress._ticker is not None and not progress._ticker.is_alive()
    assert out.getvalue().count("\n") == 1


@pytest.mark.parametrize("workers", [1, 2])
def test_score_shows_one_bar_over_every_phase(capsys, monkeypatch, workers):
    monkeypatch.setattr("dynaeval.core.progress.LOG_INTERVAL", 0.0)  # a line per tick
    root = sample_dir()
    dynaeval.score(root / "pred", root / "gt", metrics=("psnr",), workers=workers, progress=True,
                   focus=FocusConfig(source="motion"))
    bars = _bars(capsys.readouterr().err)
    assert bars[0] == (0, "regions 0/16") and bars[-1] == (100, "all phases")
    assert [p for p, _ in bars] == sorted(p for p, _ in bars)
    assert [p for p, _ in bars].count(100) == 1
    _assert_phases_advance(bars, one_camera_at_a_time=workers == 1)  # 2: both cameras at once
    seen = {t.rsplit(" ", 1)[0] for _, t in bars}
    assert {"regions", "frames", "temporal pairs", "video metrics"} <= seen


def test_cli_quiet_draws_no_bar(tmp_path, capsys):
    root = sample_dir()
    code = main(["score", str(root / "pred"), str(root / "gt"), "--focus", "motion", "--no-lpips",
                 "--workers", "2", "-q", "-o", str(tmp_path / "r.json")])
    assert code == 0
    assert "scoring" not in capsys.readouterr().err


def test_a_log_gets_a_line_every_log_interval_while_a_long_step_runs():
    """Issue 43 item 5: written to a log (not a terminal), a suite printed nothing for 40 s: a
    line came only when a unit was done. A ticker writes one every ``log_interval`` seconds."""
    import time as real_time

    out = io.StringIO()
    progress = Progress({"frames": 2}, stream=out, tty=False, log_interval=0.05)
    real_time.sleep(0.4)  # a long step: no unit done
    progress.close()
    lines = out.getvalue().splitlines()
    assert len(lines) >= 4 and all("frames 0/2" in line for line in lines[:-1])
    assert progress._ticker is not None and not progress._ticker.is_alive()


@pytest.mark.parametrize("focus", ["motion", "detector"])
def test_the_regions_phase_moves_frame_by_frame_within_a_camera(capsys, monkeypatch, focus):
    """Issue 43 item 5: on a terminal the bar sat at one phase for 11 s: the regions phase
    counted a camera's frames only once its motion masks and detector runs were all done
    (``regions 0/16``, ``8/16``, ``16/16``). It moves as each frame's pass is done; what a log
    gets is unchanged (a line at most every ``log_interval``: ``_draw``)."""
    monkeypatch.setattr("dynaeval.core.progress.LOG_INTERVAL", 0.0)  # a line per tick
    root = sample_dir()
    dynaeval.score(root / "pred", root / "gt", metrics=("psnr",), progress=True,
                   temporal=False, presence=False, focus=FocusConfig.parse(focus))
    bars = _bars(capsys.readouterr().err)
    counts = {int(t.split()[1].split("/")[0]) for _, t in bars if t.startswith("regions ")}
    # motion masks: a frame each; with the detector too, half a frame per pass
    assert counts >= (set(range(1, 17)) if focus == "motion" else set(range(1, 8))), counts
    assert [p for p, _ in bars] == sorted(p for p, _ in bars)  # never backwards
    assert bars[-1] == (100, "all phases")
