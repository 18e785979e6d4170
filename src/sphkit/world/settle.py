"""Settling before t = 0: a weakly compressible fluid at rest in its container starts in its
solver's own equilibrium (``configuration.start.settle``).

The hydrostatic start (:mod:`sphkit.world.startup`) gives every particle the density and
pressure of its column, but not the positions of the solver's discrete equilibrium: a block
written the way SPlisHSPlasH's scenes write it sits a fraction of a particle spacing off the
floor (its lowest row 3r above Akinci particles, which hold fluid at about 2.1r), so at t = 0
the lowest rows are out of the wall's range, carry no pressure, and the whole column falls by
that gap. The fall excites the column's acoustic modes, which physical viscosity damps only
over tens of seconds: a 2D WCSPH column 0.48 m deep (stiffness 50,000, c = 18.7 m/s, period
4H/c = 0.1 s) swung its frame-by-frame pressure slope between 0.54 and 1.68 of rho0 g for 3 s.

Settling (:meth:`sphkit.simulation.Simulation.settle`) is dynamic relaxation (Day 1965, "An
introduction to dynamic relaxation", The Engineer 219; Underwood 1983, "Dynamic relaxation",
in Computational Methods for Transient Analysis, ch. 5): the simulation's own step, with
gravity, and after every step the velocities damped as ``v <- v exp(-gamma dt)`` at the
critical rate of the deepest column's first acoustic mode (a quarter wave, ``omega_1 = pi c /
(2 H)``, ``gamma = 2 omega_1``), so that the slowest mode decays fastest and the others are
overdamped. Fluid of columns that do not rest on a wall (start pressure 0: a block in the air)
is held in place. It stops once the fluid's root mean square speed is below ``settle_speed``
after at least ``settle_min_periods`` periods of the mode (20), or after ``settle_periods``
periods (30); then every velocity is set to 0 and the clock starts at t = 0, step 0. The
minimum is for the packing, not the waves: a 2D block sampled on SPlisHSPlasH's square lattice
is below 5 mm/s after one period, but the square lattice is not a rest state of 2D SPH and
keeps shearing into hexagonal grains for 1-2 s, and a column released earlier drifts with it
(measurements: validation/README.md, "Settling WCSPH fluid, continued").

``"auto"`` settles only what settling does not change in kind: a solver with a speed of sound
(:meth:`sphkit.core.methods.PressureSolver.acoustic_speed`: WCSPH), gravity, fluid resting on
walls, and every resting particle deeper than h below its free surface either with a full
neighbourhood as sampled or with a wall within 2h across its empty side (within 20 degrees of
the direction away from its neighbours) -- fluid in a container, also when written a few r off
its walls; a side wall along a face, as in a narrow channel, does not contain it; a dam break's
free face (a resting particle deep in its column with an empty side and no wall near) would
flow while it settles, so such a scene is not settled. Moving bodies, emitters, elastic solids
and animation fields, which the step moves by their own clocks, are not settled either, nor
several fluids, whose columns' modes the one damping rate does not match (with ``settle:
true`` they are named in a warning). A settling that becomes unstable is undone (the
run then starts from the unsettled state, with a warning).
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass

import numpy as np

from sphkit.core.methods import PressureSolver
from sphkit.core.pairs import min_image_rows
from sphkit.core.state import SimState
from sphkit.scene.schema import Scene

#: a resting particle with an empty side is at a free face unless a wall lies within this many
#: support radii h (a block written a few r off its container's walls is still contained) ...
FACE_GAP = 2.0
#: ... across that side: within this angle [degrees] of the direction away from its neighbours
#: (a side wall along the face, as in a narrow channel, does not contain it)
FACE_CONE = 20.0

# The settling's loop is the simulation's (:meth:`sphkit.simulation.Simulation.settle`): it
# steps the simulation, which the world does not import.


@dataclass
class SettlePlan:
    """What a settling does (module docstring): damping rate ``gamma`` [1/s], the deepest
    column's depth [m] and speed of sound [m/s], the stopping speed [m/s], the longest and the
    shortest settling [s]; the ids (sorted) and positions (dim, k) of the fluid held in place."""

    gamma: float
    depth: float
    sound_speed: float
    speed: float
    max_time: float
    min_time: float
    held_ids: np.ndarray
    held_x: np.ndarray

    @property
    def period(self) -> float:
        """The period 4 H / c of the deepest column's first acoustic mode [s]."""
        return 4.0 * self.depth / self.sound_speed


