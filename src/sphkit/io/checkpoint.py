"""Checkpoints: the complete state of a run, to continue it later bit for bit (on the CPU).

A checkpoint is one NumPy ``.npz`` archive (uncompressed, written atomically with
:mod:`sphkit.io.atomic`, read without pickle):

* ``meta``: a JSON text with ``format`` ("sphkit-checkpoint"), ``format_version`` (1), the sphkit
  and library versions and platform, the scene (``Scene.model_dump``), the simulation's clock
  (``time``, ``step_count``, ``dt``, ``frame``: the last frame written), the state of components
  that keep any outside the particle fields (emitters: layers emitted), the last step's
  statistics, the layout of each particle set (``ParticleSet.state``: n, next id, field kinds and
  dtypes, object ranges) and ``extra`` (what the caller adds, e.g. the command's run statistics);
* ``<set>/<field>``: every registered field of the particle sets ``fluid`` and ``boundary`` in
  memory order (so that the z-sort order, and with it the order of every neighbour sum, is the
  same after a restore).

Methods keep their state between steps in registered fields (DFSPH's ``dfsph_kappa`` and
``dfsph_kappa_v`` warm starts, IISPH's pressure, PBF's ``pbf_x_last``, Weiler's ``weiler_dv``,
the micropolar ``omega``); the solvers' other attributes are parameters from the scene or
quantities they recompute from the fields (PCISPH's and PBF's template factors). The z-sort
phase follows from ``step_count``. Files are named ``checkpoint_<step>.npz`` in the folder
``checkpoints/`` of the output folder; :func:`newest_checkpoint` finds the latest.

Reading never unpickles (``allow_pickle=False``; a file that is not a zip archive is refused
before NumPy looks at it) and refuses a checkpoint whose positions or velocities are not finite.
Reading a folder takes the newest checkpoint that reads, with a warning naming each newer one
that does not (:func:`read_checkpoint`).
"""

from __future__ import annotations

import json
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.io.atomic import atomic_open
from sphkit.io.manifest import library_versions, platform_info, sphkit_version

FORMAT = "sphkit-checkpoint"
FORMAT_VERSION = 1
CHECKPOINT_DIR = "checkpoints"
_NAME = re.compile(r"^checkpoint_(\d+)\.npz$")


class CheckpointError(ValueError):
    """A checkpoint that cannot be read or does not fit the simulation."""


@dataclass
class Checkpoint:
    """A checkpoint read back: ``meta`` (the JSON part) and the particle arrays by set."""

    path: Path
    meta: dict[str, Any]
    arrays: dict[str, dict[str, np.ndarray]]

    @property
    def time(self) -> float:
        """Simulated time [s] of the checkpoint."""
        return float(self.meta["state"]["time"])

    @property
    def step_count(self) -> int:
        """Steps taken before the checkpoint."""
        return int(self.meta["state"]["step_count"])

    @property
    def frame(self) -> int:
        """The last frame written before the checkpoint (-1: none)."""
        return int(self.meta["state"]["frame"])

    @property
    def extra(self) -> dict[str, Any]:
        """What the writer added (``write_checkpoint(extra=...)``)."""
        return self.meta.get("extra") or {}


def _threads() -> int:
    import numba

    return int(numba.get_num_threads())


def checkpoint_path(out_dir: str | os.PathLike[str], step: int) -> Path:
    """``<out_dir>/checkpoints/checkpoint_<step>.npz``."""
    return Path(out_dir) / CHECKPOINT_DIR / f"checkpoint_{step:09d}.npz"


def list_checkpoints(out_dir: str | os.PathLike[str]) -> list[Path]:
    """The checkpoints in ``<out_dir>/checkpoints``, oldest (fewest steps) first."""
    folder = Path(out_dir) / CHECKPOINT_DIR
    if not folder.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in folder.iterdir() if (m := _NAME.match(p.name))]
    return [p for _, p in sorted(found)]


def newest_checkpoint(out_dir: str | os.PathLike[str]) -> Path | None:
    """The checkpoint with the most steps in ``<out_dir>/checkpoints``, or None."""
    found = list_checkpoints(out_dir)
    return found[-1] if found else None


