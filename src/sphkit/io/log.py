"""Logging: the library logs to the logger ``"sphkit"`` (and its children, e.g. ``"sphkit.io"``);
the ``sphkit`` command routes it to the console and to ``sphkit.log`` in the output folder.

The library never configures logging itself: an application that imports sphkit sees its records
through the usual ``logging`` configuration (they propagate to the root logger). The command
line uses :func:`command_logging` for the duration of a command:

* console: errors only with ``--quiet``, warnings and the command's own progress by default,
  everything down to debug records (per-step statistics) with ``--verbose``;
* ``<output folder>/sphkit.log``: info records and up (debug with ``--verbose``), each line
  ``2025-01-01 12:00:00,123 INFO sphkit.cli: message``. ``sphkit run`` starts a new log file;
  ``sphkit surface`` and ``sphkit render`` append to the run's.
"""

from __future__ import annotations

import logging
import os
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
            self.emit_text(self.format(record))
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
        self._handlers: list[logging.Handler] = [
            CallbackHandler(lambda text: self.console(text), console_level)
        ]
        self.log_file: Path | None = None

    def add_file(self, log_dir: str | os.PathLike[str], append: bool = False) -> Path:
        """Also log to ``<log_dir>/sphkit.log`` (a new file unless ``append``); return its path."""
        path = Path(log_dir) / LOG_FILE_NAME
        fh = logging.FileHandler(path, mode="a" if append else "w", encoding="utf-8")
        fh.setLevel(logging.DEBUG if self.verbose else logging.INFO)
        fh.setFormatter(logging.Formatter(_FILE_FORMAT))
        self._attach(fh)
        self.log_file = path
        return path

    def _attach(self, h: logging.Handler) -> None:
        self._handlers.append(h)
        self.logger.addHandler(h)


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
    try:
        yield session
    finally:
        for h in session._handlers:
            logger.removeHandler(h)
            h.close()
        logger.setLevel(old_level)
