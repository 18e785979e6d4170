"""A consistent start: density relaxation of sampled fluid and the masses of its target density.

Fluid sampled on a lattice is at rest density in its interior (its volume is the lattice's,
README "mass of lattice-sampled fluid"), but not where a wall's boundary contribution overlaps a
full fluid neighbourhood: a block written up to the walls (SPlisHSPlasH's scenes place the first
particle 2r off the wall surface) starts 7 % (Akinci particles), 6 % (density maps) and 29 %
(2D) to 100 % (3D) (volume maps) too dense next to them. Two passes make the start consistent
with the summation density :func:`sphkit.core.operators.density_body` that every solver uses
(:mod:`sphkit.world.startup` runs them once, before the first step):

* :func:`relax_pass` -- one Jacobi sweep of the position projection of Macklin & Mueller 2013
  ("Position based fluids", ACM TOG 32(4), Eq. 8-12) on the clamped density constraint
  ``C_i = max(rho_hat_i / t_i - 1, 0)`` (``rho_hat = sum_j V_j W_ij + sum_b V_b W_ib`` with
  ``V = m / rho0``, target ``t_i``: 1, or the hydrostatic compression): ``lambda_i = -C_i /
  (sum_k |grad_k C_i|^2 + eps)``, ``dx_i = sum_j (lambda_i + lambda_j) V_j grad W_ij + lambda_i
  sum_b V_b grad W_ib``, each displacement capped. There is no time and no velocity: it moves
  the particles that sit in a wall's range out of it, into the space the boundary model leaves
  for the fluid; particles at or below their target are not pulled (a free surface, and the
  thin spots the sweeps leave, which the masses fill). A two-sided constraint, which would
  pull them, makes these Jacobi sweeps oscillate.
* :func:`mass_pass` -- one fixed-point sweep ``m_i <- min(m_cap_i, m_i t_i rho0_i / rho_i)`` of
  the masses whose summation density is the target, below a cap per particle: the lattice mass
  times the target compression for a kernel-truncated free surface (which keeps that mass and
  its density deficit), a few per cent above it where the kernel is filled.

The sweeps are :mod:`sphkit.core.projection`'s pair loops, PBF's own (with the target and a
period L > 0 along x).
"""

from __future__ import annotations

import numba
import numpy as np

from sphkit.core.pairs import period_arg
from sphkit.core.projection import constraint_correction, constraint_lambda

_JIT = dict(cache=True, fastmath=True)
#: constraint-force mixing of the projection [1/m^2] (PBF's epsilon, SPlisHSPlasH's 1e-6)
EPSILON = 1e-6


def relax_pass(x: np.ndarray, V: np.ndarray, target: np.ndarray, nl_ff, nl_fb,
               bx: np.ndarray, bV: np.ndarray, h: float, kid: int, dim: int, L: float,
               cap: float, tol: float = 1e-9) -> tuple[float, float, np.ndarray]:
    """One position-projection sweep (module docstring) at the positions x (dim, N) with the
    rest volumes V = m / rho0 (N,), targets (N,) and this state's neighbour lists; the
    boundary (bx, bV) does not move. Returns (mean, max) of the clamped constraint ``C``
    before the sweep (as fractions) and the displacement (dim, N), each at most ``cap`` [m]
    long; constraints up to ``tol`` count as met (the interior of a lattice sits at its target
    to round-off)."""
    n = x.shape[1]
    lam = np.empty(n, dtype=x.dtype)
    rho_hat = np.empty(n, dtype=x.dtype)
    dx = np.zeros_like(x)
    avg, mx = constraint_lambda(x, V, target, nl_ff.offsets, nl_ff.indices, bx, bV,
                                nl_fb.offsets, nl_fb.indices, float(h), int(kid), int(dim),
                                period_arg(L), EPSILON, float(tol), lam, rho_hat)
    if mx > 0.0:
        out = np.empty_like(x)
        # a geometric relaxation: lambdas unweighted (no rest-density ratios)
        constraint_correction(x, V, lam, nl_ff.offsets, nl_ff.indices, bx, bV,
                              nl_fb.offsets, nl_fb.indices, float(h), int(kid), int(dim),
                              period_arg(L), False, 0.0, 0.0, 1.0, 0.0, out)
        a = np.sqrt((out * out).sum(axis=0))
        dx = out * np.where(a > cap, cap / np.where(a > 0.0, a, 1.0), 1.0)
    return float(avg), float(mx), dx


@numba.njit(parallel=True, **_JIT)
def _masses(m, cap, target_rho, rho, tol):
    err = 0.0
    for i in numba.prange(m.shape[0]):
        e = rho[i] / target_rho[i] - 1.0
        # off the fixed point: away from the target, unless capped below it
        if e > tol or (e < -tol and m[i] < cap[i]):
            err = max(err, abs(e))
            m[i] = min(cap[i], m[i] * target_rho[i] / rho[i])
    return err


def mass_pass(m: np.ndarray, cap: np.ndarray, target_rho: np.ndarray, rho: np.ndarray,
              tol: float = 1e-9) -> float:
    """One fixed-point sweep of the masses (module docstring), in place: ``m_i <- min(cap_i,
    m_i target_i / rho_i)`` with rho the summation densities of the current masses. Returns the
    largest relative deviation ``|rho / target - 1|`` of the particles not yet on the fixed
    point (those off their target by more than ``tol``, unless at their cap and below it)."""
    return float(_masses(m, cap, target_rho, rho, float(tol)))
