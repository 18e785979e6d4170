"""Micropolar vorticity model (survey Sec. 5.3, SPlisHSPlasH ``vorticityMethod`` 1).

Bender, Koschier, Kugelstadt, Weiler 2017, "A Micropolar Material Model for Turbulent SPH
Fluids", SCA 2017, extended in "Turbulent Micropolar SPH Fluids with Foam", IEEE TVCG 25(6),
2019, as SPlisHSPlasH implements it (``SPlisHSPlasH/Vorticity/MicropolarModel_Bender2017.cpp``).

Every fluid particle carries an angular velocity (microrotation) ``omega`` [1/s], registered as the
'vector3' field ``"omega"`` (three rows in 2D and 3D; in 2D only the z row is used). The model is
the micropolar fluid of Eringen/Lukaszewicz with the dissipative coupling terms left out
("inviscid, non-dissipative coupling"); per unit mass

    Dv/Dt     = ... + nu_t curl(omega)
    Domega/Dt = nu_t / Theta (curl(v) - 2 omega) + angular viscosity

with the vortex viscosity / transfer coefficient ``nu_t`` and the microinertia ``Theta`` (the
model's parameter is its inverse). The spin angular momentum of a particle is ``m_i Theta
omega_i``, so the total angular momentum is ``sum_i m_i (x_i x v_i + Theta omega_i)``; in the
continuum the two coupling terms exchange angular momentum (``int rho x x nu_t curl(omega) =
2 nu_t int rho omega`` against ``-2 nu_t int rho omega`` in the spin equation, up to surface
terms).

SPH discretization (difference curls, ``omega_ij = omega_i - omega_j``, ``v_ij = v_i - v_j``,
``grad W_ij = W'(r)/r (x_i - x_j)``; boundary particles b of Akinci et al. 2012 with mass
``psi_b = rho0 V_b``, velocity ``v_b`` and ``omega_b = 0``)::

    a_i     += nu_t / rho_i [ sum_j m_j omega_ij x grad W_ij + sum_b psi_b omega_i x grad W_ib ]
    alpha_i  = nu_t / (Theta rho_i) [ sum_j m_j v_ij x grad W_ij
                                      + sum_b psi_b (v_i - v_b) x grad W_ib ]
               - 2 nu_t / Theta omega_i
               - zeta / (Theta dt) sum_j (m_j / rho_j) omega_ij W_ij
    omega_i <- omega_i + dt alpha_i

The accelerations use ``omega`` at the start of the step; ``omega`` is advanced (explicit Euler)
after all of them are computed. ``(1/rho_i) sum_j m_j A_ij x grad W_ij`` is the SPH curl
(:func:`sphkit.core.operators.curl`; a rigid rotation ``v = Omega x x`` gives ``2 Omega``), so
the first line is ``nu_t curl(omega)`` and the bracket of the second ``curl(v)``. The last term of
``alpha`` is SPlisHSPlasH's angular viscosity: an XSPH filter on ``omega`` that blends each
``omega_i`` towards its neighbours' by the weight ``zeta / Theta`` per time step.

In 2D the velocity lies in the plane, ``omega = (0, 0, omega_z)``: ``curl(v)`` is the scalar
``(v_ij x grad W_ij)_z = v_ij,x g_y - v_ij,y g_x`` and ``omega x grad W = omega_z (-g_y, g_x)``
lies in the plane; one compiled function handles both dimensions (``if dim == 3`` branches).

Parameters and units (the units follow from the equations above; SPlisHSPlasH and its scenes
give plain numbers, read as SI):

* ``vorticity`` = ``nu_t`` [m^2/s] (``curl(omega)`` is in 1/(m s), so ``nu_t`` is a kinematic
  viscosity, not a dimensionless factor), SPlisHSPlasH default 0.01;
* ``inertia_inverse`` = ``1/Theta`` [1/m^2] (``Theta`` is a moment of inertia per unit mass),
  default 0.5; ``2 nu_t / Theta`` [1/s] is the rate at which ``omega`` relaxes to ``curl(v)/2``;
* ``viscosity_omega`` = ``zeta`` [m^2], default 0.1: ``zeta / Theta`` is the dimensionless XSPH
  weight per time step (kept below 1 for stability).

Stability of the explicit update needs ``2 nu_t dt / Theta < 2``; with SPlisHSPlasH's values it
is far below.

Differences from SPlisHSPlasH: only Akinci et al. 2012 boundary particles exist in sphkit, so the
density-map and volume-map boundary variants are absent; boundaries are static, so the reaction
``-m_i a_i`` on dynamic bodies is not applied; fluids are single-phase (SPlisHSPlasH sums over
same-phase neighbours only). As there, the boundary has ``omega_b = 0`` and takes no part in the
XSPH term. Angular momentum is not conserved exactly by this discretization: the difference curl
of a uniform ``omega`` vanishes at a free surface (the jump of ``omega`` to zero outside the fluid
is not seen), the spin source ``sum_i (m_i/rho_i) sum_j m_j v_ij x grad W_ij`` vanishes only for
full neighbourhoods, and the XSPH term is symmetric only where ``rho_i = rho_j``. In the interior
of a regular lattice the exchange balances up to the lattice error of ``sum_j V_j x_ij . grad
W_ij = -d`` (1.2% in 2D, 2.0% in 3D for the cubic spline at h = 4r); see tests/test_vorticity.py.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core import arrays
from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import pair_slots, point, separation
from sphkit.core.params import checked_number
from sphkit.core.state import SimState


@numba.njit(inline="always", cache=True, fastmath=True)
def micropolar_body(i, x, v, m, rho, omega, off, idx, bx, bv, bV, boff, bidx, nu_t, zeta,
                    inv_theta, inv_dt, rho0, h, kid, dim, a, alpha):
    """Particle i: add ``nu_t curl(omega)`` to ``a[:, i]`` and write ``alpha[:, i]`` (a kernel
    body, :func:`sphkit.backend.launch`; ``omega`` is advanced after every particle's pass)."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi0, vi1, vi2 = point(v, i, dim)
    wi0 = omega[0, i] if dim == 3 else 0.0
    wi1 = omega[1, i] if dim == 3 else 0.0
    wi2 = omega[2, i]
    # sums of m_j omega_ij x gradW, m_j v_ij x gradW, (m_j/rho_j) omega_ij W
    cw0 = cw1 = cw2 = 0.0
    cv0 = cv1 = cv2 = 0.0
    xs0 = xs1 = xs2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, 0.0)
        f = kernel_dw(kid, r, h, dim)
        g0 = f * d0
        g1 = f * d1
        mj = m[j]
        sw = mj / rho[j] * kernel_w(kid, r, h, dim)
        u0 = vi0 - v[0, j]
        u1 = vi1 - v[1, j]
        e2 = wi2 - omega[2, j]
        if dim == 3:
            g2 = f * d2
            u2 = vi2 - v[2, j]
            e0 = wi0 - omega[0, j]
            e1 = wi1 - omega[1, j]
            cw0 += mj * (e1 * g2 - e2 * g1)
            cw1 += mj * (e2 * g0 - e0 * g2)
            cw2 += mj * (e0 * g1 - e1 * g0)
            cv0 += mj * (u1 * g2 - u2 * g1)
            cv1 += mj * (u2 * g0 - u0 * g2)
            xs0 += sw * e0
            xs1 += sw * e1
        else:
            cw0 -= mj * e2 * g1
            cw1 += mj * e2 * g0
        cv2 += mj * (u0 * g1 - u1 * g0)
        xs2 += sw * e2
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, 0.0)
        f = kernel_dw(kid, r, h, dim)
        psi = rho0 * bV[b]
        g0 = f * d0
        g1 = f * d1
        u0 = vi0 - bv[0, b]
        u1 = vi1 - bv[1, b]
        if dim == 3:
            g2 = f * d2
            u2 = vi2 - bv[2, b]
            cw0 += psi * (wi1 * g2 - wi2 * g1)
            cw1 += psi * (wi2 * g0 - wi0 * g2)
            cw2 += psi * (wi0 * g1 - wi1 * g0)
            cv0 += psi * (u1 * g2 - u2 * g1)
            cv1 += psi * (u2 * g0 - u0 * g2)
        else:
            cw0 -= psi * wi2 * g1
            cw1 += psi * wi2 * g0
        cv2 += psi * (u0 * g1 - u1 * g0)
    c_lin = nu_t / rho[i]
    c_ang = c_lin * inv_theta
    c_xs = inv_dt * inv_theta * zeta
    c_rel = 2.0 * inv_theta * nu_t
    a[0, i] += c_lin * cw0
    a[1, i] += c_lin * cw1
    if dim == 3:
        a[2, i] += c_lin * cw2
        alpha[0, i] = c_ang * cv0 - c_xs * xs0 - c_rel * wi0
        alpha[1, i] = c_ang * cv1 - c_xs * xs1 - c_rel * wi1
    else:
        alpha[0, i] = 0.0
        alpha[1, i] = 0.0
    alpha[2, i] = c_ang * cv2 - c_xs * xs2 - c_rel * wi2


