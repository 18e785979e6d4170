"""ParticleSet: struct-of-arrays particle state with registered fields and per-object ranges.

Scalar fields have shape (N,), vector fields (dim, N) -- one contiguous row per coordinate, as
DESIGN.md prescribes; :meth:`ParticleSet.view` hands out the usual (N, dim) layout as a view.
Methods register the per-particle fields they need (``register``) instead of keeping private
arrays, so that output, checkpoints, reordering and the GPU backend see every field.
Every set carries an ``id`` field: a stable user-visible particle number that survives reordering.

Storage grows by capacity doubling: each field lives in a flat buffer of ``capacity`` particles
and ``ps[name]`` is a C-contiguous view of its first ``n`` (a (dim, n) view for vectors), so that
appending particles every few steps (emitters) reallocates only when the capacity is exceeded.
The views are replaced when particles are added: take ``ps[name]`` again after :meth:`add`.

Device residency (:meth:`to`): on a GPU every field of the set is a device array in the same
``fields`` (the time step's kernel bodies run where their arrays are, :mod:`sphkit.backend`);
:meth:`to` ``("cpu")`` copies them back into the host buffers. Adding, resizing, compacting and
checkpoint state need the set on the host; :meth:`add` and :meth:`resize` work on the device too
(an emitter's layers, the virtual particles of maps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from sphkit.backend import launch, launch_reduce, to_device, to_host
from sphkit.core import arrays


@numba.njit(cache=True, inline="always")
def _append_body(i, old, new, n, w, out):
    """Column i of ``old`` (w, n) followed by ``new`` (w, M) into ``out`` (w, n + M)."""
    for d in range(w):
        out[d, i] = old[d, i] if i < n else new[d, i - n]


@numba.njit(cache=True, inline="always")
def _scatter_body(i, idx, new, w, out):
    """Column i of ``new`` (w, M) into column ``idx[i]`` of ``out`` (w, n)."""
    for d in range(w):
        out[d, idx[i]] = new[d, i]


@numba.njit(cache=True, inline="always")
def _id_body(i, ids):
    """Particle i's id, for the largest (a reduction)."""
    return float(ids[i])


@dataclass
class FieldSpec:
    """How a field is stored: ``kind`` is 'scalar' (N,), 'vector' (dim, N) or 'vector3' (3, N).

    'vector3' is for quantities that have three components whatever the dimension (angular
    velocity, vorticity: in 2D only the z row is used).
    """

    name: str
    kind: str
    dtype: np.dtype
    fill: float = 0.0  #: value of particles added later (e.g. NaN: "no history yet")
    #: a field added by a later sphkit version whose ``fill`` is what older versions meant: a
    #: state written without it restores with the fill (:meth:`ParticleSet.set_state`)
    optional: bool = False


@dataclass
class ObjectRange:
    """The particles one scene object created: ids in ``[start, end)``.

    Ids are handed out contiguously per object, so the range stays valid after the particles are
    reordered (select with ``(ps["id"] >= start) & (ps["id"] < end)``).
    """

    name: str
    start: int
    end: int


