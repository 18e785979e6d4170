"""``sphkit run``: simulate a scene and write its frames and ``manifest.json``.

::

    sphkit run [SCENE] [--until T] [--out DIR] [--fps F] [--format vtk,ply,bgeo] [--quiet|--verbose]
    sphkit run SCENE --max-particles N
    sphkit run SCENE --checkpoint-every T [--keep-checkpoints N]
    sphkit run --resume DIR [--until T]

``SCENE`` is a built-in name (see ``sphkit scenes``) or a scene file (sphkit JSON/YAML or
SPlisHSPlasH JSON; default ``dambreak-3d``). The frames and ``manifest.json`` go into the output
folder (``--out``, else the scene's ``output.directory``, else ``out/<scene name>``; relative
paths are relative to the current folder). Frames of an earlier run that its manifest lists, and
its checkpoints, are removed first, so that the folder holds one run. Progress goes to stderr
(:mod:`sphkit.cli.progress`); the manifest records the statistics per frame and as run means.
At most one frame is written per time step (``--fps`` is at most 1e6). ``--max-particles`` sets
the particle budget the scene is checked against before anything is allocated
(``configuration.max_particles``, 20 million). SIGINT and SIGTERM stop the run after the current
step with a checkpoint (a second signal stops at once); checkpoints and ``--resume`` are in
:mod:`sphkit.cli.resume`. Exit codes: 0 finished,
1 failed (e.g. an output file could not be written), 2 bad command line or scene, 3 the
simulation became unstable (frames so far are kept, the diagnosis is printed and recorded in the
manifest), 130 interrupted by Ctrl-C (143 by SIGTERM).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sphkit.cli.common import (
    COMPILING,
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_TERMINATED,
    EXIT_UNSTABLE,
    EXIT_USAGE,
    Interrupts,
    add_verbosity,
    choices_list,
    error,
    positive_float,
    positive_int,
    watch_compiles,
)
from sphkit.cli.progress import Reporter, fmt, reporter
from sphkit.cli.resume import CheckpointSchedule, prepare_resume
from sphkit.io.bodies import BodyWriter, body_formats
from sphkit.io.frames import (
    FORMATS,
    MULTIPHASE_FIELDS,
    FrameFormatError,
    FrameWriter,
    resolve_attributes,
)
from sphkit.io.log import get_logger
from sphkit.io.manifest import MANIFEST_NAME, Manifest, read_manifest, sphkit_version
from sphkit.registry import DEVICE_CHOICES
from sphkit.scene.limits import MAX_FPS, MAX_PARTICLES

DEFAULT_SCENE = "dambreak-3d"

_FORMAT_LIST = choices_list(tuple(FORMATS), "vtk,ply,bgeo", "the formats ")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit run`` to the ``sphkit`` command's subcommands."""
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
    run.add_argument("--until", type=positive_float("simulated end time in seconds", "2.5"),
                     metavar="T", help="simulated end time [s] (default: the scene's)")
    run.add_argument("--out", type=Path, metavar="DIR",
                     help="output folder (default: the scene's output.directory, "
                          "else out/<scene name>)")
    run.add_argument("--fps", type=positive_float("frames per simulated second", "25", MAX_FPS),
                     metavar="F", help="frames per simulated second [1/s] (default: the scene's; "
                                       "at most one frame is written per time step)")
    run.add_argument("--format", type=_FORMAT_LIST, dest="formats", metavar="LIST",
                     help=f"comma-separated frame formats out of {', '.join(FORMATS)} "
                          "(default: the scene's)")
    run.add_argument("--checkpoint-every", type=positive_float(
                         "simulated seconds between checkpoints", "0.5"), metavar="T",
                     help="write a checkpoint every T simulated seconds and at the end into "
                          "DIR/checkpoints (one is always written when a signal stops the run)")
    run.add_argument("--keep-checkpoints", type=positive_int, default=2, metavar="N",
                     help="keep the newest N checkpoints (default 2)")
    run.add_argument("--max-particles", type=positive_int, metavar="N",
                     help="particle budget: refuse a scene that needs more particles, estimated "
                          "before anything is allocated (default: the scene's "
                          f"configuration.max_particles, {MAX_PARTICLES:,})")
    run.add_argument("--precision", choices=("float64", "float32"),
                     help="floating-point type of the particle fields and the cached pair "
                          "values (default: the scene's configuration.precision; unset: float32 "
                          "on the GPU, float64 on the CPU); "
                          "float32 halves their memory (also on --device cuda)")
    run.add_argument("--device", choices=DEVICE_CHOICES, default="auto",
                     help="where the time step runs: cpu, cuda (refused, naming the method "
                          "or field, when the scene uses one that does not run on the GPU; "
                          "`sphkit methods` lists the ones that do) or auto (the GPU when one "
                          "is found and every method runs there, else the CPU; default); the "
                          "manifest records it")
    run.add_argument("--resume", type=Path, metavar="DIR",
                     help="continue the run in output folder DIR from its newest checkpoint, "
                          "appending frames (only --until may change the scene)")
    add_verbosity(run, exclusive=False,
                  verbose_help="also print the library's log (info and per-step debug records); "
                               "the log file sphkit.log in the output folder gets them too")
    run.set_defaults(handler=cmd_run)


