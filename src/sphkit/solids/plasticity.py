"""Plasticity of the corotated solids: von Mises (J2) yield with linear isotropic hardening.

Simo & Hughes 1998, "Computational Inelasticity" (Springer), Ch. 3, the radial return
algorithm of small-strain J2 flow theory (Box 3.1 there, here with isotropic hardening only,
no kinematic back stress), applied to the corotated small strain of
:mod:`sphkit.solids.corotation`: the strain ``eps = sym(R^T F) - I`` of a particle, measured in
its corotated frame, splits additively into an elastic and a plastic part, ``eps = eps_e +
eps_p``; the stress is Hooke's law of the elastic part, ``sigma = 2 mu eps_e + lambda tr(eps_e)
I``. The plastic strain is deviatoric (``tr eps_p = 0``: plastic flow keeps the volume), so
only the deviatoric stress ``s = 2 mu dev(eps - eps_p)`` yields. One step of the return
mapping, given the plastic strain ``eps_p,n`` and the equivalent plastic strain ``alpha_n``
(``d alpha = sqrt(2/3) |d eps_p|``) of the last step:

1. trial deviatoric stress ``s_tr = 2 mu (dev eps - eps_p,n)``; the yield function
   ``f_tr = |s_tr| - sqrt(2/3) (sigma_y + H alpha_n)`` (``|.|`` the Frobenius norm, so
   ``sqrt(3/2) |s|`` is the von Mises stress and the yield surface is "von Mises stress =
   sigma_y + H alpha": ``sigma_y`` the yield stress of uniaxial tension, ``H`` the linear
   hardening modulus, the slope of the uniaxial yield stress over the equivalent plastic
   strain);
2. ``f_tr <= 0``: elastic, nothing changes;
3. else the plastic multiplier ``dgamma = f_tr / (2 mu + 2 H / 3)``, the flow direction
   ``n = s_tr / |s_tr|``, and ``eps_p,n+1 = eps_p,n + dgamma n``, ``alpha_n+1 = alpha_n +
   sqrt(2/3) dgamma``; the deviatoric stress returns radially onto the grown yield surface,
   ``s = s_tr - 2 mu dgamma n``, ``sqrt(3/2) |s| = sigma_y + H alpha_n+1`` (exactly).

The models store ``eps_p`` in the corotated (rest) frame of each particle, so a rigid rotation
of a plastically deformed body leaves it unchanged. The update is explicit in time: each step
returns the strain of the step's start (becker2009; peer2018 and kugelstadt2021 then solve
their implicit elastic step with the plastic strain of that return held, an operator split).
Following O'Brien, Bargteil & Hodgins 2002 and Gerszewski, Bhattacharya & Bargteil 2009 (SPH
graphics' plastic solids), the plastic strain then simply shifts the elastic rest state; unlike
those papers there is no flow rate nor plastic strain cap (rate-independent J2 plasticity).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_JIT = dict(cache=True, fastmath=True)

#: sqrt(2/3), the factor between |eps_p| increments and the equivalent plastic strain
SQRT23 = math.sqrt(2.0 / 3.0)


@numba.njit(inline="always", **_JIT)
def radial_return(e00, e11, e22, e01, e02, e12, ep, ep_s, alpha, i, mu, yield_stress,
                  hardening):
    """One return mapping of particle ``i`` (module docstring): the total corotated strain
    ``e..`` (symmetric tensor components); its plastic strain ``ep[:, i]`` (diagonal 00, 11,
    22), ``ep_s[:, i]`` (01, 02, 12) and equivalent plastic strain ``alpha[i]`` are updated in
    place. Returns the elastic strain ``eps - eps_p`` (six components)."""
    p00, p11, p22 = ep[0, i], ep[1, i], ep[2, i]
    p01, p02, p12 = ep_s[0, i], ep_s[1, i], ep_s[2, i]
    m = (e00 + e11 + e22) / 3.0
    # trial deviatoric strain dev(eps) - eps_p (eps_p is deviatoric)
    d00, d11, d22 = e00 - m - p00, e11 - m - p11, e22 - m - p22
    d01, d02, d12 = e01 - p01, e02 - p02, e12 - p12
    nrm = math.sqrt(d00 * d00 + d11 * d11 + d22 * d22
                    + 2.0 * (d01 * d01 + d02 * d02 + d12 * d12))
    f = 2.0 * mu * nrm - SQRT23 * (yield_stress + hardening * alpha[i])
    if f > 0.0:
        dg = f / (2.0 * mu + 2.0 * hardening / 3.0)
        c = dg / nrm
        p00 += c * d00
        p11 += c * d11
        p22 += c * d22
        p01 += c * d01
        p02 += c * d02
        p12 += c * d12
        ep[0, i], ep[1, i], ep[2, i] = p00, p11, p22
        ep_s[0, i], ep_s[1, i], ep_s[2, i] = p01, p02, p12
        alpha[i] += SQRT23 * dg
    return e00 - p00, e11 - p11, e22 - p22, e01 - p01, e02 - p02, e12 - p12


@numba.njit(parallel=True, **_JIT)
def return_mapping(eps, ep, ep_s, alpha, mu, lam, yield_stress, hardening, sigma):
    """The return mapping of every column of ``eps`` (6, n: total strains 00, 11, 22, 01, 02,
    12) with the plastic state ``ep``, ``ep_s``, ``alpha`` (updated in place); the stresses
    after the return into ``sigma`` (6, n). The per-particle form of what the corotated passes
    call (tests, validation)."""
    for i in numba.prange(eps.shape[1]):
        a00, a11, a22, a01, a02, a12 = radial_return(
            eps[0, i], eps[1, i], eps[2, i], eps[3, i], eps[4, i], eps[5, i], ep, ep_s, alpha,
            i, mu, yield_stress, hardening)
        ltr = lam * (a00 + a11 + a22)
        sigma[0, i] = 2.0 * mu * a00 + ltr
        sigma[1, i] = 2.0 * mu * a11 + ltr
        sigma[2, i] = 2.0 * mu * a22 + ltr
        sigma[3, i] = 2.0 * mu * a01
        sigma[4, i] = 2.0 * mu * a02
        sigma[5, i] = 2.0 * mu * a12


def von_mises(sigma: np.ndarray) -> np.ndarray:
    """The von Mises stress of stresses ``sigma`` (6, n: 00, 11, 22, 01, 02, 12) [Pa]."""
    s00, s11, s22, s01, s02, s12 = sigma
    return np.sqrt(0.5 * ((s00 - s11) ** 2 + (s11 - s22) ** 2 + (s22 - s00) ** 2)
                   + 3.0 * (s01 ** 2 + s02 ** 2 + s12 ** 2))


#: the per-particle fields of a plastic solid (name -> kind): the plastic strain in the
#: particle's corotated frame, diagonal (00, 11, 22) and off-diagonal (01, 02, 12), and the
#: equivalent plastic strain (dimensionless)
FIELDS: dict[str, str] = {"solid_plastic": "vector3", "solid_plastic_shear": "vector3",
                          "solid_plastic_alpha": "scalar"}


def check_parameters(yield_stress: float | None, hardening: float) -> tuple[float, float]:
    """``(yield_stress, hardening)`` as floats (None: 0, purely elastic); a clear error naming
    the field when one is not a finite number >= 0."""
    ys = 0.0 if yield_stress is None else yield_stress
    for name, val in (("yield_stress", ys), ("hardening", hardening)):
        try:
            ok = math.isfinite(float(val)) and float(val) >= 0.0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ValueError(f"elasticity.{name}: {val!r}; expected a finite number >= 0 [Pa]"
                             + (" (0 or absent: purely elastic)" if name == "yield_stress"
                                else ""))
    return float(ys), float(hardening)
