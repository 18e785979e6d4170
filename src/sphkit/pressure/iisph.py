"""Implicit incompressible SPH (IISPH).

Ihmsen, Cornelis, Solenthaler, Horvath, Teschner 2014, "Implicit incompressible SPH", IEEE TVCG
20(3), as SPlisHSPlasH's ``TimeStepIISPH`` implements it, in normalized units
(``rho_hat = rho / rho0``, ``V_j = m_j / rho0``, pressure variable ``p_hat = p / rho0``):

* advection (Alg. 1): ``v_adv = v + dt a_nonp``,
  ``rho_hat_adv,i = rho_hat_i + dt sum_j V_j v_adv,ij . grad W_ij + dt sum_b V_b (v_adv,i - v_b)
  . grad W_ib`` (Eq. 4 with the Akinci boundary of Sec. 5);
* the diagonal (Eq. 12) ``a_ii = sum_j V_j (d_ii - d_ji) . grad W_ij + sum_b V_b d_ii . grad W_ib``
  with ``d_ii = -(1/rho_hat_i^2) (sum_j V_j grad W_ij + sum_b (1 + m_b) V_b grad W_ib)`` (m_b:
  the boundary's ``pressure_mirror``, see :mod:`sphkit.core.ppe`) and
  ``d_ji = (V_i / rho_hat_i^2) grad W_ij``, i.e. ``a_ii = -D_i / rho_hat_i^2`` with
  :func:`sphkit.core.ppe.diagonal_cached`;
* warm start ``p_hat_i = 0.5 p_hat_i(t - dt)`` (Sec. 4.3);
* relaxed Jacobi (Eq. 13, omega = 0.5) with pressure clamping:
  ``p_hat_i <- max(p_hat_i + omega / (a_ii dt^2) (s_i - A p_hat_i), 0)``,
  ``s_i = 1 - rho_hat_adv,i``,
  where ``A p_hat`` is the density change that the pressure acceleration
  ``a_i = -sum_j V_j (p_hat_i/rho_hat_i^2 + p_hat_j/rho_hat_j^2) grad W_ij
  - sum_b (1 + m_b) V_b p_hat_i/rho_hat_i^2 grad W_ib`` causes in dt (Eq. 10-11, written as
  the survey's ``(A p)_i = dt^2 sum_j V_j (a_i - a_j) . grad W_ij
  + dt^2 sum_b V_b a_i . grad W_ib``);
  iterations stop when the average compression is at most ``max_error``.

The loop is :func:`sphkit.core.solver.jacobi_ppe` with weight ``w = 1 / rho_hat^2``.

**Time step** (not in the paper nor in SPlisHSPlasH; :class:`sphkit.core.solver.StepBound`, as
PCISPH's, with :data:`sphkit.core.solver.JACOBI_STEP_BOUND`): a solve that stops at
``max_iterations`` with its average error above ``slack`` (1.5) times the tolerance sets a bound
of ``shrink`` (0.8) times its step (at least ``floor``, 0.1 ms); each solve that converges
within half of ``max_iterations`` raises the bound by ``grow`` (2 %; dropped above ``free``,
1 s). The bound starts only with such a failed solve, so runs
whose solves converge take the same steps as without it. Why: at SPlisHSPlasH's 5 ms cap IISPH's
2D column with volume maps stopped at its 100 iterations in most steps and sloshed at 8 cm/s
without coming to rest (slope 2.9 % high; at 2 ms it rests within 0.5 %); most of its solves
there stopped at 2-14 times the tolerance. The constants (milder than PCISPH's 0.5 and 10 %: IISPH's
unconverged solves did not diverge, and its warm start carries the pressure across steps) are
the ones measured in validation/README.md; others were not compared. Why the slack: a solve that
stops at the limit just above the tolerance (a deep column's landing after its start) has not
shown that the step is too long, while a shorter step makes the per-step tolerance's leftover
corrections faster (a leftover compression ``eta L`` is removed in one step at ``eta L / dt``),
and a deep two-layer column at 1:10 does not come to rest at 1 ms while it does at 2 ms
(validation/README.md, "The step bound's slack"). The bound is kept in checkpoints
(:meth:`IISPH.checkpoint_state`).

**Impacts** (sphkit's; :mod:`sphkit.core.impacts`): a solve whose pressure acceleration would
carry a particle more than 1.15 r within the step is made again, from the same warm start, with
the walls' plain term ``V_b k_i`` (no mirrored share ``m_b``, SPlisHSPlasH's; the maps' wall
moment stays); the walls keep the plain term for the next ten steps, and the step bound below is
cut to half the step. With volume maps the steps after a block's flat landing threw the fluid
at a wall's corner apart, where SPlisHSPlasH's IISPH, with the plain term, lands it; with the
re-solve alone 2 of 20 drops (heights 0.8-3 m, two map resolutions) still did, with the rule
none (validation/README.md, "A block dropped onto a volume-map floor").

**Emitters** (sphkit's; SPlisHSPlasH's IISPH solves for them and only leaves them out of the
integration): a particle that an emitter's region moves rigidly in this step
(``state.animated``, :func:`sphkit.core.ppe.held`) gets no Jacobi scale and no warm start, so
its pressure stays 0, and its residual is left out of the error, as DFSPH's. ``Emitter_2D.json``
at twice its particle radius with IISPH (its emitter then r off the tank's wall, every layer
starting compressed) took 4,123 steps to 0.95 s, its step control shrinking the step after
every solve (validation/README.md, "PCISPH at an emitter").

**Closed domains** (scene ``configuration.pressure.free_surface``, as DFSPH's; by default where
every axis is periodic, there are no walls and the fluid fills the period,
:func:`sphkit.core.solver.closed_domain`; not in the paper nor in SPlisHSPlasH): the source
``1 - rho_hat_adv`` less its mean over the fluid, and signed pressures (no clamp at 0), the
compatibility condition of a pressure equation without a free surface
(:mod:`sphkit.pressure.dfsph`, "Closed domains", for why the clamped solve fails there).
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core import arrays
from sphkit.core.impacts import ImpactBounded, Impacts
from sphkit.core.methods import BoundaryReaction, PressureSolver
from sphkit.core.ppe import held, release_body
from sphkit.core.solver import (
    JACOBI_STEP_BOUND,
    IterationControl,
    PairGradients,
    SolverStats,
    StepBound,
    closed_domain,
    jacobi_ppe,
)
from sphkit.core.state import SimState


@numba.njit(cache=True, fastmath=True, inline="always")
def setup_body(i, rho, inv_rho0, div, D, dt, tiny, s, w, scale):
    """Particle i's source ``s_i = 1 - rho_hat_adv,i``, weight ``w_i = 1 / rho_hat_i^2`` and
    Jacobi scale ``rho_hat_i^2 / (D_i dt^2)`` (0 where ``D_i <= tiny``)."""
    rh = rho[i] * inv_rho0[i]
    s[i] = 1.0 - (rh + dt * div[i])
    w[i] = 1.0 / (rh * rh)
    # omega / (a_ii dt^2) with a_ii = -D / rho_hat^2; the engine applies -omega * scale
    scale[i] = rh * rh / (D[i] * dt * dt) if D[i] > tiny else 0.0


class IISPH(ImpactBounded, PressureSolver):
    """Implicit incompressible SPH with relaxed Jacobi (omega = 0.5) and warm start."""

    uses_pair_gradients = True  #: the simulation computes them with the densities
    name = "iisph"

    @classmethod
    def from_config(cls, p: Any) -> IISPH:
        """The IISPH of a scene's ``configuration.pressure`` (scene model)."""
        return cls(max_error=p.max_error, min_iterations=p.min_iterations,
                   max_iterations=p.max_iterations, free_surface=p.free_surface)

    def __init__(self, max_error: float = 0.01, min_iterations: int | None = None,
                 max_iterations: int = 100, omega: float = 0.5,
                 free_surface: bool | None = None) -> None:
        """``max_error`` in percent of rho0 (SPlisHSPlasH maxError); ``free_surface`` False: a
        closed domain (module docstring), None: decided by :meth:`init` from the domain."""
        self.control = IterationControl("IISPH", 2 if min_iterations is None else min_iterations,
                                        max_iterations, max_error / 100.0)
        self.omega = omega
        #: the walls' plain term after a solve that threw a particle (module docstring)
        self.impacts = Impacts("IISPH")
        #: the adaptive time-step bound (see max_time_step)
        self.step_bound = StepBound(**JACOBI_STEP_BOUND)
        self.free_surface = free_surface
        #: sources relative to the fluid's mean, signed pressures (module docstring)
        self.closed = free_surface is False

    def init(self, state: SimState) -> None:
        """Register the pressure field (p [Pa]; the warm start reads it back); decide whether
        the domain is closed where the scene left it open (``free_surface`` None)."""
        state.fluid.register("p")
        self.closed = closed_domain(state, self.free_surface)

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Pressure solve on v_adv = v + dt a; adds the pressure acceleration to a."""
        f = state.fluid
        n = f.n
        grads = PairGradients.of(state)
        v_star = arrays.axpy_into(f["v"], dt, f["a"])
        div = grads.velocity_divergence(v_star)
        D = grads.diagonal()
        s, w, scale = (arrays.empty_like(div) for _ in range(3))
        launch(setup_body, n, f["rho"], state.rest().inv_rho0, div, D, dt,
               1e-9 / state.h ** 2, s, w, scale)
        if self.closed:  # the source relative to its mean (module docstring)
            s -= np.mean(s)
        # particles an emitter moves are left out (module docstring, "Emitters")
        rows = held(state)
        if rows is not None:
            launch(release_body, n, rows, scale)
        walls = grads.wall_args(v_star, dt, "iisph", density=True)

        def relaxed_jacobi(mirror: np.ndarray | None) -> tuple:
            """The solve from the warm start (normalized pressure 0.5 p / rho0), with the
            walls' mirror weights ``mirror`` (None: the coupling's): (p, a, its, avg, mx, ok)."""
            p = arrays.divided_by(arrays.scaled(f["p"], 0.5), f["rho0"])
            if rows is not None:
                launch(release_body, n, rows, p)
            return p, *jacobi_ppe(state, self.control, p, w, s, scale, dt * dt, self.omega,
                                  rows, grads=grads, clamp=not self.closed, mirror=mirror,
                                  **walls)

        impacts = self.impacts  # module docstring, "Impacts"
        (p, a, its, avg, mx, ok), hit = impacts.solve(state, dt, relaxed_jacobi)
        self.step_bound.update(dt, its, self.control.max_iterations, ok,
                               miss=avg / self.control.tolerance)
        if hit:
            impacts.cut(self.step_bound, dt)
        arrays.axpy(f["a"], 1.0, a)
        arrays.multiplied(p, f["rho0"], out=f["p"])
        return SolverStats(iterations=its, density_error_avg=avg, density_error_max=mx,
                           converged=ok)

    def boundary_reaction(self, state: SimState) -> BoundaryReaction:
        """The boundary term of :func:`sphkit.core.ppe.kappa_accel_cached`:
        ``k_i = p_i rho0 / rho_i^2``, mirrored share included."""
        f = state.fluid
        return BoundaryReaction(f["p"] * f["rho0"] / f["rho"] ** 2, self.impacts.share(state))