class Terminated(KeyboardInterrupt):
    """SIGTERM (a second one while a run stops), handled like Ctrl-C."""


class _StopRequest:
    """The signal (SIGINT/SIGTERM) that asked the run to stop after the current step."""

    def __init__(self) -> None:
        self.signum: int | None = None


@contextmanager
def _graceful_stop(stop: _StopRequest) -> Iterator[None]:
    """While the block runs, SIGINT and SIGTERM ask the run to stop after the current step
    (``stop.signum``); a second signal stops at once (KeyboardInterrupt, or Terminated)."""
    def handler(signum: int, frame: object) -> None:
        if stop.signum is not None:
            raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
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
    """Delete the files an earlier run's manifest lists in ``out_dir`` and its checkpoints
    (else ``--resume`` would continue the earlier run's state, which has more steps, under the
    new run's manifest); return how many."""
    from sphkit.io.checkpoint import list_checkpoints

    removed = 0
    for ck in list_checkpoints(out_dir):
        ck.unlink(missing_ok=True)
        removed += 1
    path = out_dir / MANIFEST_NAME
    if not path.is_file():
        return removed
    try:
        old = read_manifest(path)
        names = [f for rec in old.get("frames", [])
                 for f in [*rec.get("files", []), *rec.get("body_files", [])]]
        for key in ("series", "body_series"):
            series = old.get("output", {}).get(key)
            if series:
                names.append(series)
    except (OSError, ValueError, AttributeError, TypeError):
        return removed
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


def _say(report: Reporter, text: str) -> None:
    """An informational line on the console (unless --quiet) and in the log file."""
    report.message(text)
    get_logger("cli").info(text, extra={"console": False})


