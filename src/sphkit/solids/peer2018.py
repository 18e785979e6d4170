"""Implicit corotated linear elasticity (SPlisHSPlasH ``elasticityMethod`` 2).

Peer, Gissler, Band & Teschner 2018, "An Implicit SPH Formulation for Incompressible Linearly
Elastic Solids", Computer Graphics Forum 37(6): the corotated linear elastic force of the
step, taken at the end-of-step positions ``x + dt v'`` (backward Euler in the velocities), with
the rotations of the step's start held; the linear system

    (M - dt^2 K) v' = M (v + dt a + dt M^-1 f(x))

(``K``: the stiffness, the derivative of the elastic force by the positions at fixed
rotations, symmetric negative semi-definite; ``a``: the other accelerations of the stage,
gravity, viscosity, ...) is solved matrix-free by the shared CG (:func:`sphkit.core.krylov.cg`,
``max_iterations``/``max_error``: SPlisHSPlasH's ``elasticityMaxIter`` 100 and
``elasticityMaxError`` 1e-4, the relative residual), warm-started with ``v + dt a`` as
SPlisHSPlasH does. A product ``K v`` is one displacement-gradient pass and one force pass of
:mod:`sphkit.solids.corotation` on the displacement field ``dt v`` (rest positions zero), so
the implicit model shares the explicit one's discretisation: gradient weights
(``gradient_correction``), rest volumes, the energy-consistent force. The zero-energy-mode
force (``alpha``; Ganzenmüller 2015's, as SPlisHSPlasH) is evaluated at the step's start, as in
SPlisHSPlasH, but linearly implicit (sphkit's): its stiffness is approximated by the constant
Hessian ``alpha E Z`` of Kugelstadt et al. 2021's zero-energy-mode energy
(:func:`sphkit.solids.operators.zero_energy_operator`, the same error vectors and pair
weights, not projected on the pair direction, so at least as stiff), which joins the system's
matrix: ``(M - dt^2 K + dt^2 alpha E Z) v' = ...``. At rest (``v' = 0``) the added term
vanishes, so static states are those of the explicit force; what it buys is stability at
steps above the hourglass force's explicit bound: with the term explicit, a block afloat at
the fluid's step (10 times the P-wave bound, alpha 0.1) vibrated at 5-9 m/s and jumped off the
water, with alpha 0 it floated (validation/README.md, "Floating block"; the pressure solve's
push, which this solve sees a step late, was not the cause: taking the last step's push into
the right-hand side moved the depth by 0.02 mm). The implicit part
adds backward-Euler damping to the modes where Z is stiffer than the projected force. The
elastic acceleration of the stage is
``(v' - v) / dt - a``, so ``a`` becomes ``(v' - v) / dt`` (SPlisHSPlasH adds ``(v' - v)/dt`` to
``a``, which counts ``a`` twice). Pinned particles keep ``v' = 0`` (identity rows and columns).
The pressure solver then acts on the result (operator splitting). No time-step bound of its
own. Plasticity (``yield_stress``, ``hardening``): the return mapping of
:mod:`sphkit.solids.plasticity` acts on the strain of the step's start (the explicit force
``f(x)``); ``K`` stays the elastic stiffness, so the solve extrapolates the step elastically
with the plastic strain held, and the next step's return corrects it.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from sphkit.core.krylov import cg
from sphkit.core.state import SimState
from sphkit.solids.base import ImplicitCorotatedSolid
from sphkit.solids.corotation import forces, stresses
from sphkit.solids.operators import gradient_operators, zero_energy_operator


class Peer2018(ImplicitCorotatedSolid):
    """Implicit corotated linear elasticity (module docstring)."""

    name: ClassVar[str] = "peer2018"
    #: ``alpha E Z``, the zero-energy-mode stiffness of the implicit part (None: alpha 0)
    Z: sp.csr_matrix | None = None

    def init(self, state: SimState) -> None:
        """The base's rest configuration; with ``alpha > 0`` the zero-energy-mode stiffness
        ``alpha E Z`` of the implicit part (module docstring)."""
        super().init(state)
        self.Z = None
        if self.alpha > 0 and self.rest.n:
            rest = self.rest
            off, idx = rest.lists.offsets, rest.lists.indices
            D = gradient_operators(off, idx, self.G, state.dim)
            self.Z = (self.alpha * self.youngs_modulus * zero_energy_operator(
                rest.x0, rest.V0, off, idx, D, rest.h, state.kid, state.dim)).tocsr()

    def max_time_step(self, state: SimState) -> float:
        """Implicit: no bound of its own."""
        return math.inf

    def apply(self, state: SimState, dt: float) -> None:
        """Solve for the end-of-step velocities; set the solid's acceleration to
        ``(v' - v) / dt``."""
        rest = self.rest
        if rest is None or rest.n == 0:
            return
        f = state.fluid
        dim = state.dim
        pos = rest.update(state)
        a_before = f["a"][:, pos].copy()
        super().apply(state, dt)  # rotations, P = R sigma, explicit f(x) and hourglass into a
        v = f["v"][:, pos]
        b = (v + dt * f["a"][:, pos]) * rest.m  # M (v + dt a + dt f / m)
        pinned = rest.fixed
        b[:, pinned] = 0.0
        w = self.work
        scratch_x = np.zeros_like(f["x"])
        scratch_a = np.zeros_like(f["a"])
        zeros0 = np.zeros_like(rest.x0)
        noshift = np.zeros_like(self.C)  # K v is linear in v: no face-clamp shift
        vm = np.zeros(f.n)
        F, P, M = np.zeros_like(w["F"]), np.zeros_like(w["P"]), np.zeros_like(w["M"])
        off, idx = rest.lists.offsets, rest.lists.indices
        m = rest.m
        Z = self.Z
        dt2 = dt * dt

        def matvec(y: np.ndarray, out: np.ndarray) -> None:
            yv = y.reshape(dim, rest.n).copy()
            yv[:, pinned] = 0.0
            scratch_x[:, pos] = dt * yv
            scratch_a[:, pos] = 0.0
            stresses(scratch_x, pos, zeros0, off, idx, self.G, noshift, dim, self.mu, self.lam,
                     w["R"], F, P, M, vm, *self.plastic_state(state), 0.0, 0.0, False)
            forces(scratch_x, pos, zeros0, rest.V0, m, off, idx, self.G, self.rev, rest.h,
                   state.kid, dim, P, M, 0.0, scratch_a)
            o = out.reshape(dim, rest.n)
            o[...] = m * (yv - dt * scratch_a[:, pos])
            if Z is not None:  # the zero-energy-mode stiffness, linearly implicit
                for a in range(dim):
                    o[a] += dt2 * (Z @ yv[a])
            o[:, pinned] = y.reshape(dim, rest.n)[:, pinned]

        x0 = (v + dt * a_before)
        x0[:, pinned] = 0.0
        sol, stats = cg(matvec, b.ravel(), x0.ravel(), tol=self.max_error,
                        max_iter=self.max_iterations, name="peer2018 elasticity",
                        step=state.step)
        self.stats = stats
        vnew = sol.reshape(dim, rest.n)
        f["a"][:, pos] = (vnew - v) / dt
