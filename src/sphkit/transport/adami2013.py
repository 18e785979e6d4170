"""Transport-velocity formulation of Adami, Hu & Adams 2013 (J. Comput. Phys. 241, 292-307).

Standard SPH advects the particles with their momentum velocity v; on flows with hyperbolic
stagnation points (the Taylor-Green vortex, a lid-driven cavity) the particles then line up
along the stretching direction and clump across it, and the disorder of the neighbour sets
costs accuracy and energy. Adami et al. advect the particles with a transport velocity ``v~``
instead, which adds to the momentum velocity the acceleration of a constant background pressure
``p_b`` (with the kernel of the other sums; the half-step kick of the paper's kick-drift-kick
integration, as its Eq. 15 in PySPH's ``TransportVelocityStep``, for a time step dt):

    v~_i = v_i + (dt / 2) a^b_i,   a^b_i = -(p_b / m_i) sum_j (V_i^2 + V_j^2) grad W_ij

(``V = m / rho`` the particle volumes; boundary particles with their volume ``V_b``, so that a
wall pushes the fluid next to it as fluid would). On an ordered, uniform neighbour set the sum
vanishes; where the particles clump or leave holes it moves them back towards uniform spacing,
at no cost to the momentum (the shift is not a force on v). The momentum equation of a fluid
moving with ``v~`` gains the divergence of the stress ``A = rho v (v~ - v)``, discretised in
the paper's inter-particle-averaged form, ``(V_i^2 + V_j^2)`` as in its pressure term:

    a_i += (1 / m_i) sum_j (V_i^2 + V_j^2) (A_i + A_j) / 2 . grad W_ij,
    (A . grad W)_a = rho v_a ((v~ - v) . grad W)

over fluid neighbours (the walls have no transport velocity; as PySPH's implementation). Both
sums are antisymmetric in the pair, so the linear momentum is conserved to round-off.

In sphkit's symplectic Euler (:meth:`sphkit.simulation.Simulation.step`) the particles move by
``dt v~ = dt v^{n+1} + (dt^2 / 2) a^b``: :meth:`Adami2013.apply` evaluates ``a^b`` at the step's
positions and adds the A term with ``v~ - v = (dt / 2) a^b``, and :meth:`Adami2013.advect` adds
the shift ``(dt^2 / 2) a^b`` after the integration (the paper's shift per step; a full ``dt``
kick, twice as strong, made the lid-driven cavity at Re 1000 violently unstable through the A
term, validation/README.md). Background pressure: PySPH's TVF scheme (an
implementation of the paper) takes ``p_b = p0 = rho0 c^2`` with the state equation's speed of
sound c, as sphkit does when ``configuration.transport.background_pressure`` is unset; the
shift per step is then a fixed fraction of the spacing at the acoustic step ``dt ~ h / c``.
Its state equation keeps no background pressure (``p = c^2 (rho - rho0)``): in sphkit that is
WCSPH's linear equation with a small ``pressure.background_pressure`` (which switches the clamp
off).
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core.kernels import kernel_dw
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import add_vector, pair_slots, point, separation, set_vector
from sphkit.core.state import SimState


@numba.njit(cache=True, fastmath=True, inline="always")
def background_body(i, x, m, rho, off, idx, bx, bV, boff, bidx, pb, h, kid, dim, L, ab):
    """``ab[:, i] = -(p_b / m_i) (sum_j (V_i^2 + V_j^2) grad W_ij + sum_b (V_i^2 + V_b^2)
    grad W_ib)``: the background-pressure acceleration of the transport velocity (module
    docstring)."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi = m[i] / rho[i]
    vi2 = vi * vi
    a0 = a1 = a2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        vj = m[j] / rho[j]
        s = (vi2 + vj * vj) * kernel_dw(kid, r, h, dim)
        a0 += s * d0
        a1 += s * d1
        a2 += s * d2
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        s = (vi2 + bV[b] * bV[b]) * kernel_dw(kid, r, h, dim)
        a0 += s * d0
        a1 += s * d1
        a2 += s * d2
    c = -pb / m[i]
    set_vector(ab, i, dim, c * a0, c * a1, c * a2)


