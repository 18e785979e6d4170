"""Vorticity confinement (survey Sec. 5.3, SPlisHSPlasH ``vorticityMethod`` 2).

Fedkiw, Stam, Jensen 2001, "Visual simulation of smoke", SIGGRAPH 2001, for SPH as in Macklin &
Mueller 2013, "Position based fluids", ACM TOG 32(4):104, Eqs. 15-16, with SPlisHSPlasH's SPH
sums (``SPlisHSPlasH/Vorticity/VorticityConfinement.cpp``). Numerical dissipation damps vortices;
confinement puts the lost energy back by pushing the flow around the existing vortex cores:

1. vorticity (Eq. 15) ``omega_i = curl(v)_i = (1/rho_i) sum_j m_j v_ij x grad W_ij``
   (``v_ij = v_i - v_j``; a rigid rotation ``v = Omega x x`` gives ``2 Omega``, as
   :func:`sphkit.core.operators.curl`);
2. location vector ``eta_i = grad|omega|_i = (1/rho_i) sum_j m_j |omega_j| grad W_ij`` and
   ``N_i = eta_i / |eta_i|`` (pointing towards the vortex cores);
3. confinement acceleration (Eq. 16) ``a_i += epsilon (N_i x omega_i)``.

In 2D omega is the scalar ``omega_z`` and ``N x omega = omega_z (N_y, -N_x)``. No boundary terms
(SPlisHSPlasH has none either): the curl and eta sums run over fluid neighbours.

Difference from SPlisHSPlasH: it evaluates ``omega_i = -(1/rho_i) sum_j m_j v_ij x grad W_ij``,
i.e. minus the curl, and then adds ``epsilon eta_i x omega_i``, which turns the force against
the rotation (it decelerates a vortex instead of confining it). sphkit uses the sign of Macklin
& Mueller (Eq. 15, ``omega = curl v``) and Fedkiw et al., which speeds the flow up along the
rotation; tests/test_surface_drag_vorticity.py checks that the kinetic energy of a decaying
vortex stays higher with confinement than without. Macklin & Mueller also apply XSPH viscosity
after confinement; in sphkit that is the separate ``xsph`` viscosity model.

The force is not momentum conserving (survey: "fast and easy, amplifies only existing vortices,
not momentum conserving").

Units: ``epsilon`` [m/s] (``epsilon omega`` is an acceleration). Default (SPlisHSPlasH
``vorticity``) 0.01. The fluid field ``vorticity`` ('vector3', [1/s]) holds the last step's
omega (in 2D only the z row).
"""

from __future__ import annotations

import math
from typing import Any

import numba

from sphkit.core.kernels import kernel_dw
from sphkit.core.methods import NonPressureForce
from sphkit.core.operators import curl_sum
from sphkit.core.pairs import pair_slots, point, separation
from sphkit.core.state import SimState


@numba.njit(parallel=True, cache=True, fastmath=True)
def _vorticity_cpu(x, v, m, rho, off, idx, h, kid, dim, omega, norm):
    """``omega_i = curl(v)_i`` (:func:`sphkit.core.operators.curl_sum`) and ``norm_i =
    |omega_i|``."""
    for i in numba.prange(x.shape[1]):
        c0, c1, c2 = curl_sum(i, x, m, v, off, idx, h, kid, dim, 0.0)
        inv = 1.0 / rho[i]
        omega[0, i] = c0 * inv
        omega[1, i] = c1 * inv
        omega[2, i] = c2 * inv
        norm[i] = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) * inv


@numba.njit(inline="always", cache=True, fastmath=True)
def confinement_body(i, x, m, rho, omega, norm, off, idx, eps, h, kid, dim, a):
    """Add ``eps N_i x omega_i`` to ``a[:, i]`` (``N_i`` = unit gradient of ``|omega|``)."""
    xi0, xi1, xi2 = point(x, i, dim)
    e0 = e1 = e2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, 0.0)
        f = m[j] * norm[j] * kernel_dw(kid, r, h, dim)
        e0 += f * d0
        e1 += f * d1
        e2 += f * d2
    le = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if le == 0.0 or le <= 1.0e-9 * norm[i] / h:  # no |omega| gradient: N undefined
        return
    n0 = e0 / le
    n1 = e1 / le
    n2 = e2 / le
    w0 = omega[0, i]
    w1 = omega[1, i]
    w2 = omega[2, i]
    if dim == 3:
        a[0, i] += eps * (n1 * w2 - n2 * w1)
        a[1, i] += eps * (n2 * w0 - n0 * w2)
        a[2, i] += eps * (n0 * w1 - n1 * w0)
    else:
        a[0, i] += eps * n1 * w2
        a[1, i] -= eps * n0 * w2


@numba.njit(parallel=True, cache=True, fastmath=True)
def _confinement_cpu(x, m, rho, omega, norm, off, idx, eps, h, kid, dim, a):
    for i in numba.prange(x.shape[1]):
        confinement_body(i, x, m, rho, omega, norm, off, idx, eps, h, kid, dim, a)


class VorticityConfinement(NonPressureForce):
    """Vorticity confinement (Macklin & Mueller 2013, Eqs. 15-16; SPlisHSPlasH "Vorticity
    confinement"). ``coefficient``: epsilon [m/s]. Registers the fluid fields ``vorticity``
    ('vector3', [1/s]) and ``vorticity_norm`` ([1/s])."""

    name = "confinement"
    repeatable = True  #: apply adds to a (the vorticity fields it writes are made from x, v)

    @classmethod
    def from_config(cls, p: Any) -> VorticityConfinement:
        """The VorticityConfinement of a material's ``vorticity`` (scene model)."""
        return cls(p.coefficient)

    def __init__(self, coefficient: float = 0.01) -> None:
        eps = float(coefficient)
        if not (math.isfinite(eps) and eps >= 0.0):
            raise ValueError(f"vorticity confinement: coefficient {coefficient!r}; expected a "
                             "finite number >= 0 [m/s]")
        self.coefficient = eps

    def init(self, state: SimState) -> None:
        """Register ``vorticity`` and ``vorticity_norm`` on the fluid."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"vorticity confinement: dimension {state.dim}; expected 2 or 3 (a curl needs "
                "a plane)"
            )
        state.fluid.register("vorticity", "vector3")
        state.fluid.register("vorticity_norm")

    def apply(self, state: SimState, dt: float) -> None:
        """Compute the vorticity, then add the confinement acceleration to ``a``."""
        f = state.fluid
        if f.n == 0:
            return
        if "vorticity" not in f:
            self.init(state)
        nl = state.nl_ff
        _vorticity_cpu(f["x"], f["v"], f["m"], f["rho"], nl.offsets, nl.indices, state.h,
                       state.kid, state.dim, f["vorticity"], f["vorticity_norm"])
        _confinement_cpu(f["x"], f["m"], f["rho"], f["vorticity"], f["vorticity_norm"],
                         nl.offsets, nl.indices, self.coefficient, state.h, state.kid, state.dim,
                         f["a"])
