"""XSPH velocity smoothing as an artificial viscosity (survey Sec. 5.1).

Monaghan 1989/1992 ("SPH", ARA&A 30, Eq. 4.1), in the force form SPlisHSPlasH's
``XSPH`` uses:

    a_i += (c / dt) sum_j (m_j / rho_j) (v_j - v_i) W_ij
         + (c_b / dt) sum_b (rho0 V_b / rho_i) (v_b - v_i) W_ib

with dimensionless smoothing factors c, c_b in [0, 1] (Macklin & Mueller 2013 use c = 0.01).
"""

from __future__ import annotations

from typing import Any

import numba

from sphkit.backend import launch
from sphkit.core.kernels import kernel_w
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import add_vector, delta, distance, pair_slots, point
from sphkit.core.state import SimState


@numba.njit(cache=True, fastmath=True, inline="always")
def xsph_body(i, x, v, m, rho, off, idx, bx, bv, bV, boff, bidx, c, cb, rho0, h, kid, dim, inv_dt,
              a):
    """Add the XSPH acceleration of fluid particle i to ``a[:, i]`` (a kernel body,
    :func:`sphkit.backend.launch`)."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi0, vi1, vi2 = point(v, i, dim)
    acc0 = acc1 = acc2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        s = (c * inv_dt * (m[j] / rho[j])
             * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, 0.0), h, dim))
        w0, w1, w2 = delta(vi0, vi1, vi2, v, j, dim, 0.0)  # v_i - v_j
        acc0 -= s * w0
        acc1 -= s * w1
        acc2 -= s * w2
    if cb > 0.0:
        for k in pair_slots(boff, i):
            b = bidx[k]
            s = (cb * inv_dt * (rho0 * bV[b] / rho[i])
                 * kernel_w(kid, distance(xi0, xi1, xi2, bx, b, dim, 0.0), h, dim))
            w0, w1, w2 = delta(vi0, vi1, vi2, bv, b, dim, 0.0)
            acc0 -= s * w0
            acc1 -= s * w1
            acc2 -= s * w2
    add_vector(a, i, dim, acc0, acc1, acc2)


class XSPH(NonPressureForce):
    """XSPH smoothing with factors ``c`` (fluid) and ``c_boundary`` (dimensionless, 0..1)."""

    name = "xsph"
    repeatable = True  #: apply adds to a only

    @classmethod
    def from_config(cls, p: Any) -> XSPH:
        """The XSPH of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.boundary_coefficient)

    def __init__(self, c: float, c_boundary: float = 0.0) -> None:
        if not (0 <= c <= 1 and 0 <= c_boundary <= 1):
            raise ValueError(f"xsph: factors {c!r}/{c_boundary!r}; expected values in [0, 1]")
        self.c = float(c)
        self.c_boundary = float(c_boundary)

    def apply(self, state: SimState, dt: float) -> None:
        """Add the XSPH acceleration to ``state.fluid['a']``."""
        f, b = state.fluid, state.boundary
        launch(xsph_body, f.n, f["x"], f["v"], f["m"], f["rho"], state.nl_ff.offsets,
               state.nl_ff.indices, b["x"], b["v"], b["V"], state.nl_fb.offsets,
               state.nl_fb.indices, self.c, self.c_boundary, state.rho0, state.h, state.kid,
               state.dim, 1.0 / dt, f["a"])
