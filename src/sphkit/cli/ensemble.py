"""Ensembles of scene variants as Dask tasks, shared by ``sphkit dataset`` and ``sphkit sweep``.

One task per variant (:func:`run_job`): it builds the variant's scene, simulates it and writes
its result atomically (``dataset``: ``DIR/variants/variant-00007.h5``; ``sweep``: the run folder
``DIR/variant-00007/`` with frames and manifest, committed by ``variant.json`` written last),
then returns a small summary. :func:`run_jobs` runs the tasks on a ``LocalCluster`` of
``workers`` processes (one task at a time each; a task's Numba kernels get
``cpu_count // workers`` threads), on a running scheduler (``--scheduler ADDRESS``), or in this
process with ``workers = 0``.

* A rerun skips the variants whose result is complete and was made from the same variant scene,
  end time and frame rate (the *fingerprint* stored in the result); it computes only the others.
* A worker that dies during a task (killed, out of memory) is replaced by its nanny and the
  scheduler runs the task again (distributed's ``distributed.scheduler.allowed-failures``, 3 by
  default: a task whose workers died more often fails as ``KilledWorker``); a task that raised
  is retried once (``retries=1``).
* A variant that becomes unstable (:class:`~sphkit.simulation.InstabilityError`) is not retried:
  it is recorded as failed with the diagnosis (``variant-00007.failed.json``, or the run's
  manifest) and reported; the command goes on with the others and exits 3.
* Progress: a line per finished variant on stderr, ``[done/total]``.
* Ctrl-C: the futures are cancelled, the client and the local cluster closed, exit 130.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: the module a dataset or sweep needs besides sphkit's own (the ``dataset`` extra)
EXTRA_HINT = "install sphkit[dataset] (pip install 'sphkit[dataset]': h5py, dask[distributed])"


@dataclass
class Job:
    """One variant: its index ``k``, its parameter ``values`` (path -> number), its scene (JSON
    form, end time and frame rate already set) and where its result goes."""

    kind: str  #: "dataset" or "sweep"
    k: int
    values: dict[str, Any]
    scene: dict[str, Any]
    out: str  #: dataset: the dataset folder; sweep: the variant's run folder
    fingerprint: str
    extra: dict[str, Any] = field(default_factory=dict)  #: provenance stored with the result
    #: test-only: (marker file, k): the task of variant k kills its own worker process the
    #: first time it runs (the marker file records that it did)
    kill_once: tuple[str, int] | None = None
    #: Numba threads of the task (``numba.set_num_threads``; None: all). Set at run time, not
    #: through NUMBA_NUM_THREADS: a process started with another thread count compiles anew
    #: and replaces the cached machine code of the parallel kernels
    threads: int | None = None

    @property
    def key(self) -> str:
        """The Dask key of the task."""
        return f"sphkit-{self.kind}-variant-{self.k:05d}-{self.fingerprint[:12]}"


def fingerprint(kind: str, scene: dict[str, Any]) -> str:
    """A hash of what decides a variant's result: the kind and the scene (values, end time and
    frame rate included)."""
    text = json.dumps({"kind": kind, "format": 1, "scene": scene}, sort_keys=True,
                      allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def sweep_marker(folder: str | os.PathLike[str]) -> Path:
    """The file that commits a sweep variant's run folder."""
    return Path(folder) / "variant.json"


def sweep_record(job: Job) -> dict[str, Any] | None:
    """The committed record of a sweep variant's run folder when it was made from the same
    fingerprint, else None."""
    try:
        with open(sweep_marker(job.out), encoding="utf-8") as f:
            rec = json.load(f)
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) and rec.get("fingerprint") == job.fingerprint else None


def is_complete(job: Job) -> bool:
    """Whether the result of ``job`` is on disk, complete and of the same fingerprint."""
    if job.kind == "dataset":
        from sphkit.io.datasets import read_variant, variant_path

        meta = read_variant(variant_path(job.out, job.k))
        return meta is not None and meta.get("fingerprint") == job.fingerprint
    rec = sweep_record(job)
    return rec is not None and rec.get("status") == "finished"


# -- the task -------------------------------------------------------------------------------------
def _maybe_kill(job: Job) -> None:
    if job.kill_once is None or job.kill_once[1] != job.k:
        return
    marker = Path(job.kill_once[0])
    if marker.exists():
        return
    marker.write_text(f"{os.getpid()}\n")
    os.kill(os.getpid(), signal.SIGKILL)


