"""Predictive-corrective incompressible SPH (PCISPH).

Solenthaler & Pajarola 2009, "Predictive-corrective incompressible SPH", ACM TOG 28(3), as
SPlisHSPlasH's ``TimeStepPCISPH`` implements it, in normalized units (``V_j = m_j / rho0``,
``rho_hat = rho / rho0``, pressure variable ``p~ = p / rho0`` [m^2/s^2]).

**Scaling factor** (paper Eq. 8; SPlisHSPlasH ``SimulationDataPCISPH::init``), computed once on a
*template* particle with a filled neighbourhood: the lattice of spacing 2r (the sampling lattice)
inside the support radius h, the template itself left out,
``S1 = sum_k grad W(x_k)``, ``S2 = sum_k |grad W(x_k)|^2``, ``beta = 2 V^2`` and
``delta = 1 / (beta (|S1|^2 + S2))`` [m^2]. This is the paper's
``delta = -1 / (beta_p (-S1 . S1 - S2))`` with ``beta_p = 2 dt^2 m^2 / rho0^2``: the paper's
``p = delta_p rho_err`` becomes ``p~ = (delta / dt^2) (rho_hat* - 1)``. (SPlisHSPlasH picks the
scene particle with the most fluid neighbours as template; for lattice-sampled fluid that is the
same neighbourhood.)

**Per step** (paper Alg. 1), with the neighbour lists of the step start and ``p~ = 0``,
``a_p = 0`` initially, each iteration

1. predicts ``v* = v + dt (a_nonp + a_p)`` and ``x* = x + dt v*``;
2. predicts the normalized density ``rho_hat*_i = V_i W(0) + sum_j V_j W(x*_i - x*_j)
   + sum_b V_b W(x*_i - x_b)`` (boundary included; :func:`sphkit.core.ppe.density_at` with
   ``dx = x* - x``; density maps place their virtual particles for x* in every iteration,
   ``state.coupling.boundary_at``, also in scenes whose bodies yield inside the solve (those
   predictions then leave out the bodies' in-solve displacement); boundary particles keep the
   step's, displaced with the yielding bodies; volume maps keep the step's virtual particle
   and move it with the fluid particle's displacement along the wall
   (:meth:`sphkit.boundary.bender2019.Bender2019.following`: the fixed particle lost up to a
   fifth of the wall's density when the fluid slid 0.8 r along the wall in a step; with it the
   2D dam break of validation/startup.py runs 3 s, peak 19 m/s, instead of going unstable at
   0.37 s with the adaptive step below; queried anew at x*, V_b(x*) changes by grad V_b terms
   that the forces' ``V_b grad W`` leaves out and the 3D dam break's first solve diverged; a
   yielding volume-map body's in-solve displacement is left out too: added to the sliding
   particles, it made validation/startup.py's 3D floating cube unstable at 0.27 s);
3. updates the pressure ``p~_i <- p~_i + (delta / dt^2) (max(rho_hat*_i, 1) - 1)``: the predicted
   density is clamped to ``>= 1`` as in SPlisHSPlasH, so the increments are never negative and
   ``p~ >= 0`` holds without a further clamp (free-surface particles with a particle deficiency
   get no suction). The other clamped form, ``p~_i <- max(p~_i + (delta / dt^2) (rho_hat*_i - 1),
   0)`` (the paper's signed update plus clamping), lets an overshooting pressure fall again within
   a step; on the hydrostatic column and the 2D dam break of the tests both forms gave the same
   iteration counts, errors and pressure slopes within the step-to-step noise. The factor of a
   particle whose own PPE diagonal exceeds ``CAP`` times the template's is scaled down to
   ``CAP`` times (:func:`diagonal_cap`; not in the paper nor in SPlisHSPlasH): next to a volume
   map the template's factor overshot up to 50-fold;
4. recomputes the pressure acceleration at the step-start positions (paper Eq. 5 with rho0 in
   the denominators, Akinci boundary as SPlisHSPlasH)
   ``a_p,i = -sum_j V_j (p~_i + p~_j) grad W_ij - sum_b V_b (1 + m_b) p~_i grad W_ib`` (m_b: the
   boundary's ``pressure_mirror``, see :mod:`sphkit.core.ppe`)
   (:func:`sphkit.core.ppe.kappa_accel_cached` of ``k = p~``, from the step's cached
   pair gradients :class:`sphkit.core.solver.PairGradients`).

The error of an iteration is the average compression ``mean(max(rho_hat* - 1, 0))`` of the
prediction it started from (SPlisHSPlasH's ``avg_density_err``); iterations stop through
:class:`sphkit.core.solver.IterationControl` once it is at most ``max_error`` percent after at
least ``min_iterations`` (default 3, SPlisHSPlasH's fixed minimum). With several rest
densities the average stays the one over all particles, unlike the other iterative solvers
(:func:`sphkit.core.solver.group_error`) and SPlisHSPlasH, which tests each fluid model's own:
tested per rest density, a deep two-layer column at 1:10 hit the iteration limit from its
start on and did not come to rest, where the average over all particles rests it
(validation/README.md, "One convergence test per rest density"). The final ``a_p`` is added to
``state.fluid["a"]`` and the simulation integrates ``v += dt a``, ``x += dt v``, which is
SPlisHSPlasH's final ``v = v_last + dt (a + a_p)``, ``x = x_last + dt v``.

The reported pressure is ``p = rho0 p~`` [Pa].

**Solved walls** (scene ``configuration.boundary.solved``; the default where the fluids' rest
densities differ by more than a factor 4, :mod:`sphkit.scene.schema`): each static wall particle b
carries its own ``k_b >= 0`` (in the boundary term ``-V_b (p~_i + k_b) grad W_ib`` instead of the
MLS or mirrored value), updated in every sweep after the fluid's pressures from the wall's predicted
number density ``rho_hat*_b = sum_f V_f W(x*_f - x_b)``: ``k_b <- min(max(k_b + 0.5 (rho_hat*_b -
rho_target_b) / (dt^2 D_b), 0), cap max_f k_f)`` (:func:`sphkit.core.solved_walls.wall_update` with
the walls' Jacobi scale D_b of :func:`sphkit.core.solved_walls.wall_diagonal`, as IISPH's and
DFSPH's solved walls), the target the wall's density at the step start (``true``/``"velocity"``: its
rate held) or, with ``"density"``, its start-up value where the wall was covered
(:meth:`sphkit.core.coupling.BoundaryCoupling.wall_rest`; ``"stratified"`` solves only the wall
particles beside a lighter fluid below the heaviest one, each holding its value of the solve that
first made it a row, and takes the MLS value elsewhere); warm-started from the last step's ``k_b``
(the fluid's ``p~`` starts from zero, as in the paper). The convergence test stays the fluid's. Why:
with the MLS term a light fluid under a heavy one (1:6 to 1:10) threw single light particles up the
side walls at 8-15 m/s until a solve failed (2D unstable at 1.4 s, 3D at 0.41 s); with the solved
walls those columns run (validation/README.md, "Several rest densities: the solved walls by
default").

Several fluids (``p~_i = p_i / rho0_i``, neighbour weight ``rho0_j / rho0_i``): the factor is
per particle, ``delta D_i(ratio 1) / D_i(ratios)`` (:func:`phase_factor`), the template's step
corrected by the ratios in the particle's own diagonal; a single fluid keeps the scalar.

Notes. ``delta / dt^2`` is the inverse of twice the template's PPE diagonal, so one iteration is a
Jacobi sweep with omega = 0.5 (survey Sec. 4.4) and the pressure starts from 0 every step (no warm
start, as paper and SPlisHSPlasH): holding a column of height H at rest with an average error
``eta`` takes about ``g H dt^2 / (2 delta eta)`` iterations (about 50 for H = 0.5 m, dt = 2 ms,
eta = 0.05 %, r = 0.01 m; a quarter of that at dt = 1 ms). A start far from equilibrium is not
resolved: fluid sampled 2r from Akinci walls starts 3-4.5 % compressed at the walls, the pressure
needed to remove that within one step moves particles by a sizeable fraction of their spacing, the
density prediction becomes nonlinear and the iteration diverges; start such scenes a fraction of
r (0.15-0.2 r) off the walls.

**Time step** (not in the paper nor in SPlisHSPlasH; after the adaptive step of Ihmsen, Akinci,
Gissler and Teschner 2010, "Boundary handling and adaptive time-stepping for PCISPH", VRIPHYS,
which shrinks the step when the density error is too large): a solve that stops at
``max_iterations`` above the tolerance halves the step bound (:meth:`PCISPH.max_time_step`, at
least ``DT_FLOOR``); a solve that converges within half of ``max_iterations`` raises it by 10 %
(dropped above ``DT_FREE``). Why: with SPlisHSPlasH's defaults (steps up to 5 ms, 100 iterations,
0.01 %) a 2D column 0.5 m high (r = 1 cm) landing on its floor needs more sweeps than 100 from p =
0 (the linearized iteration matrix ``delta A`` has eigenvalues in (0, 1.2]: stable, but its
smallest, the column's hydrostatic mode, is about 0.001). The residual compression piles up at the
walls (13 % predicted before the pressure at a step start), the pressure that removes it moves
particles by 0.3-0.8 r within the iteration while the forces keep the step-start gradients, and the
nonlinear prediction makes the error grow again (it fell to 0.32 % after 30 sweeps and rose to 0.6
% at 95, then to 1,400 m/s in the next steps). SPlisHSPlasH 2.19's own PCISPH, run on the same
scene through pysplishsplash, diverges the same way at step 11-13 (1,400-4,000 m/s) with all three
boundary models. A warm start (IISPH's ``0.5 p``) did not prevent it; a fixed 2 ms step did (100
unconverged sweeps per step at rest); the bound settles where 100 sweeps suffice (about 1.1 ms for
that column at rest, 62 sweeps a step). Where the run's first solve builds pressure, the bound
starts at that first step (the scene's initial step), so the steps grow from it by 10 % per easy
solve instead of jumping to the CFL cap in the second step; a first solve without pressure (a lone
particle) leaves the CFL step (measurements: validation/README.md, "The first step").
The bound is kept in checkpoints (:meth:`PCISPH.checkpoint_state`). The bound only shrinks the
*next* step; a solve that failed by more than ``REJECT`` times the tolerance has its own step
computed again with the shrunk bound (:meth:`PCISPH.rejects`, the simulation's
``configuration.time.retries``): a column-wide impact, 79 layers falling on the floor at 1 m/s
in a 1.95 ms step, needs more sweeps than 100 and its error grew from the first sweep.
The adaptive bound learns from failed solves only, and a fluid that carries no pressure (a
block falling onto its floor) solves easily at any step, so the bound grows by 10 % a step
while it falls. Hence a second, predictive bound (:meth:`PCISPH.load_bound`): the step at
which a column as deep as the fluid (its extent along gravity, H) needs :data:`LOAD` times
``max_iterations`` sweeps from p = 0 by the estimate above, ``dt <= sqrt(2 delta eta LOAD
N_max / (|g| H))``. Where maps cannot compute a step again (below), the landing of such a
fluid at a grown step diverged: SPlisHSPlasH's DamBreakWithObjects with PCISPH and density
maps (its block sampled 2r above a 3D density map's floor, where the map holds fluid about 1.1
r off) fell for 17 steps while the bound grew from 1 to 5 ms, and stopped as unstable at step
19 (validation/README.md, "SPlisHSPlasH's scenes with another solver and boundary model").

**Emitters** (sphkit's; SPlisHSPlasH's DFSPH leaves such particles out of its pressure solve,
its PCISPH does not): a particle that an emitter's region moves rigidly in this step
(``state.animated``, :meth:`sphkit.world.emitters.FluidEmitter.mark`,
:func:`sphkit.core.ppe.held`) keeps ``p~ = 0`` and its compression counts as none. Emitted
layers start compressed where the emitter lies near a wall (``Emitter_2D.json``'s, 2r off a
volume-map wall: 10-20 %, from the wall's volume beside a lattice), and the solve cannot move
them: its pressure on them pushed the layers ahead, and with volume maps a solve diverged at
the 15th layer (0.50-0.55 s; validation/README.md, "PCISPH at an emitter").

**Thrown particles** (sphkit's; a force condition ``dt <= lambda sqrt(h_s / |a|)`` as Monaghan's
and Ihmsen et al.'s, on the solve's own pressure acceleration, checked after the solve: with
:data:`THROW` = 0.5, ``lambda`` = 0.5 and ``h_s = 2r``): the prediction is linear in the pressure
displacement ``dt^2 a_p``, and a solve can converge on the average while
one particle's prediction has left the linear range. Traced (validation/README.md, "PCISPH's
energy bursts"): a splash particle with two fluid neighbours next to a wall's face, whose
predicted density *rose* with its pressure once its predicted displacement neared r, ended a
converged solve (0.0093 % against 0.01 %) with the pressure that threw it at 20 m/s; an inviscid
2D dam break of 100 particles multiplied its energy by up to 36 and went unstable. So a solve
whose pressure acceleration moves a particle more than :data:`THROW` r within the step counts as
failed: the bound shrinks and the step is computed again (:meth:`PCISPH.rejects`).

**Impacts** (sphkit's; :mod:`sphkit.core.impacts`, as IISPH and DFSPH): a solve whose pressure
would carry a particle more than :data:`sphkit.core.impacts.THROW_PLAIN` r within the step is
made again from p = 0 with the walls' plain term (and where that solve throws as well and the
step cannot be computed again, once more without the particles whose speed its pressure
raised by more than that per step, their pressure 0 in this step:
:meth:`sphkit.core.impacts.Impacts.released`), the plain term kept for the next ten
steps, and the step bound is cut to half the step; where the step can be computed again, the
thrown-particle test above then judges the second solve. It matters where it cannot (map walls,
bodies: the world is not repeatable; validation/README.md, "Volume maps on the geometry's
surface" and "PCISPH's thrown particles left out of the re-solve"). Not with solved
walls, whose pressures the sweeps carry.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.backend import launch, launch_reduce, specialize
from sphkit.core import arrays
from sphkit.core import solver as solver_module
from sphkit.core.impacts import THROW_PLAIN, ImpactBounded, Impacts
from sphkit.core.methods import BoundaryReaction, PressureSolver
from sphkit.core.pairs import period_arg
from sphkit.core.ppe import (
    density_at,
    diagonal_cached,
    held,
    kappa_accel_cached,
    lattice_diagonal,
)
from sphkit.core.solved_walls import wall_density, wall_update
from sphkit.core.solver import (
    IterationControl,
    PairGradients,
    SolverStats,
    StepBound,
    WallRows,
    solved_kappa,
)
from sphkit.core.state import SimState
from sphkit.core.timestep import max_speed

_JIT = dict(cache=True, fastmath=True)
#: adaptive time step (module docstring, "Time step"; :class:`sphkit.core.solver.StepBound`):
#: factor after an unconverged solve, per-step growth after an easy one, the smallest bound [s]
#: (the default time.dt_min, as SPlisHSPlasH's cflMinTimeStepSize) and the bound above which it
#: is dropped [s]
DT_SHRINK, DT_GROW, DT_FLOOR, DT_FREE = 0.5, 1.1, 1e-4, 1.0
#: a solve stopped at its iteration limit with an average error above REJECT times the
#: tolerance failed, and its step is computed again (:meth:`PCISPH.rejects`). Measured on the
#: impact of the 493k dam break (benchmarks/README.md, "seventeenth session"): 21 times the
#: tolerance after 100 iterations at 1.95 ms, 3.0 at 0.98 ms, 1.6 at 0.49 ms; with 10 the
#: 0.98 ms step was kept and the next solve diverged at every step down to 31 us, with 2 the
#: step was computed again at 0.49 ms and the run went on
REJECT = 2.0
#: a solve whose pressure acceleration moves a particle more than THROW particle radii within
#: the step threw it (module docstring, "Thrown particles"): the step is computed again and the
#: bound shrinks. Measured (validation/energy.py's 2D PCISPH dam break with Akinci walls): 0.5
#: took the largest energy from 4.3 to 1.04 times the start's with 24-38 retries in 4 s; 1.0
#: left 1.4-1.7
THROW = 0.5
#: a particle's factor is capped where its own PPE diagonal exceeds CAP times the template's
#: (:func:`diagonal_cap`): omega at most 0.5 CAP. Measured in validation/startup.py's 3D tank
#: with volume maps: CAP 5 left the dam break unstable at 1.52 s (none: 0.42 s); with the
#: maps' surface on the mesh, CAP 3 threw a lone particle back off a volume-map wall faster
#: than it came (3 -> 3.12 m/s), CAP 2 does not (1.08 m/s) and runs the tank's dam break and
#: float 3 s (validation/README.md, "Volume maps on the geometry's surface"); Akinci walls
#: reach 4.2 in validation/single_fluid_identity.py's small 2D dam break
CAP = 2.0
#: the load bound (module docstring, "Time step"): a step at most that at which a column as
#: deep as the fluid needs LOAD times ``max_iterations`` sweeps from p = 0 (measured on
#: SPlisHSPlasH's DamBreakWithObjects with PCISPH and density maps: the fluid fell 1 r onto the
#: 3D map's floor while the bound grew to 5 ms, and the landing diverged at step 19 (0.046 s);
#: with 1 it runs, benchmarks/scenes/dambreak_pcisph.json takes 321 steps instead of 314)
LOAD = 1.0


@numba.njit(**_JIT, inline="always")
def height_body(i, x, u0, u1, u2, dim):
    """``u . (x_i - x_0)``: particle i's height along the unit direction u above particle 0's
    (0 for particle 0 itself, so the reduction's maximum, which starts at 0, is the largest)."""
    s = u0 * (x[0, i] - x[0, 0]) + u1 * (x[1, i] - x[1, 0])
    if dim == 3:
        s += u2 * (x[2, i] - x[2, 0])
    return s


specialize(height_body, "dim")


def fluid_depth(state: SimState, g: np.ndarray) -> float:
    """The fluid's extent [m] along the gravity g (dim,; not zero): the highest particle's
    height above particle 0 plus the lowest's depth below it (0 without fluid)."""
    f = state.fluid
    if f.n == 0:
        return 0.0
    u = np.zeros(3)
    u[: state.dim] = -g / float(np.linalg.norm(g))
    x = f["x"]
    above = launch_reduce(height_body, f.n, x, u[0], u[1], u[2], state.dim)[1]
    below = launch_reduce(height_body, f.n, x, -u[0], -u[1], -u[2], state.dim)[1]
    return above + below


@numba.njit(**_JIT, inline="always")
def predict_body(i, x, v, a, ap, dt, dim, dx, xp):
    """``dx[:, i] = x*_i - x_i = dt (v_i + dt (a_i + ap_i))`` and ``xp[:, i] = x*_i``."""
    for d in range(dim):
        dx[d, i] = dt * (v[d, i] + dt * (a[d, i] + ap[d, i]))
        xp[d, i] = x[d, i] + dx[d, i]


specialize(predict_body, "dim")  # an element loop: unrolled per dimension


@numba.njit(**_JIT, inline="always")
def pressure_update_body(i, rho_hat, factor, factors, each, rows, p):
    """``p_i += f_i max(rho_hat_i - 1, 0)`` with ``f_i = factors[i]`` if ``each`` (several
    fluids, capped factors), else ``factor``; returns the compression ``max(rho_hat_i - 1, 0)``
    before the update, 0 for a particle the solve does not hold (``rows[i]`` false; an empty
    array: it holds every particle), whose pressure stays 0."""
    if rows.shape[0] > 0 and not rows[i]:
        return 0.0
    e = max(rho_hat[i] - 1.0, 0.0)
    if each:
        p[i] += factors[i] * e
    else:
        p[i] += factor * e
    return e


@numba.njit(**_JIT, inline="always")
def ratio_scale_body(i, plain, weighted, out):
    """``out_i = plain_i / weighted_i`` (1 where the weighted diagonal vanishes)."""
    out[i] = plain[i] / weighted[i] if weighted[i] > 0.0 else 1.0


@numba.njit(**_JIT, inline="always")
def cap_body(i, d, limit, out):
    """``out_i = min(1, limit / d_i)``; returns 1 where that is below 1, else 0."""
    if d[i] > limit:
        out[i] = limit / d[i]
        return 1.0
    out[i] = 1.0
    return 0.0


def phase_factor(state: SimState, g: PairGradients) -> Any:
    """Per-particle correction of the template factor for several fluids (N,).

    In the own variable ``p~_i = p_i / rho0_i`` the PPE diagonal of particle i is
    ``D_i = (G_i + B_i) . (G_i + M_i) + sum_j (rho0_i / rho0_j) V_j^2 |grad W_ij|^2``
    (:func:`sphkit.core.ppe.diagonal_cached`): the template's ``delta`` assumes every ratio is
    1. A heavy particle among light ones (ratio 10) has a diagonal up to ten times the
    template's, so ``delta`` over-corrects it up to tenfold (omega 5 instead of 0.5) and the
    iteration diverges at the interface (measured: unstable at 0.022 s in the 1:10
    heavy-over-light column). The correction is ``D_i(ratio 1) / D_i(ratios)`` from the
    step-start neighbourhood, so that ``delta_i = delta D_i(1) / D_i`` keeps the template's
    step where every neighbour is of the particle's own phase."""
    st = state
    n = st.fluid.n
    x = st.fluid["x"]
    mirror = st.coupling.mirror(st, diagonal=True)
    rest = st.rest()
    plain = arrays.empty(n, st.fluid.dtype, like=x)
    weighted = arrays.empty(n, st.fluid.dtype, like=x)
    diagonal_cached(st.nl_ff.offsets, st.nl_fb.offsets, st.nl_fb.indices, mirror, g.gw, g.gwb,
                    st.dim, plain)
    diagonal_cached(st.nl_ff.offsets, st.nl_fb.offsets, st.nl_fb.indices, mirror, g.gw, g.gwb,
                    st.dim, weighted, st.nl_ff.indices, rest.c, rest.inv_c)
    out = arrays.empty(n, st.fluid.dtype, like=x)
    launch(ratio_scale_body, n, plain, weighted, out)
    return out


def diagonal_cap(state: SimState, g: PairGradients, d0: float) -> Any:
    """Per-particle cap of the template factor, ``min(1, CAP d0 / D_i)`` with the particle's
    own PPE diagonal ``D_i`` (:func:`sphkit.core.ppe.diagonal_cached`, boundary and mirror
    included) from the step start; None where no particle exceeds ``CAP d0``.

    The template's factor makes a sweep a Jacobi step with omega ``0.5 D_i / d0`` for particle
    i: fine in the fluid, where ``D_i`` is about the template's, but a volume map's one virtual
    particle carries V_B of up to about 20 particle volumes at 2 r, so next to such a wall
    ``D_i / d0`` reaches 3 at rest and 14-50 where a particle closes in. One sweep then
    overshoots the predicted density below rho0, where the clamped update stops: the solve
    "converges" in 3 sweeps with MPa pressures and throws the particle off at 14-70 m/s (the
    3D dam break of validation/startup.py, unstable at 0.42 s). Capped at omega = 0.5 CAP = 1
    the sweep does not overshoot a linear prediction; particles with ``D_i <= CAP d0`` keep the
    template's factor exactly."""
    if d0 <= 0.0:
        return None
    st = state
    n = st.fluid.n
    x = st.fluid["x"]
    d = arrays.empty(n, st.fluid.dtype, like=x)
    diagonal_cached(st.nl_ff.offsets, st.nl_fb.offsets, st.nl_fb.indices,
                    st.coupling.mirror(st, diagonal=True), g.gw, g.gwb, st.dim, d)
    out = arrays.empty(n, st.fluid.dtype, like=x)
    capped, _ = launch_reduce(cap_body, n, d, CAP * d0, out)  # the one scalar read back
    return out if capped else None


class PCISPH(ImpactBounded, PressureSolver):
    """Predictive-corrective incompressible SPH with SPlisHSPlasH's template scaling factor."""

    uses_pair_gradients = True  #: the simulation computes them with the densities
    name = "pcisph"

    @classmethod
    def from_config(cls, p: Any) -> PCISPH:
        """The PCISPH of a scene's ``configuration.pressure`` (scene model)."""
        return cls(max_error=p.max_error, min_iterations=p.min_iterations,
                   max_iterations=p.max_iterations)

    def __init__(self, max_error: float = 0.01, min_iterations: int | None = None,
                 max_iterations: int = 100) -> None:
        """``max_error`` in percent of rho0 (SPlisHSPlasH maxError); ``min_iterations`` None
        means SPlisHSPlasH's 3."""
        if min_iterations is None:
            min_iterations = min(3, max_iterations)
        self.control = IterationControl("PCISPH", min_iterations, max_iterations,
                                        max_error / 100.0)
        self.delta = 0.0  #: template scaling factor [m^2]
        self.d0 = 0.0  #: the template's PPE diagonal [1/m^2] (delta = 1 / (2 d0))
        #: the adaptive time-step bound (see max_time_step)
        self.step_bound = StepBound(DT_SHRINK, DT_GROW, DT_FLOOR, DT_FREE)
        self.impacts = Impacts("PCISPH")

    def init(self, state: SimState) -> None:
        """Register the pressure field and precompute the template factor delta."""
        f = state.fluid
        f.register("p")
        V = float(f["V0"].max()) if f.n else 0.0
        if V > 0:
            self.d0 = lattice_diagonal(2.0 * state.r, state.h, state.kid, state.dim, V)
            self.delta = 0.5 / self.d0

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Predict-correct loop on the current non-pressure accelerations; adds a_p to a."""
        f, b = state.fluid, state.boundary
        nl, nb = state.nl_ff, state.nl_fb
        x, v, a = f["x"], f["v"], f["a"]
        n = f.n
        p = arrays.zeros(n, f.dtype, like=x)
        ap = arrays.zeros(x.shape, x.dtype, like=x)
        dx = arrays.empty_like(x)
        xp = arrays.empty_like(x)  # x* = x + dx
        rho_hat = arrays.empty(n, f.dtype, like=x)
        factor = self.delta / (dt * dt)
        coupling = state.coupling
        plain = self.impacts.mirror(state)
        mirror = coupling.mirror(state) if plain is None else plain
        kb = coupling.boundary_kappa(state)
        kb_phase = kb.phase  # several rest densities: the MLS values of each phase (None
        # with every static wall solved, whose k_b has one value per wall particle)
        g = PairGradients.of(state)  # a_p is evaluated at the step-start positions every sweep
        rest = state.rest()  # several fluids: the pressure sums weigh p~_j by rho0_j / rho0_i
        pc = p if rest.uniform else arrays.empty_like(p)
        # several fluids: each particle's own step (phase_factor); one fluid: the template's;
        # both capped where the particle's own diagonal exceeds the template's (diagonal_cap)
        scale = diagonal_cap(state, g, self.d0)
        if not rest.uniform:
            phase = phase_factor(state, g)
            scale = phase if scale is None else arrays.multiplied(scale, phase)
        each = scale is not None
        factors = arrays.scaled(scale, factor) if each else arrays.empty(0, f.dtype, like=x)
        # particles an emitter moves are not the solve's to hold (module docstring, "Emitters")
        solved = held(state)
        if solved is None:
            solved = arrays.absent(0, np.bool_, like=x)
        # bodies that yield to the pressure are predicted as the fluid is (strong coupling)
        bdx = [coupling.displacement(state, p, g.gwb, dt)]
        still = arrays.empty((state.dim, 0), x.dtype, like=x)  # no boundary displacement
        walls = coupling.solved and b.n > 0  # the static walls' own pressures (docstring)
        if walls:
            rows = WallRows.of(state, g, "pcisph")  # k_b warm-started from the last step
            use, wk, Vf, wd, wkmax = rows.use, rows.stored, rows.Vf, rows.D, rows.kmax
            target = coupling.wall_density(state, use)  # the step start's: the rate held
            if coupling.density_walls:  # the start's density where the wall was covered
                covered = coupling.wall_rest(state)
                target = np.where(covered >= 0.0, covered, target)
            rho_b, src = (np.zeros(b.n, dtype=f.dtype) for _ in range(2))
            zero = np.zeros(b.n, dtype=f.dtype)
            L = period_arg(state.pair_period)

            kb = solved_kappa(kb, use, wk)  # the walls' own values (and the model's)

        def sweep(_k: int) -> tuple[float, float]:
            launch(predict_body, n, x, v, a, ap, float(dt), int(state.dim), dx, xp)
            # density maps are queried at x* (their lists), with or without yielding bodies,
            # volume maps' virtual particles slide along the wall; the step's boundary
            # particles take the bodies' predicted displacement
            bx, bV, nbp, _ = coupling.boundary_at(state, dx)
            bd = bdx[0] if bx is b["x"] else still
            density_at(xp, rest.mu, nl.offsets, nl.indices, bx, bd, bV,
                       nbp.offsets, nbp.indices, state.rho0, state.h, state.kid, state.dim,
                       rho_hat, rest.one_mass)
            tot, mx = launch_reduce(pressure_update_body, n, rho_hat, float(factor), factors,
                                    each, solved, p)
            if not rest.uniform:
                arrays.multiplied(p, rest.c, out=pc)
            if walls:  # each wall particle's k_b from its predicted density (omega 0.5)
                wall_density(xp, Vf, b["x"], nb.offsets, nb.indices, state.h, state.kid,
                             state.dim, L, use, rho_b)
                np.subtract(target, rho_b, out=src)
                wall_update(zero, src, wd, dt * dt, 0.5, wk, pc, nb.offsets, nb.indices,
                            solver_module.WALL_CAP, wkmax)
            kappa_accel_cached(pc, kb(pc), nl.offsets, nl.indices, nb.offsets, nb.indices,
                               mirror, g.gw, g.gwb, state.dim, ap, rest.sums_factor, kb_phase)
            bdx[0] = coupling.displacement(state, p, g.gwb, dt)
            return tot / max(n, 1), mx

        its, avg, mx, ok = self.control.run(sweep, state.step)
        throw = dt * dt * max_speed(ap) / state.r  # module docstring, "Thrown particles"
        # an impact (module docstring, "Impacts"): the solve made again from p = 0 with the
        # walls' plain term (not with solved walls, whose pressures the sweeps carry)
        hit = not walls and self.impacts.thrown(state, ap, dt, throw)

        def again() -> None:  # the solve made again from p = 0
            nonlocal its, avg, mx, ok, throw
            arrays.fill(p, 0.0)
            arrays.fill(ap, 0.0)
            bdx[0] = coupling.displacement(state, p, g.gwb, dt)
            its, avg, mx, ok = self.control.run(sweep, state.step)
            throw = dt * dt * max_speed(ap) / state.r

        if hit:
            mirror = self.impacts.mirror(state)
            again()
            # it threw as well, and the step cannot be computed again: once more without the
            # particles whose speed its pressure raised (Impacts.released)
            if throw > THROW_PLAIN and not state.retries:
                solved, count = self.impacts.released(state, a, ap, dt, solved)
                if count:
                    again()
        # fluid under pressure at the first step: the steps grow from the scene's initial one;
        # a throw shrinks the bound as a failed solve does
        self.step_bound.update(dt, its, self.control.max_iterations, ok and throw <= THROW,
                               start=state.step == 1 and arrays.any_above(p, 0.0))
        if hit:
            self.impacts.cut(self.step_bound, dt)
        arrays.axpy(a, 1.0, ap)
        arrays.multiplied(p, f["rho0"], out=f["p"])
        return SolverStats(iterations=its, density_error_avg=avg, density_error_max=mx,
                           converged=ok, displacement=throw)

    def max_time_step(self, state: SimState) -> float:
        """The adaptive bound and the load bound [s] (module docstring, "Time step")."""
        return min(self.step_bound.value, self.load_bound(state))

    def load_bound(self, state: SimState) -> float:
        """``sqrt(2 delta eta LOAD N / (|g| H))`` [s]: the step at which holding a column of
        the fluid's depth H (:func:`fluid_depth`, plus 2r) from p = 0 takes ``LOAD`` times the
        ``N = max_iterations`` sweeps at the tolerance eta (inf without gravity; g without its
        components along periodic axes)."""
        g = state.standing_gravity()
        gn = float(np.linalg.norm(g))
        if gn == 0.0 or self.delta <= 0.0 or state.fluid.n == 0:
            return float("inf")
        depth = fluid_depth(state, g) + 2.0 * state.r
        return math.sqrt(2.0 * self.delta * self.control.tolerance * LOAD
                         * self.control.max_iterations / (gn * depth))

    def rejects(self, stats: SolverStats) -> bool:
        """A solve that stopped at its iteration limit with an average error above
        :data:`REJECT` times its tolerance failed (the impact that needs it: the iterate's error
        grew from the first iteration), and so did one that threw a particle (its pressure moves
        it more than :data:`THROW` r within the step), and the step is computed again with the
        shrunk step bound (where :class:`~sphkit.core.solver.StepBound`, after Ihmsen et al.
        2010, only shrinks the next step). The solve changes nothing before it returns but ``a`` and
        ``p`` (its pressure starts from zero); solved walls, whose pressures it keeps as the
        next solve's warm start, make the world not repeatable
        (:attr:`sphkit.world.World.repeatable`)."""
        return (not stats.converged
                and stats.density_error_avg > REJECT * self.control.tolerance
                or stats.displacement > THROW)

    def boundary_reaction(self, state: SimState) -> BoundaryReaction:
        """The boundary term of :func:`sphkit.core.ppe.kappa_accel_cached` with PCISPH's
        variable ``p~ = p / rho0``, mirrored share included (none in an impact's plain steps)."""
        return BoundaryReaction(state.fluid["p"] / state.fluid["rho0"], self.impacts.share(state))