def _nonneg(name: str, value: float) -> float:
    return checked_number(f"micropolar model: {name}", value)


class MicropolarBender2017(NonPressureForce):
    """Micropolar vorticity model of Bender et al. 2017 (SPlisHSPlasH's "Micropolar model").

    ``vorticity``: transfer coefficient nu_t [m^2/s]; ``viscosity_omega``: angular viscosity
    zeta [m^2] (XSPH weight zeta/Theta per step); ``inertia_inverse``: 1/Theta [1/m^2].
    Fields: ``omega`` (angular velocity [1/s], 'vector3') and ``angular_acceleration`` ([1/s^2],
    'vector3', the last step's ``alpha``) of the fluid.
    """

    name = "micropolar"

    @classmethod
    def from_config(cls, p: Any) -> MicropolarBender2017:
        """The MicropolarBender2017 of a material's ``vorticity`` (scene model)."""
        return cls(p.coefficient, p.viscosity_omega, p.inertia_inverse)

    def __init__(self, vorticity: float = 0.01, viscosity_omega: float = 0.1,
                 inertia_inverse: float = 0.5) -> None:
        self.vorticity = _nonneg("vorticity", vorticity)
        self.viscosity_omega = _nonneg("viscosity_omega", viscosity_omega)
        self.inertia_inverse = _nonneg("inertia_inverse", inertia_inverse)

    def init(self, state: SimState) -> None:
        """Register ``omega`` (zero unless already set) and ``angular_acceleration``."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"micropolar model: dimension {state.dim}; expected 2 or 3 (a curl needs a plane)"
            )
        state.fluid.register("omega", "vector3")
        state.fluid.register("angular_acceleration", "vector3")
        bd = state.boundary
        if "V" not in bd:
            bd.register("V")
        if "v" not in bd:
            bd.register("v", "vector")

    def apply(self, state: SimState, dt: float) -> None:
        """Add ``nu_t curl(omega)`` to ``state.fluid['a']`` and advance ``omega`` by ``dt``."""
        f, b = state.fluid, state.boundary
        if f.n == 0:
            return
        if "omega" not in f:
            self.init(state)
        if not dt > 0.0:
            raise ValueError(f"micropolar model: time step {dt!r}; expected dt > 0")
        dt = float(dt)
        alpha = f["angular_acceleration"]
        launch(micropolar_body, f.n, f["x"], f["v"], f["m"], f["rho"], f["omega"],
               state.nl_ff.offsets, state.nl_ff.indices, b["x"], b["v"], b["V"],
               state.nl_fb.offsets, state.nl_fb.indices, self.vorticity, self.viscosity_omega,
               self.inertia_inverse, 1.0 / dt, state.rho0, state.h, state.kid, state.dim, f["a"],
               alpha)
        arrays.axpy(f["omega"], dt, alpha)  # omega += dt alpha (explicit Euler)

    def angular_momentum(self, state: SimState) -> np.ndarray:
        """Total angular momentum about the origin, ``sum_i m_i (x_i x v_i + Theta omega_i)``
        [kg m^2/s], as a 3-vector (in 2D only z is non-zero); ``Theta = 1/inertia_inverse``."""
        f = state.fluid
        m, x, v = f["m"], f["x"], f["v"]
        lin = np.zeros(3)
        if state.dim == 3:
            lin[:] = (m * np.cross(x.T, v.T).T).sum(axis=1)
        else:
            lin[2] = (m * (x[0] * v[1] - x[1] * v[0])).sum()
        if self.inertia_inverse > 0.0 and "omega" in f:
            lin += (m * f["omega"]).sum(axis=1) / self.inertia_inverse
        return lin
