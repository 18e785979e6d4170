"""Time integration and time-step control.

* Symplectic (semi-implicit) Euler, as in all SPlisHSPlasH solvers (survey Sec. 3.3):
  ``v <- v + dt a`` then ``x <- x + dt v``.
* CFL time step (survey Eq. for the Courant condition): ``dt = cfl_factor * 0.4 * 2r / max_i
  |v_i|`` with the velocities at the start of the step (and the moving boundary's), clamped to
  ``[dt_min, dt_max]``. SPlisHSPlasH's ``Simulation::updateTimeStepSizeCFL`` takes ``|v_i + dt
  a_i|`` with the previous step's dt and accelerations; :func:`max_speed` computes that form too
  when given ``a``.
* CFL with iteration control (SPlisHSPlasH's ``cflMethod`` 2, ``Simulation::
  updateTimeStepSize``; ``configuration.time.iteration_control``): the last step times 0.9
  after a pressure solve of more than 10 iterations, times 1.1 after one of fewer than 5, else
  the last step, and never above the CFL step (:func:`iteration_controlled_step`); the rule
  starts from the first step's CFL step, not from the scene's initial ``timeStepSize``, as
  SPlisHSPlasH 2.19 does (measured: validation/README.md).
* Acoustic limit for state-equation solvers (Becker & Teschner 2007; Monaghan 1992):
  ``dt <= 0.4 h / c_s``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numba
import numpy as np

from sphkit.backend import launch, launch_reduce, specialize

_JIT = dict(cache=True, fastmath=True)


@numba.njit(inline="always", **_JIT)
def euler_body(i, x, v, a, dt, dim):
    """Particle i of :func:`symplectic_euler` (a kernel body)."""
    for d in range(dim):
        v[d, i] += dt * a[d, i]
        x[d, i] += dt * v[d, i]


specialize(euler_body, "dim")  # an element loop: unrolled per dimension


def symplectic_euler(x: np.ndarray, v: np.ndarray, a: np.ndarray, dt: float) -> None:
    """``v += dt a``; ``x += dt v`` for all particles (arrays of shape (dim, N))."""
    launch(euler_body, x.shape[1], x, v, a, float(dt), x.shape[0])


@numba.njit(parallel=True, **_JIT)
def wrap_periodic(x, lo, L, a=0):
    """Map the coordinates along axis ``a`` (row a of x, (dim, N); x by default) into
    ``[lo, lo + L)`` (periodic along that axis)."""
    for i in numba.prange(x.shape[1]):
        t = (x[a, i] - lo) / L
        x[a, i] -= L * np.floor(t)
        if x[a, i] >= lo + L:  # round-off at the upper end
            x[a, i] -= L
        if x[a, i] < lo:
            x[a, i] = lo


@numba.njit(inline="always", **_JIT)
def speed2_body(i, v, a, dt, dim):
    """``|v_i + dt a_i|^2`` (a kernel body whose maximum :func:`max_speed` takes)."""
    s = 0.0
    for d in range(dim):
        t = v[d, i] + dt * a[d, i]
        s += t * t
    return s


specialize(speed2_body, "dim")  # an element loop: unrolled per dimension


@numba.njit(cache=True, inline="always")
def finite_speed2_body(i, v, dim):
    """``|v_i|^2`` where it is finite, else 0 (compiled without fast math: it must see NaN)."""
    s = 0.0
    for d in range(dim):
        s += v[d, i] * v[d, i]
    return s if math.isfinite(s) else 0.0


@numba.njit(cache=True, inline="always")
def nonfinite_body(i, v, dim):
    """1 where a velocity component of particle i is NaN or infinite, else 0."""
    s = 0.0
    for d in range(dim):
        s += v[d, i] * v[d, i]
    return 0.0 if math.isfinite(s) else 1.0


def max_speed(v: np.ndarray, a: np.ndarray | None = None, dt: float = 0.0) -> float:
    """``max_i |v_i + dt a_i|`` (0 for an empty set)."""
    if v.shape[1] == 0:
        return 0.0
    return math.sqrt(launch_reduce(speed2_body, v.shape[1], v, v if a is None else a,
                                   0.0 if a is None else float(dt), v.shape[0])[1])


def speed_check(v: np.ndarray) -> tuple[float, int]:
    """Maximum finite speed and the number of particles with a non-finite velocity."""
    if v.shape[1] == 0:
        return 0.0, 0
    m = launch_reduce(finite_speed2_body, v.shape[1], v, v.shape[0])[1]
    bad = launch_reduce(nonfinite_body, v.shape[1], v, v.shape[0])[0]
    return math.sqrt(m), int(bad)


def step_check(x: np.ndarray, v: np.ndarray, domain: Domain | None) -> tuple[float, int, bool]:
    """The end of a step's checks in one pass where nothing is wrong: ``(max finite speed,
    particles with a non-finite velocity, clean)``; ``clean``: every velocity and position is
    finite and no particle is outside ``domain`` (None: no box), which :func:`instability`
    then need not count again. Where :func:`step_check_body` flags a particle, the speed and the
    count come from :func:`speed_check`'s passes and ``clean`` is False (so the diagnosis is the
    one those passes give)."""
    if v.shape[1] == 0:
        return 0.0, 0, True
    box = _NO_BOX if domain is None else _box_args(*domain)
    m = launch_reduce(step_check_body, v.shape[1], x, v, v.shape[0], *box)[1]
    if math.isfinite(m):
        return math.sqrt(m), 0, True
    vmax, bad = speed_check(v)
    return vmax, bad, False


@numba.njit(cache=True, inline="always")
def outside_body(i, x, dim, lo0, lo1, lo2, hi0, hi1, hi2, up, top, sgn):
    """1 where point i of x lies outside the box ``[lo, hi]`` (bounds may be infinite: no fast
    math) and not above the walls' top (``up`` >= 0: ``sgn (x_up - top) > 0``, fluid flying
    over the walls of an open box, not through them), else 0."""
    if up >= 0 and sgn * (x[up, i] - top) > 0.0:
        return 0.0
    out = x[0, i] < lo0 or x[0, i] > hi0
    if dim > 1:
        out = out or x[1, i] < lo1 or x[1, i] > hi1
    if dim > 2:
        out = out or x[2, i] < lo2 or x[2, i] > hi2
    return 1.0 if out else 0.0


@numba.njit(cache=True, inline="always")
def nonfinite_point_body(i, x, dim):
    """1 where a coordinate of point i is NaN or infinite, else 0 (no fast math)."""
    for d in range(dim):
        if not math.isfinite(x[d, i]):
            return 1.0
    return 0.0


class Domain(NamedTuple):
    """The region the fluid must stay in (the step's leak check, :func:`outside_count`): the box
    ``[lo, hi]`` (bounds may be infinite) and, with ``up`` >= 0, the walls' top ``top`` [m] along
    axis ``up`` (``sgn`` +1: up is +x_up): fluid above it is not checked (it flies over the
    walls of an open box, not through them)."""

    lo: np.ndarray
    hi: np.ndarray
    up: int = -1
    top: float = 0.0
    sgn: float = 1.0


def outside_count(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, up: int = -1,
                  top: float = 0.0, sgn: float = 1.0) -> int:
    """The number of points of ``x`` ((dim, N)) outside the box ``[lo, hi]`` (bounds may be
    infinite) and not above the walls' top (``up`` >= 0: ``sgn (x_up - top) > 0``; see
    :class:`Domain`)."""
    if x.shape[1] == 0:
        return 0
    return int(launch_reduce(outside_body, x.shape[1], x, x.shape[0],
                             *_box_args(lo, hi, up, top, sgn))[0])


def _box_args(lo: np.ndarray, hi: np.ndarray, up: int = -1, top: float = 0.0,
              sgn: float = 1.0) -> tuple:
    """The box of :class:`Domain` as :func:`outside_body`'s scalar arguments after ``dim``:
    ``lo0, lo1, lo2, hi0, hi1, hi2, up, top, sgn`` (bounds beyond the dimension 0)."""
    b = [float(t) for t in lo] + [0.0] * 3
    t = [float(u) for u in hi] + [0.0] * 3
    return b[0], b[1], b[2], t[0], t[1], t[2], int(up), float(top), float(sgn)


_NO_BOX = _box_args(np.full(3, -math.inf), np.full(3, math.inf))  # no domain: nothing outside


@numba.njit(cache=True, inline="always")
def step_check_body(i, x, v, dim, lo0, lo1, lo2, hi0, hi1, hi2, up, top, sgn):
    """``|v_i|^2``, or infinity where particle i's velocity or position is not finite or it lies
    outside the box of :func:`outside_body` (no fast math: it must see NaN): the maximum is
    finite exactly when :func:`speed_check`'s count, :func:`nonfinite_count` and
    :func:`outside_count` would all be 0."""
    s = 0.0
    for d in range(dim):
        if not math.isfinite(x[d, i]):
            return math.inf
        s += v[d, i] * v[d, i]
    if not math.isfinite(s):
        return math.inf
    if outside_body(i, x, dim, lo0, lo1, lo2, hi0, hi1, hi2, up, top, sgn) > 0.0:
        return math.inf
    return s


def nonfinite_count(x: np.ndarray) -> int:
    """The number of points of ``x`` ((dim, N)) with a NaN or infinite coordinate."""
    if x.shape[1] == 0:
        return 0
    return int(launch_reduce(nonfinite_point_body, x.shape[1], x, x.shape[0])[0])


def cfl_time_step(vmax: float, r: float, factor: float, dt_min: float, dt_max: float) -> float:
    """``factor * 0.4 * 2r / vmax`` clamped to ``[dt_min, dt_max]`` (dt_max when at rest)."""
    if vmax <= 1e-12:
        return dt_max
    return min(max(factor * 0.4 * 2.0 * r / vmax, dt_min), dt_max)


#: SPlisHSPlasH's cflMethod 2: a solve of more than ITERATIONS_HIGH iterations shrinks the next
#: step by SHRINK, one of fewer than ITERATIONS_LOW grows it by GROW (Simulation.cpp)
ITERATIONS_HIGH, ITERATIONS_LOW, SHRINK, GROW = 10, 5, 0.9, 1.1


def iteration_controlled_step(last: float, iterations: int, dt_min: float) -> float:
    """The step after one of ``last`` [s] whose pressure solve took ``iterations``: ``last``
    times 0.9 above 10 iterations, times 1.1 below 5, else ``last``; at least ``dt_min``
    (SPlisHSPlasH lets the step shrink without a floor; the caller takes the smaller of this
    and the CFL step)."""
    if iterations > ITERATIONS_HIGH:
        last *= SHRINK
    elif iterations < ITERATIONS_LOW:
        last *= GROW
    return max(last, dt_min)


def _as_is(path: str) -> str:
    return path


#: with a fixed step, the CFL number of the fluid within the walls' reach has to exceed
#: ``configuration.max_cfl`` in this many steps in a row (or the CFL number anywhere twice the
#: limit in one step) to stop the run (:class:`WallCfl`)
CFL_STEPS = 5


@numba.njit(cache=True, inline="always")
def wall_speed2_body(i, v, boff, dim):
    """``|v_i|^2`` where fluid particle i has a boundary neighbour (the CSR offsets ``boff``;
    a particle emitted after the search has none), else 0."""
    if i + 1 >= boff.shape[0] or boff[i + 1] == boff[i]:
        return 0.0
    s = 0.0
    for d in range(dim):
        s += v[d, i] * v[d, i]
    return s


class WallCfl:
    """The guard's CFL number with a fixed step: ``max |v_i| dt / 2r`` over the fluid particles
    with a boundary neighbour, where a step too long carries fluid through a wall (the WCSPH of
    stiffness 1 at a fixed 20 ms: 4.96 at the floor), and the steps in a row it exceeded
    ``configuration.max_cfl``. Not over all the fluid: fluid falling free goes on gaining speed
    harmlessly -- SPlisHSPlasH's ``SurfaceTension_FluidChain_JWL+23.json`` (two jets, a fixed
    1 ms step, r = 1 cm, no container) passes CFL 1 after 0.45 s (1.27 at 1 s, the chain's
    lowest drops 9 m down), its fluid at the emitters' housings at most 0.62."""

    def __init__(self) -> None:
        self.cfl = 0.0  #: the last step's CFL number at the walls
        self.steps = 0  #: steps in a row with it above the limit

    def __call__(self, cfg: Any, s: Any, state: Any) -> WallCfl:
        """Measure the step of the statistics ``s`` of the simulation state ``state`` (its
        fluid velocities and fluid-boundary neighbour lists) under the scene's
        ``configuration`` cfg; itself, for :func:`instability`."""
        v, boff = state.fluid["v"], state.nl_fb.offsets
        if cfg.time.cfl or v.shape[1] == 0:
            self.cfl, self.steps = 0.0, 0
            return self
        v2 = launch_reduce(wall_speed2_body, v.shape[1], v, boff, v.shape[0])[1]
        self.cfl = math.sqrt(v2) * s.dt / (2.0 * state.r)
        self.steps = self.steps + 1 if self.cfl > cfg.max_cfl else 0
        return self


