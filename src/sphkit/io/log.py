"""Logging: the library logs to the logger ``"sphkit"`` (and its children, e.g. ``"sphkit.io"``);
the ``sphkit`` command routes it to the console and to ``sphkit.log`` in the output folder.

The library never configures logging itself: an application that imports sphkit sees its records
through the usual ``logging`` configuration (they propagate to the root logger). The command
line uses :func:`command_logging` for the duration of a command:

* console: errors only with ``--quiet``, warnings and the command's own progress by default,
  everything down to debug records (per-step statistics) with ``--verbose``. A warning that
  repeats (the same text but for its numbers: a solver that misses its tolerance step after
  step) is shown :data:`REPEATS` times; the later ones are counted, and the count is said once
  when the command ends (:class:`RepeatLimit`; ``--verbose`` shows them all);
* ``<output folder>/sphkit.log``: info records and up (debug with ``--verbose``), each line
  ``2025-01-01 12:00:00,123 INFO sphkit.cli: message``, every repeat included, and the records
  of the command before the folder was known (the scene's warnings) at its start.
  ``sphkit run`` starts a new log file; ``sphkit surface`` and ``sphkit render`` append to the
  run's.
* Python warnings that sphkit's modules (and the libraries under them) issue while a command
  runs -- a scene field sphkit ignores, a coarse map -- go through the same logger as ``WARNING:
  message`` lines (:func:`_show_warning`), not as Python's ``file:line: UserWarning`` display
  with a line of source code under it; where warnings are being recorded (``warnings.
  catch_warnings(record=True)``, pytest) they are left to the recorder.
"""

from __future__ import annotations

import logging
import os
import re
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

LOGGER_NAME = "sphkit"
LOG_FILE_NAME = "sphkit.log"
_FILE_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


def get_logger(name: str | None = None) -> logging.Logger:
    """The logger ``"sphkit"`` or its child ``"sphkit.<name>"``."""
    return logging.getLogger(LOGGER_NAME if not name else f"{LOGGER_NAME}.{name}")


def console_level(quiet: bool = False, verbose: bool = False) -> int:
    """The console's level for ``--quiet`` (errors), ``--verbose`` (debug) or neither (warnings)."""
    if quiet:
        return logging.ERROR
    if verbose:
        return logging.DEBUG
    return logging.WARNING


#: how many warnings of one kind the console shows (:class:`RepeatLimit`)
REPEATS = 3
#: what the console adds to the last warning of a kind that it shows
NOTE = " [shown {} times; the later ones of this kind are counted at the end]"
#: the numbers in a message, which do not make it another kind of warning
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


class RepeatLimit(logging.Filter):
    """A console filter that lets through at most ``limit`` warnings of each kind: the same
    logger and the same text once its numbers are left out (``... no convergence in 100
    iterations at step 4 ...`` and ``... at step 5 ...`` are one kind). The last one shown says
    so; the others are counted (:meth:`summary`). Errors always pass."""

    def __init__(self, limit: int = REPEATS) -> None:
        super().__init__()
        self.limit = limit
        #: kind -> [times seen, the first message]
        self.seen: dict[tuple[str, str], list] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno != logging.WARNING:
            return True
        text = record.getMessage()
        entry = self.seen.setdefault((record.name, _NUMBER.sub("#", text)), [0, text])
        entry[0] += 1
        # the last one shown says what happens to the others (CallbackHandler adds the note)
        record.sphkit_note = NOTE.format(self.limit) if entry[0] == self.limit else ""
        return entry[0] <= self.limit

    def summary(self, log_file: Path | None) -> list[str]:
        """One line per kind that was cut: how many were not shown, and where they are."""
        where = f"all of them in {log_file}" if log_file is not None else "not written anywhere"
        return [f"WARNING: {n - self.limit} more like \"{first}\" were not shown ({where})"
                for n, first in self.seen.values() if n > self.limit]