def run_job(job: Job) -> dict[str, Any]:
    """Simulate one variant and write its result (on a worker); return its summary: ``k``,
    ``status`` ("done", "unstable"), ``message``, ``wall_s`` and what the kind adds."""
    t0 = time.perf_counter()
    _maybe_kill(job)
    if job.threads is not None:
        import numba

        numba.set_num_threads(max(1, min(job.threads, numba.config.NUMBA_NUM_THREADS)))
    summary = _run_dataset(job) if job.kind == "dataset" else _run_sweep(job)
    summary.update(k=job.k, values=job.values, wall_s=round(time.perf_counter() - t0, 3),
                   pid=os.getpid())
    return summary


def _run_dataset(job: Job) -> dict[str, Any]:
    from sphkit import registry
    from sphkit.io.atomic import atomic_write_text
    from sphkit.io.datasets import MOVING_WALL, RIGID_BODY, TrajectoryRecorder, variant_path
    from sphkit.scene.files import scene_from_dict
    from sphkit.simulation import InstabilityError, Simulation

    scene = scene_from_dict(job.scene)
    sim = Simulation(scene)
    body_types = {b + 1: (RIGID_BODY if body.dynamic else MOVING_WALL)
                  for b, body in enumerate(sim.rigid.bodies)}
    # density and volume maps fill the boundary set with each step's virtual particles (their
    # number changes): such walls have no particles to store
    walls = registry.get("boundary", scene.configuration.boundary.method).kind == "particles"
    rec = TrajectoryRecorder(sim.fluid, sim.boundary, body_types, walls=walls)
    until, fps = scene.configuration.time.until, scene.output.fps
    failed = variant_path(job.out, job.k, failed=True)
    try:
        # frames at exactly k / fps: the learners difference them (Simulation.run)
        sim.run(until=until, fps=fps, exact_frames=True,
                on_frame=lambda s, k: rec.record(s.fluid, s.boundary, k))
        position = rec.array()
    except (InstabilityError, ValueError) as e:
        failed.parent.mkdir(parents=True, exist_ok=True)
        status = "unstable" if isinstance(e, InstabilityError) else "failed"
        atomic_write_text(failed, json.dumps({"variant": job.k, "status": status,
                                              "values": job.values, "message": str(e),
                                              "fingerprint": job.fingerprint}, indent=1))
        return {"status": status, "message": str(e), "steps": sim.step_count}
    from sphkit.io.datasets import write_variant

    write_variant(variant_path(job.out, job.k), position, rec.particle_type,
                  {"variant": job.k, "values": job.values, "fingerprint": job.fingerprint,
                   "steps": sim.step_count, "extent": rec.extent, "host": socket.gethostname(),
                   "pid": os.getpid(), "particle_radius": scene.configuration.particle_radius,
                   **job.extra})
    try:
        failed.unlink()
    except FileNotFoundError:
        pass
    return {"status": "done", "message": None, "steps": sim.step_count,
            "frames": int(position.shape[0]), "particles": int(position.shape[1])}


def _run_sweep(job: Job) -> dict[str, Any]:
    import argparse

    from sphkit.cli.run import cmd_run
    from sphkit.io.atomic import atomic_write_text
    from sphkit.io.manifest import read_manifest
    from sphkit.scene.files import scene_from_dict

    scene = scene_from_dict(job.scene)
    out = Path(job.out)
    out.mkdir(parents=True, exist_ok=True)
    args = argparse.Namespace(
        scene=f"{scene.name} variant {job.k}", scene_object=scene, until=None, out=out,
        fps=None, formats=None, checkpoint_every=None, keep_checkpoints=2, max_particles=None,
        precision=None,
        resume=None, quiet=True, verbose=False, log_session=None)
    code = cmd_run(args, ["sweep", "variant", str(job.k)])
    try:
        m = read_manifest(out)
        status = {"finished": "done"}.get(m.get("status"), m.get("status") or "failed")
        message = m.get("message")
        frames = len(m.get("frames") or [])
        steps = (m.get("run_stats") or {}).get("steps", "?")
    except (OSError, ValueError):
        status, message, frames, steps = "failed", f"exit code {code}, no manifest", 0, "?"

    record = {"variant": job.k, "values": job.values, "fingerprint": job.fingerprint,
              "status": "finished" if status == "done" else status, "message": message,
              "exit_code": code}
    atomic_write_text(sweep_marker(out), json.dumps(record, indent=1) + "\n")
    return {"status": status, "message": message, "frames": frames, "steps": steps,
            "exit_code": code}


# -- the runner -----------------------------------------------------------------------------------
def _failure(job: Job, e: BaseException) -> dict[str, Any]:
    return {"k": job.k, "values": job.values, "status": "failed",
            "message": f"{type(e).__name__}: {e}", "wall_s": None}


