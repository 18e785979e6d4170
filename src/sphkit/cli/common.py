"""What the subcommands of ``sphkit`` share: exit codes, the error printer, argument types,
verbosity flags, log lines, and reading a run folder (``surface``, ``render``).

Errors are written by :func:`error` (``sphkit: error: ...`` on stderr, and into ``sphkit.log``
when the command has one; ``sphkit compat`` prints its few on stdout with its table) and name the
value and what was expected; the argument types below raise :class:`argparse.ArgumentTypeError`
with such a message, which argparse prints with the usage line (exit code 2). Every module of
the command logs to the logger ``"sphkit.cli"`` (:func:`sphkit.io.log.get_logger` ``("cli")``).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import sys
import types
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from sphkit.io.log import get_logger
from sphkit.io.manifest import MANIFEST_NAME, read_manifest

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_UNSTABLE = 3
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

#: the handler a subcommand module registers with ``parser.set_defaults(handler=...)``: it gets
#: the parsed arguments and the command line (without ``sphkit``) and returns the exit code
Handler = Callable[[argparse.Namespace, Sequence[str]], int]

#: the folder of ``sphkit surface``'s meshes in a run folder, and its index
SURFACE_DIR = "surface"
SURFACE_MANIFEST = "surface.json"

log = get_logger("cli")


# -- messages ------------------------------------------------------------------------------------
#: the longest error message printed (characters; the rest is cut)
MAX_MESSAGE = 4000


def error(text: str) -> None:
    """``sphkit: error: <text>`` on stderr, and an error record in the log file (cut after
    :data:`MAX_MESSAGE` characters)."""
    if len(text) > MAX_MESSAGE:
        text = text[:MAX_MESSAGE] + f"... ({len(text) - MAX_MESSAGE} more characters)"
    print(f"sphkit: error: {text}", file=sys.stderr, flush=True)
    log.error(text, extra={"console": False})


def say(args: argparse.Namespace, text: str) -> None:
    """An informational line on stderr (unless ``--quiet``) and in the log file."""
    if not args.quiet:
        print(text, file=sys.stderr, flush=True)
    log.info(text, extra={"console": False})


#: the line said as a run's first compilation starts (:func:`watch_compiles`)
COMPILING = ("compiling with Numba: the first run of these methods on this machine (about a "
             "minute for the default scene; cached for the next runs)")


def watch_compiles(args: argparse.Namespace) -> Any:
    """Start the command's :class:`sphkit.io.compiling.CompileWatch` (kept as
    ``args.compile_watch``; call once the simulation's modules are imported): its first
    compilation is announced with :data:`COMPILING` (unless ``--quiet``), since a first run
    pauses for up to a minute before its first step with no progress to show."""
    from sphkit.io.compiling import CompileWatch

    watch = getattr(args, "compile_watch", None)
    if watch is None:
        watch = CompileWatch(on_first=lambda: say(args, COMPILING)).start()
        args.compile_watch = watch
    return watch


def open_log(args: argparse.Namespace, folder: Path) -> None:
    """Append the command's log to ``sphkit.log`` in ``folder`` (a run folder)."""
    session = getattr(args, "log_session", None)
    if session is not None:
        try:
            session.add_file(folder, append=True)
        except OSError as e:
            raise UsageError(f"cannot write the log file in {str(folder)!r}: {e}") from None


class Interrupts:
    """Ctrl-C while a command starts (imports, building the simulation): the handler records
    the signal and raises KeyboardInterrupt as Python's own does. Some libraries catch every
    exception around their optional imports (trimesh: ``except BaseException``), which swallows
    the KeyboardInterrupt or turns it into a later, unrelated error; the record tells the command
    that it was interrupted all the same (:meth:`check`)."""

    received: int | None = None

    @classmethod
    def handler(cls, signum: int, frame: types.FrameType | None) -> None:
        """The SIGINT handler: record, then raise KeyboardInterrupt -- unless the signal arrived
        while Numba compiles (a frame of numba's or llvmlite's code on the stack). There an
        exception is unsafe: raised in a ctypes callback from LLVM it is printed and dropped,
        and raised in Numba's pipeline it leaves LLVM's objects half-built, whose finalisation
        crashed the process (SIGSEGV) or the compilation went on for a minute before the
        interrupt reached sphkit's code. Nothing has been written then that an exit would leave
        inconsistent (frames and checkpoints are written atomically, between steps), so the
        command ends at once: the log is flushed, the one line printed, exit code 130."""
        cls.received = signum
        f = frame
        while f is not None:
            name = f.f_code.co_filename.replace("\\", "/")
            if "/llvmlite/" in name or "/numba/" in name:
                exit_now(f"interrupted while compiling ({signal_name(signum)})")
            f = f.f_back
        raise KeyboardInterrupt

    @classmethod
    def check(cls) -> None:
        """Raise KeyboardInterrupt if a SIGINT arrived (even one a library swallowed)."""
        if cls.received is not None:
            raise KeyboardInterrupt


