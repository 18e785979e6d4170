"""Divergence-free SPH (DFSPH).

Bender & Koschier 2015, "Divergence-free smoothed particle hydrodynamics", SCA, and 2017,
"Divergence-free SPH for incompressible and viscous fluids", IEEE TVCG 23(3); as SPlisHSPlasH's
``TimeStepDFSPH`` implements it (with warm starts, ``USE_WARMSTART`` / ``USE_WARMSTART_V``).

Per step (2017 paper, Alg. 1): after the neighbour search and the densities,

1. the factor (Eq. 9, in SPlisHSPlasH's normalized units, V_j = m_j / rho0)
   ``alpha_i = 1 / ((G_i + B_i) . (G_i + M_i) + sum_j |V_j grad W_ij|^2)`` with
   ``G_i = sum_j V_j grad W_ij``, ``B_i = sum_b V_b grad W_ib``, ``M_i = sum_b (1 + m_b) V_b grad
   W_ib`` (the paper's ``|G_i + B_i|^2`` when m_b = 0, see below);
2. the **divergence-free solver** (Alg. 3) on the current velocities: source
   ``s_i = -max(D rho_hat_i / Dt, 0)`` (0 for particles with fewer than 20 neighbours in 3D, 7 in
   2D, whose residual is also left out of the error), warm start
   ``kappa^v_i = 0.5 min(kappa^v_prev, 0.5 rho0_ref / rho0_i) / dt`` where the density
   increases (the cap bounds ``p / rho0_ref``, the same pressure in every phase; SPlisHSPlasH
   caps its own kappa, i.e. a light phase at a tenth of the pressure), iterations
   ``kappa^v_i <- max(kappa^v_i - 0.5 (s_i - A kappa^v_i) alpha_i / dt, 0)`` until the average
   ``|D rho_hat / Dt| dt`` is at most ``max_error_v``; then ``v += dt a(kappa^v)``, and a
   boundary that yields to the pressure (``state.coupling``: dynamic rigid bodies, strong
   coupling) takes its velocity change ``dt a_b(kappa^v)`` too, so that the density
   solve sees the bodies as the fluid now does (otherwise it stops a landing body a second time:
   the 2D heavy square of tests/test_rigid_2d.py was thrown back at 30x its weight and blew up);
3. non-pressure forces (the simulation), ``v* = v + dt a``; the boundary velocities of dynamic
   rigid bodies are advanced by theirs (gravity) too (:meth:`sphkit.boundary.rigid.RigidBodies.
   predict`), so that the density solve sees the bodies fall as the fluid does;
4. the **constant-density solver** (Alg. 2): ``rho_hat*_i = rho_hat_i + dt D rho_hat_i/Dt(v*)``,
   ``s_i = 1 - rho_hat*_i`` (not clamped: the iterations clamp the pressure, and the error
   counts compression only), warm start ``kappa_i = 0.5 min(kappa_prev, 0.00025 rho0_ref /
   rho0_i) / dt^2``
   where ``rho_hat* > 1``, iterations ``kappa_i <- max(kappa_i - 0.5 (s_i - A kappa_i) alpha_i /
   dt^2, 0)`` until the average compression is at most ``max_error``; the pressure acceleration
   ``a = -sum_j V_j (kappa_i + kappa_j) grad W_ij - sum_b V_b (1 + m_b) kappa_i grad W_ib``
   (m_b = the boundary's ``pressure_mirror``: 0 as SPlisHSPlasH for surface-sampled boundaries,
   1, full mirroring, for lattice walls; see :mod:`sphkit.core.ppe`) is added to the
   particle accelerations and the simulation integrates.

**Emitters** (SPlisHSPlasH's ``TimeStepDFSPH``: a particle whose state is not ``Active`` is
skipped by both solves' iterations and gets no pressure acceleration): a particle that an
emitter's region moves rigidly in this step (``state.animated``, :func:`sphkit.core.ppe.held`)
has no factor (alpha 0), so its kappa and kappa^v stay 0, and its residual is left out of both
errors. Layers emitted within 2r of a wall start compressed and the solves cannot move them:
``Emitter_2D.json`` at twice its particle radius (its emitter then r off the tank's wall) took
13-15 iterations in every step, which the scene's step control (``cflMethod`` 2) answered by
shrinking the step 10 % a step, to 3,866 steps for 1 s (validation/README.md, "PCISPH at an
emitter").

``kappa = p / (rho0 rho_hat^2)`` is stored time-step independent (times dt^2, resp. dt) for the
warm start, as SPlisHSPlasH does; the reported pressure is ``p = (kappa + kappa^v) rho^2 / rho0``
(both solves apply pressure impulses within the step).

The iterations are SPlisHSPlasH's (``TimeStepDFSPH::pressureSolveIteration`` /
``divergenceSolveIteration``): the relaxed Jacobi update ``kappa_i <- max(kappa_i - 0.5 (s_i -
A kappa_i) alpha_i, 0)`` in both directions, clamped at 0; only the *error* counts compressive
residuals ``min(s_i - A kappa_i, 0)`` alone. (Until 2026-11-26 sphkit used the line SPlisHSPlasH
keeps commented out, ``kappa_i -= min(s_i - A kappa_i, 0) alpha_i``: one-sided, weight 1, so
kappa could only grow from its halved warm start. At rest that turned the pressure into a
relaxation oscillation -- it decayed by half per step until the column compressed, then was
rebuilt in one step -- with a per-step hydrostatic slope scattering by +-94 % (SPlisHSPlasH's
2D column: +-1.9 %, sphkit's now +-1.8 %), a column that never came to rest (mean speed 0.02
m/s) and a time-averaged 2D slope 1-2 % steep; see validation/README.md, "2D hydrostatic
columns".) Both solvers are :func:`sphkit.core.solver.jacobi_ppe` with A from
:mod:`sphkit.core.ppe`.

**Impacts** (sphkit's; :mod:`sphkit.core.impacts`): a constant-density solve whose pressure
would carry a particle more than 1.15 r within the step is made again, from the same warm start,
with the walls' plain term ``V_b kappa_i`` (``m_b = 0``, SPlisHSPlasH's); both solves keep the
plain term for the next ten steps, and the step bound below is cut to half the step. Why: with
volume maps a block landing flat on the floor went unstable in the steps after the landing in 5
of 20 drops (heights 0.8-3 m, two map resolutions) and others threw particles at 70-93 m/s;
with the plain term kept but no cut 1 of 10 still did; with the rule none did, at 18-73 m/s
(validation/README.md, "A block dropped onto a volume-map floor").

**Time step** (not in the papers nor in SPlisHSPlasH; :class:`sphkit.core.solver.StepBound`
with IISPH's constants and rule, :data:`sphkit.core.solver.JACOBI_STEP_BOUND`): a
constant-density solve that stops at ``max_iterations`` with its average error above ``slack``
times the tolerance sets a bound of ``shrink`` times its step, each solve converged within half
of them raises it by ``grow``; the bound starts only with such a failed solve, so runs whose
solves converge take the same steps as without it. Why: at SPlisHSPlasH's 5 ms cap the 2D columns of
validation/hydrostatic.py stopped at the 100 iterations in every step and sloshed at 5 cm/s
(validation/README.md, "DFSPH's step bound"); most of their solves stopped at 2-7 times the
tolerance. Why the slack: a solve just above the tolerance (a deep column's landing after its
start) does not show that the step is too long, and a shorter step makes the per-step
corrections faster (IISPH's module docstring, "Time step"; validation/README.md, "The step
bound's slack"). The bound is kept in checkpoints.

**Closed domains** (scene ``configuration.pressure.free_surface: false``; by default where every
axis is periodic, there are no walls and the fluid fills the period; not in the papers nor in
SPlisHSPlasH): without a free surface the fluid cannot expand, and the summed density of a
disordered particle set exceeds rho0 on average (the self term; on the lattice it is rho0), so
the clamped solves above, whose source counts compression only, never converge and push with
growing pressure (validation/README.md, "DFSPH in closed domains"). There both solves take their
sources relative to the fluid's mean, the compatibility condition of a pressure equation without
a free surface (its constant pressure is free): ``s_i = mean(rho_hat*) - rho_hat*_i`` and ``s_i
= -(D rho_hat_i / Dt - mean(D rho_hat / Dt))`` for every particle; the pressures are signed (no
clamp at 0; the warm starts' caps bound |kappa|), and the error is the compressive residual as
before (the residual sums to about zero, so it is about half of the mean |residual|). Not with
walls: next to a wall a negative pressure pulls the fluid in (the mirrored wall term), and a box
filled to the lid loses volume into its walls; the scene check refuses it there.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core import arrays
from sphkit.core.impacts import ImpactBounded, Impacts
from sphkit.core.methods import BoundaryReaction, PressureSolver
from sphkit.core.ppe import held, release_body, surrounded
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

_BODY = dict(cache=True, fastmath=True, inline="always")


@numba.njit(**_BODY)
def alpha_body(i, D, tiny, alpha):
    """The factor ``alpha_i = 1 / D_i`` (0 where ``D_i <= tiny``)."""
    alpha[i] = 1.0 / D[i] if D[i] > tiny else 0.0


@numba.njit(**_BODY)
def density_source_body(i, rho, inv_rho0, div, dt, kprev, inv_c, s, kappa):
    """The constant-density solve's source and warm start of particle i."""
    # s = 1 - max(rho_hat*, 1); warm start where the predicted density exceeds rho0 (inv_rho0
    # (N,): 1 / each particle's rest density); the cap bounds the pressure p / rho0_ref, so in
    # each particle's own kappa it is 0.00025 inv_c (inv_c = rho0_ref / rho0_i, 1 for one fluid)
    pred = rho[i] * inv_rho0[i] + dt * div[i]
    s[i] = 1.0 - pred
    kappa[i] = 0.5 * min(kprev[i], 0.00025 * inv_c[i]) / (dt * dt) if pred > 1.0 else 0.0


