"""Atomic file writes: a reader sees either the old file or the complete new one, never a part.

Every file sphkit writes goes through here. The data is written to a temporary file in the same
folder (``.<name>.tmp-<pid>-<token>``, hidden and on the same file system), flushed to disk with
``fsync`` and then moved onto the final name with :func:`os.replace`, which is atomic on POSIX and
Windows. If writing fails -- an exception, a full disk, Ctrl-C -- the temporary file is removed,
the final name is left as it was and the exception propagates.

Three forms, for three kinds of writer::

    # a writer that takes a path
    atomic_write(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))
    # the same, as a block
    with atomic_path(path) as tmp:
        mesh.export(tmp, file_type="stl")
    # a writer that takes an open file
    with atomic_open(path, "w") as f:
        json.dump(data, f)

Writers that pick the format from the file name (meshio) must be told the format explicitly,
because the temporary name does not end in the final extension.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any


def temp_name(path: str | os.PathLike[str]) -> Path:
    """A fresh temporary name beside ``path``: ``<dir>/.<name>.tmp-<pid>-<token>``."""
    p = Path(path)
    return p.with_name(f".{p.name}.tmp-{os.getpid()}-{secrets.token_hex(3)}")


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(folder: Path) -> None:
    """Make the rename durable (POSIX); a no-op where folders cannot be opened (Windows)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _remove_quietly(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


@contextmanager
def atomic_path(path: str | os.PathLike[str], *, fsync: bool = True) -> Iterator[Path]:
    """Yield a temporary path to write to; on normal exit it replaces ``path`` atomically.

    The folder of ``path`` must exist. If the block raises (any exception, KeyboardInterrupt
    included), or leaves no file at the temporary path, the temporary file is removed and
    ``path`` is untouched; the exception propagates. ``fsync=False`` skips flushing the data to
    the disk (faster, still atomic against concurrent readers, not against power loss).
    """
    final = Path(path)
    if not final.parent.is_dir():
        raise FileNotFoundError(
            f"cannot write {str(final)!r}: folder {str(final.parent)!r} does not exist"
        )
    tmp = temp_name(final)
    try:
        yield tmp
        if not tmp.exists():
            raise FileNotFoundError(
                f"atomic write of {str(final)!r}: the writer created no file at {str(tmp)!r}"
            )
        if fsync:
            _fsync_file(tmp)
        os.replace(tmp, final)
    except BaseException:
        _remove_quietly(tmp)
        raise
    if fsync:
        _fsync_dir(final.parent)


def atomic_write(path: str | os.PathLike[str], writer: Callable[[Path], Any], *,
                 fsync: bool = True) -> Path:
    """Call ``writer(tmp_path)`` and move the result onto ``path`` atomically; return ``path``.

    ``writer`` must create the file at the path it is given (the name does not end in the final
    extension: pass the format explicitly). See :func:`atomic_path` for the failure behaviour.
    """
    with atomic_path(path, fsync=fsync) as tmp:
        writer(tmp)
    return Path(path)


@contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb", *, fsync: bool = True,
                **kwargs: Any) -> Iterator[IO[Any]]:
    """Open a temporary file for writing; on normal exit it replaces ``path`` atomically.

    ``mode`` is "w" (text; ``encoding`` defaults to UTF-8) or "wb" (binary); other keyword
    arguments go to :func:`open`. See :func:`atomic_path` for the failure behaviour.
    """
    if mode not in ("w", "wb", "wt"):
        raise ValueError(f"atomic_open mode {mode!r}: expected 'w', 'wt' or 'wb'")
    if "b" not in mode:
        kwargs.setdefault("encoding", "utf-8")
    with atomic_path(path, fsync=fsync) as tmp:
        # "x": never write through a name that appeared in the meantime (e.g. a symlink)
        with open(tmp, mode.replace("w", "x"), **kwargs) as f:
            yield f


def atomic_write_text(path: str | os.PathLike[str], text: str, *, fsync: bool = True) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; return ``path``."""
    with atomic_open(path, "w", fsync=fsync) as f:
        f.write(text)
    return Path(path)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, *, fsync: bool = True) -> Path:
    """Write ``data`` to ``path`` atomically; return ``path``."""
    with atomic_open(path, "wb", fsync=fsync) as f:
        f.write(data)
    return Path(path)
