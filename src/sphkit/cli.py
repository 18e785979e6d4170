"""The ``sphkit`` command.

::

    sphkit run [SCENE] [--until T] [--out DIR] [--fps F] [--format vtk,ply,bgeo] [--quiet|--verbose]
    sphkit surface OUTDIR [--format obj,ply,vtk] [--radius R] [--smoothing-length 2] ...
    sphkit render OUTDIR [--color velocity|pressure|density] [--video auto|mp4|gif|none] ...
    sphkit run --resume DIR [--until T]
    sphkit compat [--markdown docs/compatibility.md] [--radius-scale F] [--steps N]
    sphkit scenes
    sphkit --version

``sphkit run`` simulates a scene (a built-in name, see ``sphkit scenes``, or a scene file: sphkit
JSON/YAML or SPlisHSPlasH JSON) and writes the frames and ``manifest.json`` into the output folder
(``--out``, else the scene's ``output.directory``, else ``out/<scene name>``; relative paths are
relative to the current folder). Frames of an earlier run that its manifest lists are removed
first, so that the folder holds one run. Progress goes to stderr: a live bar on a terminal, a log
line every ~2 s and at every frame otherwise. Each shows steps per second, particles, the time
step, the density error, the pressure solver's iterations per step (``iters``, the mean over the
steps since the previous update; ``div``: DFSPH's divergence-solver iterations, shown when there
are any) and the largest speed. The manifest records them per frame and as run means.

Exit codes: 0 finished; 1 failed (e.g. an output file could not be written); 2 bad command line
or scene; 3 the simulation became unstable (frames so far are kept, the diagnosis is printed and
recorded in the manifest); 130 interrupted by Ctrl-C (143 by SIGTERM).

Logging: the library logs to the logger ``"sphkit"``; a command writes it, with its progress
lines, to ``sphkit.log`` in the output folder (``run`` starts the file, ``surface`` and
``render`` append). ``--quiet`` prints only errors, ``--verbose`` also the library's info and
debug records (per-step statistics) on the console and in the log file. ``sphkit surface`` and
``sphkit render`` are in :mod:`sphkit.cli_post`.
"""

from __future__ import annotations

import argparse
import logging
import math
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

from sphkit.io.frames import FORMATS, FrameWriter, resolve_attributes
from sphkit.io.log import command_logging, get_logger
from sphkit.io.manifest import MANIFEST_NAME, Manifest, read_manifest, sphkit_version

DEFAULT_SCENE = "dambreak-3d"

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_UNSTABLE = 3
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

LOG_INTERVAL_S = 2.0


# -- argument types: each names the value and what was expected ---------------------------------
def _positive_float(what: str, example: str) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(
                f"got {text!r}; expected a positive number: {what}, e.g. {example}"
            )
        return value

    parse.__name__ = "positive number"
    return parse


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"got {text!r}; expected a positive integer, e.g. 2")
    return value


_positive_int.__name__ = "positive integer"


def _formats(text: str) -> list[str]:
    names = [s.strip().lower() for s in text.split(",") if s.strip()]
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        what = f"unknown format {bad[0]!r} in {text!r}" if bad else f"got {text!r}"
        raise argparse.ArgumentTypeError(
            f"{what}; expected a comma-separated list of the formats "
            f"{', '.join(FORMATS)} (e.g. vtk,ply,bgeo)"
        )
    return list(dict.fromkeys(names))


