"""Approximate air-fluid drag of Gissler et al. 2017 (survey Sec. 5.5, SPlisHSPlasH
``dragMethod`` 2).

Gissler, Band, Peer, Ihmsen, Teschner 2017, "Approximate air-fluid interactions for SPH",
VRIPHYS 2017, Sec. 4 (the drag part of the paper; the air-particle sampling of Sec. 5 is not
implemented), as SPlisHSPlasH implements it (``SPlisHSPlasH/Drag/DragForce_Gissler2017.cpp``).

Each fluid particle is a droplet of radius ``L = (3/(4 pi))^(1/3) 2r`` that the air deforms
(Taylor analogy breakup, O'Rourke & Amsden 1987). With the water constants below,

* damping time ``t_d = 2 rho_l L^2 / (C_d mu_l)`` and oscillation frequency
  ``omega^2 = C_k sigma / (rho_l L^3) - 1/t_d^2``;
* time of the largest deformation ``t_max = -2 (atan(sqrt(1 + (t_d omega)^2) + t_d omega) -
  pi) / omega`` (Eq. 6; SPlisHSPlasH clamps the atan argument to [-pi/2, pi/2]) and
  ``c_def = 1 - exp(-t_max/t_d) (cos(omega t_max) + sin(omega t_max)/(omega t_d))`` (Eq. 7);
* per particle, with the relative air velocity ``u_i = v_air - v_i``: Weber number
  ``We = rho_a |u|^2 L / sigma``, deformation ``y_max = min(1, C_F We c_def / (C_k C_b))``
  (Eq. 8), Reynolds number ``Re = 2 max(0.1, rho_a |u| L / mu_a)``, sphere drag
  ``C_D = 24/Re (1 + Re^(2/3)/6)`` (Re <= 1000) else 0.424, deformed-droplet drag
  ``C_Liu = C_D (1 + 2.632 y_max)`` (Eq. 9);
* neighbour count n_i (fluid + boundary neighbours) against a full neighbourhood ``n_full``:
  ``f_n = min(1, n_i / (2/3 n_full))``, drag coefficient ``C_i = (1 - f_n) C_Liu + f_n``
  (Eq. 10), droplet cross-section ``A_drop = pi (L + C_b L y_max)^2`` (Eq. 12) blended with a
  particle's face ``(2r)^2``: ``A_unocc = (1 - f_n) A_drop + f_n (2r)^2`` (Eq. 13);
* occlusion by neighbours lying downstream: ``w_i = clamp(1 - max_j (u_i/|u_i|) . x_ij/|x_ij|,
  0, 1)`` with ``x_ij = x_i - x_j`` (Eq. 15), ``A_i = w_i A_unocc`` (Eq. 14);
* drag ``a_i += c / m_i * 1/2 rho_a |u_i| u_i C_i A_i`` (the drag equation), with the user's
  dimensionless scale c (SPlisHSPlasH ``drag``, default 0.01).

Equation numbers are those SPlisHSPlasH's comments give (Eqs. 6-10, 12-15).

The acceleration points along the relative air velocity ``u_i``; a particle in the middle of
the fluid is occluded (``w_i = 0`` as soon as a neighbour lies straight upstream) and feels none.

Constants (SPlisHSPlasH's, SI): air density rho_a 1.2041 kg/m^3, air viscosity mu_a 1.845e-5
Pa s, water surface tension sigma 0.0724 N/m, water viscosity mu_l 1.02e-3 Pa s, TAB constants
C_F = 1/3, C_k = 8, C_d = 5, C_b = 1/2; rho_l is the fluid's rest density.

Differences from SPlisHSPlasH: it hard-codes ``n_full = 38`` (a full 3D neighbourhood at its
rest volume 0.8 (2r)^3); sphkit uses the expected neighbour count of a full support at its own
rest volume V0, ``n_full = |B_h| / V0 - 1`` (|B_h| the area or volume of the support disc or
ball), which is 32.5 in 3D and 11.6 in 2D for h = 4r, so that 2D works too. The air velocity is
a parameter (SPlisHSPlasH: 0). The same formulas (3D droplet radius L) are used in 2D.

Units: the scale ``c`` is dimensionless.
"""

from __future__ import annotations

import math

import numba

from sphkit.core.pairs import dot, pair_slots, point, separation
from sphkit.core.state import SimState
from sphkit.drag.base import AirDrag

RHO_AIR = 1.2041  #: air density [kg/m^3]
MU_AIR = 0.00001845  #: dynamic viscosity of air [Pa s]
SIGMA_WATER = 0.0724  #: surface tension of water [N/m]
MU_WATER = 0.00102  #: dynamic viscosity of water [Pa s]
C_F = 1.0 / 3.0
C_K = 8.0
C_D = 5.0
C_B = 0.5


