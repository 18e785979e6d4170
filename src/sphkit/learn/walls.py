"""Collision of a learned rollout's fluid particles with the static wall particles.

A learned simulator predicts each fluid particle's next position from its neighbourhood; with
little training (GNS papers train 10^5 to 10^6 steps, ten minutes on two CPU cores give about
10^4) nothing but the training data keeps a fast particle from being moved through a wall, and
once one is behind it the network has never seen its state. Simulators that move particles by
position updates handle solids the same way: position-based fluids (Macklin & Mueller 2013,
Sec. 5) project every predicted position out of the colliders after the solver. Here the
colliders are the wall particles of the rollout (the points the network sees as its static
nodes), so the rule needs no geometry beyond them:

* the walls' surface is a level set of the smooth field ``phi(x) = sum_w (1 - |x - x_w|^2 /
  R^2)^3`` (R = 3 dx), the level being its value :data:`CONTACT` dx above the top layer's
  centres of a flat wall of two layers (the wall's outer face is 0.5 dx above them); its
  outward normal is the weighted direction away from the wall particles, ``sum_w (1 - |x -
  x_w|^2 / R^2)^2 (x - x_w)``, which tilts by at most 0.3 % over a flat lattice wall;
* the step of a fluid particle from ``x0`` to ``x1`` is sampled every ``dx/8`` (swept test: a
  particle that moves 4.5 dx a frame, as the dam break's splashes do at 100 frames/s, cannot
  tunnel through a wall two layers thick); from the last sample before the first one in
  contact, the particle's remaining displacement loses its component into the wall, so it
  slides along the wall and keeps its tangential motion (a perfectly inelastic, frictionless
  contact); that is repeated up to three times (corners), after which a particle still driven
  into a wall stays at its last sample clear of it.

The level 0.25 dx is below every position of the solver's own particles in the 2D dam breaks of
``sphkit dataset`` at 100 frames/s (the highest field value among them is that of 0.29 dx above a
flat wall, in corners), so the collisions change only predictions that go into a wall. The
baseline of :func:`sphkit.learn.rollout.constant_velocity` can be given the same collisions so
that comparisons stay fair (``sphkit learn eval`` does).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: height / dx above the top layer's centres of a flat wall at which its contact surface lies
#: (the wall's outer face is at 0.5: the surface lies a little inside it, see the module notes)
CONTACT = 0.25
#: spacing of the swept test's samples / dx
SAMPLE = 0.125
#: projections per step (a particle driven into a corner meets two walls)
PASSES = 3
#: radius / dx of the smooth weight that defines the wall's surface and normal
RADIUS = 3.0
#: height / dx above the contact surface to which a sliding particle is lifted (the surface of
#: a lattice wall ripples; a slide that starts on it would touch it again at once)
LIFT = 0.05


def _field(p: np.ndarray, pts: np.ndarray, tree: cKDTree,
           rad: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The field ``phi = sum_w (1 - |p - x_w|^2 / R^2)^3`` of the points ``pts`` (their
    ``tree``) within R = ``rad`` at the points ``p`` (K, dim), the unit direction away from them
    ``sum_w (1 - |p - x_w|^2 / R^2)^2 (p - x_w)`` (K, dim) and the field's gradient's magnitude
    (K,), which is 6 / R^2 times that sum's."""
    phi = np.zeros(len(p))
    away = np.zeros_like(p)
    near = tree.query_ball_point(p, rad, return_sorted=False)
    lens = np.fromiter(map(len, near), dtype=np.int64, count=len(p))
    if lens.sum():
        rows = np.repeat(np.arange(len(p)), lens)
        d = p[rows] - pts[np.concatenate(near).astype(np.int64)]
        q = 1.0 - (d * d).sum(axis=1) / rad ** 2
        phi = np.bincount(rows, weights=q ** 3, minlength=len(p))
        for k in range(p.shape[1]):
            away[:, k] = np.bincount(rows, weights=q ** 2 * d[:, k], minlength=len(p))
    norm = np.linalg.norm(away, axis=1, keepdims=True)
    unit = np.divide(away, norm, out=np.zeros_like(away), where=norm > 0)
    return phi, unit, 6.0 * norm[:, 0] / rad ** 2


def _sample(a: np.ndarray, b: np.ndarray, k: np.ndarray, f: float) -> np.ndarray:
    """Sample ``k`` (K,) of the segments ``a -> b`` (K, dim) sampled at fractions ``f``."""
    return a + (k * f)[:, None] * (b - a)


