"""The ``sphkit`` command.

::

    sphkit run [SCENE] [--until T] [--out DIR] [--fps F] [--format vtk,ply,bgeo] [--quiet|--verbose]
    sphkit surface OUTDIR [--format obj,ply,vtk] [--radius R] [--smoothing-length 2] ...
    sphkit render OUTDIR [--color velocity|pressure|density] [--video auto|mp4|gif|none] ...
    sphkit run --resume DIR [--until T]
    sphkit compat [--markdown docs/compatibility.md] [--radius-scale F] [--steps N]
    sphkit scenes
    sphkit dataset SCENE --count N [--vary PATH=LO:HI ...] [--seed S] [--out DIR] [--split F,F,F]
                   [--until T] [--fps F] [--workers W] [--scheduler ADDRESS]
    sphkit sweep SCENE --count N --vary PATH=LO:HI [...] [--out DIR] [--workers W] ...
    sphkit learn train DATASET | rollout MODEL SCENE | eval MODEL DATASET   (sphkit[learn])
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

``sphkit dataset`` writes randomised variants of a scene in LagrangeBench's HDF5 layout (train,
valid and test files, ``metadata.json``) for learned simulators; ``sphkit sweep`` runs them like
``sphkit run``, one folder each. Both run one Dask task per variant (a local cluster, or
``--scheduler``), redo a variant whose worker died, and on a rerun compute only the missing
variants (the ``dataset`` extra: h5py, dask[distributed]).

Logging: the library logs to the logger ``"sphkit"``; a command writes it, with its progress
lines, to ``sphkit.log`` in the output folder (``run`` starts the file, ``surface`` and
``render`` append). ``--quiet`` prints only errors, ``--verbose`` also the library's info and
debug records (per-step statistics) on the console and in the log file.

One module per subcommand: :mod:`sphkit.cli.run` (with :mod:`sphkit.cli.progress` and
:mod:`sphkit.cli.resume`), :mod:`sphkit.cli.scenes`, :mod:`sphkit.cli.surface`,
:mod:`sphkit.cli.render`, :mod:`sphkit.cli.compat`, :mod:`sphkit.cli.dataset` and
:mod:`sphkit.cli.sweep` (variants of a scene as Dask tasks, :mod:`sphkit.cli.ensemble`),
:mod:`sphkit.cli.learn` (learned simulators; PyTorch is imported only when one of its commands
runs); what they share (exit codes, the error printer, argument types, verbosity flags, run
folders) is in :mod:`sphkit.cli.common`. A subcommand module has ``add_parser(sub)``, which adds
its parser and sets its handler (``parser.set_defaults(handler=cmd)``, a
:data:`~sphkit.cli.common.Handler`: ``cmd(args, argv) -> exit code``); adding a subcommand is
a new module and its line in :data:`COMMANDS`.
"""

from __future__ import annotations

import os
import signal
import sys
import threading


def _interrupted_at_start(signum: int, frame: object) -> None:
    """Ctrl-C while the command's modules are imported: exit 130 at once, no traceback."""
    os.write(2, b"sphkit: error: interrupted\n")
    os._exit(130)


# Installed before the heavy imports below (NumPy, meshio, ...: the first half second of every
# command), restored once they are done; from then on main() turns Ctrl-C into exit code 130.
# A process started with SIGINT ignored (nohup, a background job) keeps ignoring it.
_MAIN = (threading.current_thread() is threading.main_thread()
         and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
_previous = signal.signal(signal.SIGINT, _interrupted_at_start) if _MAIN else None

import argparse  # noqa: E402
from collections.abc import Sequence  # noqa: E402

from sphkit.cli import (  # noqa: E402
    compat,
    dataset,
    learn,
    methods,
    render,
    run,
    scenes,
    surface,
    sweep,
)
from sphkit.cli.common import (  # noqa: E402
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USAGE,
    Interrupts,
)
from sphkit.io.log import command_logging  # noqa: E402
from sphkit.io.manifest import sphkit_version  # noqa: E402

if _MAIN:
    signal.signal(signal.SIGINT, _previous if _previous is not None else signal.SIG_DFL)

__all__ = ["COMMANDS", "build_parser", "main"]

#: the subcommand modules, in the order ``sphkit --help`` lists them
COMMANDS = (run, scenes, methods, surface, render, compat, dataset, sweep, learn)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``sphkit`` command."""
    parser = argparse.ArgumentParser(
        prog="sphkit",
        description="Smoothed Particle Hydrodynamics for computer graphics.",
    )
    parser.add_argument("--version", action="version", version=f"sphkit {sphkit_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``sphkit`` command with ``argv`` (default ``sys.argv[1:]``); return the exit code.

    Ctrl-C at any point (also while a command imports its modules or builds its simulation)
    ends the command with exit code 130 (SIGTERM in a run: 143) and one line, no traceback."""
    Interrupts.received = None
    own = (threading.current_thread() is threading.main_thread()
           and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    if own:
        signal.signal(signal.SIGINT, Interrupts.handler)
    try:
        return _main(argv)
    except BaseException as e:  # outside the command's own handling: no log to write to
        interrupt = isinstance(e, KeyboardInterrupt)
        if not interrupt and (Interrupts.received is None or not isinstance(e, Exception)):
            raise
        # a KeyboardInterrupt, or an error that followed a Ctrl-C a library swallowed
        terminated = isinstance(e, run.Terminated)
        print(f"sphkit: error: {'terminated' if terminated else 'interrupted'}", file=sys.stderr,
              flush=True)
        return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
    finally:
        if own:
            signal.signal(signal.SIGINT, signal.default_int_handler)


def _main(argv: Sequence[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help, --version, or a usage error (already printed)
        return e.code if isinstance(e.code, int) else EXIT_USAGE
    with command_logging(quiet=getattr(args, "quiet", False),
                         verbose=getattr(args, "verbose", False)) as session:
        args.log_session = session
        return args.handler(args, argv)