@numba.njit(inline="always", cache=True, fastmath=True)
def gissler_body(i, x, v, m, off, idx, boff, va, coeff, y_coeff, L, diam, n_full23, dim, a):
    """Add the drag acceleration of fluid particle i to ``a[:, i]``."""
    u0 = va[0] - v[0, i]
    u1 = va[1] - v[1, i]
    u2 = va[2] - v[2, i] if dim == 3 else 0.0
    u2n = u0 * u0 + u1 * u1 + u2 * u2
    un = math.sqrt(u2n)
    if un <= 1.0e-6:
        return
    e0 = u0 / un
    e1 = u1 / un
    e2 = u2 / un
    y_max = min(u2n * y_coeff, 1.0)
    re = 2.0 * max(RHO_AIR * un * L / MU_AIR, 0.1)
    if re <= 1000.0:
        cd_sphere = 24.0 / re * (1.0 + re ** (2.0 / 3.0) / 6.0)
    else:
        cd_sphere = 0.424
    cd_liu = cd_sphere * (1.0 + 2.632 * y_max)
    nn = (off[i + 1] - off[i]) + (boff[i + 1] - boff[i])
    fn = min(n_full23, float(nn)) / n_full23
    cd = cd_liu if nn == 0 else (1.0 - fn) * cd_liu + fn
    h1 = L + C_B * L * y_max
    a_drop = math.pi * h1 * h1
    a_unocc = (1.0 - fn) * a_drop + fn * diam * diam
    xi0, xi1, xi2 = point(x, i, dim)
    max_vx = 0.0
    for k in pair_slots(off, i):
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, idx[k], dim, 0.0)
        if r > 0.0:
            max_vx = max(max_vx, dot(e0, e1, e2, d0, d1, d2) / r)
    w = max(0.0, min(1.0, 1.0 - max_vx))
    c = coeff * 0.5 / m[i] * RHO_AIR * un * cd * w * a_unocc
    a[0, i] += c * u0
    a[1, i] += c * u1
    if dim == 3:
        a[2, i] += c * u2


@numba.njit(parallel=True, cache=True, fastmath=True)
def _gissler_cpu(x, v, m, off, idx, boff, va, coeff, y_coeff, L, diam, n_full23, dim, a):
    for i in numba.prange(x.shape[1]):
        gissler_body(i, x, v, m, off, idx, boff, va, coeff, y_coeff, L, diam, n_full23, dim, a)


def deformation_coefficient(L: float, rho_l: float) -> float:
    """``C_F c_def rho_a L / (C_k C_b sigma)`` [s^2/m^2]: ``y_max = min(1, this * |u|^2)``
    (Eqs. 5-8 of Gissler et al. 2017 with the constants of this module)."""
    inv_td = 0.5 * C_D * MU_WATER / (rho_l * L * L)
    td = 1.0 / inv_td
    omega = math.sqrt(max(C_K * SIGMA_WATER / (rho_l * L**3) - inv_td * inv_td, 0.0))
    val = math.sqrt(td * td * omega * omega + 1.0) + td * omega
    val = min(max(val, -0.5 * math.pi), 0.5 * math.pi)
    t_max = -2.0 * (math.atan(val) - math.pi) / omega
    c_def = 1.0 - math.exp(-t_max / td) * (math.cos(omega * t_max)
                                           + math.sin(omega * t_max) / (omega * td))
    we_wo_v = RHO_AIR * L / SIGMA_WATER
    return C_F * we_wo_v * c_def / (C_K * C_B)


class Gissler2017(AirDrag):
    """Droplet-deformation air drag of Gissler et al. 2017 (SPlisHSPlasH "Gissler et al. 2017").

    ``coefficient``: dimensionless scale of the drag (SPlisHSPlasH ``drag``);
    ``air_velocity``: velocity of the surrounding air [m/s] (default at rest).
    """

    name = "gissler2017"
    repeatable = True  #: apply adds to a only
    unit = "(dimensionless)"

    def apply(self, state: SimState, dt: float) -> None:
        """Add the drag acceleration to ``state.fluid['a']``."""
        f = state.fluid
        if f.n == 0:
            return
        diam = 2.0 * state.r
        L = (0.75 / math.pi) ** (1.0 / 3.0) * diam
        y_coeff = deformation_coefficient(L, state.rho0)
        V0 = float(f["m"][0]) / state.rho0
        ball = math.pi * state.h**2 if state.dim == 2 else 4.0 / 3.0 * math.pi * state.h**3
        n_full23 = max(ball / V0 - 1.0, 1.0) * 2.0 / 3.0
        va = self.air(state.dim)
        _gissler_cpu(f["x"], f["v"], f["m"], state.nl_ff.offsets, state.nl_ff.indices,
                     state.nl_fb.offsets, va, self.coefficient, y_coeff, L, diam, n_full23,
                     state.dim, f["a"])