class WallCollision:
    """Frictionless, inelastic collisions of moving points with static wall particles ``walls``
    (M, dim) of lattice spacing ``dx``."""

    def __init__(self, walls: np.ndarray, dx: float) -> None:
        walls = np.asarray(walls, dtype=np.float64)
        self.dim = walls.shape[1]
        self.dx = float(dx)
        self.walls = walls
        self.rad = RADIUS * self.dx
        self.tree = cKDTree(walls) if len(walls) else None
        # the surface's level: the field at CONTACT dx above a flat wall of two layers, over
        # the middle of a lattice cell (the field's lowest point at that height)
        n = int(RADIUS) + 2
        axis = np.arange(-n, n + 1) * self.dx
        grids = np.meshgrid(*([axis] * (self.dim - 1)), indexing="ij")
        flat = np.stack([g.ravel() for g in grids], axis=1)
        ref = np.concatenate([np.insert(flat, 1, y, axis=1) for y in (0.0, -self.dx)])
        probe = np.full((2, self.dim), 0.5 * self.dx)
        probe[:, 1] = np.array([CONTACT, CONTACT + LIFT]) * self.dx
        self.level, self.lifted = _field(probe, ref, cKDTree(ref), self.rad)[0]

    def field(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The wall field (K,) at the points ``p`` (K, dim), the wall's outward unit normal
        there (K, dim) and the field's gradient's magnitude (K,) (:func:`_field`)."""
        return _field(p, self.walls, self.tree, self.rad)

    def first_contact(self, x0: np.ndarray, x1: np.ndarray) -> tuple[np.ndarray, float]:
        """For each segment ``x0 -> x1`` (N, dim): the index of its first sample in contact
        (-1 for none; samples ``x0 + k/n (x1 - x0)``, k = 0..n), and the samples' fraction
        ``1/n`` of the step."""
        d = x1 - x0
        n = max(1, int(np.ceil(np.linalg.norm(d, axis=1).max(initial=0.0)
                               / (SAMPLE * self.dx))))
        s = np.arange(n + 1) / n
        pts = (x0[:, None, :] + s[None, :, None] * d[:, None, :]).reshape(-1, self.dim)
        hit = np.zeros(len(pts), dtype=bool)
        # only samples within the field's reach can be in contact
        dist, _ = self.tree.query(pts, distance_upper_bound=self.rad)
        close = np.flatnonzero(np.isfinite(dist))
        if len(close):
            hit[close] = self.field(pts[close])[0] > self.level
        hit = hit.reshape(len(x0), n + 1)
        return np.where(hit.any(axis=1), hit.argmax(axis=1), -1), 1.0 / n

    def lift(self, p: np.ndarray) -> np.ndarray:
        """The points ``p`` (K, dim) moved out along the walls' normal to the level LIFT dx
        above the contact surface where they lie below it (Newton steps on the field)."""
        p = p.copy()
        todo = np.arange(len(p))
        for _ in range(4):
            phi, nrm, grad = self.field(p[todo])
            over = (phi > self.lifted) & (grad > 0)
            todo = todo[over]
            if len(todo) == 0:
                break
            p[todo] += ((phi[over] - self.lifted) / grad[over])[:, None] * nrm[over]
        return p

    def __call__(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """The positions (N, dim) the points moving from ``x0`` to ``x1`` reach with the walls
        in the way."""
        x1 = np.array(x1, dtype=np.float64)
        if self.tree is None or len(x1) == 0:
            return x1
        start = np.asarray(x0, dtype=np.float64).copy()
        active = np.arange(len(x1))
        for _ in range(PASSES):
            first, f = self.first_contact(start[active], x1[active])
            hit = first >= 0
            idx, k = active[hit], first[hit]
            a, b = start[idx], x1[idx]
            free = _sample(a, b, np.maximum(k - 1, 0), f)  # the last sample clear of the wall
            nrm = self.field(_sample(a, b, k, f))[1]
            rest = b - free
            into = np.minimum((rest * nrm).sum(axis=1), 0.0)
            # a step that starts in contact and moves along or away from the wall goes on
            moved = (k > 0) | (into < 0.0)
            idx, free = idx[moved], free[moved]
            x1[idx] = self.lift(free + rest[moved] - into[moved, None] * nrm[moved])
            start[idx] = free
            active = idx
            if len(active) == 0:
                return x1
        first, f = self.first_contact(start[active], x1[active])
        k = first > 0
        idx = active[k]  # still driven into a wall after PASSES projections: stop at the last
        x1[idx] = _sample(start[idx], x1[idx], first[k] - 1, f)  # sample clear of it
        return x1