_formats.__name__ = "format list"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``sphkit`` command."""
    parser = argparse.ArgumentParser(
        prog="sphkit",
        description="Smoothed Particle Hydrodynamics for computer graphics.",
    )
    parser.add_argument("--version", action="version", version=f"sphkit {sphkit_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    run = sub.add_parser(
        "run", help="simulate a scene and write frames",
        description="Simulate a scene and write its frames and manifest.json.",
        epilog="Exit codes: 0 finished, 1 failed, 2 bad arguments or scene, 3 unstable, "
               "130 interrupted (143 terminated); a run stopped by a signal writes a "
               "checkpoint and continues with --resume DIR.",
    )
    run.add_argument("scene", nargs="?", default=None, metavar="SCENE",
                     help=f"built-in scene name (see 'sphkit scenes') or scene file "
                          f"(default: {DEFAULT_SCENE})")
    run.add_argument("--until", type=_positive_float("simulated end time in seconds", "2.5"),
                     metavar="T", help="simulated end time [s] (default: the scene's)")
    run.add_argument("--out", type=Path, metavar="DIR",
                     help="output folder (default: the scene's output.directory, "
                          "else out/<scene name>)")
    run.add_argument("--fps", type=_positive_float("frames per simulated second", "25"),
                     metavar="F", help="frames per simulated second [1/s] (default: the scene's)")
    run.add_argument("--format", type=_formats, dest="formats", metavar="LIST",
                     help=f"comma-separated frame formats out of {', '.join(FORMATS)} "
                          "(default: the scene's)")
    run.add_argument("--checkpoint-every", type=_positive_float(
                         "simulated seconds between checkpoints", "0.5"), metavar="T",
                     help="write a checkpoint every T simulated seconds and at the end into "
                          "DIR/checkpoints (one is always written when a signal stops the run)")
    run.add_argument("--keep-checkpoints", type=_positive_int, default=2, metavar="N",
                     help="keep the newest N checkpoints (default 2)")
    run.add_argument("--resume", type=Path, metavar="DIR",
                     help="continue the run in output folder DIR from its newest checkpoint, "
                          "appending frames (only --until may change the scene)")
    run.add_argument("--quiet", "-q", action="store_true",
                     help="print nothing but errors")
    run.add_argument("--verbose", "-v", action="store_true",
                     help="also print the library's log (info and per-step debug records); "
                          "the log file sphkit.log in the output folder gets them too")

    sub.add_parser("scenes", help="list the built-in scenes",
                   description="List the built-in scenes with their descriptions.")
    from sphkit.cli_post import add_post_commands

    add_post_commands(sub)
    from sphkit.cli_compat import add_compat_command

    add_compat_command(sub)
    return parser


# -- progress reporting ----------------------------------------------------------------------
def _fmt(value: float | None, spec: str, scale: float = 1.0, unit: str = "") -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value * scale:{spec}}{unit}"


class _Reporter:
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

    def stats_text(self, sim: Any) -> str:
        """Speed, size and health of the run: steps/s, particles, dt, density error, solver
        iterations, max|v|."""
        last = sim.last
        parts = [
            f"{_fmt(self.rate, '.3g')} steps/s",
            f"{sim.fluid.n} particles",
            f"dt {_fmt(sim.dt, '.2e')} s",
            f"rho err avg {_fmt(last and last.density_error_avg, '.2f', 100, '%')}",
        ]
        iterations = self.iterations_text(sim)
        if iterations:
            parts.append(iterations)
        parts.append(f"max|v| {_fmt(last and last.max_velocity, '.3g')} m/s")
        return "  ".join(parts)

    def __enter__(self) -> _Reporter:
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


class _PlainReporter(_Reporter):
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


class _RichReporter(_Reporter):
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


def _reporter(until: float, quiet: bool, stream: TextIO) -> _Reporter:
    if quiet:
        return _Reporter(until)
    if stream.isatty():
        return _RichReporter(until, stream)
    return _PlainReporter(until, stream)


# -- the run command -------------------------------------------------------------------------
class _Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C."""


class _StopRequest:
    """The signal (SIGINT/SIGTERM) that asked the run to stop after the current step."""

    def __init__(self) -> None:
        self.signum: int | None = None


@contextmanager
def _graceful_stop(stop: _StopRequest) -> Iterator[None]:
    """While the block runs, SIGINT and SIGTERM ask the run to stop after the current step
    (``stop.signum``); a second signal stops at once (KeyboardInterrupt, or _Terminated)."""
    def handler(signum: int, frame: object) -> None:
        if stop.signum is not None:
            raise _Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
        stop.signum = signum

    previous = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, handler)
    except ValueError:  # not the main thread
        for sig, old in previous.items():
            signal.signal(sig, old)
        yield
        return
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def _remove_previous_run(out_dir: Path) -> int:
    """Delete the files an earlier run's manifest lists in ``out_dir``; return how many."""
    path = out_dir / MANIFEST_NAME
    if not path.is_file():
        return 0
    try:
        old = read_manifest(path)
        names = [f for rec in old.get("frames", []) for f in rec.get("files", [])]
        series = old.get("output", {}).get("series")
        if series:
            names.append(series)
    except (OSError, ValueError, AttributeError, TypeError):
        return 0
    removed = 0
    for name in names:
        p = Path(name)
        if not isinstance(name, str) or p.is_absolute() or len(p.parts) != 1:
            continue  # only plain file names inside the folder
        try:
            (out_dir / p).unlink()
            removed += 1
        except FileNotFoundError:
            pass
    return removed


