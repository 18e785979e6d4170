"""Position based fluids (PBF).

Macklin & Mueller 2013, "Position based fluids", ACM TOG 32(4), as SPlisHSPlasH's ``TimeStepPBF``
implements it, in normalized units (``V_j = m_j / rho0``, ``rho_hat = rho / rho0``).

Per step, with ``a_ext`` = gravity + non-pressure accelerations already in ``state.fluid["a"]``:

1. prediction (paper Alg. 1, lines 2-3): ``v_pred = v + dt a_ext``, ``x* = x + dt v_pred``; the
   step-start positions ``x_old = x`` are kept;
2. iterations through :class:`sphkit.core.solver.IterationControl` (default at least 2, as
   SPlisHSPlasH; with several rest densities each one's average error is tested, as
   SPlisHSPlasH tests each fluid model's, :func:`sphkit.core.solver.group_error`), each a
   Jacobi sweep over all density constraints:

   * ``rho_hat_i(x*) = V_i W(0) + sum_j V_j W(x*_i - x*_j) + sum_b V_b W(x*_i - x_b)`` -- the same
     sum as :func:`sphkit.core.ppe.density_at`, fused here with the gradients; density maps
     place their virtual particles x_b for x* in every sweep, as SPlisHSPlasH's
     ``TimeStepPBF::pressureSolveIteration`` queries its maps (``state.coupling.boundary_at``);
     volume maps keep the step's virtual particles (see ``Bender2019.boundary_at``), moved
     along the wall with their fluid particle's displacement ``x* - x`` (``Bender2019.
     following``, through the same ``state.coupling.boundary_at``, as PCISPH's prediction).
     Held fixed instead, a virtual particle left behind
     by a fluid particle sliding along a wall pushed it along the wall as well: in a 2D tank
     at rest (r = 5 mm, volume maps) the fluid at the side walls reached 2-4.6 m/s within
     0.5 s; sliding, 0.2-0.37 m/s (validation/README.md, "PBF with dynamic bodies");
   * ``C_i = max(rho_hat_i - 1, 0)`` (clamped, as SPlisHSPlasH: no attraction at the free
     surface, so no clumping there; the paper's Eq. 1 is unclamped);
   * ``lambda_i = -C_i / (sum_k |grad_k C_i|^2 + epsilon)`` (Eq. 11) with
     ``grad_j C_i = -V_j grad W_ij`` and ``grad_i C_i = sum_j V_j grad W_ij + sum_b V_b grad W_ib``
     (Eq. 8; boundary particles are not moved, so they contribute only to ``grad_i C_i``);
     ``epsilon`` [1/m^2] is the constraint-force-mixing relaxation (SPlisHSPlasH 1e-6).
     Several fluids: the neighbour's term weighs ``rho0_i / rho0_j``, the weight with which the
     correction below moves neighbour j by lambda_i, so lambda_i stays the Newton step of C_i
     (the PBD form with inverse-mass weights, Macklin & Mueller's equal masses generalized;
     SPlisHSPlasH's ``TimeStepPBF`` leaves the ratio out of the denominator, and a heavy
     particle among light ones was corrected ten times too far at 1:10: the heavy-over-light
     column blew up at 1.07 s in 2D and 0.51 s in 3D; validation/README.md, "PBF with several
     rest densities");
   * ``dx_i = sum_j (lambda_i + lambda_j + s_corr,ij) V_j grad W_ij + sum_b lambda_i V_b grad W_ib``
     (Eq. 12/14, Akinci boundary as SPlisHSPlasH), then ``x* += dx`` for all particles;
   * the error of a sweep is the average compression ``mean(C)`` before its correction
     (SPlisHSPlasH's ``avg_density_err``); the reported error is that of the last sweep.

   The two pair loops are :mod:`sphkit.core.projection`'s (target 1), which the start-up's
   density relaxation shares.

   ``grad W_ij`` is evaluated at the predicted positions x*. **The neighbour lists are those of
   the step start** (built at x by the simulation), unlike SPlisHSPlasH, which searches again at
   x*: a pair that moves into the support radius within one step is missed for that step (its
   kernel weight is nearly 0 at the edge of the support, and the CFL step keeps the motion per
   step below about 0.4 (2r) = 0.2 h).

   Optional artificial pressure (Eq. 13, ``s_corr=True``):
   ``s_corr,ij = -k (W(|x*_ij|) / W(dq h))^n / D0``. The paper's s_corr is a dimensionless
   addition to lambda in its units (particle mass and support of order 1); here lambda has units
   m^2, so s_corr is divided by ``D0 = sum_k |grad_k C|^2`` of a filled lattice neighbourhood
   (:func:`sphkit.core.ppe.lattice_diagonal`; PCISPH's template, ``D0 = 1 / (2 delta)``), i.e.
   it acts like a compression of ``k (W / W(dq h))^n``. The paper's defaults: k = 0.1, n = 4,
   dq = 0.2 h.
3. velocity: first order ``v_new = (x* - x_old) / dt`` (SPlisHSPlasH's default), or second order
   (BDF2) ``v_new = (1.5 x* - 2 x_old + 0.5 x_oldold) / dt`` with ``x_oldold`` the positions at the
   start of the previous step (registered field ``pbf_x_last``; NaN until a particle has taken
   one step, and such particles use the first-order update).

**As an acceleration.** The simulation integrates ``v += dt a``, ``x += dt v`` after every
solver, so ``solve`` writes the result as the effective acceleration
``a = (v_new - v_old) / dt``, **replacing** ``state.fluid["a"]`` (the positional solve already
contains a_ext). For the first-order update ``a = (x* - x_old - dt v_old) / dt^2`` gives exactly
(up to round-off) ``v = (x* - x_old) / dt`` and ``x = x*`` after the integration. The BDF2
velocity is not ``(x* - x_old) / dt``, so for it ``solve`` also sets ``x = x* - dt v_new``,
which the integration carries to ``x*``.

**Rigid bodies** (two-way coupling, as SPlisHSPlasH's ``TimeStepPBF::pressureSolveIteration``,
which adds ``m_i dx / dt^2`` to the boundary neighbour for each boundary pair's
correction):
every sweep's boundary share of the correction of fluid particle i, ``dx_i<-b = lambda_i V_b
grad W(x*_i - x_b)`` (Akinci particles and the virtual particles of density and volume maps,
at the sweep's own ``x*`` and ``x_b``), acts on the body of b as the force ``-m_i dx_i<-b /
dt^2`` at x_b, summed pair by pair over all sweeps (:meth:`sphkit.core.methods.
BoundaryCoupling.pair_reaction`, :meth:`sphkit.boundary.rigid.coupling.FluidCoupling.
pair_reaction`) and handed to the bodies as :attr:`sphkit.core.methods.BoundaryReaction.
forces` by :meth:`PBF.boundary_reaction`. With the first-order update the fluid's velocity
changes by ``sum dx_i<-b / dt`` from the same pairs, so the momentum of fluid and bodies is
conserved to round-off (tests/test_rigid.py, tests/test_rigid_2d.py); the angular momentum is
not, no more than by PBF's own pairs (corrections along the predicted separations change
velocities at the step-start positions). Kinematic bodies take the same force (reported, not
applied) and stay at their step-start pose through the solve.

*Strong coupling* of dynamic bodies (not in SPlisHSPlasH's ``TimeStepPBF``, whose bodies keep
their step-start pose through the solve and move afterwards; after Gissler et al. 2019,
"Interlinked SPH pressure solvers for strong fluid-rigid coupling", ACM TOG 38(1), in the
simplest form that DFSPH, IISPH and PCISPH use here, :mod:`sphkit.boundary.rigid.coupling`):
every sweep places the dynamic bodies where the reaction summed over the sweeps so far moves
them in the step, the rigid displacement ``dt (V* + dt A(F))`` (``V*``: the body's velocities
with its non-pressure change, :meth:`sphkit.core.coupling.BoundaryCoupling.predict`; ``A``: its
linear and angular accelerations under the summed force and torque F, through the joints;
:meth:`sphkit.core.coupling.BoundaryCoupling.motion`), and evaluates the constraints with the
boundary there (:meth:`sphkit.core.coupling.BoundaryCoupling.boundary_at` with ``motion``):
the bodies' particles moved rigidly, density maps queried with the bodies at their predicted
poses, volume maps' sliding virtual particles moved with their body. The body's force stays
the summed reaction, so it moves after the solve by about what the last sweep assumed (the
contacts with walls act only then).

*Yielding samples in the denominator* (sphkit's, not in the paper nor in SPlisHSPlasH): a
fluid particle squeezed between a dynamic body and a wall (the film under a landing body) has
boundary gradients from both sides that nearly cancel, ``grad_i C_i ~ 0`` with ``C_i > 0``, so
Eq. 11's lambda_i grows without bound; its own correction, the sum of the two shares, stays
small, but the body's share and its reaction do not: with density maps (one virtual particle
stands for a whole body) one sweep gave the landing square 27,000 times its weight. Each
sample of a dynamic body therefore adds ``BODY_WEIGHT |V_b grad W_ib|^2`` to the denominator,
as a fluid neighbour of the body's volume V_b would (the body treated as if its samples moved
as fluid: a mass splitting, :func:`sphkit.core.projection.constraint_lambda`'s ``bw``): lambda
stays below ``C_i / sum_b |V_b grad W_ib|^2``. This changes only the size of the sweeps' steps
next to dynamic bodies, not the state they converge to (every ``C_i <= 0``). With both, a
heavy body landing through water is no longer thrown: it lands, or rests on the last fluid
layer over the floor, which is at rest density between two walls in this discrete model and
which nothing drains (:mod:`sphkit.boundary.rigid.coupling`, the last paragraph); each change
alone still threw some landings (validation/README.md, "PBF: strong coupling and a heavy
body's landing").

With the second-order (BDF2) velocity update the corrections change the fluid's velocity by
``1.5 dx / dt`` in their step, so the exchange is exact only over the positions, not per step
in momentum.

**Pressure.** PBF has no pressure variable; sphkit reports the equivalent pressure of the
position corrections, ``p_i = -rho0 Lambda_i / dt^2`` [Pa] with ``Lambda_i`` the sum of the
lambdas of all sweeps: a correction ``sum_j (Lambda_i + Lambda_j) V_j grad W_ij`` is the
displacement ``dt^2 a`` of the pressure acceleration ``-sum_j V_j (p_i + p_j)/rho0 grad W_ij``
(the PCISPH form). Unlike SPlisHSPlasH, non-pressure forces are evaluated before the solve at
the step-start state (sphkit's step order), while SPlisHSPlasH applies viscosity after the
velocity update; gravity enters the prediction in both.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core import arrays
from sphkit.core.kernels import kernel_w
from sphkit.core.methods import BoundaryReaction, PressureSolver
from sphkit.core.ppe import lattice_diagonal
from sphkit.core.projection import constraint_correction, constraint_lambda
from sphkit.core.solver import IterationControl, SolverStats, group_error
from sphkit.core.state import SimState

#: the bodies of the prediction and the velocity update are compiled without fast math: each
#: does the IEEE operations of the NumPy expression it replaced, in its order and in the
#: fields' precision (the scalars are passed in it), so the CPU's results are those of the
#: NumPy expressions to the last bit (as :mod:`sphkit.core.arrays`)
_EXACT = dict(cache=True, inline="always")
#: the weight of a dynamic body's sample in lambda's denominator, as a fluid neighbour's
#: (module docstring, "Yielding samples in the denominator"; other weights measured in
#: validation/README.md, "PBF: strong coupling and a heavy body's landing")
BODY_WEIGHT = 1.0


@numba.njit(**_EXACT)
def predict_body(i, x, v, a, dt, dim, dx, xp):
    """``dx[:, i] = x*_i - x_old,i = dt (v_i + dt a_i)`` and ``xp[:, i] = x*_i``."""
    for d in range(dim):
        dx[d, i] = dt * (v[d, i] + dt * a[d, i])
        xp[d, i] = x[d, i] + dx[d, i]


@numba.njit(**_EXACT)
def first_order_body(i, v, dx, dt, dt2, dim, a):
    """``a[:, i] = (dx_i - dt v_i) / dt^2`` (``dt2 = dt^2``): the acceleration that carries
    ``x_old`` to ``x*`` with ``v = dx / dt``."""
    for d in range(dim):
        a[d, i] = (dx[d, i] - dt * v[d, i]) / dt2


@numba.njit(**_EXACT)
def second_order_body(i, x, v, dx, last, dt, c15, c05, dim, a):
    """BDF2: ``v_new = (1.5 dx - 0.5 (x_old - x_oldold)) / dt`` (``dx / dt`` where
    ``x_oldold`` is NaN; ``c15``, ``c05``: 1.5 and 0.5 in the fields' precision); then
    ``last = x_old``, ``x = x_old + (dx - dt v_new)`` and ``a = (v_new - v) / dt``."""
    for d in range(dim):
        xo = x[d, i]
        lo = last[d, i]
        if math.isnan(lo):
            vn = dx[d, i] / dt
        else:
            vn = (c15 * dx[d, i] - c05 * (xo - lo)) / dt
        last[d, i] = xo
        x[d, i] = xo + (dx[d, i] - dt * vn)
        a[d, i] = (vn - v[d, i]) / dt


@numba.njit(**_EXACT)
def pressure_body(i, rho0, lam_sum, dt2, p):
    """The equivalent pressure ``p_i = -rho0_i / dt^2 * Lambda_i`` (``dt2 = dt^2``)."""
    p[i] = -rho0[i] / dt2 * lam_sum[i]


class PBF(PressureSolver):
    """Position based fluids: Jacobi sweeps over clamped density constraints."""

    name = "pbf"
    uses_boundary_pressure = False  #: density constraints on positions: no boundary pressure

    @classmethod
    def from_config(cls, p: Any) -> PBF:
        """The PBF of a scene's ``configuration.pressure`` (scene model)."""
        return cls(max_error=p.max_error, min_iterations=p.min_iterations,
                   max_iterations=p.max_iterations, epsilon=p.pbf_epsilon, s_corr=p.pbf_s_corr,
                   s_corr_k=p.pbf_s_corr_k, s_corr_n=p.pbf_s_corr_n, s_corr_dq=p.pbf_s_corr_dq,
                   velocity_update=p.pbf_velocity_update)

    def __init__(self, max_error: float = 0.01, min_iterations: int | None = None,
                 max_iterations: int = 100, epsilon: float = 1e-6, s_corr: bool = False,
                 s_corr_k: float = 0.1, s_corr_n: float = 4.0, s_corr_dq: float = 0.2,
                 velocity_update: str = "first_order") -> None:
        """``max_error`` in percent of rho0; ``epsilon`` [1/m^2]; ``s_corr_dq`` a fraction of h;
        ``velocity_update`` 'first_order' or 'second_order'."""
        if velocity_update not in ("first_order", "second_order"):
            raise ValueError(f"pressure.pbf_velocity_update: {velocity_update!r}; expected "
                             "'first_order' or 'second_order'")
        if min_iterations is None:
            min_iterations = min(2, max_iterations)
        self.control = IterationControl("PBF", min_iterations, max_iterations, max_error / 100.0)
        self.epsilon = float(epsilon)
        self.s_corr = bool(s_corr)
        self.s_corr_k = float(s_corr_k)
        self.s_corr_n = float(s_corr_n)
        self.s_corr_dq = float(s_corr_dq)
        self.second_order = velocity_update == "second_order"
        self._d0_inv = 0.0  # 1 / D0 of the template neighbourhood [m^2]
        self._forces: np.ndarray | None = None  # the bodies' reaction of the last solve

    def init(self, state: SimState) -> None:
        """Register p (equivalent pressure) and, for BDF2, the previous step-start positions."""
        f = state.fluid
        f.register("p")
        if self.second_order:
            f.register("pbf_x_last", "vector", fill=np.nan)
        V = float(f["V0"].max()) if f.n else 0.0
        if V > 0:
            self._d0_inv = 1.0 / lattice_diagonal(2.0 * state.r, state.h, state.kid, state.dim, V)

    def max_time_step(self, state: SimState) -> float:
        """No limit of its own beyond the CFL step."""
        return float("inf")

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Positional solve; writes the effective acceleration into ``a`` (see module doc)."""
        f = state.fluid
        nl = state.nl_ff
        x, v, a, V = f["x"], f["v"], f["a"], f["V0"]
        n = f.n
        dim = int(state.dim)
        t = x.dtype.type  # the scalars in the fields' precision (as NumPy casts them)
        dx = arrays.empty_like(x)  # x* - x_old
        xp = arrays.empty_like(x)  # x*, kept with dx (the pair passes gather it)
        launch(predict_body, n, x, v, a, t(dt), dim, dx, xp)
        lam = arrays.empty(n, f.dtype, like=x)
        lam_sum = arrays.zeros(n, f.dtype, like=x)
        rho_hat = arrays.empty(n, f.dtype, like=x)
        corr = arrays.empty_like(x)
        w_dq = float(kernel_w(state.kid, self.s_corr_dq * state.h, state.h, state.dim))

        target = arrays.full(n, 1.0, f.dtype, like=x)  # C_i = rho_hat_i - 1
        rest = state.rest()  # several fluids: lambda_j weighs rho0_j / rho0_i
        # ... and lambda_i's denominator the neighbours by rho0_i / rho0_j (constraint_lambda)
        ratios = () if rest.uniform else (rest.c, rest.inv_c)
        groups = rest.groups  # several rest densities: each one's average error is tested

        coupling = state.coupling
        self._forces = None  # the bodies' reaction, summed over the sweeps (module doc)
        react = coupling.reacts  # kinematic or dynamic bodies take the reaction
        k_b = np.empty(n, np.float64) if react else None
        inv_dt2 = -1.0 / (dt * dt)

        def sweep(_k: int) -> tuple[float, float]:
            # dynamic bodies at the poses the reaction so far gives them (strong coupling;
            # None: no body yields); density maps queried at x*, volume maps' virtual
            # particles slid along the wall
            motion = coupling.motion(state, self._forces, dt)
            bx, bV, nb, body = coupling.boundary_at(state, dx, motion)
            yielding = coupling.yielding(state, body)
            bw = None if yielding is None else BODY_WEIGHT * yielding.astype(f.dtype)
            avg, mx = constraint_lambda(xp, V, target, nl.offsets, nl.indices, bx, bV,
                                        nb.offsets, nb.indices, state.h, state.kid,
                                        state.dim, 0.0, self.epsilon, 0.0, lam, rho_hat, bw,
                                        *ratios)
            if groups is not None:  # C_i = max(rho_hat_i - 1, 0) per class (group_error)
                avg = group_error(np.maximum(arrays.to_host(rho_hat) - 1.0, 0.0), groups, avg)
            constraint_correction(xp, V, lam, nl.offsets, nl.indices, bx, bV,
                                  nb.offsets, nb.indices, state.h, state.kid, state.dim, 0.0,
                                  self.s_corr, self.s_corr_k, self.s_corr_n, w_dq,
                                  self._d0_inv, corr, *ratios)
            if react:  # the bodies take minus the boundary share of this sweep's correction
                np.multiply(lam, inv_dt2, out=k_b)  # dx_i<-b = lambda_i V_b grad W = -dt^2 k_i ..
                fb = coupling.pair_reaction(state, k_b, xp, bx, bV, nb, body)
                self._forces = fb if self._forces is None else self._forces + fb
            arrays.axpy(dx, 1.0, corr)
            arrays.axpy(xp, 1.0, corr)
            arrays.axpy(lam_sum, 1.0, lam)
            return avg, mx

        its, avg, mx, ok = self.control.run(sweep, state.step)
        if self.second_order:
            # v_new = (1.5 x* - 2 x_old + 0.5 x_oldold)/dt = (1.5 dx - 0.5 (x_old - x_oldold))/dt;
            # x_oldold <- x_old; x <- x_old + dx - dt v_new: the integration x += dt v_new then
            # lands on x*
            launch(second_order_body, n, x, v, dx, f["pbf_x_last"], t(dt), t(1.5), t(0.5), dim,
                   a)
        else:
            launch(first_order_body, n, v, dx, t(dt), t(dt * dt), dim, a)
        launch(pressure_body, n, f["rho0"], lam_sum, t(dt * dt), f["p"])
        return SolverStats(iterations=its, density_error_avg=avg, density_error_max=mx,
                           converged=ok)

    def boundary_reaction(self, state: SimState) -> BoundaryReaction | None:
        """The bodies' reaction to the boundary share of the last solve's corrections, summed
        pair by pair over its sweeps at their predicted positions (:attr:`BoundaryReaction.
        forces`; ``k`` = ``p / rho0`` = ``-Lambda / dt^2``, the equivalent pressure's field, for
        reference); None when the scene has no bodies."""
        if self._forces is None:
            return None
        f = state.fluid
        return BoundaryReaction(f["p"] / f["rho0"], 0.0, self._forces)