@numba.njit(**_BODY)
def density_source_closed_body(i, rho, inv_rho0, div, dt, mean, kprev, inv_c, s, kappa):
    """Closed domains (module docstring): the source relative to the mean predicted density
    ``mean`` and a signed warm start (|kappa| within the open form's cap)."""
    s[i] = mean - (rho[i] * inv_rho0[i] + dt * div[i])
    cap = 0.00025 * inv_c[i]
    kappa[i] = 0.5 * min(max(kprev[i], -cap), cap) / (dt * dt)


@numba.njit(**_BODY)
def divergence_source_closed_body(i, div, mean, dt, kprev, inv_c, s, kappa):
    """Closed domains: the divergence relative to its mean ``mean``, every particle, signed
    warm start."""
    s[i] = mean - div[i]
    cap = 0.5 * inv_c[i]
    kappa[i] = 0.5 * min(max(kprev[i], -cap), cap) / dt


@numba.njit(**_BODY)
def divergence_source_body(i, div, active, dt, kprev, inv_c, s, kappa):
    """The divergence-free solve's source and warm start of particle i."""
    if active[i] and div[i] > 0.0:
        s[i] = -div[i]
        kappa[i] = 0.5 * min(kprev[i], 0.5 * inv_c[i]) / dt
    else:
        s[i] = 0.0
        kappa[i] = 0.0


