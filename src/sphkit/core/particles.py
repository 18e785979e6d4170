"""ParticleSet: struct-of-arrays particle state with registered fields and per-object ranges.

Scalar fields have shape (N,), vector fields (dim, N) -- one contiguous row per coordinate, as
DESIGN.md prescribes; :meth:`ParticleSet.view` hands out the usual (N, dim) layout as a view.
Methods register the per-particle fields they need (``register``) instead of keeping private
arrays, so that output, checkpoints, reordering and the GPU backend see every field.
Every set carries an ``id`` field: a stable user-visible particle number that survives reordering.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class FieldSpec:
    """How a field is stored: ``kind`` is 'scalar' (N,), 'vector' (dim, N) or 'vector3' (3, N).

    'vector3' is for quantities that have three components whatever the dimension (angular
    velocity, vorticity: in 2D only the z row is used).
    """

    name: str
    kind: str
    dtype: np.dtype


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
        self.specs: dict[str, FieldSpec] = {}
        self.fields: dict[str, np.ndarray] = {}
        self.objects: list[ObjectRange] = []
        self.register("x", "vector")
        self.register("id", "scalar", np.int64)

    def register(self, name: str, kind: str = "scalar", dtype: np.dtype | str | None = None,
                 fill: float = 0.0) -> np.ndarray:
        """Add a field (no-op if it exists with the same layout) and return its array."""
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
        self.specs[name] = FieldSpec(name, kind, dt)
        self.fields[name] = np.full(self._shape(kind, self.n), fill, dtype=dt)
        return self.fields[name]

    def _shape(self, kind: str, n: int) -> tuple[int, ...]:
        if kind == "vector":
            return (self.dim, n)
        if kind == "vector3":
            return (3, n)
        return (n,)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.fields[name]

    def __setitem__(self, name: str, value: np.ndarray) -> None:
        if name not in self.specs:
            raise KeyError(f"field {name} is not registered")
        self.fields[name][...] = value

    def __contains__(self, name: str) -> bool:
        return name in self.fields

    def view(self, name: str) -> np.ndarray:
        """The field in user layout: (N, dim) for vectors (a transposed view), (N,) for scalars."""
        a = self.fields[name]
        return a if self.specs[name].kind == "scalar" else a.T

    def add(self, x: np.ndarray, name: str = "object", **values: np.ndarray | float) -> ObjectRange:
        """Append particles at positions ``x`` (M, dim) and return their object range.

        Keyword arguments give initial values of registered fields (broadcast); other fields are
        zero. Ids continue from the largest id so far.
        """
        x = np.asarray(x, dtype=self.dtype)
        if x.ndim != 2 or x.shape[1] != self.dim:
            raise ValueError(f"{name}: positions of shape {x.shape}; expected (M, {self.dim})")
        m = x.shape[0]
        start = self.n
        next_id = int(self.fields["id"].max()) + 1 if self.n else 0
        for fname, spec in self.specs.items():
            new = np.zeros(self._shape(spec.kind, self.n + m), dtype=spec.dtype)
            new[..., : self.n] = self.fields[fname]
            self.fields[fname] = new
        self.n += m
        self.fields["x"][:, start:] = x.T
        self.fields["id"][start:] = np.arange(next_id, next_id + m)
        for fname, val in values.items():
            if fname not in self.specs:
                raise KeyError(f"field {fname} is not registered")
            arr = np.asarray(val, dtype=self.specs[fname].dtype)
            if self.specs[fname].kind != "scalar":
                self.fields[fname][:, start:] = arr.reshape(-1, 1) if arr.ndim == 1 else arr.T
            else:
                self.fields[fname][start:] = arr
        rng = ObjectRange(name, start, self.n)
        self.objects.append(rng)
        return rng

    def resize(self, n: int) -> None:
        """Set the number of particles to ``n``, every field reallocated and zeroed (for sets
        rebuilt each step, such as the virtual boundary particles of density and volume maps;
        object ranges are cleared)."""
        n = int(n)
        if n < 0:
            raise ValueError(f"resize: {n} particles; expected a count >= 0")
        for fname, spec in self.specs.items():
            if self.fields[fname].shape != self._shape(spec.kind, n):
                self.fields[fname] = np.zeros(self._shape(spec.kind, n), dtype=spec.dtype)
            else:
                self.fields[fname][...] = 0
        self.n = n
        self.objects = []

    def permute(self, perm: np.ndarray) -> None:
        """Reorder every field by ``perm`` (new[i] = old[perm[i]]); ids travel with particles."""
        for fname, spec in self.specs.items():
            a = self.fields[fname]
            b = a[perm] if spec.kind == "scalar" else a[:, perm]
            self.fields[fname] = np.ascontiguousarray(b)

    def order_by_id(self) -> np.ndarray:
        """Permutation that sorts the particles by id (to compare states across reorderings)."""
        return np.argsort(self.fields["id"], kind="stable")
