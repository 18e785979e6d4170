"""Datasets for learned simulators: HDF5 in LagrangeBench's layout (``sphkit dataset``).

Layout of a dataset folder (checked against LagrangeBench's code, github.com/tumaer/lagrangebench
at b880a6c: ``lagrangebench/data/data.py`` (H5Dataset), ``lagrangebench/data/utils.py``
(get_dataset_stats), ``lagrangebench/case_setup/case.py`` (case_builder),
``lagrangebench/runner.py``, ``lagrangebench/evaluate/metrics.py``, ``lagrangebench/utils.py``
(NodeType) and ``data_gen/lagrangebench_data/gen_dataset.py``, plus its test dataset
``tests/3D_LJ_3_1214every1``)::

    DIR/train.h5, valid.h5, test.h5   one group per trajectory, named 00000, 00001, ... (five
                                      digits, numbered from 0 in each split, as gen_dataset.py)
        <group>/position              float32 (T, N, dim) [m], gzip (gen_dataset.py and the
                                      tfrecord converter write float32; H5Dataset reads
                                      f["00000/position"].shape[0] as the sequence length)
        <group>/particle_type         int32 (N,) (the test dataset's dtype): NodeType of
                                      lagrangebench/utils.py: 0 FLUID, 1 SOLID_WALL,
                                      2 MOVING_WALL, 3 RIGID_BODY (-1 is its padding value);
                                      several fluids: phase k >= 1 is type 3 + k (4 to 8,
                                      :func:`fluid_types`)
        <group> attributes            sphkit's: variant (index), values (JSON of the sampled
                                      parameters); LagrangeBench ignores them
    DIR/metadata.json
    DIR/variants/variant-00007.h5     one file per variant (the Dask tasks' results, written
                                      atomically; a rerun skips the complete ones), and
                                      variant-00007.failed.json for an unstable variant

Several fluids (``materials``, :mod:`sphkit.multiphase`): the first phase keeps FLUID (0) and
phase k >= 1 gets type 3 + k, the types LagrangeBench's NodeType leaves free below its ``SIZE``
9 (its models embed every type and move every particle that is not kinematic, 1 and 2), so a
learned simulator can tell the phases apart (at most six phases); every fluid type counts as
fluid for the statistics and in :mod:`sphkit.learn` (:func:`is_fluid`).

Particles keep one order for the whole trajectory: the fluid sorted by its stable id (sphkit
reorders it along a z-curve while it runs), then the particles of static walls (type 1), then
those of moving bodies: kinematic ones (prescribed motion, type 2 MOVING_WALL: LagrangeBench's
``get_kinematic_mask`` treats 1 and 2 as kinematic) and dynamic ones (moved by the fluid, type 3
RIGID_BODY), each at its position in every frame. Walls represented by density or volume maps
have no particles and do not appear. N is fixed per trajectory (scenes with emitters are
refused); trajectories may differ in N when a variation changes the fluid's size, which
LagrangeBench's loader handles with its ``matscipy`` neighbour backend (it pads to
``num_particles_max``).

``metadata.json``, the keys LagrangeBench reads (file where it reads them):

* ``dim`` (runner.py, metrics.py), ``dx`` (metrics.py: the particle spacing 2r [m]; the
  largest of the dataset when a variation changes the particle radius),
* ``dt`` and ``write_every`` (runner.py, metrics.py use ``dt * write_every`` as the time
  between two stored frames): sphkit writes ``dt`` = the frame interval 1/fps [s] and
  ``write_every`` = 1 (LagrangeBench's own files give the solver step and the steps per frame);
  the solver's steps land exactly on every frame time k/fps (``Simulation.run(...,
  exact_frames=True)``: the steps before a frame are shortened evenly), so the frame interval
  is exact and frame differences are velocities and accelerations without timing jitter,
* ``bounds`` [[lo, hi] per axis] (runner.py: the box ``hi - lo``, periodic space; features.py:
  distances to the bounds): the box holding every particle of every trajectory (the outer faces
  of the walls: centres +- r; along a periodic axis exactly ``configuration.periodic_x``),
* ``periodic_boundary_conditions`` [bool] * dim (case.py: periodic in all directions if any),
* ``default_connectivity_radius`` [m] (case.py: the neighbour-list cutoff and the feature
  scale): 1.45 dx rounded to two digits, as gen_dataset.py (``1.45 * dx``, "around 1.5 dx");
  sphkit's own smoothing length h = 4 r = 2 dx is recorded in ``sphkit.smoothing_length``,
* ``num_particles_max`` (case.py, data.py),
* ``vel_mean``, ``vel_std``, ``acc_mean``, ``acc_std`` [dim each] (data/utils.py): as
  gen_dataset.py's compute_statistics_h5 defines them, from the fluid particles (type 0; 4-8
  of further phases) only: velocity = the position difference of consecutive frames x[t+1] -
  x[t] (a length per frame, not divided by dt; minimum image along periodic axes),
  acceleration = the difference of
  consecutive velocities; the mean is the mean over trajectories of each trajectory's mean over
  frames and particles, the std the square root of the mean over trajectories of the mean squared
  deviation from that mean; a std below 1e-7 becomes 1. sphkit computes them over the training
  split (gen_dataset.py loops over all three splits; sphkit keeps valid and test out of the
  normalisation),
* ``sequence_length_train``, ``num_trajs_train``, ``sequence_length_test``, ``num_trajs_test``
  (gen_dataset.py; the GNS convention: a trajectory has ``sequence_length + 1`` frames), plus
  ``sequence_length`` (the same number), ``num_trajs_valid`` and ``num_frames`` (T),
* ``case``, ``solver``, ``t_end``, ``viscosity``, ``g_ext_magnitude`` (informational, as
  gen_dataset.py writes them).

``sphkit``: provenance: ``format_version``, ``scene`` (the base scene as JSON), ``vary`` (the
specs), ``seed``, ``count``, ``split`` (fractions), ``fps``, ``until``, ``smoothing_length``,
``trajectories`` (per trajectory: split, key, variant index, values, particle counts),
``failed`` (unstable variants and their diagnosis), ``versions`` (sphkit, numpy, numba, h5py).

h5py is imported inside the functions (the ``dataset`` extra); :func:`read_dataset` and
:func:`iter_trajectories` read a dataset back.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.io.atomic import atomic_path, atomic_write_text

__all__ = [
    "FLUID", "MOVING_WALL", "PHASE_TYPES", "RIGID_BODY", "SOLID_WALL", "SPLITS",
    "TrajectoryRecorder", "assemble_dataset", "connectivity_radius", "fluid_particle_types",
    "fluid_types", "frame_statistics", "is_fluid", "iter_trajectories", "read_dataset",
    "read_variant", "split_counts", "variant_path", "write_variant",
]

#: LagrangeBench's NodeType (lagrangebench/utils.py)
FLUID, SOLID_WALL, MOVING_WALL, RIGID_BODY = 0, 1, 2, 3
#: the particle type of each fluid phase (several fluids: the module docstring): 0 for the
#: first, then the types LagrangeBench's NodeType leaves free below its SIZE 9
PHASE_TYPES = (FLUID, 4, 5, 6, 7, 8)
SPLITS = ("train", "valid", "test")
METADATA_NAME = "metadata.json"
VARIANTS_DIR = "variants"
FORMAT_VERSION = 1


def fluid_types(phase: np.ndarray) -> np.ndarray:
    """The particle type (int32) of fluid particles of the given phases (:data:`PHASE_TYPES`);
    ValueError beyond the sixth phase."""
    phase = np.asarray(phase, dtype=np.int64)
    if phase.size and (phase.min() < 0 or phase.max() >= len(PHASE_TYPES)):
        raise ValueError(f"fluid phase {int(phase.max())}: a dataset labels at most "
                         f"{len(PHASE_TYPES)} fluid phases (LagrangeBench's particle types)")
    return np.asarray(PHASE_TYPES, dtype=np.int32)[phase]


def fluid_particle_types(fluid: Any, order: np.ndarray) -> np.ndarray:
    """The particle types (int32) of the particle set ``fluid`` in the order ``order``: FLUID,
    or per phase (:func:`fluid_types`) where the fluid has several materials."""
    if "phase" in fluid.fields:
        return fluid_types(np.asarray(fluid["phase"])[order])
    return np.full(len(order), FLUID, dtype=np.int32)


def is_fluid(particle_type: Any) -> Any:
    """Boolean mask of the fluid particles (every phase's type, :data:`PHASE_TYPES`) of a
    NumPy array of particle types."""
    t = np.asarray(particle_type)
    return (t == FLUID) | ((t >= PHASE_TYPES[1]) & (t <= PHASE_TYPES[-1]))


def variant_path(folder: str | os.PathLike[str], k: int, failed: bool = False) -> Path:
    """``<folder>/variants/variant-00007.h5`` (``.failed.json`` for an unstable one)."""
    return Path(folder) / VARIANTS_DIR / (f"variant-{k:05d}" + (".failed.json" if failed
                                                                 else ".h5"))


def connectivity_radius(dx: float) -> float:
    """LagrangeBench's default connectivity radius: 1.45 dx, two significant digits."""
    return float(f"{1.45 * dx:.2g}")


class TrajectoryRecorder:
    """Positions of one run in a fixed particle order, a frame at a time.

    ``fluid`` and ``boundary`` are the particle sets (fields ``x``, ``id``; the boundary's
    ``rigid_body``: 0 static, else the 1-based moving body); ``body_types[b]`` is the
    particle type of moving body b (MOVING_WALL or RIGID_BODY). ``walls=False``: the boundary set
    holds no wall particles (density and volume maps put each step's virtual particles there),
    only the fluid is stored."""

    def __init__(self, fluid: Any, boundary: Any, body_types: Mapping[int, int],
                 walls: bool = True) -> None:
        self.n_fluid = int(fluid.n)
        self.walls = walls
        nb = int(boundary.n) if walls else 0
        if nb:
            body = (np.asarray(boundary["rigid_body"], dtype=np.int64) if "rigid_body" in
                    boundary.fields else np.zeros(nb, np.int64))
            ids = np.asarray(boundary["id"])
            # static walls first, then the moving bodies by number; by id within each
            self.boundary_order = np.lexsort((ids, body))
            types = np.where(body == 0, SOLID_WALL, 0)
            for b, t in body_types.items():
                types[body == b] = t
            types = types[self.boundary_order]
            if np.any(types == FLUID):
                raise ValueError("a moving body without a particle type")
        else:
            self.boundary_order = np.zeros(0, np.int64)
            types = np.zeros(0, np.int64)
        # the fluid in the order record() stores it
        fluid_type = fluid_particle_types(fluid, np.argsort(fluid["id"], kind="stable"))
        self.particle_type = np.concatenate([fluid_type, types]).astype(np.int32)
        self.frames: list[int] = []
        self.positions: list[np.ndarray] = []
        #: the extent (lo, hi) per axis of the walls' and of all particles' centres over the
        #: frames, in the simulation's precision (the bounds of the metadata)
        self.extent: dict[str, list[list[float]]] = {}

    def record(self, fluid: Any, boundary: Any, frame: int) -> None:
        """Store the positions of frame ``frame`` (N, dim)."""
        if fluid.n != self.n_fluid:
            raise ValueError(f"the fluid has {fluid.n} particles at frame {frame}, "
                             f"{self.n_fluid} at the start: a dataset needs a fixed count")
        xf = np.asarray(fluid.view("x"))[np.argsort(fluid["id"], kind="stable")]
        if self.walls and boundary.n != len(self.boundary_order):
            raise ValueError(f"the boundary has {boundary.n} particles at frame {frame}, "
                             f"{len(self.boundary_order)} at the start")
        xb = (np.asarray(boundary.view("x"))[self.boundary_order] if len(self.boundary_order)
              else np.zeros((0, xf.shape[1])))
        x = np.concatenate([xf, xb])
        for name, part in (("all", x), ("walls", xb)):
            if len(part):
                lo, hi = part.min(axis=0).tolist(), part.max(axis=0).tolist()
                if name in self.extent:
                    old_lo, old_hi = self.extent[name]
                    lo = [min(a, b) for a, b in zip(lo, old_lo, strict=True)]
                    hi = [max(a, b) for a, b in zip(hi, old_hi, strict=True)]
                self.extent[name] = [lo, hi]
        self.positions.append(x.astype(np.float32))
        self.frames.append(int(frame))

    def array(self) -> np.ndarray:
        """(T, N, dim) float32; ValueError when a frame was skipped (a step longer than the
        frame interval)."""
        if self.frames != list(range(len(self.frames))):
            missing = sorted(set(range(max(self.frames) + 1)) - set(self.frames))
            raise ValueError(f"frames {missing[:5]} were skipped (a time step longer than the "
                             "frame interval); expected one stored frame per interval: lower "
                             "--fps or time.dt_max")
        return np.stack(self.positions)


# -- per-variant files ----------------------------------------------------------------------------
def write_variant(path: str | os.PathLike[str], position: np.ndarray,
                  particle_type: np.ndarray, meta: Mapping[str, Any]) -> Path:
    """Write one trajectory and its ``meta`` (JSON) atomically; the rename is the commit, and
    ``complete = 1`` is the last attribute written."""
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            f.create_dataset("position", data=np.asarray(position, np.float32),
                             compression="gzip")
            f.create_dataset("particle_type", data=np.asarray(particle_type, np.int32))
            f.attrs["sphkit"] = json.dumps(dict(meta))
            f.attrs["complete"] = 1
    return path


def read_variant(path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The meta of a complete variant file, None when it is missing, unreadable or
    incomplete."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if int(f.attrs.get("complete", 0)) != 1:
                return None
            meta = json.loads(f.attrs["sphkit"])
            t, n, _ = f["position"].shape
            if f["particle_type"].shape != (n,) or t < 1:
                return None
            return meta
    except (OSError, KeyError, ValueError, TypeError):
        return None


# -- statistics -----------------------------------------------------------------------------------
def _differences(x: np.ndarray, box: np.ndarray | None) -> np.ndarray:
    """x[1:] - x[:-1], with the minimum image along the axes where ``box`` is positive."""
    d = np.diff(x.astype(np.float64), axis=0)
    if box is not None:
        for a, length in enumerate(box):
            if length > 0:
                d[..., a] -= length * np.round(d[..., a] / length)
    return d


def frame_statistics(trajectories: Sequence[tuple[np.ndarray, np.ndarray]],
                     box: np.ndarray | None = None) -> dict[str, list[float]]:
    """``vel_mean``/``vel_std``/``acc_mean``/``acc_std`` of (position (T, N, dim),
    particle_type) pairs as LagrangeBench's gen_dataset.py defines them (module docstring);
    ``box[a] > 0``: axis a is periodic with that period."""
    vels = []
    for x, ptype in trajectories:
        v = _differences(x[:, is_fluid(ptype)], box)
        vels.append((v, np.diff(v, axis=0)))
    if not vels:
        raise ValueError("no trajectories to compute statistics from")
    vel_mean = np.mean([v.mean(axis=(0, 1)) for v, _ in vels], axis=0)
    acc_mean = np.mean([a.mean(axis=(0, 1)) for _, a in vels], axis=0)
    vel_std = np.sqrt(np.mean([((v - vel_mean) ** 2).mean(axis=(0, 1)) for v, _ in vels],
                              axis=0))
    acc_std = np.sqrt(np.mean([((a - acc_mean) ** 2).mean(axis=(0, 1)) for _, a in vels],
                              axis=0))
    vel_std = np.where(vel_std < 1e-7, 1.0, vel_std)
    acc_std = np.where(acc_std < 1e-7, 1.0, acc_std)
    return {"vel_mean": vel_mean.tolist(), "vel_std": vel_std.tolist(),
            "acc_mean": acc_mean.tolist(), "acc_std": acc_std.tolist()}


def split_counts(n: int, fractions: Sequence[float]) -> tuple[int, int, int]:
    """Trajectories per split (train, valid, test) of ``n``: valid and test get their rounded
    share, at least one each when their fraction is positive and ``n >= 3``; train the rest."""
    total = float(sum(fractions))
    counts = []
    for f in fractions[1:]:
        c = int(round(n * f / total)) if total > 0 else 0
        if f > 0 and n >= 3:
            c = max(c, 1)
        counts.append(c)
    n_valid, n_test = counts
    while n_valid + n_test > n - (1 if fractions[0] > 0 and n >= 1 else 0):
        if n_test >= n_valid and n_test > 0:
            n_test -= 1
        elif n_valid > 0:
            n_valid -= 1
        else:
            break
    return n - n_valid - n_test, n_valid, n_test


# -- assembling the dataset -----------------------------------------------------------------------
def assemble_dataset(folder: str | os.PathLike[str], variants: Sequence[int],
                     fractions: Sequence[float], metadata: Mapping[str, Any],
                     provenance: Mapping[str, Any], *, radius: float,
                     periodic_x: Sequence[float] | None = None) -> dict[str, Any]:
    """Write ``train.h5``, ``valid.h5``, ``test.h5`` and ``metadata.json`` (each atomically)
    from the complete variant files of ``variants`` (in this order: the first go to train, then
    valid, then test). ``metadata`` holds the scene's keys (dim, dt, ...), ``provenance`` the
    ``sphkit`` block; ``radius`` the particle radius r [m] of the base scene, which a variant's
    own (``particle_radius`` in its file, when a variation changed it) replaces: ``dx`` is
    twice the largest radius of the dataset. Returns the metadata."""
    import h5py

    folder = Path(folder)
    counts = split_counts(len(variants), fractions)
    bounds_lo: np.ndarray | None = None
    bounds_hi: np.ndarray | None = None
    n_max, n_frames, r_max = 0, None, 0.0
    records: list[dict[str, Any]] = []
    split_of: list[tuple[str, int, int]] = []  # (split, index in split, variant)
    start = 0
    for split, c in zip(SPLITS, counts, strict=True):
        split_of += [(split, j, k) for j, k in enumerate(variants[start:start + c])]
        start += c
    dim = int(metadata["dim"])
    for split in SPLITS:
        members = [(j, k) for s, j, k in split_of if s == split]
        with atomic_path(folder / f"{split}.h5") as tmp, h5py.File(tmp, "w") as out:
            for j, k in members:
                src_path = variant_path(folder, k)
                with h5py.File(src_path, "r") as src:
                    meta = json.loads(src.attrs["sphkit"])
                    key = f"{j:05d}"
                    g = out.create_group(key)
                    src.copy(src["position"], g, "position")
                    src.copy(src["particle_type"], g, "particle_type")
                    g.attrs["variant"] = int(k)
                    g.attrs["values"] = json.dumps(meta.get("values", {}))
                    t, n, _ = src["position"].shape
                    ptype = src["particle_type"][:]
                    # the walls hold everything in; without walls (or along a periodic axis
                    # the fluid crosses) every particle counts
                    extent = meta["extent"]
                    lo, hi = (np.array(v) for v in extent.get("walls", extent["all"]))
                    if periodic_x is not None:
                        lo = np.minimum(lo, extent["all"][0])
                        hi = np.maximum(hi, extent["all"][1])
                    r = float(meta.get("particle_radius", radius))
                    r_max = max(r_max, r)
                    lo, hi = lo - r, hi + r
                bounds_lo = lo if bounds_lo is None else np.minimum(bounds_lo, lo)
                bounds_hi = hi if bounds_hi is None else np.maximum(bounds_hi, hi)
                n_max = max(n_max, n)
                if n_frames is not None and t != n_frames:
                    raise ValueError(f"variant {k} has {t} frames, others {n_frames}")
                n_frames = t
                records.append({"split": split, "key": key, "variant": int(k),
                                "values": meta.get("values", {}), "particle_radius": r,
                                "n_particles": int(n), "n_fluid": int(is_fluid(ptype).sum())})
    if bounds_lo is None or bounds_hi is None or n_frames is None:
        raise ValueError("no complete variants to assemble")
    bounds = [[float(a), float(b)] for a, b in zip(bounds_lo, bounds_hi, strict=True)]
    periodic = [False] * dim
    box = None
    if periodic_x is not None:
        bounds[0] = [float(periodic_x[0]), float(periodic_x[1])]
        periodic[0] = True
        box = np.zeros(dim)
        box[0] = periodic_x[1] - periodic_x[0]
    train = []
    with h5py.File(folder / "train.h5", "r") as f:
        for key in f:
            train.append((f[key]["position"][:], f[key]["particle_type"][:]))
    stats = frame_statistics(train, box)
    seq = n_frames - 1
    dx = 2.0 * r_max
    md: dict[str, Any] = dict(metadata)
    md.update({
        "dx": float(dx), "write_every": 1,
        "sequence_length_train": seq, "num_trajs_train": counts[0],
        "sequence_length_test": seq, "num_trajs_test": counts[2],
        "num_trajs_valid": counts[1], "sequence_length": seq, "num_frames": n_frames,
        "num_particles_max": int(n_max), "periodic_boundary_conditions": periodic,
        "bounds": bounds, "default_connectivity_radius": connectivity_radius(dx),
        **stats,
    })
    prov = dict(provenance)
    prov["trajectories"] = records
    prov["format_version"] = FORMAT_VERSION
    md["sphkit"] = prov
    atomic_write_text(folder / METADATA_NAME, json.dumps(md, indent=1, allow_nan=False) + "\n")
    return md


# -- reading --------------------------------------------------------------------------------------
def read_dataset(folder: str | os.PathLike[str]) -> tuple[dict[str, Any], dict[str, list[str]]]:
    """(metadata, {split: its trajectory keys}) of a dataset folder."""
    import h5py

    folder = Path(folder)
    with open(folder / METADATA_NAME, encoding="utf-8") as f:
        metadata = json.load(f)
    keys = {}
    for split in SPLITS:
        path = folder / f"{split}.h5"
        if path.is_file():
            with h5py.File(path, "r") as h:
                keys[split] = sorted(h.keys())
        else:
            keys[split] = []
    return metadata, keys


def iter_trajectories(folder: str | os.PathLike[str], split: str = "train"
                      ) -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
    """(key, position (T, N, dim) float32, particle_type (N,) int32) of each trajectory of
    ``split``, in key order."""
    import h5py

    if split not in SPLITS:
        raise ValueError(f"split {split!r}: expected one of {', '.join(SPLITS)}")
    with h5py.File(Path(folder) / f"{split}.h5", "r") as f:
        for key in sorted(f.keys()):
            yield key, f[key]["position"][:], f[key]["particle_type"][:]
