"""Disk cache of precomputed geometry arrays (signed distance lattices, boundary maps).

:func:`cached_arrays` stores computed arrays on disk, keyed by a SHA-256 hash of everything that
determines them (for meshes: vertices and faces as placed in the scene, so the transform is
included, and the lattice); files are written atomically (temporary file, then rename). The cache
folder is ``$SPHKIT_CACHE_DIR`` or ``~/.cache/sphkit``; ``SPHKIT_CACHE_DIR=off`` disables it.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

#: bumped whenever a change alters cached results
CACHE_VERSION = "sdf-1"


def cache_folder(override: str | os.PathLike[str] | None = None) -> Path | None:
    """The cache folder: ``override``, else ``$SPHKIT_CACHE_DIR``, else ``~/.cache/sphkit``;
    None when the value is ``off`` (caching disabled)."""
    value = str(override) if override is not None else os.environ.get("SPHKIT_CACHE_DIR", "")
    if value.strip().lower() in ("off", "none", "0", "false"):
        return None
    if value.strip():
        return Path(value).expanduser()
    return Path.home() / ".cache" / "sphkit"


def cache_key(items: Sequence) -> str:
    """SHA-256 (hex) of a list of arrays, numbers, strings and nested lists."""
    h = hashlib.sha256(CACHE_VERSION.encode())

    def feed(x) -> None:
        if isinstance(x, np.ndarray):
            a = np.ascontiguousarray(x)
            h.update(f"nd{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        elif isinstance(x, (list, tuple)):
            h.update(f"seq{len(x)}".encode())
            for y in x:
                feed(y)
        elif isinstance(x, float):
            h.update(f"f{x!r}".encode())
        else:
            h.update(f"{type(x).__name__}{x!r}".encode())

    feed(list(items))
    return h.hexdigest()


def cached_arrays(kind: str, items: Sequence, compute: Callable[[], dict[str, np.ndarray]],
                  folder: Path | None) -> tuple[dict[str, np.ndarray], bool]:
    """Arrays from ``<folder>/<kind>-<hash>.npz``, or ``compute()`` stored there atomically.

    Returns (arrays, hit). A cache file that cannot be read is recomputed and replaced; a folder
    that cannot be written leaves the result uncached.
    """
    if folder is None:
        return compute(), False
    path = Path(folder) / f"{kind}-{cache_key([kind, *items])}.npz"
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}, True
        except (OSError, ValueError, KeyError):
            pass
    arrays = compute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, **arrays)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError:
        pass
    return arrays, False