def signal_name(signum: int) -> str:
    """``SIGINT`` for 2, and so on."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def exit_now(why: str, code: int = 130) -> NoReturn:
    """End the process at once with ``code`` after flushing the log and printing ``sphkit:
    error: why`` (no interpreter shutdown: no finalisers, no atexit)."""
    for h in logging.getLogger("sphkit").handlers + logging.getLogger().handlers:
        try:
            h.flush()
        except Exception:  # noqa: BLE001 -- a broken handler must not keep the process alive
            pass
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 -- a closed pipe: nothing more to say
            pass
    os.write(2, f"sphkit: error: {why}\n".encode())
    os._exit(code)


class UsageError(Exception):
    """A problem with the arguments or the run folder (exit code 2)."""


def guarded(command: Callable[[argparse.Namespace], int], args: argparse.Namespace) -> int:
    """Run ``command(args)``; a :class:`UsageError` is printed (exit code 2), Ctrl-C too (130)."""
    try:
        return command(args)
    except UsageError as e:
        error(str(e))
        return EXIT_USAGE
    except KeyboardInterrupt:
        error("interrupted")
        return EXIT_INTERRUPTED


# -- argument types: each names the value and what was expected ---------------------------------
def _shown(text: str) -> str:
    """An argument as a message repeats it (cut after 60 characters)."""
    return repr(text) if len(text) <= 60 else repr(text[:60]) + f"... ({len(text)} characters)"


def positive_float(what: str, example: str,
                   upper: float | None = None) -> Callable[[str], float]:
    """A positive finite number (at most ``upper``); the message names ``what`` and gives
    ``example``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(
                f"got {_shown(text)}; expected a positive number: {what}, e.g. {example}"
            )
        if upper is not None and value > upper:
            raise argparse.ArgumentTypeError(
                f"got {_shown(text)}; expected a positive number of at most {upper:g}: {what}, "
                f"e.g. {example}"
            )
        return value

    parse.__name__ = "positive number"
    return parse


def positive_int(text: str) -> int:
    """A positive integer (``20000000`` or ``2e7``)."""
    try:
        value = int(text)
    except ValueError:
        try:
            f = float(text)
            value = int(f) if math.isfinite(f) and f == int(f) else 0
        except (ValueError, OverflowError):
            value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(
            f"got {_shown(text)}; expected a positive integer, e.g. 2")
    return value


positive_int.__name__ = "positive integer"


def positive(what: str, integer: bool = False, allow_zero: bool = False) -> Callable[[str], Any]:
    """A number (an integer with ``integer``) > 0, or >= 0 with ``allow_zero``."""

    def parse(text: str) -> float:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = math.nan
        ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
        if not ok:
            kind = "an integer" if integer else "a number"
            raise argparse.ArgumentTypeError(
                f"got {_shown(text)}; expected {kind} {'>= 0' if allow_zero else '> 0'}: {what}"
            )
        return value

    parse.__name__ = "number"
    return parse


def choices_list(choices: Sequence[str], example: str,
                 noun: str = "") -> Callable[[str], list[str]]:
    """A comma-separated list of ``choices`` (lower case, duplicates dropped); the message
    lists them after ``noun`` (e.g. ``"the formats "``) and gives ``example``."""

    def parse(text: str) -> list[str]:
        names = [s.strip().lower() for s in text.split(",") if s.strip()]
        bad = [n for n in names if n not in choices]
        if bad or not names:
            what = f"unknown format {bad[0]!r} in {text!r}" if bad else f"got {text!r}"
            raise argparse.ArgumentTypeError(
                f"{what}; expected a comma-separated list of {noun}{', '.join(choices)} "
                f"(e.g. {example})"
            )
        return list(dict.fromkeys(names))

    parse.__name__ = "format list"
    return parse


