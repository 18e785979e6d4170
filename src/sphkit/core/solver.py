"""Shared iteration control of the pressure solvers, and the relaxed-Jacobi PPE engine.

Every iterative pressure solver (PCISPH, PBF, IISPH, DFSPH) runs its iterations through
:class:`IterationControl`: at least ``min_iterations``, at most ``max_iterations``, stopping as
soon as the average density error is at most the tolerance (SPlisHSPlasH's ``maxError``, a
percentage of rho0, stored here as a fraction). With several rest densities the average is
each rest density's own and the largest is tested (:func:`group_error`; PCISPH: the average
over all particles). Hitting the limit without convergence logs a warning naming the solver,
the step and the error. Each step reports :class:`SolverStats`.

:func:`jacobi_ppe` is the relaxed Jacobi engine of the survey (Sec. 4.4): for a variable q with
pressure acceleration ``a = kappa_accel_cached(w q)`` it iterates
``q <- max(q - omega scale (s - A q), 0)``
with ``A q = ap_factor * pair_divergence_cached(a)``. IISPH and both DFSPH solvers are this
engine with their own source s, diagonal (``scale``), weight w and time factor.

:class:`StepBound` is the adaptive time-step bound of the solvers whose solves can stop at
their iteration limit (PCISPH, IISPH): shrunk after an unconverged solve, grown after easy ones.
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sphkit.core import arrays
from sphkit.core.ppe import (
    density_pair_gradients,
    diagonal_cached,
    jacobi_sweep,
    kappa_accel_cached,
    pair_divergence_cached,
    pair_gradients,
)
from sphkit.core.solved_walls import wall_diagonal, wall_sums, wall_update
from sphkit.core.state import SimState

if TYPE_CHECKING:
    from sphkit.core.coupling import BoundaryKappa

log = logging.getLogger("sphkit")

#: solved walls: a wall particle's k_b is at most this times the largest k of its fluid
#: neighbours (:func:`sphkit.core.solved_walls.wall_update`; without the bound the walls'
#: values grew to 1e5-1e8 and a 3D 1:10 heavy-over-light column blew up at 1.2 s, also with
#: omega 0.1)
WALL_CAP = 1.0


#: the last-level cache :func:`pair_cache_dtype` compares with where the system does not say
#: how large it is [bytes]
LLC_BYTES = 32 * 2**20


@functools.cache
def last_level_cache() -> int:
    """The size of the largest CPU cache that core 0 sees, in bytes (Linux: sysfs, the cache a
    core shares with its neighbours, e.g. a Zen 4 CCD's 32 MB of L3); :data:`LLC_BYTES` where
    the system does not say."""
    sizes = []
    for entry in Path("/sys/devices/system/cpu/cpu0/cache").glob("index*"):
        try:
            text = (entry / "size").read_text().strip().upper()
            scale = {"K": 2**10, "M": 2**20, "G": 2**30}.get(text[-1:], 1)
            sizes.append(int(text.rstrip("KMG")) * scale)
        except (OSError, ValueError):
            continue
    return max(sizes) if sizes else LLC_BYTES


def pair_cache_dtype(setting: str, values: int, fields: np.dtype) -> np.dtype:
    """The floating-point type of a step's cached pair gradients (``values`` numbers) on the
    CPU, by ``configuration.pair_cache``: "float64"/"float32" as given; "auto": float32 where
    the cache in float64 would not fit in the last-level cache (:func:`last_level_cache`),
    else the fields' type. Why: beyond the cache the passes over the pairs move memory at the
    machine's bandwidth, and half the bytes made the DFSPH dam break's step at 59,319 and
    493,039 particles 9-13 % faster; within it they are bound by arithmetic, and the conversion
    of each value made the step 8-12 % slower at 6,859 and 24,389 particles
    (benchmarks/README.md). The values differ from float64's by float32's rounding (relative
    6e-8), far below the solvers' tolerances: a 3D column at rest of 73,728 particles keeps
    its pressure slope to the fourth digit (validation/README.md, "The pair cache in
    float32")."""
    fields = np.dtype(fields)
    if setting == "float32" or fields == np.float32:
        return np.dtype(np.float32)
    if setting == "auto" and values * 8 > last_level_cache():
        return np.dtype(np.float32)
    return fields


@dataclass
class SolverStats:
    """Statistics of one pressure solve.

    ``density_error_avg``/``_max``: average / maximum compression error of the last iteration as
    fractions of rho0 (0.001 = 0.1 %). ``divergence_error``: average divergence error (|D rho/Dt|
    dt / rho0, a fraction) of DFSPH's divergence solver, else 0. ``converged`` is False when an
    iteration limit stopped a solver. ``displacement``: how far the solve's pressure acceleration
    alone moves a particle within the step, ``dt^2 max_i |a_p,i|`` in particle radii (PCISPH,
    whose density prediction is linear in it; 0 for the other solvers).
    """

    iterations: int = 0
    density_error_avg: float = 0.0
    density_error_max: float = 0.0
    divergence_iterations: int = 0
    divergence_error: float = 0.0
    converged: bool = True
    displacement: float = 0.0


def group_error(err: np.ndarray, groups: tuple[np.ndarray, np.ndarray] | None,
                mean: float) -> float:
    """The average error a solver's convergence test reads: ``mean`` (over all particles) for
    one rest density (``groups`` None), else the largest of the averages of each class of
    equal rest density (:attr:`sphkit.core.state.RestArrays.groups`) over the per-particle
    errors ``err`` (N,). SPlisHSPlasH tests each fluid model's own average error
    (``chk = chk && avg_density_err <= eta`` per fluid model). With one average over all
    particles a light phase that is expanded (its clamped errors 0) let a solve stop with the
    heavy phase's error at twice the tolerance; in a column at rest the heavy layer then pushed
    the light one up step after step (validation/README.md, "One convergence test per rest
    density"). IISPH, DFSPH, ICSPH and PBF test this; PCISPH keeps the average over all
    particles (:mod:`sphkit.pressure.pcisph`)."""
    if groups is None:
        return mean
    index, counts = groups
    sums = np.bincount(index, weights=arrays.to_host(err), minlength=counts.shape[0])
    return float((sums / np.maximum(counts, 1.0)).max())


@dataclass
class IterationControl:
    """Minimum/maximum iterations and the tolerance (a fraction) of one solver loop."""

    name: str
    min_iterations: int
    max_iterations: int
    tolerance: float

    def run(self, sweep: Callable[[int], tuple[float, float]],
            step: int = -1) -> tuple[int, float, float, bool]:
        """Call ``sweep(k)`` (one iteration returning (average, max) error) until converged.

        Returns (iterations, average error, max error, converged).
        """
        avg = mx = 0.0
        for k in range(self.max_iterations):
            avg, mx = sweep(k)
            if k + 1 >= self.min_iterations and avg <= self.tolerance:
                return k + 1, avg, mx, True
        log.warning(
            "%s: no convergence in %d iterations at step %d: average error %.4g%% "
            "(tolerance %.4g%%), max %.4g%%", self.name, self.max_iterations, step,
            100 * avg, 100 * self.tolerance, 100 * mx)
        return self.max_iterations, avg, mx, False


#: the adaptive step bound of the relaxed-Jacobi density solves of IISPH and DFSPH
#: (:class:`StepBound`'s arguments; :mod:`sphkit.pressure.iisph`, "Time step"): the step after
#: a failed solve ``shrink`` times that step, the bound's growth per easy solve, the smallest
#: bound [s] (the default time.dt_min), the bound above which it is dropped [s], and the error,
#: in tolerances, up to which a solve stopped at max_iterations does not fail
JACOBI_STEP_BOUND = {"shrink": 0.8, "grow": 1.02, "floor": 1e-4, "free": 1.0, "slack": 1.5}


class StepBound:
    """An adaptive time-step bound [s] driven by the convergence of a solver's solves.

    After each solve, :meth:`update`: a solve that stopped at its iteration limit with its error
    above ``slack`` times the tolerance ("failed") sets the bound to ``shrink`` times that step
    (at least ``floor``); a solve that converged within half of the limit ("easy") multiplies a
    finite bound by ``grow``, and a bound above ``free`` is dropped (inf: no bound); a solve
    that stopped at the limit within ``slack`` times the tolerance leaves the bound as it is.
    ``start``, given by the solver, sets an absent bound to the step's dt before that rule
    (PCISPH: its first solve built pressure, so the steps grow from the scene's initial step).
    Without a failed solve or a start the bound stays inf and the run is what it would be
    without it. After Ihmsen, Akinci, Gissler and Teschner 2010, "Boundary handling and
    adaptive time-stepping for PCISPH", VRIPHYS, which shrinks the step when the density error
    is too large.
    """

    def __init__(self, shrink: float, grow: float, floor: float, free: float,
                 slack: float = 1.0) -> None:
        """``shrink``: factor of the step after a failed solve (< 1); ``grow``: factor per
        easy solve (> 1); ``floor``: the smallest bound [s]; ``free``: the bound [s] above which
        it is dropped; ``slack``: the error, in tolerances, up to which a solve stopped at the
        limit does not count as failed (1: every unconverged solve fails)."""
        self.shrink, self.grow, self.floor, self.free = shrink, grow, floor, free
        self.slack = slack
        self.value = math.inf  #: the bound [s] (inf: none)

    def update(self, dt: float, iterations: int, max_iterations: int, converged: bool,
               start: bool = False, miss: float = math.inf) -> None:
        """The rule after a solve of step ``dt`` [s] that took ``iterations`` of at most
        ``max_iterations`` and ``converged`` (or not), ending at ``miss`` times its tolerance
        (inf when not given: an unconverged solve fails)."""
        if start and math.isinf(self.value):
            self.value = dt
        if not converged and miss > self.slack:
            self.value = max(self.shrink * dt, self.floor)
        elif iterations <= max_iterations // 2 and math.isfinite(self.value):
            self.value *= self.grow
            if self.value > self.free:
                self.value = math.inf

    def checkpoint_state(self) -> dict:
        """The bound, for checkpoints (JSON-ready; None for no bound)."""
        return {"dt_bound": None if math.isinf(self.value) else float(self.value)}

    def restore(self, state: dict) -> None:
        """Take the bound back from :meth:`checkpoint_state` (no bound when absent: checkpoints
        written before the bound existed)."""
        b = state.get("dt_bound")
        self.value = math.inf if b is None else float(b)



class StepBounded:
    """The pressure-solver hooks of a solver that holds a :class:`StepBound` in
    ``self.step_bound`` (PCISPH, IISPH, DFSPH): the bound as the solver's largest time step,
    kept in checkpoints. Put it before the solver's role in the bases."""

    step_bound: StepBound

    def max_time_step(self, state: SimState) -> float:
        """The adaptive bound [s] (inf: none; see :class:`StepBound`)."""
        return self.step_bound.value

    def checkpoint_state(self) -> dict:
        """The adaptive step bound, for checkpoints (JSON-ready; None for no bound)."""
        return self.step_bound.checkpoint_state()

    def restore_checkpoint_state(self, state: dict) -> None:
        """Take the bound back from :meth:`checkpoint_state` (no bound when absent: checkpoints
        written before the bound existed)."""
        self.step_bound.restore(state)


class PairGradients:
    """``V_j grad W_ij`` for every fluid and boundary pair of the current neighbour lists,
    computed once per step and shared by all Jacobi iterations of the step.

    ``with_density`` also computes the fluid densities ``rho`` in the same pass over the pairs
    (the simulation does that for solvers with ``uses_pair_gradients`` and puts the result in
    ``state.pair_grads``; :meth:`of` returns it, or computes the gradients when it is absent).
    """

    def __init__(self, state: SimState, with_density: bool = False,
                 volumes: np.ndarray | None = None,
                 scratch: arrays.Scratch | None = None) -> None:
        """``volumes``: the fluid volumes V_j of the gradients (N,) [m^dim] instead of the rest
        volumes ``V0`` (ICSPH's current volumes ``m_j / rho_j``); not with ``with_density``.
        ``scratch``: the block the gradients are laid in (the simulation's step, whose next
        neighbour search reuses it; :class:`sphkit.core.arrays.Scratch`); None: arrays of
        their own."""
        f, b = state.fluid, state.boundary
        nl, nb = state.nl_ff, state.nl_fb
        x = f["x"]
        shapes = (state.dim, nl.indices.shape[0]), (state.dim, nb.indices.shape[0])
        if arrays.on_device(x):
            self.gw = arrays.empty(shapes[0], f.dtype, like=x)
            self.gwb = arrays.empty(shapes[1], f.dtype, like=x)
        else:  # the fluid pairs' gradients in the type of configuration.pair_cache
            kind = pair_cache_dtype(state.pair_cache, shapes[0][0] * shapes[0][1], f.dtype)
            if scratch is not None:
                self.gw, self.gwb = scratch.take((shapes[0], kind), (shapes[1], f.dtype))
            else:
                self.gw, self.gwb = np.empty(shapes[0], kind), np.empty(shapes[1], f.dtype)
        if with_density:
            rest = state.rest()
            density_pair_gradients(f["x"], rest.mu, nl.offsets, nl.indices, b["x"], b["V"],
                                   nb.offsets, nb.indices, state.rho0, state.h, state.kid,
                                   state.dim, f["rho"], self.gw, self.gwb, state.pair_period,
                                   V=rest.V, c=rest.c)
        else:
            V = f["V0"] if volumes is None else volumes
            pair_gradients(f["x"], V, nl.offsets, nl.indices, b["x"], b["V"], nb.offsets,
                           nb.indices, state.h, state.kid, state.dim, self.gw, self.gwb,
                           state.pair_period)
        self.state = state
        self._bsum: np.ndarray | None = None  # boundary_sums(), made when first asked

    def boundary_sums(self) -> np.ndarray:
        """``B_i = sum_b V_b grad W_ib`` (dim, N) of this step's boundary pairs, which the pass
        of :meth:`diagonal` adds up (the solvers make the diagonal first; otherwise it is made
        here for them)."""
        if self._bsum is None:
            self._diagonal(0.0, None)
        return self._bsum

    @staticmethod
    def of(state: SimState) -> PairGradients:
        """This step's cache from ``state.pair_grads`` when the simulation made it, else new."""
        g = state.pair_grads
        return g if g is not None else PairGradients(state)

    def diagonal(self, mirror_shift: float = 0.0) -> np.ndarray:
        """``D_i`` of :func:`sphkit.core.ppe.diagonal_cached` (DFSPH's 1/alpha, IISPH's
        -a_ii rho^2); ``mirror_shift`` is added to the mirror weights (ICSPH's psi - 1)."""
        return self._diagonal(mirror_shift, None)[0]

    def diagonal_and_divergence(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`diagonal` and :meth:`velocity_divergence` of v in one pass over the pairs
        (DFSPH's factor and divergence source)."""
        return self._diagonal(0.0, v)

    def _diagonal(self, mirror_shift: float, v: np.ndarray | None) -> tuple:
        st = self.state
        out = arrays.empty(st.fluid.n, st.fluid.dtype, like=self.gw)
        rest = st.rest()
        mirror = st.coupling.mirror(st, diagonal=True)
        if mirror_shift:
            mirror = mirror + mirror_shift
        fresh = self._bsum is None  # the pass makes boundary_sums() too
        if fresh:
            self._bsum = arrays.empty((st.dim, st.fluid.n), st.fluid.dtype, like=self.gw)
        div = None if v is None else arrays.empty(st.fluid.n, st.fluid.dtype, like=v)
        diagonal_cached(st.nl_ff.offsets, st.nl_fb.offsets, st.nl_fb.indices,
                        mirror, self.gw, self.gwb, st.dim, out, st.nl_ff.indices,
                        *((None, None) if rest.uniform else (rest.c, rest.inv_c)),
                        bsum=self._bsum if fresh else None, v=v, bv=st.boundary["v"], div=div)
        return out, div

    def wall_rate(self, v: np.ndarray) -> np.ndarray:
        """``D rho_hat_b / Dt = sum_f V_f (v_f - v_b) . grad_f W_fb`` of the fluid velocities v
        relative to the wall particle's (walls moved through ``state.boundary``, as the fluid's
        own divergence reads them) at each solved wall particle (0 at the others;
        :func:`sphkit.core.solved_walls.wall_sums`)."""
        st = self.state
        b = st.boundary
        out = np.empty(b.n, dtype=st.fluid.dtype)
        rest = st.rest()
        Vf = st.fluid["V0"] if rest.uniform else rest.V
        wall_sums(v, b["v"], Vf, b["V"], st.nl_fb.offsets, st.nl_fb.indices, self.gwb,
                  st.dim, st.coupling.solved_walls(st), out)
        return out

    def wall_args(self, v: np.ndarray, factor: float, key: str, scale: float = 1.0,
                  density: bool = False) -> dict:
        """:func:`jacobi_ppe`'s solved-wall arguments (scene ``configuration.boundary.solved``):
        the walls' source ``-factor D rho_hat_b / Dt`` of the velocities v
        (:meth:`wall_rate`), the name of their warm start and its scale; none (``{}``) when
        the walls are not solved.

        ``density``: the caller is a density solve (source ``1 - rho_hat - dt div``, factor
        dt: IISPH's, DFSPH's constant-density solve). With ``solved: "density"`` the walls'
        source there is at density level too, ``rho_rest_b - rho_hat_b - factor D rho_hat_b /
        Dt`` (:meth:`~sphkit.core.coupling.BoundaryCoupling.wall_rest`: the wall particles
        covered at the start; the others keep the velocity level)."""
        cp = self.state.coupling
        if not cp.solved:
            return {}
        src = -factor * self.wall_rate(v)
        if density and cp.density_walls:
            st = self.state
            rest = cp.wall_rest(st)
            held = rest >= 0.0
            rho_b = cp.wall_density(st, held)
            src = np.where(held, src + (rest - rho_b), src).astype(src.dtype)
        return {"wall_source": src, "wall_key": key, "wall_scale": scale}

    def velocity_divergence(self, v: np.ndarray, fluid_only: bool = False) -> np.ndarray:
        """``D rho_hat / Dt`` of the velocities v (boundary velocities from the state);
        ``fluid_only``: the fluid neighbours' share alone, ``sum_j V_j (v_i - v_j) . grad
        W_ij``."""
        st = self.state
        out = arrays.empty(st.fluid.n, st.fluid.dtype, like=v)
        boff, bidx = st.nl_fb.offsets, st.nl_fb.indices
        if fluid_only:  # empty boundary rows
            boff = arrays.zeros(boff.shape[0], boff.dtype, like=boff)
        pair_divergence_cached(v, st.boundary["v"], st.nl_ff.offsets, st.nl_ff.indices,
                               boff, bidx, self.gw, self.gwb, st.dim, out)
        return out


@dataclass
class WallRows:
    """The solved walls' rows of one solve (scene ``configuration.boundary.solved``), shared by
    :func:`jacobi_ppe` (IISPH, DFSPH) and PCISPH's predict-correct loop: ``use`` the solved
    wall particles; ``stored`` their warm start, the boundary field of
    :meth:`~sphkit.core.coupling.BoundaryCoupling.wall_kappa` (zero where not solved);
    ``Vf`` the fluid volumes of the walls' sums; ``D`` their Jacobi scale
    (:func:`sphkit.core.solved_walls.wall_diagonal`); ``kmax`` the work array of the cap of
    :func:`sphkit.core.solved_walls.wall_update`."""

    use: np.ndarray
    stored: np.ndarray
    Vf: np.ndarray
    D: np.ndarray
    kmax: np.ndarray

    @classmethod
    def of(cls, state: SimState, g: PairGradients, key: str) -> WallRows:
        """The rows of the solve named ``key`` with the step's pair gradients ``g``."""
        f, b = state.fluid, state.boundary
        rest = state.rest()
        use = state.coupling.solved_walls(state)
        stored = state.coupling.wall_kappa(state, key)
        stored[~use] = 0.0
        Vf = f["V0"] if rest.uniform else rest.V
        D = np.empty(b.n, dtype=f.dtype)
        wall_diagonal(Vf, b["V"], rest.inv_c, state.nl_fb.offsets, state.nl_fb.indices, g.gwb,
                      state.dim, use, D)
        return cls(use, stored, Vf, D, np.empty(b.n, dtype=f.dtype))


def solved_kappa(model_kb: BoundaryKappa, use: np.ndarray,
                 wk: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The boundary values ``k_b`` of a solve with solved walls: the walls' own ``wk`` where
    they are solved (``use``) and, with ``solved: "stratified"``, the boundary pressure model's
    extrapolation of the fluid's field at the others (every phase's row of a per-phase model);
    ``wk`` alone where the model is off (every static wall solved)."""
    if model_kb.model is None:
        return lambda _k: wk
    out: list[np.ndarray] = []  # the mixed values, apart from the model's own array, which it
    # keeps from solve to solve as it wrote it

    def kb(k: np.ndarray) -> np.ndarray:
        model = model_kb(k)
        if not out or out[0].shape != model.shape:
            out[:] = [np.empty_like(model)]
        np.copyto(out[0], model)
        out[0][..., use] = wk[use]
        return out[0]

    return kb


#: a periodic domain counts as filled (closed) where the fluid's rest volume is at least this
#: share of the period's (a free surface in a doubly periodic box leaves more room)
FILLED = 0.95


def filled_period(state: SimState) -> bool:
    """True where every axis is periodic, there is no boundary and the fluid's rest volume
    ``sum m_i / rho0_i`` fills at least :data:`FILLED` of the period: a closed domain without a
    free surface, whose PPE solvers take sources relative to the mean
    (:mod:`sphkit.pressure.dfsph`, "Closed domains"; :mod:`sphkit.pressure.iisph`)."""
    axes = state.periodic_axes
    if len(axes) < state.dim or state.fluid.n == 0 or state.boundary.n > 0:
        return False
    if getattr(state.coupling.model, "geometries", None):  # walls as maps
        return False
    f = state.fluid
    volume = float(np.sum(np.asarray(f["m"]) / np.asarray(f["rho0"])))
    return volume >= FILLED * float(np.prod([period for _axis, _lo, period in axes]))


def closed_domain(state: SimState, free_surface: bool | None) -> bool:
    """Whether a PPE solver treats ``state`` as a closed domain (sources relative to the
    fluid's mean, signed pressures): as the scene's ``pressure.free_surface`` says where it is
    set (False: closed), else where :func:`filled_period` finds the period filled."""
    return filled_period(state) if free_surface is None else not free_surface


def jacobi_ppe(state: SimState, control: IterationControl, q: np.ndarray, w: np.ndarray | None,
               s: np.ndarray, scale: np.ndarray, ap_factor: float, omega: float,
               active: np.ndarray | None, error_factor: float = 1.0,
               grads: PairGradients | None = None, shift: float = 0.0, clamp: bool = True,
               mirror: np.ndarray | None = None, wall_source: np.ndarray | None = None,
               wall_key: str = "", wall_scale: float = 1.0
               ) -> tuple[np.ndarray, int, float, float, bool]:
    """Relaxed Jacobi on ``A q = s``; q is updated in place and clamped to q >= 0.

    A compressible PPE (ICSPH) passes ``shift`` > 0: the residual becomes
    ``s - A q + shift q`` (the equation ``(A - shift) q = s``); ``clamp=False`` lets q go
    negative; ``mirror`` replaces the coupling's mirror weights ``m_b`` in the boundary term of
    the iterations (ICSPH's boundary factor psi = 1 + m_b; the returned acceleration uses them
    too).

    One iteration: ``a = kappa_accel_cached(w q)``; ``Ap = ap_factor * pair_divergence_cached(a)``;
    ``q <- max(q - omega scale (s - Ap), 0)`` (:func:`sphkit.core.ppe.jacobi_sweep` computes Ap
    and updates q in one pass). The error of an iteration is the compressive residual
    ``max(Ap - s, 0)`` of ``active`` particles (None: all) averaged over all particles, times
    ``error_factor``. ``w`` None: the weight 1 (the weighted variable is q itself).
    ``grads`` are the step's cached pair gradients (computed here when not given).

    Solved walls (scene ``configuration.boundary.solved``,
    :meth:`~sphkit.core.coupling.BoundaryCoupling.solved_walls`): a solver that passes
    ``wall_source`` (N_boundary,), the source of the walls' constraint in the units of s (its
    velocity part: ``-dt D rho_hat_b / Dt`` of the predicted velocities where s is ``1 - rho_hat
    - dt div``, ``-D rho_hat_b / Dt`` where s is ``-div``; :meth:`PairGradients.wall_rate`;
    with ``solved: "density"`` the density solves add ``rho_rest_b - rho_hat_b``,
    :meth:`PairGradients.wall_args`),
    has the static walls' ``k_b`` (warm-started from the coupling's field ``wall_key``, which
    keeps ``k_b wall_scale``: DFSPH's dt^2 or dt, as its own warm starts) updated
    in every iteration from the same accelerations as the fluid's q:
    ``k_b <- max(k_b - omega (s_b - f Ap_b) / (f D_b), 0)`` (:func:`sphkit.core.ppe.
    wall_update`); the convergence test stays the fluid's. Several rest densities: the
    average error is each class's own and the largest is tested (:func:`group_error`).
    Returns (pressure acceleration of the final q, iterations, average error, max error,
    converged).
    """
    f = state.fluid
    x = f["x"]
    nl, nb = state.nl_ff, state.nl_fb
    g = PairGradients(state) if grads is None else grads
    dim = state.dim
    a = arrays.empty_like(x)
    coupling = state.coupling

    # several fluids: the weighted variable carries the rest-density ratio c (the neighbour
    # weight rho0_j / rho0_i of the pressure sums, sphkit.core.state.RestArrays); c = 1 for one
    rest = state.rest()
    if not rest.uniform:
        w = rest.c if w is None else arrays.multiplied(w, rest.c)
    # the weighted variable, kept up to date by jacobi_sweep (q itself where the weight is 1)
    k = q if w is None else arrays.multiplied(w, q)
    if mirror is None:
        mirror = coupling.mirror(state)
    kb = coupling.boundary_kappa(state)
    phase = kb.phase  # several rest densities: the MLS values of each phase (None when solved)
    walls = coupling.solved and wall_source is not None and state.boundary.n > 0
    if walls:
        rows = WallRows.of(state, g, wall_key)
        use, stored, Vf, wd, wkmax = rows.use, rows.stored, rows.Vf, rows.D, rows.kmax
        wk = stored * (1.0 / wall_scale)
        b = state.boundary
        wap = np.empty(b.n, dtype=f.dtype)
        still = np.zeros_like(b["x"])  # the walls' accelerations: pressure does not move them

        kb = solved_kappa(kb, use, wk)  # the solved walls' own values (and the model's)
    # no clamping: a finite bound (the passes are compiled with fast math's no-infinities flag)
    lo = 0.0 if clamp else -1e300

    def own(k: np.ndarray) -> np.ndarray:  # k of each particle's own rest density
        return k if rest.uniform else arrays.multiplied(k, rest.inv_c)

    # a boundary that takes no pressure acceleration enters Ap_i as a_i . B_i (no pair pass)
    yields = coupling.yields
    bsum = None if yields else g.boundary_sums()
    ab_still = None if yields else coupling.response(state, k, g.gwb)  # zeros, every sweep's
    # several rest densities: each particle's residual, for each class's own average
    groups = rest.groups
    err = None if groups is None else arrays.empty(q.shape[0], q.dtype, like=q)

    def sweep(_k: int) -> tuple[float, float]:
        kappa_accel_cached(k, kb(k), nl.offsets, nl.indices, nb.offsets, nb.indices, mirror, g.gw,
                           g.gwb, dim, a, rest.sums_factor, phase)
        # boundary particles take no pressure acceleration unless they yield (dynamic bodies)
        ab = coupling.response(state, own(k), g.gwb) if yields else ab_still
        avg, mx = jacobi_sweep(a, ab, nl.offsets, nl.indices, nb.offsets, nb.indices, g.gw, g.gwb,
                               dim, q, s, ap_factor, scale, omega, active, w, k, shift, lo, bsum,
                               err)
        avg = group_error(err, groups, avg)
        if walls:  # the same accelerations: a Jacobi sweep over fluid and walls together
            wall_sums(a, still, Vf, b["V"], nb.offsets, nb.indices, g.gwb, dim, use, wap)
            wall_update(wap, wall_source, wd, ap_factor, omega, wk, k, nb.offsets, nb.indices,
                        WALL_CAP, wkmax)
        return avg * error_factor, mx * error_factor

    its, avg, mx, ok = control.run(sweep, state.step)
    if walls:
        stored[:] = wk * wall_scale
    kappa_accel_cached(k, kb(k), nl.offsets, nl.indices, nb.offsets, nb.indices, mirror, g.gw,
                       g.gwb, dim, a, rest.sums_factor, phase)
    return a, its, avg, mx, ok