@numba.njit(cache=True, inline="always")
def pressure_body(i, kappa, kappa_v, with_v, rho, rho0, p):
    """The reported pressure ``p_i = (kappa_i + kappa^v_i) rho_i^2 / rho0_i`` (``with_v``
    False: kappa alone; no fast math: NumPy's operations in NumPy's order)."""
    t = kappa[i] + kappa_v[i] if with_v else kappa[i]
    p[i] = t * (rho[i] * rho[i]) / rho0[i]


def mirrored_share(kappa: np.ndarray, kappa_v: np.ndarray) -> np.ndarray:
    """``kappa^v_i / (kappa_i + kappa^v_i)`` (0 where both are 0): the share of the reported
    pressure that a mirrored divergence solve applied in a step whose density solve took the
    plain term (module docstring, "Impacts")."""
    t = kappa + kappa_v
    return np.divide(kappa_v, t, out=np.zeros_like(t), where=t != 0.0)


#: Jacobi relaxation of both solves: SPlisHSPlasH's ``p_rho2_i = max(p_rho2_i - 0.5 (s_i -
#: aij_pj) factor_i, 0)`` (``TimeStepDFSPH::pressureSolveIteration`` and
#: ``divergenceSolveIteration``).
OMEGA = 0.5


class DFSPH(ImpactBounded, PressureSolver):
    """Divergence-free SPH: constant-density and divergence-free solvers with warm starts."""

    uses_pair_gradients = True  #: the simulation computes them with the densities
    name = "dfsph"

    @classmethod
    def from_config(cls, p: Any) -> DFSPH:
        """The DFSPH of a scene's ``configuration.pressure`` (scene model)."""
        return cls(max_error=p.max_error, min_iterations=p.min_iterations,
                   max_iterations=p.max_iterations, max_error_v=p.max_error_v,
                   max_iterations_v=p.max_iterations_v, divergence_solver=p.divergence_solver,
                   free_surface=p.free_surface)

    def __init__(self, max_error: float = 0.01, max_error_v: float = 0.1,
                 min_iterations: int | None = None, max_iterations: int = 100,
                 max_iterations_v: int = 100, divergence_solver: bool = True,
                 free_surface: bool | None = None) -> None:
        """``max_error``/``max_error_v`` in percent of rho0 (SPlisHSPlasH maxError/maxErrorV);
        ``free_surface`` False: a closed domain (module docstring), None: decided by
        :meth:`init` from the domain."""
        self.density_control = IterationControl(
            "DFSPH density solver", 2 if min_iterations is None else min_iterations,
            max_iterations, max_error / 100.0)
        self.divergence_control = IterationControl(
            "DFSPH divergence solver", 1, max_iterations_v, max_error_v / 100.0)
        self.divergence_solver = divergence_solver
        self._div_stats = (0, 0.0)
        self._kappa_v: np.ndarray | None = None  # this step's divergence kappa (for p)
        self._grads: PairGradients | None = None  # this step's pair gradients
        self._rows: np.ndarray | None = None  # the particles this step's solves hold
        #: the adaptive time-step bound (see max_time_step)
        self.step_bound = StepBound(**JACOBI_STEP_BOUND)
        #: the walls' plain term after a solve that threw a particle (module docstring)
        self.impacts = Impacts("DFSPH")
        #: an impact step's (kappa, kappa^v) for the reaction's mirrored share (None: the rule's)
        self._impact_kappas: tuple | None = None
        self.free_surface = free_surface
        #: sources relative to the fluid's mean, signed pressures (module docstring)
        self.closed = free_surface is False

    def init(self, state: SimState) -> None:
        """Register DFSPH's fields: alpha, the stored kappas, pressure; decide whether the
        domain is closed where the scene left it open (``free_surface`` None)."""
        f = state.fluid
        for name in ("p", "dfsph_alpha", "dfsph_kappa", "dfsph_kappa_v"):
            f.register(name)
        self.closed = closed_domain(state, self.free_surface)

    def pre_forces(self, state: SimState, dt: float) -> None:
        """Factors alpha, then the divergence-free solve on the current velocities."""
        f = state.fluid
        self._grads = PairGradients.of(state)
        alpha = f["dfsph_alpha"]
        if self.divergence_solver:  # the factor and the solve's source in one pass
            D, div = self._grads.diagonal_and_divergence(f["v"])
        else:
            D = self._grads.diagonal()
        launch(alpha_body, f.n, D, 1e-5, alpha)  # SPlisHSPlasH's epsilon [1/m^2]
        # particles an emitter moves are left out of both solves (module docstring, "Emitters"):
        # without a factor their kappa stays at 0
        self._rows = held(state)
        if self._rows is not None:
            launch(release_body, f.n, self._rows, alpha)
        self._div_stats = (0, 0.0)
        self._kappa_v = None
        if not self.divergence_solver:
            return
        s = arrays.empty_like(div)
        kappa = arrays.empty_like(div)
        if self.closed:
            active = self._rows
            launch(divergence_source_closed_body, f.n, div, float(np.mean(div)), dt,
                   f["dfsph_kappa_v"], state.rest().inv_c, s, kappa)
            if active is not None:
                launch(release_body, f.n, active, kappa)
        else:
            active = held(state, surrounded(state.nl_ff.offsets, state.nl_fb.offsets,
                                            20 if state.dim == 3 else 7))
            launch(divergence_source_body, f.n, div, active, dt, f["dfsph_kappa_v"],
                   state.rest().inv_c, s, kappa)
        a, its, avg, _mx, _ok = jacobi_ppe(state, self.divergence_control, kappa, None, s,
                                           arrays.divided(alpha, dt), dt, OMEGA, active,
                                           error_factor=dt, grads=self._grads,
                                           clamp=not self.closed,
                                           mirror=self.impacts.mirror(state),
                                           **self._grads.wall_args(f["v"], 1.0, "dfsph_v", dt))
        arrays.axpy(f["v"], dt, a)
        # strong coupling: a boundary that yielded to kappa^v in the solve takes its velocity
        # change too, so that the density solve sees the bodies as the fluid does
        state.coupling.take_impulse(state, kappa, self._grads.gwb, dt)
        arrays.scaled(kappa, dt, out=f["dfsph_kappa_v"])
        self._kappa_v = kappa
        self._div_stats = (its, avg)

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Constant-density solve on v* = v + dt a; adds the pressure acceleration to a."""
        f = state.fluid
        alpha = f["dfsph_alpha"]
        if self._grads is None:  # solve() without pre_forces(): build this step's cache
            self.pre_forces(state, dt)
        v_star = arrays.axpy_into(f["v"], dt, f["a"])
        div = self._grads.velocity_divergence(v_star)
        s = arrays.empty_like(div)
        rest = state.rest()
        walls = self._grads.wall_args(v_star, dt, "dfsph", dt * dt, density=True)

        def relaxed_jacobi(mirror: np.ndarray | None) -> tuple:
            """The solve from the warm start with the walls' mirror weights ``mirror`` (None:
            the coupling's): (kappa, a, its, avg, mx, ok)."""
            kappa = arrays.empty_like(div)
            if self.closed:  # the mean predicted density rho_hat* = rho / rho0 + dt div
                mean = float(np.mean(f["rho"] * rest.inv_rho0) + dt * np.mean(div))
                launch(density_source_closed_body, f.n, f["rho"], rest.inv_rho0, div, dt, mean,
                       f["dfsph_kappa"], rest.inv_c, s, kappa)
            else:
                launch(density_source_body, f.n, f["rho"], rest.inv_rho0, div, dt,
                       f["dfsph_kappa"], rest.inv_c, s, kappa)
            if self._rows is not None:
                launch(release_body, f.n, self._rows, kappa)
            return kappa, *jacobi_ppe(state, self.density_control, kappa, None, s,
                                      arrays.divided(alpha, dt * dt), dt * dt, OMEGA,
                                      self._rows, grads=self._grads, clamp=not self.closed,
                                      mirror=mirror, **walls)

        impacts = self.impacts  # module docstring, "Impacts"
        (kappa, a, its, avg, mx, ok), hit = impacts.solve(state, dt, relaxed_jacobi)
        self._grads = None
        self.step_bound.update(dt, its, self.density_control.max_iterations, ok,
                               miss=avg / self.density_control.tolerance)
        if hit:
            impacts.cut(self.step_bound, dt)
        arrays.axpy(f["a"], 1.0, a)
        arrays.scaled(kappa, dt * dt, out=f["dfsph_kappa"])
        # both solves apply pressure impulses in this step: the pressure is their sum
        with_v = self._kappa_v is not None
        launch(pressure_body, f.n, kappa, self._kappa_v if with_v else kappa, with_v, f["rho"],
               f["rho0"], f["p"])
        # the bodies' reaction: the mirrored share of the solves that took it (in an impact's
        # step the divergence solve's alone: its share of kappa + kappa^v)
        self._impact_kappas = (kappa, self._kappa_v) if hit and with_v else None
        its_v, err_v = self._div_stats
        return SolverStats(iterations=its, density_error_avg=avg, density_error_max=mx,
                           divergence_iterations=its_v, divergence_error=err_v, converged=ok)

    def boundary_reaction(self, state: SimState) -> BoundaryReaction:
        """The boundary term of :func:`sphkit.core.ppe.kappa_accel_cached` for both solves
        together: ``k_i = kappa_i + kappa^v_i = p_i rho0 / rho_i^2``, mirrored share included."""
        f = state.fluid
        k = self._impact_kappas
        return BoundaryReaction(f["p"] * f["rho0"] / f["rho"] ** 2,
                                self.impacts.share(state) if k is None else mirrored_share(*k))