def write_checkpoint(path: str | os.PathLike[str], sets: dict[str, Any], state: dict[str, Any],
                     scene: dict[str, Any], extra: dict[str, Any] | None = None,
                     keep: int | None = None) -> Path:
    """Write a checkpoint atomically; return its path.

    Args:
        path: the ``.npz`` file (its folder is created).
        sets: particle sets by name (:class:`sphkit.core.particles.ParticleSet`).
        state: the simulation's clock and component state (JSON-ready).
        scene: the scene as a JSON-ready dict.
        extra: anything else the caller needs on resume (JSON-ready).
        keep: if given, delete all but the newest ``keep`` checkpoints of the folder afterwards.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, np.ndarray] = {}
    layouts = {}
    for name, ps in sets.items():
        layout, fields = ps.state()
        layouts[name] = layout
        for fname, a in fields.items():
            arrays[f"{name}/{fname}"] = a
    meta = {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "sphkit_version": sphkit_version(), "versions": library_versions(),
        "platform": platform_info(), "numba_threads": _threads(), "state": state,
        "scene": scene, "sets": layouts,
        "extra": extra or {},
    }
    arrays["meta"] = np.array(json.dumps(meta))
    with atomic_open(p, "wb") as f:
        np.savez(f, **arrays)
    if keep is not None and keep > 0:
        for old in list_checkpoints(p.parent.parent)[:-keep]:
            if old != p:
                old.unlink(missing_ok=True)
    return p


#: the first bytes of a zip archive (an ``.npz``): anything else is refused unread
_ZIP_MAGIC = b"PK\x03\x04"


def _load(p: Path) -> Checkpoint:
    """Read one checkpoint file (CheckpointError naming it when it is not one)."""
    try:
        with open(p, "rb") as f:
            head = f.read(4)
    except OSError as e:
        raise CheckpointError(f"{str(p)!r}: cannot be read ({e.strerror or e})") from None
    if head != _ZIP_MAGIC:
        what = "an empty file" if not head else "not an .npz archive"
        raise CheckpointError(f"{str(p)!r}: not a sphkit checkpoint ({what}; a truncated or "
                              "foreign file)")
    try:
        with np.load(p, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays: dict[str, dict[str, np.ndarray]] = {}
            for key in z.files:
                if key == "meta":
                    continue
                sname, _, fname = key.partition("/")
                arrays.setdefault(sname, {})[fname] = z[key]
    except ValueError as e:
        if "pickle" in str(e):  # an object array: sphkit never writes one, and never unpickles
            raise CheckpointError(f"{str(p)!r}: holds pickled data, which sphkit checkpoints "
                                  "never contain and sphkit does not load") from None
        raise CheckpointError(f"{str(p)!r}: not a readable sphkit checkpoint ({e})") from None
    except Exception as e:  # zipfile, zlib and NumPy raise many types for a damaged archive
        raise CheckpointError(f"{str(p)!r}: not a readable sphkit checkpoint (damaged or "
                              f"truncated: {type(e).__name__}: {str(e)[:200]})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        got = meta.get("format") if isinstance(meta, dict) else type(meta).__name__
        raise CheckpointError(f"{str(p)!r}: format {got!r}; expected {FORMAT!r}")
    try:
        version = int(meta.get("format_version", 0))
    except (TypeError, ValueError):
        version = FORMAT_VERSION + 1
    if version > FORMAT_VERSION:
        raise CheckpointError(f"{str(p)!r}: format version {meta.get('format_version')!r}; "
                              f"this sphkit reads up to {FORMAT_VERSION}")
    for key in ("state", "scene", "sets"):
        if not isinstance(meta.get(key), dict):
            raise CheckpointError(f"{str(p)!r}: its meta data has no {key!r}; not a complete "
                                  "sphkit checkpoint")
    for sname, fields in arrays.items():
        for fname in ("x", "v"):
            a = fields.get(fname)
            if a is not None and a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                bad = int(np.count_nonzero(~np.isfinite(a)))
                what = "positions" if fname == "x" else "velocities"
                raise CheckpointError(f"{str(p)!r}: {sname} {what} hold {bad} NaN/inf value(s); "
                                      "expected the finite state of a stable run")
    return Checkpoint(p, meta, arrays)


def read_checkpoint(path: str | os.PathLike[str]) -> Checkpoint:
    """Read a checkpoint file, or the newest readable one in an output folder (or its
    ``checkpoints/`` folder; a UserWarning names each newer one that does not read).

    Raises:
        CheckpointError: no checkpoint there, none that reads, or a file that is not one (naming
            the path).
    """
    p = Path(path)
    if not p.is_dir():
        return _load(p)
    folder = p if list_checkpoints(p) or p.name != CHECKPOINT_DIR else p.parent
    found = list_checkpoints(folder)
    if not found:
        raise CheckpointError(f"{str(p)!r}: no checkpoint found (expected files "
                              f"{CHECKPOINT_DIR}/checkpoint_<step>.npz)")
    for f in reversed(found):  # the newest that reads
        try:
            return _load(f)
        except CheckpointError as e:
            warnings.warn(f"checkpoint skipped: {e}", UserWarning, stacklevel=2)
    names = ", ".join(repr(str(f)) for f in found[-3:])
    raise CheckpointError(f"{str(p)!r}: none of its {len(found)} checkpoint(s) can be read "
                          f"({names}{', ...' if len(found) > 3 else ''})")


def version_differences(meta: dict[str, Any]) -> list[str]:
    """Versions (sphkit, Python, libraries) that differ between a checkpoint and this process:
    a resumed run is bit-identical only with the same versions and thread count."""
    now = {"sphkit": sphkit_version(), **library_versions(), "numba threads": _threads()}
    then = {"sphkit": meta.get("sphkit_version"), **(meta.get("versions") or {}),
            "numba threads": meta.get("numba_threads")}
    return [f"{k} {then.get(k)} -> {v}" for k, v in now.items() if then.get(k) != v]