def parse_frames(text: str) -> list[tuple[int, int | None, int]]:
    """``7``, ``0:50``, ``0:50:5``, ``10:`` or a comma-separated list -> (start, stop, step)."""
    out = []
    for part in text.split(","):
        part = part.strip()
        try:
            if ":" in part:
                bits = part.split(":")
                if len(bits) > 3:
                    raise ValueError
                start = int(bits[0]) if bits[0] else 0
                stop = int(bits[1]) if len(bits) > 1 and bits[1] else None
                step = int(bits[2]) if len(bits) > 2 and bits[2] else 1
            else:
                start = int(part)
                stop, step = start + 1, 1
            if start < 0 or step < 1 or (stop is not None and stop < 0):
                raise ValueError
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"got {_shown(text)}; expected frame numbers like 7, 0:50, 0:50:5 or 0,10,20"
            ) from None
        out.append((start, stop, step))
    return out


parse_frames.__name__ = "frame selection"


def add_verbosity(p: argparse.ArgumentParser, exclusive: bool = True,
                  verbose_help: str = "also print the library's log") -> None:
    """``--quiet``/``-q`` and ``--verbose``/``-v`` (one of them with ``exclusive``)."""
    g: Any = p.add_mutually_exclusive_group() if exclusive else p
    g.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")
    g.add_argument("--verbose", "-v", action="store_true", help=verbose_help)


# -- run folders (surface, render) ---------------------------------------------------------------
def run_info(outdir: Path) -> dict[str, Any]:
    """What the manifest of the run folder ``outdir`` says about its frames and scene."""
    if not (outdir / MANIFEST_NAME).is_file():
        raise UsageError(f"OUTDIR {str(outdir)!r}: no {MANIFEST_NAME}; expected the folder of a "
                         "'sphkit run'")
    try:
        m = read_manifest(outdir)
        scene = m.get("scene") or {}
        cfg = scene.get("configuration") or {}
        materials = scene.get("materials") or [{}]
        gravity = cfg.get("gravity") or [0.0, -9.81, 0.0]
        return {
            "manifest": m,
            "frames": list(m.get("frames") or []),
            "dim": int((m.get("output") or {}).get("dim") or cfg.get("dim") or 3),
            "fps": float((m.get("output") or {}).get("fps") or 25.0),
            "radius": float(cfg.get("particle_radius") or 0.025),
            "density0": float(materials[0].get("density0") or 1000.0),
            "up": int(np.argmax(np.abs(gravity))) if any(gravity) else 1,
            "boxes": scene.get("boxes") or [],
        }
    except (OSError, ValueError, TypeError, AttributeError) as e:
        raise UsageError(f"OUTDIR {str(outdir)!r}: unreadable {MANIFEST_NAME} ({e})") from None


def frame_file(outdir: Path, rec: dict[str, Any]) -> Path | None:
    """The particle file of a frame record, preferring the fastest to read."""
    files = [outdir / f for f in rec.get("files", [])]
    rank = {".bgeo": 0, ".gz": 1, ".ply": 2, ".vtu": 3}
    files = [f for f in files if f.is_file()]
    files.sort(key=lambda f: rank.get(f.suffix.lower(), 9))
    return files[0] if files else None


def _selected(k: int, spec: list[tuple[int, int | None, int]] | None) -> bool:
    if not spec:
        return True
    return any(k >= a and (b is None or k < b) and (k - a) % s == 0 for a, b, s in spec)


def selected_frames(info: dict[str, Any],
                    spec: list[tuple[int, int | None, int]] | None) -> list[dict[str, Any]]:
    """The frame records of :func:`run_info` that the ``--frames`` selection ``spec`` names."""
    frames = [rec for rec in info["frames"] if _selected(int(rec["frame"]), spec)]
    if not frames:
        raise UsageError("no frames to process: the run has none"
                         + (" in the --frames selection" if spec else ""))
    return frames
