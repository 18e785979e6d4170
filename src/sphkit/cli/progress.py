"""Progress of ``sphkit run`` on stderr: a live bar on a terminal, log lines otherwise.

Each shows steps per second, particles, the time step, the density error, the pressure solver's
iterations per step (``iters``, the mean over the steps since the previous update; ``div``:
DFSPH's divergence-solver iterations, shown when there are any) and the largest speed. On a
terminal the bar (rich) is redrawn at most every 0.1 s; otherwise a line is printed every
``LOG_INTERVAL_S`` (2 s) of wall time and one per frame.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any, TextIO

LOG_INTERVAL_S = 2.0


def fmt(value: float | None, spec: str, scale: float = 1.0, unit: str = "") -> str:
    """``value * scale`` formatted with ``spec`` and ``unit``; ``-`` when unknown or not finite."""
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value * scale:{spec}}{unit}"


class Reporter:
    """Progress of a run on stderr; the base class prints nothing (--quiet)."""

    def __init__(self, until: float) -> None:
        self.until = until
        self.t0 = time.perf_counter()
        self._mark = (self.t0, 0)  # (wall time, step count) of the last rate measurement
        self.rate: float | None = None
        # solver iterations (pressure, divergence) summed over the steps since the last display
        self._window = [0, 0.0, 0.0]

    def _update_rate(self, step_count: int, min_interval: float) -> None:
        """Steps per wall second since the last measurement at least ``min_interval`` s ago."""
        now = time.perf_counter()
        t, n = self._mark
        if now - t < max(min_interval, 1e-3) or step_count <= n:
            return
        self.rate = (step_count - n) / (now - t)
        self._mark = (now, step_count)

    def count_step(self, stats: Any) -> None:
        """Add a step's solver iterations to the window shown by the next :meth:`stats_text`."""
        iterations = getattr(stats, "iterations", None)
        if iterations is None:
            return
        self._window[0] += 1
        self._window[1] += iterations
        self._window[2] += getattr(stats, "divergence_iterations", 0) or 0

    def iterations_text(self, sim: Any) -> str:
        """``iters N`` (and ``div N`` when DFSPH's divergence solver iterated): the mean per step
        since the previous display, else the last step's; empty before the first step."""
        n, iters, div = self._window
        if n:
            self._window = [0, 0.0, 0.0]
            iters, div = iters / n, div / n
        else:
            last = sim.last
            iters = getattr(last, "iterations", None)
            div = getattr(last, "divergence_iterations", 0) or 0
            if iters is None:
                return ""
        text = f"iters {iters:.3g}"
        if div > 0:
            text += f"  div {div:.3g}"
        return text

    @staticmethod
    def phases_text(last: Any) -> str:
        """Several fluids: `` (id n, id n)`` -- the particles of each material."""
        phases = getattr(last, "phases", None)
        if not phases:
            return ""
        return " (" + ", ".join(f"{p['material']} {p['particles']}" for p in phases) + ")"

    def stats_text(self, sim: Any) -> str:
        """Speed, size and health of the run: steps/s, particles, dt, density error, solver
        iterations, max|v|."""
        last = sim.last
        parts = [
            f"{fmt(self.rate, '.3g')} steps/s",
            f"{sim.fluid.n} particles" + self.phases_text(last),
            f"dt {fmt(sim.dt, '.2e')} s",
            f"rho err avg {fmt(last and last.density_error_avg, '.2f', 100, '%')}",
        ]
        iterations = self.iterations_text(sim)
        if iterations:
            parts.append(iterations)
        parts.append(f"max|v| {fmt(last and last.max_velocity, '.3g')} m/s")
        return "  ".join(parts)

    def __enter__(self) -> Reporter:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def message(self, text: str) -> None:
        """An informational line."""

    def step(self, sim: Any) -> None:
        """Called after every time step."""

    def frame(self, sim: Any, frame: int) -> None:
        """Called after a frame was written."""

    def done(self, sim: Any) -> None:
        """Called when the run reached its end time."""


class _PlainReporter(Reporter):
    """One log line every ~2 s of wall time and one per frame (stderr is not a terminal)."""

    def __init__(self, until: float, stream: TextIO) -> None:
        super().__init__(until)
        self.stream = stream
        self._last_line = self.t0

    def message(self, text: str) -> None:
        print(text, file=self.stream, flush=True)

    def _line(self, sim: Any, suffix: str = "") -> None:
        pct = 100.0 * sim.time / self.until
        print(f"t={sim.time:.4f}/{self.until:.4f} s ({pct:3.0f}%)  step {sim.step_count}  "
              f"{self.stats_text(sim)}{suffix}", file=self.stream, flush=True)
        self._last_line = time.perf_counter()

    def step(self, sim: Any) -> None:
        if time.perf_counter() - self._last_line >= LOG_INTERVAL_S:
            self._update_rate(sim.step_count, 0.0)
            self._line(sim)

    def frame(self, sim: Any, frame: int) -> None:
        self._update_rate(sim.step_count, 0.0)
        self._line(sim, f"  [frame {frame}]")


class _RichReporter(Reporter):
    """A live progress bar (stderr is a terminal)."""

    def __init__(self, until: float, stream: TextIO) -> None:
        super().__init__(until)
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )
        from rich.text import Text

        reporter = self

        class _TwoLineProgress(Progress):
            def get_renderables(self) -> Iterator[Any]:
                yield self.make_tasks_table(self.tasks)
                yield reporter.stats

        self.console = Console(file=stream)
        self.stats = Text("")
        self.progress = _TwoLineProgress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("t {task.completed:.3f}/{task.total:.3f} s"),
            TimeElapsedColumn(),
            TextColumn("eta"),
            TimeRemainingColumn(),
            console=self.console,
            redirect_stdout=False, redirect_stderr=False,
        )
        self.task = self.progress.add_task("frame 0", total=until)
        self._last_update = 0.0

    def __enter__(self) -> _RichReporter:
        self.progress.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.stop()

    def message(self, text: str) -> None:
        self.console.print(text, highlight=False, markup=False)

    def _update(self, sim: Any, description: str | None = None) -> None:
        self.stats.plain = self.stats_text(sim)
        self.progress.update(self.task, completed=min(sim.time, self.until),
                             description=description)
        self._last_update = time.perf_counter()

    def step(self, sim: Any) -> None:
        self._update_rate(sim.step_count, 0.5)
        if time.perf_counter() - self._last_update >= 0.1:
            self._update(sim)

    def frame(self, sim: Any, frame: int) -> None:
        self._update(sim, f"frame {frame}")

    def done(self, sim: Any) -> None:
        self._update(sim)


def reporter(until: float, quiet: bool, stream: TextIO) -> Reporter:
    """The progress display of a run to ``until`` [s]: none with ``quiet``, a live bar when
    ``stream`` is a terminal, log lines otherwise."""
    if quiet:
        return Reporter(until)
    if stream.isatty():
        return _RichReporter(until, stream)
    return _PlainReporter(until, stream)