def _moving_parts(scene: Scene) -> list[str]:
    """The scene's parts that a settling would move by their own clocks."""
    parts = [scene.field(f"meshes[{k}]") for k, mb in enumerate(scene.meshes) if mb.moving]
    parts += [scene.field(f"emitters[{k}]") for k in range(len(scene.emitters))]
    parts += [scene.field(f"animation_fields[{k}]") for k in range(len(scene.animation_fields))]
    parts += [scene.field(f"materials[{k}].elasticity") for k, m in enumerate(scene.materials)
              if m.elastic]
    return parts


def _several_fluids(state: SimState) -> bool:
    """Whether the fluid holds more than one rest density (several fluids, whose acoustic
    modes the one damping rate of the module docstring does not match)."""
    rho0 = state.fluid["rho0"]
    return bool(state.fluid.n) and float(rho0.min()) != float(rho0.max())


def _walled(state: SimState, k: np.ndarray) -> np.ndarray:
    """Whether a wall lies across the empty side of each fluid particle ``k``: a boundary
    particle within ``FACE_GAP`` h of it and within ``FACE_CONE`` of the direction away from
    its fluid neighbours' centroid (where its neighbourhood is empty)."""
    from scipy.spatial import cKDTree

    x = state.fluid["x"]
    nl = state.nl_ff.rows(k)
    rows = np.repeat(np.arange(k.size), nl.counts())
    d = x[:, nl.indices] - x[:, k[rows]]
    d = min_image_rows(d, state.pair_period)
    away = -np.stack([np.bincount(rows, weights=da, minlength=k.size) for da in d])
    away /= np.maximum(np.linalg.norm(away, axis=0), 1e-300)
    near = cKDTree(state.boundary.view("x")).query_ball_point(
        x[:, k].T, FACE_GAP * state.h, return_sorted=False)
    lens = np.fromiter(map(len, near), dtype=np.int64, count=k.size)
    b = np.fromiter(itertools.chain.from_iterable(near), dtype=np.int64, count=int(lens.sum()))
    owner = np.repeat(np.arange(k.size), lens)
    e = min_image_rows(state.boundary["x"][:, b] - x[:, k[owner]], state.pair_period)
    dist = np.maximum(np.linalg.norm(e, axis=0), 1e-300)
    ahead = np.einsum("dm,dm->m", e, away[:, owner]) >= math.cos(math.radians(FACE_CONE)) * dist
    return np.bincount(owner, weights=ahead, minlength=k.size) > 0


def plan_settle(state: SimState, scene: Scene, pressure: PressureSolver, p: np.ndarray,
                depth: np.ndarray, full: np.ndarray) -> SettlePlan | None:
    """The settling of the started fluid (module docstring), or None when there is none:
    ``p`` the start pressures, ``depth`` each particle's depth below its column's free surface
    [m], ``full`` whether its neighbourhood was full as sampled (all per fluid particle)."""
    cfg = scene.configuration.start
    if cfg.settle is False:
        return None
    f = state.fluid
    c = pressure.acoustic_speed(state)
    resting = p > 0.0
    why = None
    if not math.isfinite(c):
        why = f"the pressure solver {pressure.name!r} has no speed of sound"
    elif f.n == 0 or not np.any(state.gravity) or not resting.any():
        why = "no fluid rests on a wall under gravity"
    elif parts := _moving_parts(scene):
        why = f"{', '.join(parts)} move by their own clocks"
    elif _several_fluids(state):
        # the damping is the critical rate of one fluid's column; a heavy-light column settled
        # so ended with the heavy layer's pressures 93 % off its hydrostatic start
        why = "several fluids (the damping rate is one fluid's column's)"
    else:
        walls = np.diff(state.nl_fb.offsets) > 0
        free = resting & (depth > state.h) & ~full & ~walls
        if free.any() and state.boundary.n:  # a gap to a wall is not a free face
            k = np.flatnonzero(free)
            free[k[_walled(state, k)]] = False
        if free.any():
            why = (f"{int(free.sum())} resting fluid particles deeper than h below the free "
                   "surface have an empty side and no wall (a free face that would flow)")
    if why is not None:
        if cfg.settle is True:
            warnings.warn(f"{scene.field('configuration.start.settle')}: true, but the fluid "
                          f"is not settled: {why}", UserWarning, stacklevel=3)
        return None
    H = float(depth[resting].max())
    period = 4.0 * H / c
    order = np.argsort(f["id"])
    held = order[~resting[order]]
    return SettlePlan(gamma=math.pi * c / H, depth=H, sound_speed=c, speed=cfg.settle_speed,
                      max_time=cfg.settle_periods * period,
                      min_time=min(cfg.settle_min_periods, cfg.settle_periods) * period,
                      held_ids=f["id"][held].copy(),
                      held_x=f["x"][:, held].copy())