@numba.njit(cache=True, fastmath=True, inline="always")
def stress_body(i, x, v, m, rho, off, idx, ab, kick, h, kid, dim, L, a):
    """Add ``(1 / m_i) sum_j (V_i^2 + V_j^2) (A_i + A_j) / 2 . grad W_ij`` with
    ``A = rho v (v~ - v)``, ``v~ - v = kick ab`` (``kick = dt / 2``), to ``a[:, i]`` (module
    docstring)."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi0, vi1, vi2 = point(v, i, dim)
    ti0, ti1, ti2 = point(ab, i, dim)
    ri = rho[i]
    wi = m[i] / ri
    wi2 = wi * wi
    a0 = a1 = a2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        g = kernel_dw(kid, r, h, dim)  # grad W_ij = g d
        vj0, vj1, vj2 = point(v, j, dim)
        tj0, tj1, tj2 = point(ab, j, dim)
        rj = rho[j]
        wj = m[j] / rj
        # rho (v~ - v) . grad W of i and of j (the factor dt and 1/2 outside)
        si = ri * g * (ti0 * d0 + ti1 * d1 + ti2 * d2)
        sj = rj * g * (tj0 * d0 + tj1 * d1 + tj2 * d2)
        s = wi2 + wj * wj
        a0 += s * (si * vi0 + sj * vj0)
        a1 += s * (si * vi1 + sj * vj1)
        a2 += s * (si * vi2 + sj * vj2)
    c = 0.5 * kick / m[i]
    add_vector(a, i, dim, c * a0, c * a1, c * a2)


@numba.njit(parallel=True, cache=True, fastmath=True)
def shift_positions(x, ab, dt2):
    """``x += dt2 ab``: the transport velocity's share of the step's displacement."""
    dim, n = x.shape
    for i in numba.prange(n):
        for d in range(dim):
            x[d, i] += dt2 * ab[d, i]


class Adami2013(NonPressureForce):
    """Transport velocity with background pressure ``p_b`` [Pa] and the stress term A (module
    docstring). ``background_pressure``: p_b [Pa] (> 0)."""

    name = "adami2013"

    @classmethod
    def from_config(cls, p: Any) -> Adami2013:
        """The Adami2013 of a scene's ``configuration.transport`` with its background pressure
        resolved by the world builder (``(config, p_b)``)."""
        _, pb = p
        return cls(pb)

    def __init__(self, background_pressure: float) -> None:
        if not background_pressure > 0 or not np.isfinite(background_pressure):
            raise ValueError(f"configuration.transport.background_pressure: "
                             f"{background_pressure!r}; expected a finite number > 0 [Pa]")
        self.background_pressure = float(background_pressure)  #: p_b [Pa]
        #: the background-pressure acceleration a^b (dim, N) [m/s^2] of the last apply
        self.ab: np.ndarray | None = None

    def apply(self, state: SimState, dt: float) -> None:
        """Evaluate ``a^b`` at the step's positions and add the stress term A to
        ``state.fluid['a']``."""
        f, b = state.fluid, state.boundary
        self.ab = np.zeros_like(f["x"])
        launch(background_body, f.n, f["x"], f["m"], f["rho"], state.nl_ff.offsets,
               state.nl_ff.indices, b["x"], b["V"], state.nl_fb.offsets, state.nl_fb.indices,
               self.background_pressure, state.h, state.kid, state.dim, state.pair_period,
               self.ab)
        launch(stress_body, f.n, f["x"], f["v"], f["m"], f["rho"], state.nl_ff.offsets,
               state.nl_ff.indices, self.ab, 0.5 * float(dt), state.h, state.kid, state.dim,
               state.pair_period, f["a"])

    def advect(self, state: SimState, dt: float) -> None:
        """Move the fluid by the transport velocity's share ``(dt^2 / 2) a^b`` after the step's
        ``x += dt v``."""
        if self.ab is not None and self.ab.shape == state.fluid["x"].shape:
            shift_positions(state.fluid["x"], self.ab, 0.5 * float(dt) * float(dt))
        self.ab = None
