"""Air drag of Macklin, Mueller, Chentanez, Kim 2014 (survey Sec. 5.5, SPlisHSPlasH
``dragMethod`` 1).

Macklin, Mueller, Chentanez, Kim 2014, "Unified particle physics for real-time applications",
ACM TOG 33(4):153 (fluids: a drag force on particles at the free surface, weighted by the
density deficit as a cheap surface indicator), as SPlisHSPlasH implements it
(``SPlisHSPlasH/Drag/DragForce_Macklin2014.cpp``)::

    a_i += -(k / m_i) (v_i - v_air) max(0, 1 - rho_i / rho0)

The weight ``1 - rho_i/rho0`` is zero in a full neighbourhood and grows towards the surface
(about 1/2 on a flat surface), so only surface particles feel the air, always against their
velocity relative to the air.

Differences from SPlisHSPlasH: the weight is clamped at 0 (SPlisHSPlasH multiplies by
``1 - rho_i/rho0`` unclamped, so a compressed interior particle, rho_i > rho0, is pushed *along*
its velocity); the air velocity ``v_air`` is a parameter (SPlisHSPlasH: 0).

Units: ``k`` [kg/s] (``k v / m`` is an acceleration). Default (SPlisHSPlasH ``drag``) 0.01.
"""

from __future__ import annotations

import numba

from sphkit.core.state import SimState
from sphkit.drag.base import AirDrag


@numba.njit(parallel=True, cache=True, fastmath=True)
def _macklin_cpu(v, m, rho, k, rho0, va, dim, a):
    for i in numba.prange(v.shape[1]):
        w = 1.0 - rho[i] / rho0
        if w > 0.0:
            c = k / m[i] * w
            for d in range(dim):
                a[d, i] -= c * (v[d, i] - va[d])


class Macklin2014(AirDrag):
    """Density-deficit air drag of Macklin et al. 2014 (SPlisHSPlasH "Macklin et al. 2014").

    ``coefficient``: k [kg/s]; ``air_velocity``: velocity of the surrounding air [m/s]
    (default at rest).
    """

    name = "macklin2014"
    repeatable = True  #: apply adds to a only
    unit = "[kg/s]"

    def apply(self, state: SimState, dt: float) -> None:
        """Add the drag acceleration to ``state.fluid['a']``."""
        f = state.fluid
        if f.n == 0:
            return
        va = self.air(state.dim)
        _macklin_cpu(f["v"], f["m"], f["rho"], self.coefficient, state.rho0, va, state.dim,
                     f["a"])