def run_jobs(jobs: Sequence[Job], *, workers: int = 2, scheduler: str | None = None,
             on_result: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Run ``jobs`` (one task each) and return their summaries in the order they finished;
    ``on_result(summary)`` is called as each finishes. ``scheduler``: the address of a running
    Dask scheduler; else a LocalCluster of ``workers`` processes, or this process with
    ``workers = 0``."""
    results: list[dict[str, Any]] = []

    def done(summary: dict[str, Any]) -> None:
        results.append(summary)
        if on_result is not None:
            on_result(summary)

    if not jobs:
        return results
    if scheduler is None and workers == 0:
        for job in jobs:
            try:
                done(run_job(job))
            except Exception as e:  # a task's own error: recorded, the others go on
                done(_failure(job, e))
        return results

    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        threads = max(1, (os.cpu_count() or 1) // max(workers, 1))
        for job in jobs:  # the local workers share this machine's cores
            job.threads = threads
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=40,
                               preload=["sphkit.cli.ensemble_worker"])
    try:
        client = Client(cluster if cluster is not None else scheduler)
        try:
            futures = {client.submit(run_job, job, key=job.key, pure=False, retries=1): job
                       for job in jobs}
            try:
                for fut in as_completed(list(futures)):
                    job = futures[fut]
                    try:
                        done(fut.result())
                    except Exception as e:  # KilledWorker, or the task's own error twice
                        done(_failure(job, e))
            except BaseException:
                client.cancel(list(futures))
                raise
        finally:
            client.close()
    finally:
        if cluster is not None:
            cluster.close()
    return results


# -- what dataset and sweep share on the command line ----------------------------------------------
def add_ensemble_arguments(p: Any, default_count: int | None = None) -> None:
    """SCENE, --count, --vary, --seed, --out, --until, --fps, --workers, --scheduler, -q/-v."""
    from sphkit.cli.common import add_verbosity, positive_float, positive_int
    from sphkit.scene.limits import MAX_FPS

    p.add_argument("scene", metavar="SCENE",
                   help="built-in scene name (see 'sphkit scenes') or scene file")
    p.add_argument("--count", type=positive_int, required=default_count is None,
                   default=default_count, metavar="N", help="number of variants")
    p.add_argument("--vary", action="append", default=[], metavar="PATH=LO:HI",
                   help="vary a number of the scene by its path, uniformly in [LO, HI] or "
                        "among V1,V2,... (repeatable), e.g. fluid_blocks.0.end.1=0.6:1.0, "
                        "materials.0.viscosity.coefficient=0.001:0.05; a SPlisHSPlasH scene "
                        "also by its own fields, e.g. FluidBlocks.0.end.1=1:1.5")
    p.add_argument("--seed", type=int, default=0, metavar="S",
                   help="random seed; variant k draws from default_rng([S, k]) (default 0)")
    p.add_argument("--out", type=Path, metavar="DIR", help="output folder")
    p.add_argument("--until", type=positive_float("simulated end time in seconds", "2.5"),
                   metavar="T", help="simulated end time [s] (default: the scene's)")
    p.add_argument("--fps", type=positive_float("frames per simulated second", "25", MAX_FPS),
                   metavar="F", help="frames per simulated second (default: the scene's)")
    p.add_argument("--workers", type=int, default=2, metavar="W",
                   help="worker processes of the local Dask cluster (default 2; 0: run the "
                        "variants one after another in this process)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="address of a running Dask scheduler (e.g. tcp://10.0.0.5:8786) "
                        "instead of a local cluster")
    add_verbosity(p)


def check_extra(args: Any, need_h5py: bool) -> str | None:
    """The error message when a module of the ``dataset`` extra is missing, else None."""
    import importlib.util

    names = (["h5py"] if need_h5py else []) + (
        ["distributed"] if args.scheduler is not None or args.workers > 0 else [])
    missing = [n for n in names if importlib.util.find_spec(n) is None]
    if missing:
        return f"{', '.join(missing)} not installed: {EXTRA_HINT}"
    return None


@dataclass
class Plan:
    """The base scene, the specs and the variants of an ensemble command."""

    base: Any
    specs: list[Any]
    variants: list[tuple[int, dict[str, Any], dict[str, Any]]]  #: (k, values, scene JSON)
    defaulted: bool


def plan(args: Any, kind: str) -> Plan:
    """Load the scene, apply --until/--fps, parse --vary (the dataset's default variation
    without it) and draw and validate every variant; SceneError naming path and value."""
    from sphkit.scene.files import load_scene
    from sphkit.scene.schema import Scene, SceneError
    from sphkit.scene.variants import (
        NativeScene,
        default_specs,
        parse_vary,
        sample_values,
        variant_scene,
    )

    if args.workers < 0:
        raise SceneError(f"--workers {args.workers}: expected 0 or more worker processes")
    base = load_scene(args.scene)
    if base.emitters and kind == "dataset":  # a sweep runs each variant as sphkit run does
        raise SceneError(f"scene {args.scene!r}: emitters[0]: the scene has emitters; expected "
                         "a scene of fixed particle count (a dataset's trajectories keep their "
                         "particles; vary an emitting scene with sphkit sweep)")
    if kind == "dataset":
        from sphkit.io.datasets import PHASE_TYPES
        from sphkit.scene.checks import fluid_materials

        fluids = fluid_materials(base)
        if len(fluids) > len(PHASE_TYPES):
            raise SceneError(
                f"scene {args.scene!r}: materials: {len(fluids)} fluid materials; a dataset "
                f"labels at most {len(PHASE_TYPES)} (one particle type each, LagrangeBench's "
                "free types 4-8 beside its FLUID 0)")

    def adjust(scene: Scene) -> None:  # the command's end time and frame rate
        if args.until is not None:
            scene.configuration.time.until = args.until
        if args.fps is not None:
            scene.output.fps = args.fps

    adjust(base)
    # a SPlisHSPlasH file may be varied in its own field names (Fluid.viscosity, ...)
    native = NativeScene.of(args.scene) if args.vary else None
    specs = [parse_vary(s, base, native) for s in args.vary]
    defaulted = False
    if not specs:
        if kind != "dataset":
            raise SceneError("no --vary given; expected at least one --vary PATH=LO:HI")
        specs, defaulted = default_specs(base), True
    variants = []
    for k in range(args.count):
        values = sample_values(specs, args.seed, k)
        scene = variant_scene(base, values, native, adjust)
        variants.append((k, values, scene.model_dump(mode="json")))
    return Plan(base, specs, variants, defaulted)


def start(args: Any, kind: str) -> tuple[Plan, Path]:
    """What ``dataset`` and ``sweep`` do first: check the extra's modules, :func:`plan` the
    variants and create the output folder (``--out``, else ``out/<scene>-<kind>``; a dataset's
    with its ``variants/``) with the command's log in it. A problem raises
    :class:`~sphkit.cli.common.UsageError` (exit 2) naming it."""
    from sphkit.cli.common import UsageError, open_log
    from sphkit.scene.schema import SceneError

    missing = check_extra(args, need_h5py=kind == "dataset")
    if missing:
        raise UsageError(missing)
    try:
        p = plan(args, kind)
    except (SceneError, OSError) as e:
        raise UsageError(str(e)) from None
    out: Path = args.out or Path("out") / f"{p.base.name}-{kind}"
    try:
        (out / "variants" if kind == "dataset" else out).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UsageError(f"cannot create the output folder {str(out)!r}: {e}") from None
    open_log(args, out)
    return p, out


def progress_printer(args: Any, total: int, already: int) -> Callable[[dict[str, Any]], None]:
    """``on_result`` for :func:`run_jobs`: a line ``[done/total] variant k: ...`` each."""
    from sphkit.cli.common import say

    count = [already]

    def show(s: dict[str, Any]) -> None:
        count[0] += 1
        values = ", ".join(f"{p}={v:.4g}" for p, v in (s.get("values") or {}).items())
        wall = f" in {s['wall_s']:.1f} s" if s.get("wall_s") is not None else ""
        what = s["status"]
        if what == "done":
            detail = f"{s.get('frames', '?')} frames, {s.get('steps', '?')} steps"
            if "particles" in s:
                detail = f"{s['particles']} particles, " + detail
            what = f"done{wall} ({detail})"
        else:
            what = f"{what}{wall}: {s.get('message')}"
        say(args, f"[{count[0]}/{total}] variant {s['k']} ({values}): {what}")

    return show


def execute(args: Any, kind: str, jobs: list[Job], total: int,
            kill_once: tuple[str, int] | None = None) -> list[dict[str, Any]]:
    """Skip the complete jobs, run the others with progress lines; return their summaries."""
    from sphkit.cli.common import say

    todo = [j for j in jobs if not is_complete(j)]
    for j in todo:
        j.kill_once = kill_once
    where = (f"the Dask scheduler at {args.scheduler}" if args.scheduler else
             f"a local Dask cluster of {args.workers} worker processes" if args.workers else
             "this process")
    say(args, f"{kind}: {total} variant(s): {total - len(todo)} already complete, "
              f"{len(todo)} to compute on {where}")
    return run_jobs(todo, workers=args.workers, scheduler=args.scheduler,
                    on_result=progress_printer(args, total, total - len(todo)))