class ParticleSet:
    """Particles of one kind (fluid, or boundary) in ``dim`` dimensions."""

    def __init__(self, dim: int, dtype: np.dtype | str = np.float64) -> None:
        if dim not in (1, 2, 3):
            raise ValueError(f"dim: {dim!r} is not a dimension; expected 1, 2 or 3")
        self.dim = dim
        self.dtype = np.dtype(dtype)
        self.n = 0
        self.capacity = 0  #: particles the buffers hold before the next reallocation
        self.next_id = 0  #: the id the next added particle gets (ids are never reused)
        self.specs: dict[str, FieldSpec] = {}
        self.fields: dict[str, np.ndarray] = {}
        self._buffers: dict[str, np.ndarray] = {}
        self.objects: list[ObjectRange] = []
        self.device = "cpu"  #: where the fields are ("cpu", or "cuda": device arrays)
        self.register("x", "vector")
        self.register("id", "scalar", np.int64)

    def register(self, name: str, kind: str = "scalar", dtype: np.dtype | str | None = None,
                 fill: float = 0.0, optional: bool = False) -> np.ndarray:
        """Add a field (no-op if it exists with the same layout) and return its array.
        ``optional``: a state (checkpoint) written without this field restores it as ``fill``
        (a field that older versions did not have, whose fill is what they did)."""
        if kind not in ("scalar", "vector", "vector3"):
            raise ValueError(
                f"field {name}: kind {kind!r}; expected 'scalar', 'vector' or 'vector3'"
            )
        dt = self.dtype if dtype is None else np.dtype(dtype)
        if name in self.specs:
            spec = self.specs[name]
            if spec.kind != kind or spec.dtype != dt:
                raise ValueError(f"field {name} is already registered as {spec.kind} {spec.dtype}")
            return self.fields[name]
        self.specs[name] = FieldSpec(name, kind, dt, fill, optional)
        self._buffers[name] = np.full(self._width(kind) * self.capacity, fill, dtype=dt)
        self._view(name)
        if self.device != "cpu":
            self.fields[name] = to_device(self.fields[name], self.device)
        return self.fields[name]

    def empty_like(self) -> ParticleSet:
        """A new, empty set on the host with this set's dimension, precision and fields (each
        with its kind, dtype, fill and optional flag), for code that rebuilds a set by hand: a
        field registered without its fill would start at 0 instead (a wall's viscosity factor
        of 0 turns its viscous term off)."""
        new = ParticleSet(self.dim, self.dtype)
        for name, spec in self.specs.items():
            new.register(name, spec.kind, spec.dtype, spec.fill, spec.optional)
        return new

    def to(self, device: str) -> None:
        """Make ``device`` ("cpu" or "cuda") hold the fields: copies every field there (device
        arrays replace the host views in :attr:`fields`), or back into the host buffers."""
        if device == self.device:
            return
        if device == "cpu":
            if self.n > self.capacity:  # resized on the device (resize) beyond the buffers
                self.capacity = self.n
                for name, spec in self.specs.items():
                    self._buffers[name] = np.empty(self._width(spec.kind) * self.n, spec.dtype)
            for name in self.specs:
                dev = self.fields[name]
                self._view(name)
                if self.n:
                    self.fields[name][...] = to_host(dev)
        else:
            for name in self.specs:
                self.fields[name] = to_device(self.fields[name], device)
        self.device = device

    def _on_host(self, what: str) -> None:
        if self.device != "cpu":
            raise RuntimeError(f"ParticleSet.{what}: the fields are on the device "
                               f"{self.device!r}; move them to the host first (to('cpu'))")

    def _width(self, kind: str) -> int:
        return self.dim if kind == "vector" else 3 if kind == "vector3" else 1

    def _shape(self, kind: str, n: int) -> tuple[int, ...]:
        if kind == "scalar":
            return (n,)
        return (self._width(kind), n)

    def _view(self, name: str) -> None:
        """Point ``fields[name]`` at the first ``n`` particles of its buffer (C-contiguous)."""
        spec = self.specs[name]
        w = self._width(spec.kind)
        self.fields[name] = self._buffers[name][: w * self.n].reshape(self._shape(spec.kind,
                                                                                  self.n))

    def _grow(self, m: int) -> None:
        """Make room for ``m`` more particles: rows move apart inside the buffer, or into a
        buffer of twice the capacity when it is full."""
        n, new_n = self.n, self.n + m
        if new_n > self.capacity:
            cap = max(2 * self.capacity, new_n, 16)
            for fname, spec in self.specs.items():
                w = self._width(spec.kind)
                buf = np.full(w * cap, spec.fill, dtype=spec.dtype)
                old = self.fields[fname].reshape(w, n)
                buf[: w * new_n].reshape(w, new_n)[:, :n] = old
                self._buffers[fname] = buf
            self.capacity = cap
        else:
            for fname, spec in self.specs.items():
                w = self._width(spec.kind)
                buf = self._buffers[fname]
                for d in range(w - 1, -1, -1):  # last row first: no row overwrites an unread one
                    buf[d * new_n: d * new_n + n] = buf[d * n: d * n + n].copy()
                    buf[d * new_n + n: (d + 1) * new_n] = spec.fill
        self.n = new_n
        for fname in self.specs:
            self._view(fname)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.fields[name]

    def __setitem__(self, name: str, value: np.ndarray) -> None:
        if name not in self.specs:
            raise KeyError(f"field {name} is not registered")
        if self.device != "cpu" and np.isscalar(value):
            arrays.fill(self.fields[name], value)  # on the device, without a host array
        else:
            self.fields[name][...] = value

    def __contains__(self, name: str) -> bool:
        return name in self.fields

    def view(self, name: str) -> np.ndarray:
        """The field in user layout: (N, dim) for vectors (a transposed view), (N,) for scalars."""
        a = self.fields[name]
        return a if self.specs[name].kind == "scalar" else a.T

    def add(self, x: np.ndarray, name: str = "object", **values: np.ndarray | float) -> ObjectRange:
        """Append particles at positions ``x`` (M, dim) and return their object range.

        Keyword arguments give initial values of registered fields (broadcast); other fields get
        the ``fill`` they were registered with (0 by default). Ids continue from :attr:`next_id`
        (one past the largest id ever handed out), so they stay unique. The buffers grow by
        doubling (see the module docstring). Adds under the name of the last object, directly
        after it, extend its range instead of opening a new one (an emitter's layers).
        """
        x = np.asarray(x, dtype=self.dtype)
        if x.ndim != 2 or x.shape[1] != self.dim:
            raise ValueError(f"{name}: positions of shape {x.shape}; expected (M, {self.dim})")
        for fname in values:
            if fname not in self.specs:
                raise KeyError(f"field {fname} is not registered")
        m = x.shape[0]
        start = self.n
        if self.n:
            self.next_id = max(self.next_id, self._max_id() + 1)
        next_id = self.next_id
        if self.device != "cpu":
            self._append_on_device(x, next_id, values)
        else:
            self._grow(m)  # the new columns hold each field's fill
            for fname in ("x", "id", *values):
                w = self._width(self.specs[fname].kind)
                self.fields[fname].reshape(w, start + m)[:, start:] = self._new_columns(
                    fname, x, next_id, values)
        self.next_id = next_id + m
        last = self.objects[-1] if self.objects else None
        if last is not None and last.name == name and last.end == next_id:
            last.end = next_id + m  # repeated adds of one object (an emitter) extend its range
            return last
        rng = ObjectRange(name, next_id, next_id + m)
        self.objects.append(rng)
        return rng

    def renew(self, index: np.ndarray, x: np.ndarray, **values: np.ndarray | float) -> None:
        """Start the particles at positions ``index`` (M,) afresh at ``x`` (M, dim), keeping
        their ids: every field as :meth:`add` would set it (``values``, else the field's fill).
        SPlisHSPlasH's emitters reuse particles so (``emitterReuseParticles``); works on the
        device too (each field's new columns written there)."""
        index = np.asarray(index, dtype=np.int64)
        x = np.asarray(x, dtype=self.dtype)
        if x.shape != (index.size, self.dim):
            raise ValueError(f"renew: positions of shape {x.shape}; expected ({index.size}, "
                             f"{self.dim})")
        if index.size and (index.min() < 0 or index.max() >= self.n):
            raise ValueError(f"renew: indices outside [0, {self.n})")
        for fname in values:
            if fname not in self.specs:
                raise KeyError(f"field {fname} is not registered")
        idx = to_device(index, self.device) if self.device != "cpu" else index
        for fname, spec in self.specs.items():
            if fname == "id" or not index.size:
                continue
            w = self._width(spec.kind)
            new = self._new_columns(fname, x, 0, values)
            out = self.fields[fname].reshape(w, self.n)
            if self.device == "cpu":
                out[:, index] = new
            else:
                launch(_scatter_body, index.size, idx, to_device(new, self.device), w, out)

    def _max_id(self) -> int:
        """The largest id of the set (n > 0; on a device one scalar read back)."""
        if self.device == "cpu":
            return int(self.fields["id"].max())
        return int(launch_reduce(_id_body, self.n, self.fields["id"])[1])

    def _new_columns(self, fname: str, x: np.ndarray, next_id: int, values: dict) -> np.ndarray:
        """Field ``fname``'s (w, M) columns of the particles :meth:`add` appends at ``x`` (M,
        dim): the positions, the ids from ``next_id``, ``values[fname]`` (broadcast), else the
        field's fill."""
        spec, m = self.specs[fname], x.shape[0]
        new = np.full((self._width(spec.kind), m), spec.fill, dtype=spec.dtype)
        if fname == "x":
            new[...] = x.T
        elif fname == "id":
            new[0] = np.arange(next_id, next_id + m)
        elif fname in values:
            arr = np.asarray(values[fname], dtype=spec.dtype)
            if spec.kind == "scalar":
                new[0] = arr
            else:
                new[...] = arr.reshape(-1, 1) if arr.ndim == 1 else arr.T
        return new

    def _append_on_device(self, x: np.ndarray, next_id: int, values: dict) -> None:
        """:meth:`add` on a device: each field reallocated there for ``n + M`` particles, the
        old columns copied on the device and the new ones (:meth:`_new_columns`, built on the
        host) copied in (the buffers' capacity is the host's)."""
        m, n = x.shape[0], self.n
        for fname, spec in self.specs.items():
            w = self._width(spec.kind)
            new = to_device(self._new_columns(fname, x, next_id, values), self.device)
            old = self.fields[fname]
            out = arrays.empty(self._shape(spec.kind, n + m), spec.dtype, like=old)
            launch(_append_body, n + m, old.reshape(w, n), new, n, w, out.reshape(w, n + m))
            self.fields[fname] = out
        self.n = n + m

    def resize(self, n: int) -> None:
        """Set the number of particles to ``n``, every field reallocated and zeroed (for sets
        rebuilt each step, such as the virtual boundary particles of density and volume maps;
        object ranges are cleared); on a device the fields stay there."""
        n = int(n)
        if n < 0:
            raise ValueError(f"resize: {n} particles; expected a count >= 0")
        for fname, spec in self.specs.items():
            a, shape = self.fields[fname], self._shape(spec.kind, n)
            if a.shape != shape:  # zeros where the field is (NumPy's on the CPU)
                self.fields[fname] = arrays.zeros(shape, spec.dtype, like=a)
            elif self.device != "cpu":
                arrays.fill(a, 0)
            else:
                a[...] = 0
        if self.device == "cpu":  # the buffers hold the fields (a later add grows them)
            self._buffers = {f: a.reshape(-1) for f, a in self.fields.items()}
            self.capacity = n
        self.n = n
        self.objects = []

    def compact(self, keep: np.ndarray) -> None:
        """Keep only the particles where ``keep`` (N,) is True, in their order, and number them
        afresh: ids ``0 .. n-1`` in the order of the old ids, each object's range shrunk to the
        particles it keeps (empty objects dropped). For a world being built (fluid removed from
        inside walls, :mod:`sphkit.world.startup`): ids are renumbered, so do not use it on a
        set whose ids have been written out."""
        self._on_host("compact")
        keep = np.asarray(keep, dtype=bool)
        if keep.shape != (self.n,):
            raise ValueError(f"compact: mask of shape {keep.shape}; expected ({self.n},)")
        old_ids = self.fields["id"][keep].copy()
        kept = {name: (self.fields[name][keep] if s.kind == "scalar"
                       else self.fields[name][:, keep]).copy()
                for name, s in self.specs.items()}
        m = int(keep.sum())
        self.n = 0
        self.capacity = 0
        for name in self.specs:
            self._buffers[name] = np.zeros(0, dtype=self.specs[name].dtype)
            self._view(name)
        self._grow(m)
        for name, a in kept.items():
            self.fields[name][...] = a
        rank = np.empty(m, dtype=np.int64)  # new id = rank of the old id
        rank[np.argsort(old_ids, kind="stable")] = np.arange(m)
        self.fields["id"][...] = rank
        objects, start = [], 0
        sorted_ids = np.sort(old_ids)
        for o in self.objects:
            count = int(np.searchsorted(sorted_ids, o.end) - np.searchsorted(sorted_ids, o.start))
            if count:
                objects.append(ObjectRange(o.name, start, start + count))
                start += count
        self.objects = objects
        self.next_id = m

    def object_index(self, ids: np.ndarray) -> np.ndarray:
        """The index into :attr:`objects` of the particles with ``ids`` (-1 for an id before
        the first object)."""
        starts = np.array([o.start for o in self.objects], dtype=np.int64)
        return np.searchsorted(starts, ids, side="right") - 1

    def permute(self, perm: np.ndarray) -> None:
        """Reorder every field by ``perm`` (new[i] = old[perm[i]]); ids travel with particles.
        On the device the fields are gathered there (``perm`` is copied to it, unless it is
        there already)."""
        if self.device != "cpu":
            p = perm if arrays.on_device(perm) else to_device(
                np.ascontiguousarray(perm, dtype=np.int64), self.device)
            for fname in self.specs:
                self.fields[fname] = arrays.gathered(self.fields[fname], p)
            return
        for fname, spec in self.specs.items():
            a = self.fields[fname]
            a[...] = a[perm] if spec.kind == "scalar" else a[:, perm]

    def order_by_id(self) -> np.ndarray:
        """Permutation that sorts the particles by id (to compare states across reorderings)."""
        return np.argsort(self.fields["id"], kind="stable")

    # -- checkpoints ------------------------------------------------------------------------------
    def state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """Everything needed to rebuild this set: (metadata, {field: array of the n particles}).

        The arrays are the fields in memory order (not sorted by id), so that a restored set
        walks its neighbours in the same order and a resumed run repeats the same arithmetic.
        """
        meta = {
            "dim": self.dim, "dtype": self.dtype.str, "n": self.n, "next_id": self.next_id,
            "specs": {k: {"kind": s.kind, "dtype": s.dtype.str, "fill": s.fill}
                      for k, s in self.specs.items()},
            "objects": [[o.name, o.start, o.end] for o in self.objects],
        }
        self._on_host("state")
        return meta, {k: self.fields[k].copy() for k in self.specs}

    def set_state(self, meta: dict, arrays: dict[str, np.ndarray]) -> None:
        """Replace every field, ids and object ranges by a :meth:`state` (fields the state has
        and this set lacks are registered; a field this set has and the state lacks is an error:
        the state was written by another configuration)."""
        self._on_host("set_state")
        if int(meta["dim"]) != self.dim:
            raise ValueError(f"particle state of dimension {meta['dim']}; expected {self.dim}")
        absent = set(self.specs) - set(meta["specs"])
        missing = sorted(k for k in absent if not self.specs[k].optional)
        if missing:
            raise ValueError(f"particle state lacks the field(s) {missing} that this simulation "
                             "registered; it was written by another scene or sphkit version")
        for name, sp in meta["specs"].items():
            self.register(name, sp["kind"], np.dtype(sp["dtype"]), sp.get("fill", 0.0))
        n = int(meta["n"])
        self.n = 0
        self.capacity = 0
        for name in self.specs:
            self._buffers[name] = np.zeros(0, dtype=self.specs[name].dtype)
            self._view(name)
        self._grow(n)
        for name, spec in self.specs.items():
            if name in absent:  # optional, older state: _grow gave it its fill
                continue
            a = np.asarray(arrays[name])
            if a.shape != self.fields[name].shape or a.dtype != spec.dtype:
                raise ValueError(f"particle state field {name}: {a.dtype} {a.shape}; expected "
                                 f"{spec.dtype} {self.fields[name].shape}")
            self.fields[name][...] = a
        self.next_id = int(meta["next_id"])
        self.objects = [ObjectRange(str(a), int(b), int(c)) for a, b, c in meta["objects"]]
