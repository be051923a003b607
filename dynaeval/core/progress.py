"""One progress bar over every phase of a scoring run, with an ETA measured as the run goes.

A run is a fixed amount of work in *phases*, each counted in its own units: ``regions``
(ground-truth frames whose boxes and masks are found), ``frames`` (frames scored),
``pairs`` (temporal frame pairs) and ``video`` (cameras whose camera-level metrics are done).
Their costs differ (a temporal pair costs several frames), so the bar weighs every unit by the
seconds per unit *measured so far in its phase*: the wall time between two ticks is charged to
the phase that ticks, so a cost is wall seconds per unit at the run's parallelism (with two
workers two frames done in one second cost half a second each). A phase not seen yet borrows
the mean cost of the units seen, scaled by ``PRIOR`` (its relative cost on a typical job).
Setup time (loading the metrics) is charged to no phase (:meth:`Progress.restart`). So:

* the fraction done is ``sum(done_p * cost_p) / sum(total_p * cost_p)``; shown never
  decreasing and below 100 % until :meth:`Progress.close` (the end of the run);
* the ETA is ``sum((total_p - done_p) * cost_p)``, none before the first unit is done;
* the bar is drawn when the run starts (before any region is found) and redrawn at least every
  ``interval`` seconds on a terminal, at least every ``log_interval`` seconds as a new line
  elsewhere (logs, pipes): a ticker thread keeps the elapsed time moving while a long step runs.

``Progress(enabled=False)`` draws nothing (``-q``). Stdlib only: every layer may use it.
Thread-safe: workers tick from their threads.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import TextIO

from dynaeval.core.terminal import console_text, raw_stream

PHASES = ("regions", "frames", "pairs", "video")
"""The phases of a scoring run, in the order a camera goes through them."""

LABELS = {"regions": "regions", "frames": "frames", "pairs": "temporal pairs",
          "video": "video metrics"}
"""How each phase is named on the bar."""

LOG_INTERVAL = 10.0
"""Seconds between two progress lines when stderr is not a terminal (a log file, a pipe)."""

PRIOR = {"regions": 0.5, "frames": 1.0, "pairs": 3.0, "video": 0.5}
"""Relative cost of one unit of each phase before it is measured (a temporal pair of 1080p
frames costs about three scored frames: its three optical flows)."""


def _clock_text(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"


class Progress:
    """The bar of one run. ``totals``: units of work per phase (phases of ``PHASES``).

    ``stream``: where it is drawn (default stderr); ``tty``: redraw in place (default: whether
    ``stream`` is a terminal); ``clock``: seconds (monotonic; tests pass a fake one);
    ``interval``: a terminal's redraw period and ticker (None: no ticker thread);
    ``log_interval``: seconds between two lines when not a terminal (default ``LOG_INTERVAL``).
    The bar names the phase of the last tick (what the run is doing) and its count.
    """

    def __init__(self, totals: dict[str, int], *, enabled: bool = True, stream: TextIO | None = None,
                 tty: bool | None = None, clock: Callable[[], float] = time.monotonic,
                 interval: float | None = 0.5, log_interval: float | None = None,
                 desc: str = "scoring") -> None:
        unknown = set(totals) - set(PHASES)
        if unknown:
            raise ValueError(f"unknown progress phases {sorted(unknown)}; phases are {PHASES}")
        self.totals = {p: int(totals.get(p, 0)) for p in PHASES}
        self.done: dict[str, float] = dict.fromkeys(PHASES, 0.0)  # shares of units too
        self.spent = dict.fromkeys(PHASES, 0.0)
        self.enabled, self.desc, self.clock = enabled, desc, clock
        self.stream = stream if stream is not None else sys.stderr
        self.tty = (self.stream.isatty() if hasattr(self.stream, "isatty") else False) if tty is None else tty
        self.interval = interval
        self.log_interval = LOG_INTERVAL if log_interval is None else log_interval
        self.current = next((p for p in PHASES if self.totals[p]), PHASES[0])
        self.shown = 0.0  # the fraction last drawn (never decreases)
        self.note = ""
        self._lock = threading.RLock()
        self._start = self._last_tick = clock()
        self._last_draw: float | None = None
        self._closed = threading.Event()
        self._ticker: threading.Thread | None = None
        if enabled:
            self._draw(force=True)
            if interval is not None and (self.tty or self.log_interval > 0):  # in logs too: a
                # line every log_interval while a long step runs (a suite wrote nothing for 40 s)
                self._ticker = threading.Thread(target=self._tick_loop, daemon=True)
                self._ticker.start()

    # ------------------------------------------------------------------ counting

    def add_total(self, phase: str, units: int) -> None:
        """More work of ``phase`` than announced (e.g. a camera's pairs known late)."""
        with self._lock:
            self.totals[phase] += int(units)

    def restart(self) -> None:
        """Charge the time since the last tick to no phase (setup work, not a unit of any)."""
        with self._lock:
            self._last_tick = self.clock()

    def advance(self, phase: str, units: float = 1, note: str | None = None) -> None:
        """``units`` of ``phase`` are done (a share of one too: a frame's motion mask is half
        of its regions when a detector runs as well); the time since the last tick is charged
        to it."""
        with self._lock:
            now = self.clock()
            self.spent[phase] += now - self._last_tick
            self._last_tick = now
            self.done[phase] = min(self.totals[phase], self.done[phase] + units)
            self.current = phase
            if note is not None:
                self.note = note
            self._draw()

    def set_note(self, note: str) -> None:
        """What the run is busy with (a camera name), shown at the end of the bar."""
        with self._lock:
            self.note = note
            self._draw()

    # ------------------------------------------------------------------ estimates

    def cost(self, phase: str) -> float | None:
        """Seconds per unit of ``phase``: measured, else borrowed (None before any unit)."""
        if self.done[phase]:
            return self.spent[phase] / self.done[phase]
        seen = [p for p in PHASES if self.done[p]]
        if not seen:
            return None
        per_prior = sum(self.spent[p] for p in seen) / sum(self.done[p] * PRIOR[p] for p in seen)
        return per_prior * PRIOR[phase]

    def fraction(self) -> float:
        """Work-weighted fraction done, in [0, 1] (1 only when every unit is done)."""
        costs = {p: self.cost(p) for p in PHASES}
        if all(c is None for c in costs.values()):
            costs = dict(PRIOR)
        total = sum(self.totals[p] * (costs[p] or 0.0) for p in PHASES)
        if total <= 0:
            return 1.0 if all(self.done[p] >= self.totals[p] for p in PHASES) else 0.0
        return sum(self.done[p] * (costs[p] or 0.0) for p in PHASES) / total

    def eta(self) -> float | None:
        """Seconds left by the measured costs; None before the first unit is done."""
        costs = {p: self.cost(p) for p in PHASES}
        if all(c is None for c in costs.values()):
            return None
        return sum((self.totals[p] - self.done[p]) * (costs[p] or 0.0) for p in PHASES)

    # ------------------------------------------------------------------ drawing

    def line(self, final: bool = False) -> str:
        """The bar as text (``final``: the run is over, 100 %)."""
        frac = 1.0 if final else min(max(self.shown, self.fraction()), 0.99)
        self.shown = frac
        width = 20
        fill = int(frac * width)
        current = self.current
        phase = f"{LABELS[current]} {int(self.done[current] + 1e-6)}/{self.totals[current]}"
        elapsed = self.clock() - self._start
        eta = self.eta()
        tail = "done" if final else ("ETA ?" if eta is None else f"ETA {_clock_text(eta)}")
        note = f" | {self.note}" if self.note and not final else ""
        return (f"{self.desc} {100 * frac:3.0f}% |{'#' * fill}{' ' * (width - fill)}| "
                f"{'all phases' if final else phase}{note} | {_clock_text(elapsed)} elapsed | {tail}")

    def _draw(self, force: bool = False, final: bool = False) -> None:
        if not self.enabled:
            return
        now = self.clock()
        period = (self.interval or 0.0) if self.tty else self.log_interval
        if not (force or final) and self._last_draw is not None and now - self._last_draw < period:
            return
        self._last_draw = now
        text = console_text(self.line(final))  # its notes name pairs and files
        raw = raw_stream(self.stream)  # its own carriage return and line clearing
        raw.write(f"\r{text}\x1b[K" if self.tty else text + "\n")
        if self.tty and final:
            raw.write("\n")
        raw.flush()

    def _tick_loop(self) -> None:
        period = self.interval if self.tty else self.log_interval
        while not self._closed.wait(period):
            with self._lock:
                self._draw()

    def close(self, completed: bool = True) -> None:
        """End of the run: the last line (100 % when ``completed``), the ticker stopped."""
        self._closed.set()
        if self._ticker is not None:
            self._ticker.join()
        with self._lock:
            if self.enabled and completed:
                self._draw(final=True)
            elif self.enabled and self.tty:
                self.stream.write("\n")
                self.stream.flush()
            self.enabled = False
