"""``sphkit dataset``: randomised variants of a scene as a dataset for learned simulators.

::

    sphkit dataset SCENE --count N [--vary PATH=LO:HI ...] [--seed S] [--out DIR]
                   [--split 0.8,0.1,0.1] [--until T] [--fps F] [--workers W] [--scheduler ADDR]

Draws N variants of the scene (:mod:`sphkit.scene.variants`: ``--vary`` names a number of the
scene by its path; without ``--vary`` each component of the first fluid block's ``end`` varies
uniformly between ``start + 0.5 (end - start)`` and ``end``, and the log says so), simulates
each as one Dask task (:mod:`sphkit.cli.ensemble`: a local cluster of ``--workers`` processes
by default, any running scheduler with ``--scheduler``) and writes LagrangeBench's layout into
DIR (default ``out/<scene name>-dataset``; :mod:`sphkit.io.datasets`): ``train.h5``,
``valid.h5``, ``test.h5`` and ``metadata.json``. Frames are stored at the scene's output rate
(``--fps``) up to its end time (``--until``). Each variant's trajectory is first written to
``DIR/variants/``; a rerun computes only the missing ones (a variant of another scene, end time
or frame rate counts as missing, and so does an unstable one: the rerun tries it again) and
assembles the dataset again.

The splits take the successful variants in index order: the first ``round(0.8 n)`` to train,
then valid, then test (``--split``; valid and test get at least one each from 3 variants on).
A variant that became unstable is left out of the dataset, listed with its diagnosis in
``metadata.json`` (``sphkit.failed``) and in ``variants/variant-00007.failed.json``, and the
command exits 3 (the dataset of the others is written). Scenes with emitters are refused (a
trajectory needs a fixed particle count). Exit codes: 0 done, 1 a variant failed (e.g. its
worker died repeatedly) or the output cannot be written, 2 bad arguments or scene (the message
names the ``--vary`` path and value), 3 a variant became unstable, 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sphkit.cli.common import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_UNSTABLE,
    error,
    guarded,
    say,
)
from sphkit.cli.ensemble import (
    Job,
    add_ensemble_arguments,
    execute,
    fingerprint,
    is_complete,
    start,
)


def _split(text: str) -> list[float]:
    try:
        parts = [float(s) for s in text.split(",")]
    except ValueError:
        parts = []
    if (len(parts) != 3 or not all(math.isfinite(p) and p >= 0 for p in parts)
            or parts[0] <= 0):
        raise argparse.ArgumentTypeError(
            f"got {text!r}; expected three fractions train,valid,test >= 0 (train > 0), "
            "e.g. 0.8,0.1,0.1")
    return parts


_split.__name__ = "split fractions"


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit dataset`` to the ``sphkit`` command's subcommands."""
    p = sub.add_parser(
        "dataset", help="randomised variants of a scene as a LagrangeBench dataset (HDF5)",
        description="Simulate randomised variants of a scene as Dask tasks and write them in "
                    "LagrangeBench's layout: train.h5, valid.h5, test.h5, metadata.json.",
        epilog="Without --vary, the first fluid block's end varies between its middle and its "
               "end on each axis. Exit codes: 0 done, 1 failed, 2 bad arguments or scene, "
               "3 a variant was unstable, 130 interrupted.")
    add_ensemble_arguments(p)
    p.add_argument("--split", type=_split, default=[0.8, 0.1, 0.1], metavar="F,F,F",
                   help="fractions of train, valid, test (default 0.8,0.1,0.1)")
    p.set_defaults(handler=cmd_dataset)


def cmd_dataset(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit dataset``: return the exit code."""
    return guarded(lambda a: make_dataset(a, argv), args)


def make_dataset(args: argparse.Namespace, argv: Sequence[str] = (),
                 kill_once: tuple[str, int] | None = None) -> int:
    """The command's work (``kill_once``: the test-only hook of :class:`~sphkit.cli.ensemble.Job`,
    a variant whose task kills its worker the first time)."""
    p, out = start(args, "dataset")
    if p.defaulted:
        say(args, "no --vary given: varying the first fluid block's end on each axis between "
                  "its middle and its end: " + " ".join(s.text() for s in p.specs))
    # absolute: the workers (on other machines with --scheduler) write there
    jobs = [Job("dataset", k, values, scene, str(out.resolve()), fingerprint("dataset", scene))
            for k, values, scene in p.variants]
    results = execute(args, "dataset", jobs, len(jobs), kill_once)
    status = {r["k"]: r for r in results}
    good = [j.k for j in jobs if is_complete(j)]
    bad = [status[j.k] for j in jobs if j.k in status and status[j.k]["status"] != "done"]
    if not good:
        error(f"no variant finished; nothing to assemble in {out}")
        return EXIT_UNSTABLE if any(b["status"] == "unstable" for b in bad) else EXIT_FAILED
    try:
        md = _assemble(args, p, out, good, bad)
    except OSError as e:
        error(f"cannot write the dataset in {str(out)!r}: {e}")
        return EXIT_FAILED
    say(args, f"dataset: {md['num_trajs_train']} train, {md['num_trajs_valid']} valid, "
              f"{md['num_trajs_test']} test trajectories of {md['num_frames']} frames "
              f"(up to {md['num_particles_max']} particles, {md['dim']}D) in {out}")
    if bad:
        error(f"{len(bad)} variant(s) failed: "
              + "; ".join(f"variant {b['k']}: {b['status']}: {b['message']}" for b in bad))
        return EXIT_UNSTABLE if any(b["status"] == "unstable" for b in bad) else EXIT_FAILED
    return EXIT_OK


def _assemble(args: argparse.Namespace, p: Any, out: Path, good: list[int],
              bad: list[dict[str, Any]]) -> dict[str, Any]:
    import importlib.metadata

    from sphkit.io.datasets import assemble_dataset
    from sphkit.io.manifest import library_versions, sphkit_version

    base = p.base
    cfg = base.configuration
    r = cfg.particle_radius
    g = cfg.gravity[:cfg.dim]
    try:
        h5 = importlib.metadata.version("h5py")
    except importlib.metadata.PackageNotFoundError:
        h5 = None
    versions = library_versions()
    metadata = {
        "case": base.name, "solver": f"sphkit {cfg.pressure.method}", "dim": cfg.dim,
        "dt": 1.0 / base.output.fps, "t_end": cfg.time.until,
        "viscosity": base.materials[0].viscosity.coefficient,
        "g_ext_magnitude": float(sum(x * x for x in g) ** 0.5),
    }
    provenance = {
        "scene": base.model_dump(mode="json"), "vary": [s.as_dict() for s in p.specs],
        "vary_defaulted": p.defaulted, "seed": args.seed, "count": args.count,
        "split": list(args.split), "fps": base.output.fps, "until": cfg.time.until,
        "particle_radius": r, "smoothing_length": 4.0 * r,
        "failed": [{"variant": b["k"], "status": b["status"], "values": b.get("values"),
                    "message": b["message"]} for b in bad],
        "versions": {"sphkit": sphkit_version(), "numpy": versions.get("numpy"),
                     "numba": versions.get("numba"), "h5py": h5,
                     "python": versions.get("python")},
    }
    return assemble_dataset(out, good, args.split, metadata, provenance, radius=r,
                            periodic_x=cfg.periodic_x)
