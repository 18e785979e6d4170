"""Animation fields (SPlisHSPlasH's ``AnimationFields``, ``AnimationField::step``): regions that
impose a particle field -- velocity, angular velocity (micropolar vorticity) or position -- on
the fluid particles inside them, from expressions over time and the particle's state.

A field is a box (``scale`` the full side lengths), a sphere (``scale[0]`` its radius) or a
cylinder along its local x axis (``scale[0]`` its length, ``scale[1]`` its radius), placed at
``translation`` and rotated by ``rotation_angle`` about ``rotation_axis``; a particle at x is
inside when its local position ``R^T (x - translation)`` is (strictly) inside the shape. From
``start_time`` to ``end_time``, after every step (SPlisHSPlasH's ``animateParticles``, at the
end of its step), each component with a non-empty expression is set, for the particles inside,
to the expression's value; empty expressions leave their component alone.

Expressions (:mod:`sphkit.scene.expressions`) read ``t`` (the time after the step), ``dt``,
``x, y, z``, ``vx, vy, vz`` and ``valuex, valuey, valuez`` (the field's value; the components
are set in the order x, y, z, and a later expression reads the earlier components' new values,
as in SPlisHSPlasH).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sphkit.geometry.rotations import rotation_matrix
from sphkit.scene.expressions import compile_expression

#: the scene's field names -> the ParticleSet field they set
FIELDS = {"velocity": "v", "angular_velocity": "omega", "position": "x"}


class AnimationField:
    """One animation field of a scene (``scene.animation_fields[k]``; the module docstring)."""

    def __init__(self, cfg: Any, dim: int) -> None:
        self.field = FIELDS[cfg.field]
        self.shape = cfg.shape
        self.dim = dim
        c = np.zeros(3)
        c[: len(cfg.translation)] = cfg.translation
        self.center = c
        self.R = rotation_matrix(cfg.rotation_axis, cfg.rotation_angle)
        self.scale = np.asarray(cfg.scale, float)
        self.start, self.end = cfg.start_time, cfg.end_time
        self.expressions = [compile_expression(e) if e.strip() else None
                            for e in cfg.expression]

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Which positions x (dim, N) are inside the shape (N,) bool."""
        p = np.zeros((3, x.shape[1]))
        p[: self.dim] = x
        q = self.R.T @ (p - self.center[:, None])
        if self.shape == "sphere":
            return np.sum(q * q, axis=0) < self.scale[0] ** 2
        if self.shape == "cylinder":
            return ((np.abs(q[0]) < 0.5 * self.scale[0])
                    & (q[1] ** 2 + q[2] ** 2 < self.scale[1] ** 2))
        return np.all(np.abs(q) < 0.5 * self.scale[:, None], axis=0)

    def apply(self, fluid: Any, t: float, dt: float) -> int:
        """Set the field of the fluid particles inside at time t (after a step of dt); returns
        how many particles it set (0 outside its time window or without the field)."""
        if t < self.start or (self.end is not None and t > self.end):
            return 0
        if self.field not in fluid.fields or fluid.n == 0:
            return 0
        x, v, value = fluid["x"], fluid["v"], fluid[self.field]
        sel = np.flatnonzero(self.inside(x))
        if len(sel) == 0:
            return 0
        xs, vs = np.zeros((3, len(sel))), np.zeros((3, len(sel)))
        xs[: self.dim], vs[: self.dim] = x[:, sel], v[:, sel]
        rows = value.shape[0]  # vector fields: dim rows (x, v) or 3 (omega)
        val = np.zeros((3, len(sel)))
        val[:rows] = value[:, sel]
        env = {"t": t, "dt": dt, "x": xs[0], "y": xs[1], "z": xs[2], "vx": vs[0],
               "vy": vs[1], "vz": vs[2], "valuex": val[0], "valuey": val[1], "valuez": val[2]}
        for k, expr in enumerate(self.expressions[:rows]):  # 2D: z of x and v is not stored
            if expr is not None:
                out = np.broadcast_to(np.asarray(expr(env), dtype=float), (len(sel),))
                value[k, sel] = out
                env["value" + "xyz"[k]] = out
        return len(sel)
