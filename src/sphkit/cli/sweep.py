"""``sphkit sweep``: run randomised variants of a scene like ``sphkit run``, as Dask tasks.

::

    sphkit sweep SCENE --count N --vary PATH=LO:HI [...] [--seed S] [--out DIR]
                 [--until T] [--fps F] [--workers W] [--scheduler ADDR]

Each variant (:mod:`sphkit.scene.variants`) runs as one task (:mod:`sphkit.cli.ensemble`) with
``sphkit run``'s machinery (:func:`sphkit.cli.run.cmd_run`) into ``DIR/variant-00007/``: its
frames, ``manifest.json`` and ``sphkit.log``; ``variant.json``, written last, commits the folder
(values, status, fingerprint). ``DIR/sweep.json`` lists every variant: index, values, status
(``finished``, ``unstable``, ``failed``, ``pending``), message and folder, with the specs, the
seed and the base scene. A rerun runs only the variants without a finished run of the same
scene, end time and frame rate. DIR defaults to ``out/<scene name>-sweep``. Exit codes: 0 all
finished, 1 a variant failed, 2 bad arguments or scene, 3 a variant became unstable, 130
interrupted.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

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
    start,
    sweep_record,
)

SWEEP_NAME = "sweep.json"


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit sweep`` to the ``sphkit`` command's subcommands."""
    p = sub.add_parser(
        "sweep", help="run randomised variants of a scene (Dask tasks)",
        description="Run randomised variants of a scene like 'sphkit run', one Dask task each, "
                    "into DIR/variant-00000/, ... and list them in DIR/sweep.json.",
        epilog="Exit codes: 0 done, 1 failed, 2 bad arguments or scene, 3 a variant was "
               "unstable, 130 interrupted.")
    add_ensemble_arguments(p)
    p.set_defaults(handler=cmd_sweep)


def cmd_sweep(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit sweep``: return the exit code."""
    return guarded(lambda a: run_sweep(a), args)


def run_sweep(args: argparse.Namespace, kill_once: tuple[str, int] | None = None) -> int:
    """The command's work (``kill_once``: see :class:`~sphkit.cli.ensemble.Job`)."""
    from sphkit.io.atomic import atomic_write_text

    p, out = start(args, "sweep")
    # absolute: the workers (on other machines with --scheduler) write there
    jobs = [Job("sweep", k, values, scene, str(out.resolve() / f"variant-{k:05d}"),
                fingerprint("sweep", scene)) for k, values, scene in p.variants]
    execute(args, "sweep", jobs, len(jobs), kill_once)
    rows = []
    for j in jobs:
        rec = sweep_record(j) or {}
        rows.append({"variant": j.k, "values": j.values, "folder": Path(j.out).name,
                     "status": rec.get("status", "pending"), "message": rec.get("message")})
    doc = {"format": "sphkit-sweep", "format_version": 1, "seed": args.seed,
           "count": args.count, "vary": [s.as_dict() for s in p.specs],
           "scene": p.base.model_dump(mode="json"), "variants": rows}
    try:
        atomic_write_text(out / SWEEP_NAME, json.dumps(doc, indent=1) + "\n")
    except OSError as e:
        error(f"cannot write {str(out / SWEEP_NAME)!r}: {e}")
        return EXIT_FAILED
    n_ok = sum(r["status"] == "finished" for r in rows)
    say(args, f"sweep: {n_ok} of {len(rows)} variant(s) finished; {out / SWEEP_NAME}")
    bad = [r for r in rows if r["status"] != "finished"]
    if bad:
        error(f"{len(bad)} variant(s) did not finish: "
              + "; ".join(f"variant {r['variant']}: {r['status']}: {r['message']}"
                          for r in bad))
        return EXIT_UNSTABLE if any(r["status"] == "unstable" for r in bad) else EXIT_FAILED
    return EXIT_OK
