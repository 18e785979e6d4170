"""Weakly compressible SPH with a state equation (survey Sec. 4.1).

Becker & Teschner 2007, "Weakly compressible SPH for free surface flows", SCA:

* Tait equation (Eq. 6): ``p_i = B ((rho_i / rho0)^gamma - 1)`` with stiffness B [Pa] and
  gamma = 7;
* linear state equation (SESPH; survey Eq. 27): ``p_i = k (rho_i - rho0)`` with k [m^2/s^2];
* densities are clamped to ``rho_i >= rho0`` before the state equation, so pressure is never
  negative (no tensile clumping at the free surface; SPlisHSPlasH issue #36); with a
  background pressure ``p_b > 0`` (``pressure.background_pressure``, for flows without a free
  surface, e.g. doubly periodic ones) the density is not clamped and ``p_i = p_b + `` the state
  equation, so a rarefied particle keeps a pressure (down to 0 at a deficit of p_b / c^2) and
  the flow's low-pressure regions (vortex cores) are resolved (Morris et al. 1997, Sec. 3; Adami
  et al. 2013);
* symmetric pressure acceleration (survey Eq. 19, momentum conserving) with Akinci 2012 pressure
  mirroring at boundary neighbours: :func:`sphkit.core.operators.pressure_accel_body`.
  With ``configuration.boundary.symmetric`` (or ``solved``: the static walls) the wall term
  is ``V_b k_i`` alone, ``-sum_b rho0_i V_b p_i / rho_i^2 grad W_ib``, without the mirrored
  share and the extrapolated boundary pressure (:func:`sphkit.core.operators.replace_mirrored`
  with p_b = 0): the derivative of the elastic energy ``sum_i m_i e(rho_i)`` of the summation
  density along x_i, so the walls do no work. The mirrored and extrapolated terms are not such
  a derivative and pumped energy into fluid at rest without dissipation (validation/README.md,
  "WCSPH in the tank at rest").
* at moving bodies the boundary term takes the bodies' mirror weight ``m_b`` (boundary field
  ``pressure_mirror``) as the PPE solvers' does, ``-rho0_i V_b (p_i / rho_i^2 + m_b p_i /
  rho0_i^2) grad W_ib``: mirrored at Akinci bodies (1), one-sided at moving density and volume
  maps (0; SPlisHSPlasH's ``k_i grad rho_B`` of a dynamic body;
  :meth:`sphkit.core.coupling.BoundaryCoupling.one_sided_bodies`), and
  the body feels the reaction of that term (:meth:`WCSPH.boundary_reaction`). The maps' moving
  insets (:data:`sphkit.boundary.koschier2017.MOVING_INSET_3D` and ``_2D``,
  :data:`sphkit.boundary.bender2019.MOVING_INSET`) were made for the one-sided term; mirrored
  there, a floating body rode about 0.5-0.8 r higher than the PPE solvers float it
  (validation/README.md, "The WCSPH float with maps"). Static walls keep SPlisHSPlasH's
  mirrored WCSPH term (and the model's extrapolated pressure) unless the scene's fluid is
  nearly inviscid: ``symmetric`` left out resolves to true there
  (:meth:`sphkit.scene.schema.Scene._inviscid_wcsph_walls`), since without a viscosity to take
  it out the mirrored term's work made an inviscid dam break leak within 3 s.

The speed of sound of the state equation, ``c = sqrt(dp/drho) = sqrt(B gamma / rho0)`` (Tait) or
``sqrt(k)`` (linear), bounds the time step by ``0.4 h_s / c`` with the smoothing length
h_s = h/2 = 2r (Monaghan 1992).

Local stiffness bound (sphkit's; :meth:`WCSPH.max_time_step`): a particle pressed against its
neighbours or a wall is a spring, ``omega_i^2 = c_s^2(rho_i) |d rho_i/d x_i| |d a_i/d p_i|``
(its own density gradient with respect to its position times the factor of p_i in its pressure
acceleration; ``c_s`` at ``max(rho_i, rho0)``, so that a particle about to touch counts), and
symplectic Euler is stable only for ``omega dt < 2``. With particles and density maps the
acoustic step keeps ``omega dt`` at or below 0.60 (Akinci) and 0.74 (density maps) in
validation/startup.py's 3D dam break, where the bound ``omega dt <= 0.8``
(:data:`STIFFNESS_CFL`) does not bind (8 of 4,678 steps with density maps). A volume map's
virtual particle is much stiffer: its density contribution ``V_B(x) W(phi + 0.5 r)`` rises by
about 1.4 rho0 per r where a particle touches (``phi`` 1.5-2 r), and a lone particle reaches
``omega dt`` = 1.6 at the acoustic step at first contact, beyond 2 deeper in: it bounced off
the wall faster than it came (6 m/s in, 23 m/s out) until the dam break went unstable; the
bound takes that bounce to 1.17x (the step that enters the wall's range, before any pressure,
is not resolved) and the dam break runs (validation/README.md, "WCSPH and PCISPH with volume maps").
The bound may grow by at most :data:`STEP_GROWTH` a step: a step that follows the state (short
while particles press on a wall, long when they leave it) is taken long on the way in, before
the compression that would shorten it, and short on the way out, and symplectic Euler then
gains energy with every contact. With the symmetric wall terms, which do no work, an inviscid 3D
dam break with maps gained 10-27 % in 3 s at the free bound and keeps it within 4 % with the
limit; with a fixed step it is conserved to 0.5 % (validation/README.md, "Volume maps'
symmetric term"). Where the bound does not bind (Akinci walls, large scenes), the step is the
same.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.backend import launch_reduce
from sphkit.core import arrays
from sphkit.core.kernels import kernel_dw
from sphkit.core.methods import BoundaryReaction, PressureSolver
from sphkit.core.operators import pressure_accel_cpu, replace_mirrored
from sphkit.core.pairs import pair_slots, point, separation
from sphkit.core.solver import SolverStats
from sphkit.core.state import SimState

TAIT = 0
LINEAR = 1
#: the largest omega dt of the local stiffness bound (:meth:`WCSPH.max_time_step`)
STIFFNESS_CFL = 0.8
#: the largest factor by which the local stiffness bound grows from one step to the next
#: (module docstring; measured: 1.01 left +4-7 % in the 3D dam break with maps, 1.003 +1-2 %)
STEP_GROWTH = 1.003


@numba.njit(cache=True, fastmath=True, inline="always")
def power(x, e):
    """``x ** e``, by repeated squaring where e is a whole number from 1 to 16 (Tait's 7:
    several times faster than the library's ``pow``), else ``pow``."""
    if e == math.floor(e) and 1.0 <= e <= 16.0:
        n = np.int64(e)
        y = 1.0
        b = x
        while n > 0:
            if n & 1:
                y *= b
            b *= b
            n >>= 1
        return y
    return x ** e


@numba.njit(cache=True, fastmath=True, inline="always")
def state_equation_body(i, rho, rho0, equation, stiffness, exponent, p, pb):
    """``p[i]`` from the state equation (``rho0[i]``: particle i's rest density), clamped to
    ``rho >= rho0`` unless the background pressure ``pb`` [Pa] is > 0 (then ``p_b +`` the
    unclamped equation); returns the compression ``(rho_i - rho0_i) / rho0_i``."""
    r0 = rho0[i]
    r = max(rho[i], r0) if pb <= 0.0 else rho[i]
    if equation == TAIT:
        p[i] = stiffness * (power(r / r0, exponent) - 1.0)
    else:
        p[i] = stiffness * (r - r0)
    if pb > 0.0:
        p[i] += pb
    return (r - r0) / r0


def state_equation(rho: Any, rho0: Any, equation: int, stiffness: float, exponent: float,
                   p: Any, pb: float = 0.0) -> tuple[float, float]:
    """:func:`state_equation_body` for all particles, on the device the arrays are on; returns
    (mean, max) compression (the maximum at least 0)."""
    n = rho.shape[0]
    tot, mx = launch_reduce(state_equation_body, n, rho, rho0, int(equation), float(stiffness),
                            float(exponent), p, float(pb))
    return tot / max(n, 1), mx


@numba.njit(cache=True, fastmath=True, inline="always")
def stiffness_body(i, x, mu, rho, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, L, c, inv_c,
                   equation, stiffness, exponent):
    """``omega_i^2 = c_s^2(rho_i) |d rho_i / d x_i| |d a_i / d p_i|``: the spring constant of
    particle i's own pressure force when it moves against its neighbours and walls (module
    docstring), from the gradient of its density with respect to its own position, ``sum_j m_j
    grad W_ij + rho0_i sum_b V_b grad W_ib``, and the factor of p_i in
    :func:`sphkit.core.operators.pressure_accel_body`, mirrored at every boundary sample (at
    the one-sided moving maps an upper bound); densities below rho0_i are taken at rho0_i."""
    ci = c[i]
    r0 = rho0 * ci
    ri = max(rho[i], r0)
    xi0, xi1, xi2 = point(x, i, dim)
    g0 = g1 = g2 = 0.0  # d rho_i / d x_i
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        s = ci * mu[j] * kernel_dw(kid, r, h, dim)  # m_j rho0_i / rho0_j grad W, in both
        g0 += s * d0
        g1 += s * d1
        g2 += s * d2
    q0, q1, q2 = g0, g1, g2  # -rho_i^2 d a_i / d p_i
    mirror = 1.0 + ri * ri / (r0 * r0)
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        s = r0 * bV[b] * kernel_dw(kid, r, h, dim)
        g0 += s * d0
        g1 += s * d1
        g2 += s * d2
        q0 += mirror * s * d0
        q1 += mirror * s * d1
        q2 += mirror * s * d2
    if equation == TAIT:
        cs2 = stiffness * exponent / r0 * power(ri / r0, exponent - 1.0)
    else:
        cs2 = stiffness
    g = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    q = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    return cs2 * g * q / (ri * ri)


class WCSPH(PressureSolver):
    """State-equation pressure solver (Tait or linear) with symmetric pressure forces."""

    name = "wcsph"

    @classmethod
    def from_config(cls, p: Any) -> WCSPH:
        """The WCSPH of a scene's ``configuration.pressure`` (scene model)."""
        return cls(equation=p.equation, stiffness=p.stiffness, exponent=p.exponent,
                   acoustic_cfl=p.acoustic_cfl, background_pressure=p.background_pressure)

    def __init__(self, equation: str = "tait", stiffness: float = 50000.0,
                 exponent: float = 7.0, acoustic_cfl: bool = True,
                 background_pressure: float = 0.0) -> None:
        if equation not in ("tait", "linear"):
            raise ValueError(f"pressure.equation: {equation!r}; expected 'tait' or 'linear'")
        if not stiffness >= 0:  # 0: no pressure (elastic solids only, scene.checks)
            raise ValueError(f"pressure.stiffness: {stiffness!r}; expected a number >= 0")
        self.equation = TAIT if equation == "tait" else LINEAR
        self.stiffness = float(stiffness)
        self.exponent = float(exponent)
        self.acoustic_cfl = acoustic_cfl
        if not background_pressure >= 0:
            raise ValueError(f"pressure.background_pressure: {background_pressure!r}; expected "
                             "a number >= 0 [Pa]")
        self.background_pressure = float(background_pressure)  #: p_b [Pa] (module docstring)
        #: the last step's local stiffness bound [s] while it bound (inf: it did not)
        self.stiffness_bound = math.inf

    def init(self, state: SimState) -> None:
        """Register the pressure field."""
        state.fluid.register("p")

    def sound_speed(self, rho0: float) -> float:
        """Speed of sound c = sqrt(dp/drho) at rest density [m/s]."""
        if self.equation == TAIT:
            return float(np.sqrt(self.stiffness * self.exponent / rho0))
        return float(np.sqrt(self.stiffness))

    def acoustic_speed(self, state: SimState) -> float:
        """The speed of sound of the lightest fluid (the fastest sound) [m/s]; inf without a
        pressure."""
        if self.stiffness == 0.0:
            return float("inf")
        f = state.fluid
        if not f.n or state.rest().uniform:  # every particle at the reference rest density
            return self.sound_speed(state.rho0)
        return self.sound_speed(float(f["rho0"].min()))

    def max_time_step(self, state: SimState) -> float:
        """Acoustic time-step limit ``0.4 * 2r / c``, and the local stiffness bound
        ``STIFFNESS_CFL / max_i omega_i`` (module docstring) from this step's densities, at most
        :data:`STEP_GROWTH` times the last step's (inf when switched off). Called once a step:
        it keeps the bound it returns.

        Monaghan's condition ``dt <= 0.4 h_s / c`` is written for the smoothing length h_s, which
        is half the support radius: ``h_s = 2r`` with sphkit's support ``4r``.
        """
        if not self.acoustic_cfl or self.stiffness == 0.0:  # no pressure, no sound
            return float("inf")
        f = state.fluid
        dt = 0.4 * 2.0 * state.r / self.acoustic_speed(state)
        if f.n:
            b, rest = state.boundary, state.rest()
            _, w2 = launch_reduce(stiffness_body, f.n, f["x"], rest.mu, f["rho"],
                                  state.nl_ff.offsets, state.nl_ff.indices, b["x"], b["V"],
                                  state.nl_fb.offsets, state.nl_fb.indices, float(state.rho0),
                                  float(state.h), int(state.kid), int(state.dim),
                                  state.pair_period, rest.c, rest.inv_c, self.equation,
                                  self.stiffness, self.exponent)
            bound = STIFFNESS_CFL / math.sqrt(w2) if w2 > 0.0 else math.inf
            bound = min(bound, STEP_GROWTH * self.stiffness_bound)
            self.stiffness_bound = bound if bound < dt else math.inf
            dt = min(dt, bound)
        return dt

    def checkpoint_state(self) -> dict:
        """The last step's stiffness bound, for checkpoints (JSON-ready; None for none)."""
        b = self.stiffness_bound
        return {"stiffness_bound": None if math.isinf(b) else float(b)}

    def restore_checkpoint_state(self, state: dict) -> None:
        """Take the bound back from :meth:`checkpoint_state` (none when absent: checkpoints
        written before it existed)."""
        b = state.get("stiffness_bound")
        self.stiffness_bound = math.inf if b is None else float(b)

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Pressure from the state equation, then add the pressure acceleration to ``a``."""
        f, b = state.fluid, state.boundary
        rest = state.rest()
        avg, mx = state_equation(f["rho"], rest.rho0, self.equation, self.stiffness,
                                 self.exponent, f["p"], self.background_pressure)
        if self.stiffness > 0.0 or self.background_pressure > 0.0:  # else p = 0: no force
            pressure_accel_cpu(f["x"], f["m"], f["rho"], f["p"], state.nl_ff.offsets,
                               state.nl_ff.indices, b["x"], b["V"], state.nl_fb.offsets,
                               state.nl_fb.indices, state.rho0, state.h, state.kid, state.dim,
                               f["a"], state.pair_period, c=rest.c, inv_c=rest.inv_c)
        cp = state.coupling
        use = cp.one_sided_bodies(state)
        if cp.symmetric or cp.solved:  # the wall term V_b k_i (module docstring): p_b = 0
            walls = cp.symmetric_walls(state)
            use = walls if use is None else walls | use
        if use is not None:
            replace_mirrored(f["x"], f["p"], rest.rho0, rest.inv_c, b["x"], b["V"],
                             state.nl_fb.offsets, state.nl_fb.indices, use,
                             arrays.zeros((1, b.n), f.dtype, like=f["x"]),
                             arrays.absent(0, np.int64, like=f["x"]),
                             state.h, state.kid, state.dim, state.pair_period, f["a"])
        if not (cp.symmetric or cp.solved):
            cp.correct_mirrored(state, f["a"])  # extrapolated p_b, where modelled
        return SolverStats(iterations=1, density_error_avg=float(avg), density_error_max=float(mx))

    def compressed_density(self, p: np.ndarray, rho0: np.ndarray) -> np.ndarray:
        """The density of the state equation at pressure p >= 0 [Pa]: Tait
        ``rho0 (1 + p / B)^(1 / gamma)``, linear ``rho0 + p / k`` (the hydrostatic start)."""
        p = np.maximum(np.asarray(p, dtype=float), 0.0)
        if self.stiffness == 0.0:  # no pressure: the density does not carry any
            return np.broadcast_to(np.asarray(rho0, dtype=float), p.shape).copy()
        if self.equation == TAIT:
            return rho0 * (1.0 + p / self.stiffness) ** (1.0 / self.exponent)
        return rho0 + p / self.stiffness

    def boundary_reaction(self, state: SimState) -> BoundaryReaction:
        """The boundary term of :meth:`solve` at bodies: ``k_i = rho0_i p_i / rho_i^2`` with
        the mirrored share ``m_b rho_i^2 / rho0_i^2`` of it (``-rho0_i V_b (p_i / rho_i^2 +
        m_b p_i / rho0_i^2) grad W_ib``, module docstring); without a mirrored share with
        ``boundary.symmetric``."""
        f = state.fluid
        p, rho, rho0 = f["p"], f["rho"], f["rho0"]
        if state.coupling.symmetric:
            return BoundaryReaction(rho0 * p / rho ** 2, 0.0)
        return BoundaryReaction(rho0 * p / rho ** 2, rho ** 2 / rho0 ** 2)
