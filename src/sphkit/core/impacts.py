"""Impacts: a pressure solve that would throw a particle (sphkit's; IISPH, DFSPH and PCISPH use
it).

At a wall the mirrored share ``m_b`` of the boundary term (:mod:`sphkit.core.ppe`) doubles the
push of a boundary neighbour. When a block lands flat on a volume-map floor, the landing presses
the bottom row to 2 r, where the map's virtual particle already pushes 2.7 times as hard as the
fluid it stands for; the mirror doubles that, the row bounces back, and in the steps after it
the solves throw the fluid at the wall's corner apart (SPlisHSPlasH, whose boundary term is the
plain ``V_b k_i``, lands the same block with IISPH and DFSPH).

The rule: a solve whose pressure acceleration ``a`` would carry a particle more than
:data:`THROW_PLAIN` r within the step, ``dt^2 max_i |a_i| > 1.15 r``, is made again, from the
same warm start, with the walls' plain term (``m_b = 0``; the maps' wall moment stays); the
walls keep the plain term in every solve of the next :data:`PLAIN_STEPS` (10) steps (DFSPH: both
solves), and the solver's adaptive step bound (:class:`sphkit.core.solver.StepBound`) is cut to
:data:`IMPACT_BOUND` (0.5) times the step, from which it grows back as usual. The threshold lies
between the landings (1.2-1.5 r) and what dam breaks and columns at rest reach (at most
1.03 r); validation/README.md, "A block dropped onto a volume-map floor" and "Volume maps on
the geometry's surface", holds the measurements.

The thrown particles (PCISPH's re-solve): PCISPH evaluates its pressure accelerations at the
step start's positions while its prediction moves the particles, so a particle that a solve
carries towards a wall it barely reaches at the step's start (a splash 3 r off a volume-map
wall, at 7.5 m/s towards it) sees its predicted density *rise* with its pressure once the
wall's virtual particle, ten fluid volumes large, comes into range, and the solve pushes it on
through the wall (12 r within the step) while the average converges; the walls' plain term
does not change that. Where the plain term's solve throws as well, PCISPH solves once more
without the particles whose speed that solve's pressure raised by more than THROW_PLAIN r / dt
(:meth:`Impacts.released`): their pressure stays 0 in this step, their neighbours' pressures
still act on them, and the next step's solve linearizes at their new positions. The speed's
gain, not the displacement, tells a throw from a stop: a particle arriving at a wall at
10 m/s is stopped or turned by a pressure that moves it more than r within the step (small
blocks thrown at a volume-map wall in 2D: leaving such particles out threw them back at
19-42 m/s). Not after the first solve: in the landings, whose first solve the plain term
calms, leaving its thrown particles out made 8 of 10 PCISPH drops unstable; and not where the
step can be computed again (``state.retries``, Akinci walls without bodies), where PCISPH's
shorter step (:meth:`sphkit.pressure.pcisph.PCISPH.rejects`) does better
(validation/README.md, "PCISPH's thrown particles left out of the re-solve").
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numba
import numpy as np

from sphkit.backend import launch_reduce
from sphkit.core import arrays
from sphkit.core.pairs import norm, point
from sphkit.core.solver import StepBound, StepBounded
from sphkit.core.state import SimState
from sphkit.core.timestep import max_speed

log = logging.getLogger("sphkit")

#: the displacement [r] that a solve's pressure gives a particle within the step above which
#: the solve is made again with the walls' plain term (module docstring). Measured with the
#: volume maps' surface on the mesh (validation/README.md, "Volume maps on the geometry's
#: surface"): landings of 2D blocks dropped 0.8-3 m onto a volume-map floor throw 1.2-1.5 r (at
#: 1.25 one of 40 drops, 1.22 r in the step before its blow-up, went unstable); SPlisHSPlasH's
#: dam breaks at most 1.03 r (``DamBreakModel.json``; ``DamBreakModel_2D.json`` 0.99 r with
#: DFSPH, 0.94 r with IISPH, 3 s), settling columns 0.5 r
THROW_PLAIN = 1.15
#: the steps after an impact whose solves keep the walls' plain term, and the step bound an
#: impact sets as a fraction of its step (module docstring). Of the drops measured there, with
#: the re-solve alone IISPH still went unstable in 2 of 20, with 10 plain steps and no cut
#: DFSPH in 1 of 10; with both, DFSPH in none of 20 and IISPH in 1 of 20
PLAIN_STEPS, IMPACT_BOUND = 10, 0.5


@numba.njit(cache=True, inline="always")
def release_body(i, v, a, ap, dt, limit, dim, held, out):
    """``out[i]``: particle i stays in the solve: held (``held[i]``; an empty array holds every
    particle) and its pressure acceleration ``ap_i`` adds at most ``limit`` [m/s] to its speed
    within the step ``dt``: ``|w + dt ap_i| - |w| <= limit`` with ``w = v_i + dt
    a_i`` (``a``: the non-pressure accelerations). Returns 1 where a held particle is released."""
    v0, v1, v2 = point(v, i, dim)
    a0, a1, a2 = point(a, i, dim)
    p0, p1, p2 = point(ap, i, dim)
    w0, w1, w2 = v0 + dt * a0, v1 + dt * a1, v2 + dt * a2
    gain = norm(w0 + dt * p0, w1 + dt * p1, w2 + dt * p2) - norm(w0, w1, w2)
    h = held.shape[0] == 0 or held[i]
    out[i] = h and gain <= limit
    return 1.0 if h and gain > limit else 0.0


class Impacts:
    """The impact rule of one pressure solver (module docstring): which steps' solves take the
    walls' plain term, and whether a solve threw a particle."""

    def __init__(self, solver: str, steps: int = PLAIN_STEPS,
                 bound: float | None = IMPACT_BOUND) -> None:
        """``solver``: the name in the log message; ``steps``: the steps after an impact whose
        solves keep the plain term; ``bound``: the step bound after an impact as a fraction of
        its step (None: the bound is left as it is)."""
        self.solver, self.steps, self.bound = solver, steps, bound
        self.until = -1  #: the last step whose solves take the plain term

    def plain(self, state: SimState) -> bool:
        """Whether this step's solves take the walls' plain term (an impact within ``steps``)."""
        return state.step <= self.until

    def share(self, state: SimState) -> float:
        """The factor of the mirrored share in this step's boundary reaction
        (:class:`~sphkit.core.methods.BoundaryReaction`): 0 with the walls' plain term, else 1."""
        return 0.0 if self.plain(state) else 1.0

    def mirror(self, state: SimState) -> np.ndarray | None:
        """The walls' mirror weights for :func:`sphkit.core.solver.jacobi_ppe`: zeros (the
        plain term) in the steps after an impact, None (the coupling's) otherwise."""
        if not self.plain(state):
            return None
        b = state.boundary
        return arrays.zeros(b.n, b["V"].dtype, b["V"])

    def thrown(self, state: SimState, a: np.ndarray, dt: float,
               throw: float | None = None) -> bool:
        """Whether the solve whose pressure acceleration is ``a`` (step ``dt`` [s]) threw a
        particle with the mirrored walls (it is then to be made again with :meth:`mirror`,
        which from now on gives the plain term for ``steps`` steps). ``throw``:
        ``dt^2 max_i |a_i| / r`` where the caller has it already."""
        if self.plain(state) or not state.boundary.n:
            return False
        if throw is None:
            throw = dt * dt * max_speed(a) / state.r
        if throw <= THROW_PLAIN:
            return False
        log.info("step %d: %s's pressure moves a particle %.3g r within the step; solved again "
                 "with the walls' plain term", state.step, self.solver, throw)
        self.until = state.step + self.steps
        return True

    def released(self, state: SimState, a: np.ndarray, ap: np.ndarray, dt: float,
                 held: np.ndarray) -> tuple[np.ndarray, int]:
        """The particles a re-solve holds where the plain term's solve threw as well (PCISPH's;
        module docstring, "The thrown particles"): those of ``held`` (bool (N,); an empty
        array: every particle) whose pressure acceleration ``ap`` adds at most
        :data:`THROW_PLAIN` r / dt to their speed within the step ``dt`` [s] (a pressure that
        stops or turns a particle at a wall is not a throw), ``a`` the non-pressure
        accelerations; and how many it released."""
        f = state.fluid
        out = arrays.empty(f.n, np.bool_, like=ap)
        count, _ = launch_reduce(release_body, f.n, f["v"], a, ap, float(dt),
                                 THROW_PLAIN * state.r / dt, int(state.dim), held, out)
        if count:
            log.info("step %d: %s leaves %d thrown particle(s) out of the re-solve",
                     state.step, self.solver, int(count))
        return out, int(count)

    def solve(self, state: SimState, dt: float,
              relaxed_jacobi: Callable[[np.ndarray | None], tuple]) -> tuple[tuple, bool]:
        """A solve of step ``dt`` [s] under the rule: ``relaxed_jacobi(mirror)`` solves from the
        warm start with the walls' mirror weights (None: the coupling's) and returns a tuple
        whose second item is the pressure acceleration; made again with the plain term where it
        threw a particle (:meth:`thrown`). Returns its last result and whether it threw (then
        :meth:`cut` the step bound after its update)."""
        out = relaxed_jacobi(self.mirror(state))
        hit = self.thrown(state, out[1], dt)
        if hit:
            out = relaxed_jacobi(self.mirror(state))
        return out, hit

    def cut(self, step_bound: StepBound, dt: float) -> None:
        """After an impact (:meth:`thrown`), the solver's :class:`~sphkit.core.solver.StepBound`
        ``step_bound`` at ``bound`` times the step ``dt`` [s] at most."""
        if self.bound is not None:
            step_bound.value = min(step_bound.value, max(self.bound * dt, step_bound.floor))

    def checkpoint_state(self) -> dict:
        """The last step with the plain term, for checkpoints (JSON-ready)."""
        return {"plain_until": self.until}

    def restore(self, state: dict) -> None:
        """Take :meth:`checkpoint_state` back (none: checkpoints written before the rule)."""
        self.until = int(state.get("plain_until", -1))


class ImpactBounded(StepBounded):
    """:class:`~sphkit.core.solver.StepBounded` for a solver with an :class:`Impacts` rule in
    ``self.impacts``: both kept in checkpoints. Put it before the solver's role in the bases."""

    impacts: Impacts

    def checkpoint_state(self) -> dict:
        """The adaptive step bound and the impact rule's last plain step (JSON-ready)."""
        return {**super().checkpoint_state(), **self.impacts.checkpoint_state()}

    def restore_checkpoint_state(self, state: dict) -> None:
        """Take :meth:`checkpoint_state` back."""
        super().restore_checkpoint_state(state)
        self.impacts.restore(state)
