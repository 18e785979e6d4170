"""Interface tension between phases (scene ``interfaces[].tension``, method ``hu2006``).

Hu & Adams 2006, "A multi-phase SPH method for macroscopic and mesoscopic flows", J. Comput.
Phys. 213, Sec. 2.3 (Eqs. 12-16): the interface tension as the divergence of a surface
stress built from the gradient of the colour function (continuum surface stress, Lafaurie et
al. 1994), discretised so that the pair forces are antisymmetric. One change, below: the full
capillary stress instead of their traceless one.

Colour gradient of particle i (phase a) towards phase b (the indicator ``c^b``; difference
form, zero in the bulk of either phase, ``V_j = m_j / rho_j``)::

    g_i^b = sum_j V_j (c^b_j - c^b_i) grad_i W_ij = sum_{j in b} V_j grad_i W_ij

(for a particle of b it is the same field's gradient with the opposite sign, ``-g^a``; the
stress below is even in g). Surface stress of particle i, summed over the other phases b with
an interface tension ``sigma_ab`` [N/m]: the continuum surface stress of Lafaurie et al. 1994
(J. Comput. Phys. 113), ``sigma delta_s (I - n n)`` with ``delta_s = |g|`` (it integrates to 1
across the interface) and ``n = g / |g|``::

    Pi_i = sum_b sigma_ab (1 / |g_i^b|) (|g_i^b|^2 I - g_i^b (x) g_i^b)

and the acceleration (Hu & Adams, Eq. 16 with the pair volumes V_i^2, V_j^2 of their Eq. 7)::

    a_i += (1 / m_i) sum_j (V_i^2 Pi_i + V_j^2 Pi_j) . grad_i W_ij

over every fluid neighbour j (``Pi_j = 0`` in the bulk). The divergence of the stress is
``sigma kappa n delta_s`` (Brackbill et al. 1992's CSF force): the Laplace jump sigma kappa,
sigma / R for a 2D drop, 2 sigma / R in 3D.

Hu & Adams (Eq. 13) write ``|g|^2 I / d`` instead of ``|g|^2 I``: their stress is traceless and
differs from this one by the isotropic ``sigma (1 - 1/d) |g| I``, a pressure confined to the
interface band. It has no net jump (the 2D disc's force integral is the same to 1e-5), but the
pressure must drop by it inside the band, below the outer phase's, which the incompressible
solvers (p >= 0) cannot supply next to a free surface. Measured on an ellipse of aspect 2 in a
free square of the other phase (DFSPH, r = 5 mm, sigma = 1 N, nu = 0.01 m^2/s, dt 0.5 ms):
after 1 s its aspect was 1.24 with the full stress, 1.63 with the traceless one, and the
thinnest density among its particles (a gap opening at the interface) 0.76 and 0.60 rho0.
``traceless=True`` selects Hu & Adams' form (comparisons only; scenes run the full stress).

Properties: ``grad_i W_ij = -grad_j W_ji``, so the pair forces are antisymmetric and linear
momentum is conserved to round-off; a flat interface feels no net force; the stress is zero away
from interfaces, so a single phase is untouched. Walls are not a phase (no wall term: a contact
angle is not modelled). Explicit: the time step must resolve capillary waves, ``dt <
sqrt(rho dx^3 / (2 pi sigma))`` (Brackbill et al. 1992); it is not bounded by it.

Measured (tests/test_multiphase_interfaces.py, validation/README.md "Forces between phases"):
the force alone holds 0.94-0.97 sigma/R on sampled 2D discs of 6-10 spacings and 0.92-1.06
(2 sigma/R) on 3D balls of 3-4 spacings. Known limit: run with the incompressible solvers (p >=
0) a gap opens at the interface (the band's tangential tension is a negative stress along it;
Hu & Adams ran weakly compressible SPH with a background pressure) and a 2D drop's interior
pressure, sigma/R after 0.1 s, decays to a fifth of it by 1 s; an ellipse still relaxes.

Background pressure (``interfaces[].tension.background_pressure`` p_b, default 0): every
particle of a phase with an interface tension carries ``Pi - p_b I``, i.e. the pair force
``-(V_i^2 p_b + V_j^2 p_b) grad_i W_ij``, a repulsion that cancels in a full neighbourhood and
pushes particles into a gap (and, unopposed, out of a free surface; walls hold it through the
pressure solve). Hu & Adams ran weakly compressible SPH with a background pressure that keeps
the total pressure positive (against the tensile instability); with the clamped incompressible
solvers it is a force of its own, added to the tension's. Momentum is still conserved (the pair
form is antisymmetric). Restricted to the interface band (a nonzero colour gradient) it made
the gap worse: the step of p_b at the band's edge pushed particles out of the band (2D drop, p_b
= 50 Pa: lowest density of the drop 0.45 rho0 at 0.5 s instead of 0.73, no pressure jump left;
validation/README.md, "Forces between phases").

Several interfaces: one force holds the (P, P) table of ``sigma_ab`` over the materials of the
scene (0: none between those two), indexed by the particle field ``phase``; the stress (six
components per particle, xx yy zz xy xz yz) is a work array of the force, recomputed each step.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core.kernels import kernel_dw
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import add_vector, norm, pair_slots, point, separation
from sphkit.core.state import SimState
from sphkit.multiphase.phases import pair_table


@numba.njit(cache=True, fastmath=True, inline="always")
def surface_stress_body(i, x, m, rho, phase, off, idx, sigma, iso_share, h, kid, dim, L, S,
                        background=0.0):
    """Particle i's surface stress ``Pi_i`` (module docstring) into ``S[:, i]`` (xx, yy, zz,
    xy, xz, yz); ``sigma`` (P, P) interface tensions [N/m] by phase; ``iso_share`` the factor
    of ``|g|^2 I``: 1 (the full capillary stress) or 1 / dim (Hu & Adams' traceless one);
    ``background``: ``p_b``, subtracted from the diagonal of every particle of a phase with an
    interface tension."""
    xi0, xi1, xi2 = point(x, i, dim)
    pa = phase[i]
    s00 = s11 = s22 = s01 = s02 = s12 = 0.0
    band = False
    for b in range(sigma.shape[0]):
        sg = sigma[pa, b]
        if b == pa or sg == 0.0:
            continue
        band = True  # a phase with an interface tension: the background pressure applies
        g0 = g1 = g2 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            if phase[j] != b:
                continue
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = m[j] / rho[j] * kernel_dw(kid, r, h, dim)
            g0 += f * d0
            g1 += f * d1
            g2 += f * d2
        gn = norm(g0, g1, g2)
        if gn == 0.0:
            continue
        c = sg / gn
        iso = sg * gn * iso_share
        s00 += iso - c * g0 * g0
        s11 += iso - c * g1 * g1
        if dim > 2:
            s22 += iso - c * g2 * g2
        s01 -= c * g0 * g1
        s02 -= c * g0 * g2
        s12 -= c * g1 * g2
    if band:
        s00 -= background
        s11 -= background
        if dim > 2:
            s22 -= background
    S[0, i] = s00
    S[1, i] = s11
    S[2, i] = s22
    S[3, i] = s01
    S[4, i] = s02
    S[5, i] = s12


@numba.njit(cache=True, fastmath=True, inline="always")
def surface_stress_accel_body(i, x, m, rho, off, idx, S, h, kid, dim, L, a):
    """``a_i += (1 / m_i) sum_j (V_i^2 Pi_i + V_j^2 Pi_j) . grad_i W_ij`` (module docstring)."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi = m[i] / rho[i]
    vi2 = vi * vi
    p00, p11, p22 = vi2 * S[0, i], vi2 * S[1, i], vi2 * S[2, i]
    p01, p02, p12 = vi2 * S[3, i], vi2 * S[4, i], vi2 * S[5, i]
    acc0 = acc1 = acc2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        vj = m[j] / rho[j]
        vj2 = vj * vj
        t00 = p00 + vj2 * S[0, j]
        t11 = p11 + vj2 * S[1, j]
        t22 = p22 + vj2 * S[2, j]
        t01 = p01 + vj2 * S[3, j]
        t02 = p02 + vj2 * S[4, j]
        t12 = p12 + vj2 * S[5, j]
        if t00 == 0.0 and t11 == 0.0 and t22 == 0.0 and t01 == 0.0 and t02 == 0.0 \
                and t12 == 0.0:
            continue
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        f = kernel_dw(kid, r, h, dim)
        g0, g1, g2 = f * d0, f * d1, f * d2
        acc0 += t00 * g0 + t01 * g1 + t02 * g2
        acc1 += t01 * g0 + t11 * g1 + t12 * g2
        acc2 += t02 * g0 + t12 * g1 + t22 * g2
    mi = m[i]
    add_vector(a, i, dim, acc0 / mi, acc1 / mi, acc2 / mi)


class HuAdams2006(NonPressureForce):
    """Interface tension between unlike phases (module docstring).

    ``sigma``: (P, P) table of interface tensions [N/m] (2D: N) between the materials of the
    scene (symmetric, the diagonal unused), indexed by the fluid field ``phase``."""

    name = "hu2006"

    @classmethod
    def from_config(cls, config: Any) -> HuAdams2006:
        """The force of ``(sigma table, options)`` that the world builds from the scene's
        ``interfaces`` (:func:`sphkit.world.build_world`; no options of its own)."""
        sigma, options = config
        return cls(sigma, background_pressure=getattr(options, "background_pressure", 0.0))

    def __init__(self, sigma: Any, traceless: bool = False,
                 background_pressure: float = 0.0) -> None:
        self.sigma = pair_table(sigma, "interfaces[].tension.coefficient")
        #: p_b [Pa] of the phases with an interface tension (module docstring)
        self.background_pressure = float(background_pressure)
        #: Hu & Adams' traceless stress (``|g|^2 I / d``) instead of the full one (module
        #: docstring); for comparisons only, the scene always runs the full stress
        self.traceless = bool(traceless)
        self._S = np.zeros((6, 0))

    def stress(self, state: SimState) -> np.ndarray:
        """The surface stress ``Pi`` of every fluid particle, (6, N): xx, yy, zz, xy, xz, yz
        [N/m^(dim-1)] (needs this step's densities and neighbour lists)."""
        f = state.fluid
        if self._S.shape[1] != f.n or self._S.dtype != f["x"].dtype:
            self._S = np.zeros((6, f.n), dtype=f["x"].dtype)
        launch(surface_stress_body, f.n, f["x"], f["m"], f["rho"], f["phase"],
               state.nl_ff.offsets, state.nl_ff.indices, self.sigma,
               1.0 / state.dim if self.traceless else 1.0, float(state.h),
               int(state.kid), int(state.dim), float(state.period), self._S,
               self.background_pressure)
        return self._S

    def apply(self, state: SimState, dt: float) -> None:
        """Add the interface tension's acceleration to ``state.fluid['a']``."""
        f = state.fluid
        if f.n == 0:
            return
        S = self.stress(state)
        launch(surface_stress_accel_body, f.n, f["x"], f["m"], f["rho"], state.nl_ff.offsets,
               state.nl_ff.indices, S, float(state.h), int(state.kid), int(state.dim),
               float(state.period), f["a"])
