"""The rest configuration of an elastic solid, shared by the corotated models.

SPlisHSPlasH's semantics (``Elasticity_Becker2009.cpp``, ``Elasticity_Peer2018.cpp``): a solid
is a material of the fluid particle set; at the start its particles store their positions
``x0`` (the rest, or reference, configuration) and their neighbours within the support h in
that configuration, among the particles of the same material only; the elastic terms walk these
rest lists for the whole run (a total Lagrangian kernel), whatever the particles' current
neighbours. Particles whose rest position lies in a fixed box are pinned.

Storage. The particle set is reordered along a z-order curve during the run, so everything
per particle lives in registered fields of ``state.fluid`` (reordered, written to checkpoints
and frames with the rest): ``solid_slot`` (the particle's index in its solid, -1 for fluid),
``solid_x0`` (rest position [m]), ``solid_fixed`` (1: pinned), ``solid_V0`` (rest volume
[m^dim]: the particle's own ``V0 = m / rho0``, the volume of its sampling lattice, or with
``rest_volume="kernel_sum"`` SPlisHSPlasH's ``m_i / sum_j m_j W(x0_ij)``, self included, which
is up to 1.65 times larger at the surface, where the kernel sum is cut, and makes the surface
layer too stiff: a stretched bar 4 particles wide pulls with 1.19 of ``E eps A`` against 1.00003
with the particle volume, measured), ``solid_qw``/``solid_q`` (the rotation of
the corotated frame as a unit quaternion: its real part and its vector part) and
``solid_stress`` (von Mises stress [Pa], for output), ``solid_object`` (the index of the
scene object, fluid block or particle file, in ``state.fluid.objects`` that made the particle;
-1 for fluid; for output). The rest neighbour lists are CSR over
slots, built from ``solid_x0`` by :meth:`RestConfiguration.build` (deterministic, so a restored
checkpoint rebuilds the same lists). Each step ``pos[s]`` maps a slot to its current index.

The rest lists reach ``support * h`` (default 1: the fluid's h, as SPlisHSPlasH; the
second-order gradient of :mod:`sphkit.solids.gradients` needs more neighbours than a surface
particle has within h, see ``ElasticityConfig.rest_support``).

Pinned particles and the elastic sums (``ElasticityConfig.clamp``): with ``"particles"``
(SPlisHSPlasH's) a pinned particle is a particle of the solid like any other, with its own
strain and stress, and the free particles' gradient fits sample its zero displacement where it
lies, behind the clamp's face. A bent cantilever's curvature jumps to zero at the face, which
the fits across it smooth: the clamp acts as an elastic hinge (3D cantilever, 4 particles
across, alpha 0: the first free layer has turned by 1.00e-3 rad where Euler-Bernoulli has
0.24e-3, and the beam's slope stays about 0.6e-3 rad above Euler-Bernoulli's from there to the
tip, while its curvature in the middle matches to 0.2 %; validation/README.md). With ``"face"``
the pinned particles are rigid (no strain: their gradient weights are zero) and a free
particle's fit samples a pinned neighbour's zero displacement where the pair's segment enters
the fixed box (:meth:`RestConfiguration.clamp_vectors`; the pair's weight stays that of its rest
distance), so the fits of the free particles are exact for a quadratic displacement that
vanishes on the face. The moved sample is carried by its pinned particle (at ``x_j`` less the
pair's constant shift; the deformation gradient of :mod:`sphkit.solids.corotation`, "Face
clamp"), so its displacement is the pinned particle's own, which
assumes pinned particles at rest (kee2023's pinned particles follow a velocity field when a
scene sets one: then the face's samples carry the pinned particles' motion, exact for a
translation only).

``max_neighbors`` caps a list at the nearest neighbours; a pair is kept only when each particle
is among the other's nearest, so the capped lists stay symmetric (Kee et al. 2023 found that
SPlisHSPlasH's one-sided caps break the conservation of momentum).
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.core.kernels import kernel_w
from sphkit.core.neighbors import INDEX, NeighborList, neighbor_lists
from sphkit.core.pairs import pair_slots
from sphkit.core.state import SimState

_JIT = dict(cache=True, fastmath=True)

#: the per-particle fields of a solid (name -> kind, dtype, fill)
FIELDS: dict[str, tuple[str, Any, float]] = {
    "solid_slot": ("scalar", np.int64, -1),
    "solid_x0": ("vector", None, 0.0),
    "solid_fixed": ("scalar", np.int64, 0),
    "solid_V0": ("scalar", None, 0.0),
    "solid_qw": ("scalar", None, 1.0),
    "solid_q": ("vector3", None, 0.0),
    "solid_stress": ("scalar", None, 0.0),
    "solid_object": ("scalar", np.int64, -1),
}


@numba.njit(cache=True)
def _slot_positions(slot, base, pos):
    """``pos[s] = i`` for the particles i of the solid whose slots are ``base + s``."""
    ns = pos.shape[0]
    for i in range(slot.shape[0]):
        s = slot[i] - base
        if 0 <= s < ns:
            pos[s] = i


@numba.njit(parallel=True, **_JIT)
def _rest_volumes(x0, m, off, idx, h, kid, dim, out):
    """``V0_s = m_s / (m_s W(0) + sum_j m_j W(|x0_s - x0_j|))`` (slot order)."""
    w0 = kernel_w(kid, 0.0, h, dim)
    for s in numba.prange(x0.shape[1]):
        rho = m[s] * w0
        for k in pair_slots(off, s):
            j = idx[k]
            d0 = x0[0, s] - x0[0, j]
            d1 = x0[1, s] - x0[1, j]
            d2 = x0[2, s] - x0[2, j]
            rho += m[j] * kernel_w(kid, np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), h, dim)
        out[s] = m[s] / rho


@numba.njit(parallel=True, cache=True)
def _pin(x, v, x0, pos, fixed, dim):
    """Pinned particles: ``x = x0``, ``v = 0``."""
    for s in numba.prange(fixed.shape[0]):
        i = pos[fixed[s]]
        for d in range(dim):
            x[d, i] = x0[d, i]
            v[d, i] = 0.0


def capped_lists(x0: np.ndarray, lists: NeighborList, cap: int) -> NeighborList:
    """The lists of ``lists`` cut to the ``cap`` nearest neighbours of each point, keeping a
    pair only when each point is among the other's ``cap`` nearest (symmetric lists)."""
    n = len(lists)
    counts = lists.counts()
    rows = np.repeat(np.arange(n, dtype=np.int64), counts)
    cols = lists.indices.astype(np.int64)
    d = x0[:, rows] - x0[:, cols]
    dist = np.einsum("ij,ij->j", d, d)
    order = np.lexsort((cols, dist, rows))  # by row, then distance (ties: by index)
    rows, cols = rows[order], cols[order]
    rank = np.arange(rows.size) - lists.offsets[rows]
    keep = rank < cap
    rows, cols = rows[keep], cols[keep]
    key = rows * n + cols
    mutual = np.isin(cols * n + rows, key)
    rows, cols = rows[mutual], cols[mutual]
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=offsets[1:])
    return NeighborList(offsets, cols.astype(INDEX))