def _error(text: str) -> None:
    print(f"sphkit: error: {text}", file=sys.stderr, flush=True)
    get_logger("cli").error(text, extra={"console": False})


def _say(report: _Reporter, text: str) -> None:
    """An informational line on the console (unless --quiet) and in the log file."""
    report.message(text)
    get_logger("cli").info(text, extra={"console": False})


def _build_new_run(args: argparse.Namespace) -> tuple[Any, Any] | int:
    """The scene and simulation of a fresh run (the command-line overrides applied), or an exit
    code after printing the error."""
    from sphkit.scene.files import load_scene
    from sphkit.scene.schema import SceneError
    from sphkit.simulation import Simulation

    name = args.scene or DEFAULT_SCENE
    try:
        scene = load_scene(name)
        if args.until is not None:
            scene.configuration.time.until = args.until
        if args.fps is not None:
            scene.output.fps = args.fps
        if args.formats is not None:
            scene.output.formats = args.formats
        sim = Simulation.from_scene(scene)
    except SceneError as e:
        _error(f"scene {name!r}:\n{e}")
        return EXIT_USAGE
    except OSError as e:
        _error(f"scene {name!r}: {e}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        _error("interrupted while building the simulation")
        return EXIT_INTERRUPTED
    return scene, sim


def cmd_run(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit run``: simulate, write frames and the manifest; return the exit code."""
    from sphkit.cli_resume import CheckpointSchedule, prepare_resume
    from sphkit.simulation import InstabilityError

    resume = None
    if getattr(args, "resume", None) is not None:
        resume = prepare_resume(args, argv)
        if isinstance(resume, int):
            return resume
        scene, sim, out_dir = resume.scene, resume.sim, resume.out_dir
    else:
        built = _build_new_run(args)
        if isinstance(built, int):
            return built
        scene, sim = built
        out_dir = args.out or Path(scene.output.directory or Path("out") / scene.name)

    until = scene.configuration.time.until
    fps = resume.fps if resume else scene.output.fps
    formats = resume.formats if resume else list(scene.output.formats)
    attributes = resume.attributes if resume else scene.output.attributes
    label = str(args.resume) if resume else (args.scene or DEFAULT_SCENE)
    if attributes is not None:
        try:
            resolve_attributes(attributes, sim.fluid)
        except ValueError as e:
            _error(f"scene {label!r}: {e}")
            return EXIT_USAGE
    session = getattr(args, "log_session", None)
    log = get_logger("cli")

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        removed = 0 if resume else _remove_previous_run(out_dir)
        if session is not None:
            session.add_file(out_dir, append=resume is not None)
        writer = FrameWriter(out_dir, formats, sim.dim, attributes=attributes)
        if resume:
            writer.resume_after(sim._frame)
            manifest = resume.manifest(["sphkit", *argv])
        else:
            manifest = Manifest(
                out_dir, scene, command=["sphkit", *argv],
                output={"directory": str(out_dir), "formats": formats, "fps": fps,
                        "dim": sim.dim, "attributes": attributes,
                        "series": writer.series_path.name if "vtk" in formats else None},
            )
    except OSError as e:
        _error(f"cannot write to the output folder {str(out_dir)!r}: {e}")
        return EXIT_FAILED

    report = _reporter(until, args.quiet, sys.stderr)
    if session is not None and not args.quiet:
        session.console = report.message
    log.info("sphkit %s: %s", sphkit_version(), " ".join(["sphkit", *argv]),
             extra={"console": False})
    if removed:
        _say(report, f"removed {removed} file(s) of the previous run in {out_dir}")
    if resume:
        for line in resume.messages:
            _say(report, line)
    _say(report,
        f"scene {scene.name!r}: {sim.fluid.n} fluid and {sim.boundary.n} boundary particles, "
        f"{sim.dim}D, until t = {until:g} s; {fps:g} frames/s as {', '.join(formats)} "
        f"into {out_dir}"
    )

    def on_frame(s: Any, k: int) -> None:
        files = writer.write(s, k)
        manifest.add_frame(s, k, files, max_displacement=writer.max_displacement)
        report.frame(s, k)
        rec = manifest.frames[-1]
        log.info("frame %d t=%.6g s step %d: max|v| %s m/s, dt %s s, rho err avg %s, iters %s",
                 k, s.time, s.step_count, _fmt(rec["max_velocity"], ".3g"),
                 _fmt(rec["dt"], ".3g"), _fmt(rec["density_error_avg"], ".3g"),
                 _fmt(rec["iterations"], "g"), extra={"console": False})

    def on_step(s: Any, stats: Any) -> None:
        if log.isEnabledFor(logging.DEBUG):
            log.debug("step %s", stats)
        manifest.add_step(stats)
        report.count_step(stats)
        report.step(s)

    checkpoints = CheckpointSchedule(out_dir, sim, manifest, args.checkpoint_every,
                                     args.keep_checkpoints)
    stop = _StopRequest()

    def after_step(s: Any) -> bool:
        checkpoints.after_step(s)
        return stop.signum is not None

    try:
        with _graceful_stop(stop), report:
            finished = sim.run(until=until, fps=fps, on_frame=on_frame, on_step=on_step,
                               after_step=after_step)
            if finished:
                report.done(sim)
        if not finished:  # SIGINT/SIGTERM: the step is complete, its frames are written
            terminated = stop.signum == signal.SIGTERM
            why = "terminated (SIGTERM)" if terminated else "interrupted (Ctrl-C)"
            path = checkpoints.write(sim)
            _finish(manifest, "interrupted",
                    f"{why} at step {sim.step_count}, t = {sim.time:.6g} s; checkpoint "
                    f"{checkpoints.relative(path)}", sim.last)
            _error(f"{why} at t = {sim.time:.6g} s after step {sim.step_count}; the "
                   f"{len(manifest.frames)} frame(s) written so far are kept in {out_dir}; "
                   f"continue with: sphkit run --resume {out_dir}")
            return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
        if args.checkpoint_every is not None:
            checkpoints.write(sim)  # the end state, to extend the run with --resume --until
        manifest.finish("finished", stats=sim.last)
    except InstabilityError as e:
        _finish(manifest, "unstable", str(e), e.stats)
        _error(f"{e}\nThe {len(manifest.frames)} frame(s) written so far are kept in {out_dir}.")
        return EXIT_UNSTABLE
    except KeyboardInterrupt as e:  # a second signal, or one outside the step loop
        terminated = isinstance(e, _Terminated)
        why = "terminated (SIGTERM)" if terminated else "interrupted (Ctrl-C)"
        _finish(manifest, "interrupted",
                f"{why} at step {sim.step_count}, t = {sim.time:.6g} s", sim.last)
        _error(f"{why} at t = {sim.time:.6g} s; the {len(manifest.frames)} frame(s) written so "
               f"far are kept in {out_dir}")
        return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
    except OSError as e:
        _finish(manifest, "failed", f"{type(e).__name__}: {e}", sim.last)
        _error(f"writing the output failed: {e}")
        return EXIT_FAILED
    except BaseException as e:
        _finish(manifest, "failed", f"{type(e).__name__}: {e}", sim.last)
        raise
    wall = time.perf_counter() - report.t0
    rs = manifest.run_stats
    solver = ""
    if rs.steps:
        solver = (f" (mean {_fmt(rs.mean('iterations'), '.3g')} pressure iterations per step, "
                  f"density error {_fmt(rs.mean('density_error'), '.3g', 100, '%')})")
    _say(report,
        f"finished: {len(manifest.frames)} frame(s), {sim.step_count} steps{solver} in "
        f"{wall:.1f} s; output in {out_dir}"
    )
    return EXIT_OK


def _finish(manifest: Manifest, status: str, message: str, stats: Any) -> None:
    """Record how a run ended; a manifest that cannot be written must not mask why it ended."""
    try:
        manifest.finish(status, message, stats=stats)
    except OSError as e:
        _error(f"cannot write {str(manifest.path)!r}: {e}")


def cmd_scenes(args: argparse.Namespace) -> int:
    """``sphkit scenes``: list the built-in scenes on stdout."""
    from sphkit.scene.files import builtin_scenes

    scenes = builtin_scenes()
    width = max((len(n) for n in scenes), default=0)
    for name, description in sorted(scenes.items()):
        print(f"{name:<{width}}  {description}")
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``sphkit`` command with ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help, --version, or a usage error (already printed)
        return e.code if isinstance(e.code, int) else EXIT_USAGE
    with command_logging(quiet=getattr(args, "quiet", False),
                         verbose=getattr(args, "verbose", False)) as session:
        args.log_session = session
        if args.command == "run":
            return cmd_run(args, argv)
        if args.command == "scenes":
            return cmd_scenes(args)
        if args.command == "compat":
            from sphkit.cli_compat import cmd_compat

            return cmd_compat(args)
        from sphkit.cli_post import run_post_command

        return run_post_command(args)