def _build_new_run(args: argparse.Namespace) -> tuple[Any, Any] | int:
    """The scene and simulation of a fresh run (the command-line overrides applied), or an exit
    code after printing the error."""
    from sphkit.scene.files import load_scene
    from sphkit.scene.schema import SceneError

    name = args.scene or DEFAULT_SCENE
    try:
        # a scene given ready-made (``sphkit sweep``'s variants), else the name or file
        scene = load_scene(getattr(args, "scene_object", None) or name)
        if args.until is not None:
            scene.configuration.time.until = args.until
        if args.fps is not None:
            scene.output.fps = args.fps
        if args.checkpoint_every is None:  # the scene's interval, unless given
            args.checkpoint_every = scene.output.checkpoint_every
        if args.formats is not None:
            scene.output.formats = args.formats
        if args.max_particles is not None:
            scene.configuration.max_particles = args.max_particles
        if args.precision is not None:
            scene.configuration.precision = args.precision
        # the simulation's modules (Numba, SciPy, trimesh: most of the command's start-up) are
        # imported once the scene has been read, so that an error in it is reported at once
        from sphkit.simulation import Simulation

        watch_compiles(args)  # the world's build compiles too (walls, start-up)
        # a Ctrl-C that a library swallowed while the modules were imported (scipy and trimesh
        # catch every exception around some imports): stop before building the world (seconds
        # of sampling, start-up and compiling) rather than after it
        Interrupts.check()
        sim = Simulation.from_scene(scene, device=getattr(args, "device", "auto"))
        Interrupts.check()  # a Ctrl-C that a library swallowed while the world was built
    except SceneError as e:
        error(f"scene {name!r}:\n{e}")
        return EXIT_USAGE
    except OSError as e:
        error(f"scene {name!r}: {e}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        error("interrupted while building the simulation")
        return EXIT_INTERRUPTED
    return sim.scene, sim  # the scene as run (its precision resolved for the device)


def cmd_run(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit run``: simulate, write frames and the manifest; return the exit code."""
    args.compile_watch = None  # this run's (cli.common.watch_compiles), stopped at its end
    try:
        return _run(args, argv)
    finally:
        if args.compile_watch is not None:
            args.compile_watch.stop()


def _run(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """:func:`cmd_run`'s run."""
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
    from sphkit.simulation import InstabilityError  # imported by now

    if Interrupts.received is not None:  # a Ctrl-C that a library swallowed while starting
        error("interrupted while building the simulation")
        return EXIT_INTERRUPTED
    until = scene.configuration.time.until
    fps = resume.fps if resume else scene.output.fps
    formats = resume.formats if resume else list(scene.output.formats)
    attributes = resume.attributes if resume else scene.output.attributes
    label = str(args.resume) if resume else (args.scene or DEFAULT_SCENE)
    if attributes is not None:
        try:
            resolve_attributes(attributes, sim.fluid)
        except ValueError as e:
            error(f"scene {label!r}: {scene.as_written(str(e))}")
            return EXIT_USAGE
    session = getattr(args, "log_session", None)
    log = get_logger("cli")

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        removed = 0 if resume else _remove_previous_run(out_dir)
        if session is not None:
            session.add_file(out_dir, append=resume is not None)
        # several fluids: every frame holds each particle's phase and rest density
        extra = MULTIPHASE_FIELDS if len(sim.world.materials) > 1 else ()
        writer = FrameWriter(out_dir, formats, sim.dim, extra_fields=extra, attributes=attributes)
        bodies = BodyWriter.of(sim, out_dir, body_formats(formats, scene.output.body_formats))
        if resume:
            writer.resume_after(sim._frame)
            if bodies is not None:
                bodies.resume_after(sim._frame)
            manifest = resume.manifest(["sphkit", *argv])
        else:
            vtk_bodies = bodies is not None and "vtk" in bodies.formats
            manifest = Manifest(
                out_dir, scene, command=["sphkit", *argv],
                output={"directory": str(out_dir), "formats": formats, "fps": fps,
                        "dim": sim.dim, "attributes": attributes,
                        "series": writer.series_path.name if "vtk" in formats else None,
                        "body_series": bodies.series_path.name if vtk_bodies else None},
            )
            manifest.data["start"] = sim.world.start.to_dict()
            manifest.data["precision"] = sim.dtype.name  # also in scene.configuration
            manifest.data["device"] = sim.device
            manifest.write()
    except OSError as e:
        error(f"cannot write to the output folder {str(out_dir)!r}: {e}")
        return EXIT_FAILED

    report = reporter(until, args.quiet, sys.stderr)
    watch = watch_compiles(args)
    compiled_before = watch.seconds  # while the world was built (before the run's clock)
    if not args.quiet:  # a first compilation from here on is said above the progress line
        watch.on_first = lambda: _say(report, COMPILING)
    if session is not None and not args.quiet:
        session.console = report.message
    log.info("sphkit %s: %s", sphkit_version(), " ".join(["sphkit", *argv]),
             extra={"console": False})
    if removed:
        _say(report, f"removed {removed} file(s) of the previous run in {out_dir}")
    if resume:
        for line in resume.messages:
            _say(report, line)
    elif sim.world.start.settle_steps:
        st = sim.world.start
        _say(report, f"settled the fluid at rest before t = 0 in {st.settle_steps} steps "
                     f"({st.settle_time:.3g} s of damped time; RMS speed {st.settle_speed:.2g} "
                     "m/s): configuration.start.settle")
    _say(report,
        f"scene {scene.name!r}: {sim.fluid.n} fluid and {sim.boundary.n} boundary particles, "
        f"{sim.dim}D, until t = {until:g} s; {fps:g} frames/s as {', '.join(formats)} "
        f"into {out_dir}"
    )

    def on_frame(s: Any, k: int) -> None:
        files = writer.write(s, k)
        body_files = bodies.write(s, k) if bodies is not None else []
        manifest.add_frame(s, k, files, max_displacement=writer.max_displacement,
                           body_files=body_files)
        report.frame(s, k)
        rec = manifest.frames[-1]
        log.info("frame %d t=%.6g s step %d: max|v| %s m/s, dt %s s, rho err avg %s, iters %s",
                 k, s.time, s.step_count, fmt(rec["max_velocity"], ".3g"),
                 fmt(rec["dt"], ".3g"), fmt(rec["density_error_avg"], ".3g"),
                 fmt(rec["iterations"], "g"), extra={"console": False})

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
            _finish(manifest, watch, "interrupted",
                    f"{why} at step {sim.step_count}, t = {sim.time:.6g} s; checkpoint "
                    f"{checkpoints.relative(path)}", sim.last)
            error(f"{why} at t = {sim.time:.6g} s after step {sim.step_count}; the "
                   f"{len(manifest.frames)} frame(s) written so far are kept in {out_dir}; "
                   f"continue with: sphkit run --resume {out_dir}")
            return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
        if args.checkpoint_every is not None:
            checkpoints.write(sim)  # the end state, to extend the run with --resume --until
        manifest.data["compile_seconds"] = round(watch.seconds, 3)
        manifest.finish("finished", stats=sim.last)
    except InstabilityError as e:
        _finish(manifest, watch, "unstable", str(e), e.stats)
        error(f"{e}\nThe {len(manifest.frames)} frame(s) written so far are kept in {out_dir}.")
        return EXIT_UNSTABLE
    except KeyboardInterrupt as e:  # a second signal, or one outside the step loop
        terminated = isinstance(e, Terminated)
        why = "terminated (SIGTERM)" if terminated else "interrupted (Ctrl-C)"
        _finish(manifest, watch, "interrupted",
                f"{why} at step {sim.step_count}, t = {sim.time:.6g} s", sim.last)
        error(f"{why} at t = {sim.time:.6g} s; the {len(manifest.frames)} frame(s) written so "
               f"far are kept in {out_dir}")
        return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
    except (OSError, FrameFormatError) as e:
        _finish(manifest, watch, "failed", f"{type(e).__name__}: {e}", sim.last)
        error(f"writing the output failed: {e}")
        return EXIT_FAILED
    except BaseException as e:
        _finish(manifest, watch, "failed", f"{type(e).__name__}: {e}", sim.last)
        raise
    wall = time.perf_counter() - report.t0
    rs = manifest.run_stats
    solver = ""
    if rs.steps:
        solver = (f" (mean {fmt(rs.mean('iterations'), '.3g')} pressure iterations per step, "
                  f"density error {fmt(rs.mean('density_error'), '.3g', 100, '%')})")
    _say(report,
        f"finished: {len(manifest.frames)} frame(s), {sim.step_count} steps{solver} in "
        f"{wall:.1f} s{_compiling(watch.seconds - compiled_before)}; output in {out_dir}"
    )
    return EXIT_OK


def _compiling(seconds: float) -> str:
    """`` (N s of it compiling)`` where Numba compiled for a tenth of a second or more."""
    return f" ({seconds:.1f} s of it compiling)" if seconds >= 0.1 else ""


def _finish(manifest: Manifest, watch: Any, status: str, message: str, stats: Any) -> None:
    """Record how a run ended (and how long it compiled, ``watch``: the run's
    :class:`sphkit.io.compiling.CompileWatch`); a manifest that cannot be written must not mask
    why it ended."""
    manifest.data["compile_seconds"] = round(watch.seconds, 3)
    try:
        manifest.finish(status, message, stats=stats)
    except OSError as e:
        error(f"cannot write {str(manifest.path)!r}: {e}")