def instability(cfg: Any, x: np.ndarray, s: Any, bad: int, domain: Domain | None,
                clean: bool = False, name: Callable[[str], str] = _as_is,
                walls: WallCfl | None = None) -> tuple[str, str]:
    """What shows the step of the statistics ``s`` blowing up or leaking, and the advice for it
    (empty strings: nothing): ``bad`` particles with a NaN/inf velocity, a position that is not
    finite, a speed above ``cfg.max_velocity``, with the fixed step a CFL number above twice
    ``cfg.max_cfl`` or, at the walls, above ``cfg.max_cfl`` in :data:`CFL_STEPS` steps in a row
    (``walls``, :class:`WallCfl`; None: the step's CFL number ``s.cfl`` above the limit
    alone), fluid outside ``domain``. ``cfg`` is the
    scene's ``configuration``, x the fluid's positions; ``clean``: :func:`step_check` found
    every position finite and inside ``domain`` (not counted again); ``name``: a field path as
    the messages name it (the scene's :meth:`~sphkit.scene.schema.Scene.field`: a translated
    scene's own field first)."""
    if bad or (not clean and nonfinite_count(x)):
        return f"{bad} particle(s) with NaN/inf velocity or position", ""
    if s.max_velocity > cfg.max_velocity:
        return (f"max velocity {s.max_velocity:.4g} m/s exceeds the limit "
                f"{name('configuration.max_velocity')} = {cfg.max_velocity:.4g} m/s"), ""
    held = walls is None or walls.steps >= CFL_STEPS  # at the walls, step after step
    if not cfg.time.cfl and (s.cfl > 2.0 * cfg.max_cfl or held and s.cfl > cfg.max_cfl):
        dt, limit = name("configuration.time.dt"), name("configuration.max_cfl")
        if s.cfl > 2.0 * cfg.max_cfl or walls is None:
            what = (f"CFL number {s.cfl:.3g} exceeds {'twice ' if walls else ''}{limit} = "
                    f"{cfg.max_cfl:g}")
        else:
            what = (f"CFL number at the walls {walls.cfl:.3g} (everywhere {s.cfl:.3g}) exceeds "
                    f"{limit} = {cfg.max_cfl:g} in {walls.steps} steps in a row")
        return (f"{what} with the fixed time step {dt} = {s.dt:g} s "
                f"({name('configuration.time.cfl')} off)",
                f"Switch {name('configuration.time.cfl')} on, or make {dt} smaller (the fixed "
                "step moves the fastest particle more than the limit's share of a particle "
                "diameter).")
    if domain is not None and not clean and (n := outside_count(x, *domain)):
        box = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in zip(domain.lo, domain.hi, strict=True))
        where = ("not checked above the walls' top): the fluid leaked through a wall, or fell "
                 "beside it" if domain.up >= 0 else "the fluid shut in by closed boxes): the "
                 "fluid leaked through a wall or the lid")
        return (f"{n} fluid particle(s) left the domain {box} m (the static walls' bounding box "
                f"plus {name('configuration.domain_margin')} = {cfg.domain_margin:g} h, {where}",
                "Make the pressure stiffer or use an iterative pressure solver, a smaller time "
                f"step ({_step_fields(name)}), thicker walls (boxes[].layers), or set "
                f"{name('configuration.domain_margin')} to null if fluid may leave the walls.")
    return "", ""


def _step_fields(name: Callable[[str], str]) -> str:
    return f"{name('configuration.time.dt_max')}, {name('configuration.time.cfl_factor')}"


def diagnosis(s: Any, what: str, advice: str = "", name: Callable[[str], str] = _as_is) -> str:
    """The message of an unstable step: its step, time, ``what`` (:func:`instability`), the
    largest speed, dt, CFL number and density errors of the statistics ``s``, and ``advice``
    (default: a smaller step, its fields named by ``name`` as in :func:`instability`, or a
    stiffer or iterative solver)."""
    return (
        f"simulation unstable at step {s.step}, time {s.time:.6g} s: {what}; "
        f"max velocity {s.max_velocity:.4g} m/s, dt {s.dt:.4g} s, CFL number {s.cfl:.3g}, "
        f"density error avg {100 * s.density_error_avg:.3g}% max "
        f"{100 * s.density_error_max:.3g}%. "
        + (advice or f"Try a smaller time step ({_step_fields(name)}) or a stiffer/iterative "
           "pressure solver.")
    )
