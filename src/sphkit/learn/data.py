"""The dataset layout of the learned simulators (LagrangeBench's) and a PyTorch ``Dataset``.

A dataset is a folder::

    DIR/metadata.json
    DIR/train.h5  valid.h5  test.h5     groups "00000", "00001", ...; each holds
        position       float (T, N, dim)   particle positions [m] at the stored frames
        particle_type  int (N,)            0 fluid, 1 static wall, 2 moving wall, 3 rigid body
                                           (LagrangeBench's NodeType; walls after the fluid)

``metadata.json`` holds ``dt`` (time between stored frames [s]), ``dim``, ``bounds`` ([lo, hi]
per axis [m]), ``periodic_boundary_conditions``, ``default_connectivity_radius`` [m], ``dx``
(particle spacing [m]) and the normalisation statistics ``vel_mean``, ``vel_std``, ``acc_mean``,
``acc_std``. As in LagrangeBench (``lagrangebench/case_setup/case.py``, ``_compute_target``)
these are statistics of *frame differences*: velocities ``x[t] - x[t-1]`` and accelerations
``x[t+1] - 2 x[t] + x[t-1]``, in metres per frame (per frame squared), not SI rates; the model's
inputs and targets are the same differences, so no ``dt`` enters the network. N may differ
between trajectories.

:class:`WindowDataset` yields training windows: ``input_seq_length`` (6) consecutive positions
(5 velocities) and the next position (the target), of one trajectory. :class:`Normalizer` holds
the statistics; like LagrangeBench's ``get_dataset_stats`` the standard deviations are widened
by the training noise, ``std' = sqrt(std^2 + noise^2)``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import Dataset

from sphkit.io.datasets import SOLID_WALL, is_fluid

#: the static walls' particle type (LagrangeBench's NodeType SOLID_WALL)
WALL = SOLID_WALL
#: number of particle types the model embeds (LagrangeBench reserves 9)
NUM_TYPES = 9
#: positions per input window: 6 positions, 5 velocities (GNS, LagrangeBench)
INPUT_SEQ_LENGTH = 6
_REQUIRED = ("dt", "dim", "bounds", "default_connectivity_radius", "vel_mean", "vel_std",
             "acc_mean", "acc_std")


class DatasetError(ValueError):
    """A dataset folder that does not follow the layout (the message names file and key)."""


def read_metadata(folder: str | os.PathLike[str]) -> dict[str, Any]:
    """``folder/metadata.json``, checked for the keys the learned simulators read."""
    path = Path(folder) / "metadata.json"
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DatasetError(f"{str(folder)!r}: no metadata.json; expected a dataset folder "
                           "(metadata.json, train.h5, valid.h5, test.h5)") from None
    except (OSError, ValueError) as e:
        raise DatasetError(f"{str(path)!r}: unreadable ({e})") from None
    if not isinstance(meta, dict):
        raise DatasetError(f"{str(path)!r}: expected a JSON object")
    missing = [k for k in _REQUIRED if k not in meta]
    if missing:
        raise DatasetError(f"{str(path)!r}: missing key(s) {', '.join(missing)}")
    dim = meta["dim"]
    if dim not in (2, 3):
        raise DatasetError(f"{str(path)!r}: dim {dim!r}; expected 2 or 3")
    for key in ("vel_mean", "vel_std", "acc_mean", "acc_std"):
        v = meta[key]
        if not (isinstance(v, list) and len(v) == dim and all(math.isfinite(x) for x in v)):
            raise DatasetError(f"{str(path)!r}: {key} {v!r}; expected {dim} finite numbers")
    if not (isinstance(meta["bounds"], list) and len(meta["bounds"]) == dim):
        raise DatasetError(f"{str(path)!r}: bounds {meta['bounds']!r}; expected [lo, hi] per axis")
    if not float(meta["default_connectivity_radius"]) > 0:
        raise DatasetError(f"{str(path)!r}: default_connectivity_radius must be positive")
    meta.setdefault("periodic_boundary_conditions", [False] * dim)
    return meta


@dataclass
class Trajectory:
    """One stored trajectory: positions (T, N, dim) float32 and particle types (N,)."""

    name: str
    position: np.ndarray
    particle_type: np.ndarray

    @property
    def fluid(self) -> np.ndarray:
        """Boolean mask of the fluid particles."""
        return is_fluid(self.particle_type)


def load_split(folder: str | os.PathLike[str], split: str,
               limit: int | None = None) -> list[Trajectory]:
    """The trajectories of ``folder/<split>.h5`` (read into memory), in group order."""
    import h5py

    path = Path(folder) / f"{split}.h5"
    if not path.is_file():
        raise DatasetError(f"{str(folder)!r}: no {split}.h5")
    out = []
    try:
        with h5py.File(path, "r") as f:
            for name in sorted(f.keys()):
                g = f[name]
                if "position" not in g or "particle_type" not in g:
                    raise DatasetError(f"{str(path)!r}: group {name!r} lacks position or "
                                       "particle_type")
                pos = np.asarray(g["position"], dtype=np.float32)
                pt = np.asarray(g["particle_type"], dtype=np.int64)
                if pos.ndim != 3 or pt.shape != (pos.shape[1],):
                    raise DatasetError(f"{str(path)!r}: group {name!r}: position {pos.shape} "
                                       f"and particle_type {pt.shape} do not match (T, N, dim)"
                                       " and (N,)")
                out.append(Trajectory(name, pos, pt))
                if limit is not None and len(out) >= limit:
                    break
    except OSError as e:
        raise DatasetError(f"{str(path)!r}: unreadable HDF5 ({e})") from None
    if not out:
        raise DatasetError(f"{str(path)!r}: no trajectories")
    return out


class Normalizer:
    """Normalisation of frame-difference velocities and accelerations (see the module notes).

    ``noise_std`` (metres per frame) widens the standard deviations as LagrangeBench does."""

    def __init__(self, meta: dict[str, Any], noise_std: float = 0.0) -> None:
        self.vel_mean = np.asarray(meta["vel_mean"], dtype=np.float64)
        self.acc_mean = np.asarray(meta["acc_mean"], dtype=np.float64)
        self.vel_std = np.sqrt(np.asarray(meta["vel_std"], dtype=np.float64) ** 2 + noise_std ** 2)
        self.acc_std = np.sqrt(np.asarray(meta["acc_std"], dtype=np.float64) ** 2 + noise_std ** 2)
        if not (np.all(self.vel_std > 0) and np.all(self.acc_std > 0)):
            raise DatasetError("vel_std and acc_std must be positive (plus noise)")

    def state(self) -> dict[str, list[float]]:
        """The statistics as lists (stored in checkpoints)."""
        return {"vel_mean": self.vel_mean.tolist(), "vel_std": self.vel_std.tolist(),
                "acc_mean": self.acc_mean.tolist(), "acc_std": self.acc_std.tolist()}

    @classmethod
    def from_state(cls, state: dict[str, list[float]]) -> Normalizer:
        """Statistics saved by :meth:`state` (already widened by the noise)."""
        return cls(state, 0.0)

    def norm_vel(self, v: Any) -> Any:
        return (v - _like(self.vel_mean, v)) / _like(self.vel_std, v)

    def norm_acc(self, a: Any) -> Any:
        return (a - _like(self.acc_mean, a)) / _like(self.acc_std, a)

    def denorm_acc(self, a: Any) -> Any:
        return a * _like(self.acc_std, a) + _like(self.acc_mean, a)


def _like(stat: np.ndarray, x: Any) -> Any:
    """``stat`` as an array of ``x``'s kind (NumPy, or a torch tensor on its device)."""
    if isinstance(x, np.ndarray):
        return stat.astype(x.dtype)
    return torch.as_tensor(stat, dtype=x.dtype, device=x.device)


class WindowDataset(Dataset):
    """Training windows of a split: item k is ``(positions, particle_type)`` with positions of
    shape (N, input_seq_length + 1, dim) (float32 tensor: ``input_seq_length`` input frames and
    the target frame) and the types (N,) int64 tensor. Windows never span two trajectories."""

    def __init__(self, trajectories: list[Trajectory],
                 input_seq_length: int = INPUT_SEQ_LENGTH) -> None:
        self.trajectories = trajectories
        self.input_seq_length = input_seq_length
        self.index: list[tuple[int, int]] = []
        for k, tr in enumerate(trajectories):
            for t in range(tr.position.shape[0] - input_seq_length):
                self.index.append((k, t))
        if not self.index:
            raise DatasetError(f"no training windows: trajectories need more than "
                               f"{input_seq_length} frames")

    def __len__(self) -> int:
        return len(self.index)

    def __getitem__(self, k: int) -> tuple[torch.Tensor, torch.Tensor]:
        i, t = self.index[k]
        tr = self.trajectories[i]
        w = tr.position[t:t + self.input_seq_length + 1]  # (W, N, dim)
        return (torch.from_numpy(np.ascontiguousarray(w.transpose(1, 0, 2))),
                torch.from_numpy(tr.particle_type))