class CallbackHandler(logging.Handler):
    """Hands each formatted record to ``emit_text`` (e.g. a progress display's print)."""

    def __init__(self, emit_text: Callable[[str], None], level: int = logging.NOTSET) -> None:
        super().__init__(level)
        self.emit_text = emit_text
        self.setFormatter(logging.Formatter("%(levelname)s: %(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        if getattr(record, "console", True) is False:  # meant for the log file only
            return
        try:
            self.emit_text(self.format(record) + getattr(record, "sphkit_note", ""))
        except Exception:  # a broken console must not stop the simulation
            self.handleError(record)


class LogSession:
    """The logging of one command: a console handler now, a log file once the output folder is
    known (:meth:`add_file`). ``console`` (a callable taking a line) may be replaced while the
    command runs, e.g. by a progress display's print."""

    def __init__(self, verbose: bool, console_level: int) -> None:
        self.verbose = verbose
        self.logger = get_logger()
        self.console: Callable[[str], None] = _print_stderr
        console = CallbackHandler(lambda text: self.console(text), console_level)
        self.repeats: RepeatLimit | None = None if verbose else RepeatLimit()
        if self.repeats is not None:
            console.addFilter(self.repeats)
        # the records before the log file exists, written to it when it is added
        self._early = _Backlog(logging.DEBUG if verbose else logging.INFO)
        self._handlers: list[logging.Handler] = [console, self._early]
        self.log_file: Path | None = None

    def add_file(self, log_dir: str | os.PathLike[str], append: bool = False) -> Path:
        """Also log to ``<log_dir>/sphkit.log`` (a new file unless ``append``), starting with
        the command's records so far; return its path."""
        path = Path(log_dir) / LOG_FILE_NAME
        fh = logging.FileHandler(path, mode="a" if append else "w", encoding="utf-8")
        fh.setLevel(logging.DEBUG if self.verbose else logging.INFO)
        fh.setFormatter(logging.Formatter(_FILE_FORMAT))
        if self._early in self._handlers:  # the first file: the records so far, then no more
            for record in self._early.records:
                if record.levelno >= fh.level:
                    fh.handle(record)
            self._handlers.remove(self._early)
            self.logger.removeHandler(self._early)
            self._early.close()
        self._attach(fh)
        self.log_file = path
        return path

    def finish(self) -> None:
        """Say how many warnings the console left out (:class:`RepeatLimit`)."""
        if self.repeats is not None:
            for line in self.repeats.summary(self.log_file):
                _print_stderr(line)

    def _attach(self, h: logging.Handler) -> None:
        self._handlers.append(h)
        self.logger.addHandler(h)


class _Backlog(logging.Handler):
    """Keeps the records of a command until its log file is known (:meth:`LogSession.add_file`);
    at most :data:`BACKLOG` of them."""

    def __init__(self, level: int) -> None:
        super().__init__(level)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        if len(self.records) < BACKLOG:
            self.records.append(record)


#: the most records kept before the log file exists
BACKLOG = 1000


def _recording() -> bool:
    """True where Python's warnings are being recorded rather than shown
    (``warnings.catch_warnings(record=True)`` appends them to a list; pytest does so in every
    test)."""
    impl = getattr(warnings, "_showwarnmsg_impl", None)
    return isinstance(getattr(impl, "__self__", None), list)


def _show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  file: object = None, line: str | None = None) -> None:
    """``warnings.showwarning`` while a command runs: the warning as a record of the sphkit
    logger (its text; the category's name unless it is a plain UserWarning), or to the
    recorder where one is active."""
    if _recording():
        warnings._showwarnmsg_impl(  # type: ignore[attr-defined]
            warnings.WarningMessage(message, category, filename, lineno, file, line))
        return
    text = str(message)
    if category is not UserWarning:
        text = f"{category.__name__}: {text}"
    get_logger().warning("%s", text)


def _print_stderr(text: str) -> None:
    import sys

    print(text, file=sys.stderr, flush=True)


@contextmanager
def command_logging(*, quiet: bool = False, verbose: bool = False) -> Iterator[LogSession]:
    """Route the ``"sphkit"`` logger to the console (see :func:`console_level`) while the block
    runs, and to a log file once :meth:`LogSession.add_file` is called; yield the session."""
    session = LogSession(verbose, console_level(quiet, verbose))
    logger = session.logger
    old_level = logger.level
    logger.setLevel(logging.DEBUG if verbose else logging.INFO)
    for h in session._handlers:
        logger.addHandler(h)
    old_show = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        yield session
    finally:
        warnings.showwarning = old_show
        session.finish()
        for h in session._handlers:
            logger.removeHandler(h)
            h.close()
        logger.setLevel(old_level)