class RestConfiguration:
    """A solid's particles, rest positions, rest lists and pinned particles (module docstring).

    Arrays in slot order (the solid's own numbering): ``x0`` (3, ns) rest positions (zero rows
    beyond dim), ``V0`` rest volumes, ``m`` masses, ``offsets``/``indices`` the rest lists over
    slots, ``fixed`` the pinned slots; ``pos`` maps slots to the current particle indices
    (:meth:`update`).
    """

    def __init__(self, objects: tuple[str, ...], fixed_boxes: list, max_neighbors: int,
                 rest_volume: str = "particle", support: float = 1.0) -> None:
        if rest_volume not in ("particle", "kernel_sum"):
            raise ValueError(f"elasticity.rest_volume: {rest_volume!r}; expected 'particle' or "
                             "'kernel_sum'")
        self.rest_volume = rest_volume
        self.support = float(support)
        self.h = 0.0  #: the support radius of the rest lists [m]: support * h
        self.objects = objects
        self.fixed_boxes = fixed_boxes
        self.max_neighbors = max_neighbors
        self.base = 0
        self.n = 0
        self.x0 = np.zeros((3, 0))
        self.V0 = np.zeros(0)
        self.m = np.zeros(0)
        self.lists = NeighborList.empty(0)
        self.fixed = np.zeros(0, np.int64)
        self.pinned = np.zeros(0, dtype=bool)  #: (n,) True for a pinned slot
        self.pos = np.zeros(0, np.int64)

    def build(self, state: SimState) -> None:
        """Register the fields; on the first call claim the particles of :attr:`objects` (slots
        in id order, rest positions = current positions); then build the slot-ordered arrays
        and the rest lists from the stored fields."""
        f = state.fluid
        for name, (kind, dtype, fill) in FIELDS.items():
            f.register(name, kind, dtype, fill)
        slot = f["solid_slot"]
        ids = f["id"]
        mine = np.zeros(f.n, dtype=bool)
        obj = f["solid_object"]
        for k, o in enumerate(f.objects):
            if o.name in self.objects:
                sel = (ids >= o.start) & (ids < o.end)
                mine |= sel
                obj[sel] = k  # the scene object that made the particle (frames' "object")
        if mine.any() and (slot[mine] < 0).all():  # first call: claim the particles
            others = slot[~mine]
            self.base = int(others.max()) + 1 if others.size and others.max() >= 0 else 0
            idx = np.flatnonzero(mine)
            idx = idx[np.argsort(ids[idx], kind="stable")]
            slot[idx] = self.base + np.arange(idx.size)
            f["solid_x0"][:, idx] = f["x"][:, idx]
            f["solid_qw"][idx] = 1.0
            f["solid_q"][:, idx] = 0.0
        elif mine.any():
            self.base = int(slot[mine].min())
        self.n = int(mine.sum())
        self.pos = np.zeros(self.n, np.int64)
        self.update(state)
        dim = state.dim
        self.x0 = np.zeros((3, self.n))
        self.x0[:dim] = f["solid_x0"][:, self.pos]
        self.m = np.ascontiguousarray(f["m"][self.pos], dtype=np.float64)
        self.h = self.support * state.h
        lists = neighbor_lists(np.ascontiguousarray(self.x0[:dim]), self.h)
        if self.max_neighbors > 0:
            lists = capped_lists(self.x0, lists, self.max_neighbors)
        self.lists = lists
        if self.rest_volume == "kernel_sum":
            self.V0 = np.zeros(self.n)
            _rest_volumes(self.x0, self.m, lists.offsets, lists.indices, self.h, state.kid,
                          dim, self.V0)
        else:
            self.V0 = np.ascontiguousarray(f["V0"][self.pos], dtype=np.float64)
        f["solid_V0"][self.pos] = self.V0
        pinned = np.zeros(self.n, dtype=bool)
        for box in self.fixed_boxes:
            k = min(dim, len(box.min))
            lo, hi = np.asarray(box.min[:k], float), np.asarray(box.max[:k], float)
            pinned |= np.all((self.x0[:k].T >= lo) & (self.x0[:k].T <= hi), axis=1)
        self.pinned = pinned
        self.fixed = np.flatnonzero(pinned).astype(np.int64)
        fx = np.zeros(self.n, np.int64)
        fx[self.fixed] = 1
        f["solid_fixed"][self.pos] = fx

    def clamp_vectors(self, dim: int) -> np.ndarray:
        """The fit's sample vectors (pairs, ``dim``) of the face clamp: ``x0_ji`` for every rest
        pair (i, j), except from a free particle i to a pinned j, where the sample is moved
        along the segment to the point where it enters j's fixed box (the first such box
        boundary when j lies in several), so that the free particle's fit sees the pinned
        (zero) displacement on the clamp's face instead of behind it."""
        off, idx = self.lists.offsets, self.lists.indices
        rows = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(off))
        cols = idx.astype(np.int64)
        d = (self.x0[:dim, cols] - self.x0[:dim, rows]).T.copy()
        pinned = np.zeros(self.n, dtype=bool)
        pinned[self.fixed] = True
        sel = np.flatnonzero(~pinned[rows] & pinned[cols])
        if not sel.size:
            return d
        xi = self.x0[:dim, rows[sel]].T
        xj = self.x0[:dim, cols[sel]].T
        dd = xj - xi
        t = np.ones(sel.size)
        for box in self.fixed_boxes:
            k = min(dim, len(box.min))
            lo, hi = np.asarray(box.min[:k], float), np.asarray(box.max[:k], float)
            inside = np.all((xj[:, :k] >= lo) & (xj[:, :k] <= hi), axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                t1 = (lo - xi[:, :k]) / dd[:, :k]
                t2 = (hi - xi[:, :k]) / dd[:, :k]
            near = np.where(dd[:, :k] != 0.0, np.minimum(t1, t2), -np.inf)
            enter = np.clip(near.max(axis=1), 0.0, 1.0)
            t = np.where(inside, np.minimum(t, enter), t)
        d[sel] = t[:, None] * dd
        return d

    def update(self, state: SimState) -> np.ndarray:
        """The current particle index of every slot (after this step's reordering)."""
        _slot_positions(state.fluid["solid_slot"], self.base, self.pos)
        return self.pos

    def constrain(self, state: SimState) -> None:
        """Pinned particles back at their rest positions with zero velocity."""
        if self.fixed.size:
            f = state.fluid
            self.update(state)
            _pin(f["x"], f["v"], f["solid_x0"], self.pos, self.fixed, state.dim)
