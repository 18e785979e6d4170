"""Standard explicit viscosity (survey Sec. 5.1).

Morris, Fox & Zhu 1997, "Modeling low Reynolds number incompressible flows using SPH", J. Comput.
Phys. 136, with the vector Laplacian of Monaghan 2005 (Rep. Prog. Phys. 68, Eq. 6.xx) that
SPlisHSPlasH's ``Viscosity_Standard`` uses:

    a_i += 2 (d + 2) nu sum_j (m_j / rho_ij) (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2) grad W_ij

with kinematic viscosity nu [m^2/s] and ``rho_ij = (rho_i + rho_j) / 2`` (``0.01 h^2``: the
option ``eps`` times h^2, h the support radius; see
:data:`sphkit.core.viscous.LAPLACIAN_EPS`). SPlisHSPlasH uses
``m_j / rho_j``; the pair-averaged density makes the pair forces exactly antisymmetric, so linear
momentum is conserved to round-off (tested), and it equals ``m_j / rho_j`` at uniform density.
It is Galilean invariant, vanishes for rigid rotation and
conserves linear and angular momentum. Boundary particles (static or moving with velocity v_b)
contribute the same term with ``m_j / rho_j -> rho0 V_b / rho_i`` and their own ``nu_b``,
times the boundary field ``viscosity_factor`` (1 unless a box's ``viscosity_factors`` sets it
per face: e.g. friction on a floor only).

Wall velocity (``boundary_velocity``): ``zero`` (default, SPlisHSPlasH) uses the boundary
particle's own velocity v_b in ``v_ib``, which lets the fluid slip by a few particle spacings;
``morris1997`` gives it the velocity extrapolated antisymmetrically from the fluid particle
across the wall surface (Morris, Fox & Zhu 1997, no-slip walls, see
:func:`sphkit.core.viscous.morris_beta`): ``v_i - v_b -> beta (v_i - v_b)`` with
``beta = min(beta_max, 1 + d_b / d_i)``, d the distances to the wall surface (boundary fields
``wall_distance`` and ``wall_normal``, set for box walls; particles without a wall distance keep
beta = 1).

**Sub-steps** (``substeps``, default :data:`SUBSTEPS`): the explicit term is stable only below
Morris et al.'s diffusion condition ``dt <= 0.125 (2r)^2 / nu``
(:func:`sphkit.core.viscous.viscous_time_step`). A longer step is split into ``n =
ceil(dt / (SUBSTEP_SHARE condition))`` (at most ``substeps``) viscous sub-steps on the step's
positions and densities, ``v_{k+1} = v_k + (dt / n) a(v_k)``, and the step's viscous
acceleration is ``(v_n - v_0) / dt = (1 / n) sum_k a(v_k)``: explicit Euler of the diffusion at
dt / n inside the step, one pair pass per sub-step, where the step bound would take whole
steps. A sub-step is at most half the condition (:data:`SUBSTEP_SHARE`): at the condition the
term's shortest wave changes sign every (sub-)step (explicit Euler's factor about -0.8, the
largest eigenvalue measured), and a 3D block of nu = 0.1 m^2/s at rest on a floor threw
particles at 2.5 m/s with sub-steps at the condition, none with sub-steps at half of it
(validation/README.md, "The standard viscosity in sub-steps"). So the step is bound by
``substeps`` times half the condition (``substeps`` 1: by the condition), and at or below the
condition (n = 1) the term is the one of the formula above, unchanged. (SPlisHSPlasH applies
the term once per step without a bound.)

Where the step has cached pair gradients ``V_j grad W_ij`` (the pressure solvers that iterate on
them, :class:`sphkit.core.solver.PairGradients`), the fluid pairs take ``W'(r) / r`` from them
(:func:`standard_body` with ``cached``: the same term, no kernel evaluation in the pair loop).
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.backend import launch, specialize, to_host
from sphkit.core import arrays
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import add_vector, delta, delta2, dot, pair_slots, point
from sphkit.core.ppe import GATHER_FASTMATH
from sphkit.core.state import SimState
from sphkit.core.viscous import (
    LAPLACIAN_EPS,
    MORRIS_BETA_MAX,
    check_wall_options,
    laplacian_pair,
    register_wall_fields,
    viscous_time_step,
    wall_pair,
)


@numba.njit(cache=True, fastmath=True, inline="always")
def _wall_term(xi0, xi1, xi2, vi0, vi1, vi2, ri, bx, bv, bV, bn, bd, bf, boff, bidx, i, nub,
               beta_max, eps, c, rho0, h, kid, dim, L):
    """The boundary particles' share of particle i's viscous acceleration (the wall term of the
    module docstring; 0 when ``nub`` is 0)."""
    acc0 = acc1 = acc2 = 0.0
    if nub > 0.0:
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2, r2, beta = wall_pair(xi0, xi1, xi2, bx, b, bn, bd, beta_max, dim, L)
            w0, w1, w2 = delta(vi0, vi1, vi2, bv, b, dim, 0.0)
            s = (c * nub * bf[b] * (rho0 * bV[b] / ri) * beta
                 * laplacian_pair(kid, w0, w1, w2, d0, d1, d2, r2, eps, h, dim, 1.0))
            acc0 += s * d0
            acc1 += s * d1
            acc2 += s * d2
    return acc0, acc1, acc2


@numba.njit(cache=True, fastmath=True, inline="always")
def standard_body(i, x, v, m, rho0j, rho, off, idx, gw, cached, bx, bv, bV, bn, bd, bf, boff,
                  bidx, nu, nub, beta_max, epsf, rho0, h, kid, dim, L, a):
    """Add the viscous acceleration of fluid particle i to ``a[:, i]`` (a kernel body,
    :func:`sphkit.backend.launch`). Coordinates are hoisted into scalars and the dim branches
    are loop invariant: this form runs about twice as fast as loops over d (measured), and
    stays dimension-generic.

    ``cached`` (compiled in): the fluid pairs' ``W'(r) / r`` comes from the step's cached pair
    gradients ``gw = V_j grad W_ij`` (``V_j = m_j / rho0_j``, so ``m_j W'(r) / r x_ij =
    rho0_j gw_ij``; ``rho0j``: the fluid's rest densities), the same term without the kernel
    and the square root in the pair loop; else the kernel is evaluated (m: the masses)."""
    eps = epsf * h * h
    c = 2.0 * (dim + 2)
    acc0 = acc1 = acc2 = 0.0
    xi0, xi1, xi2 = point(x, i, dim)
    vi0, vi1, vi2 = point(v, i, dim)
    ri = rho[i]
    cn = 2.0 * c * nu
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, w0, w1, w2 = delta2(xi0, xi1, xi2, x, vi0, vi1, vi2, v, j, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        if cached:
            s = cn * rho0j[j] * dot(w0, w1, w2, d0, d1, d2) / ((r2 + eps) * (ri + rho[j]))
            acc0 += s * gw[0, k]
            if dim > 1:
                acc1 += s * gw[1, k]
            if dim > 2:
                acc2 += s * gw[2, k]
        else:
            # c nu (2 m_j / (rho_i + rho_j)) times the Laplacian's pair factor
            s = cn * m[j] * laplacian_pair(kid, w0, w1, w2, d0, d1, d2, r2, eps, h, dim,
                                           ri + rho[j])
            acc0 += s * d0
            acc1 += s * d1
            acc2 += s * d2
    b0, b1, b2 = _wall_term(xi0, xi1, xi2, vi0, vi1, vi2, ri, bx, bv, bV, bn, bd, bf, boff, bidx,
                            i, nub, beta_max, eps, c, rho0, h, kid, dim, L)
    add_vector(a, i, dim, acc0 + b0, acc1 + b1, acc2 + b2)


#: the kernel and the cached gradients' switch compiled in (a branch left in the pair loop
#: would keep the kernel path from vectorising, as PBF's switch did: ``backend.specialize``);
#: the cached path without reassociation: vectorised, its gathers of the neighbours' positions,
#: velocities and densities made it 1.2-1.3 times slower than the scalar loop (59,319 and
#: 6,859 particles, two threads), while the kernel path is 1.5 times faster vectorised
specialize(standard_body, "kid", "cached", fastmath_when={"cached": set(GATHER_FASTMATH)})

#: default largest number of viscous sub-steps of a time step (module docstring, "Sub-steps")
SUBSTEPS = 8
#: the longest sub-step as a share of Morris' condition (module docstring, "Sub-steps")
SUBSTEP_SHARE = 0.5


class StandardViscosity(NonPressureForce):
    """Explicit Morris/Monaghan viscosity; ``nu`` and ``nu_boundary`` are kinematic [m^2/s].

    ``boundary_velocity``: ``"zero"`` (the wall particles' own velocity, SPlisHSPlasH) or
    ``"morris1997"`` (no-slip extrapolation, bounded by ``beta_max``, Morris' 1.5 by default).
    ``substeps``: the largest number of explicit sub-steps a time step is split into (module
    docstring; 1: the step stays within the diffusion condition).
    """

    name = "standard"
    repeatable = True  #: apply adds to a only

    @classmethod
    def from_config(cls, p: Any) -> StandardViscosity:
        """The StandardViscosity of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.boundary_coefficient, p.boundary_velocity, p.morris_beta_max,
                   p.laplacian_eps, p.substeps)

    def __init__(self, nu: float, nu_boundary: float = 0.0, boundary_velocity: str = "zero",
                 beta_max: float = MORRIS_BETA_MAX, eps: float = LAPLACIAN_EPS,
                 substeps: int = SUBSTEPS) -> None:
        if nu < 0 or nu_boundary < 0:
            raise ValueError(f"viscosity: {nu!r}/{nu_boundary!r}; expected non-negative values")
        if not (isinstance(substeps, int | np.integer) and substeps >= 1):
            raise ValueError(f"viscosity: substeps {substeps!r}; expected an integer >= 1")
        self.substeps = int(substeps)
        check_wall_options(boundary_velocity, beta_max, eps)
        self.eps = float(eps)
        self.nu = float(nu)
        self.nu_boundary = float(nu_boundary)
        self.boundary_velocity = boundary_velocity
        self.beta_max = float(beta_max) if boundary_velocity == "morris1997" else 0.0
        self.factor_max = 1.0  # the largest boundary viscosity_factor (init)

    def init(self, state: SimState) -> None:
        """Make sure the boundary carries the wall fields of the Morris wall velocity; note the
        largest per-wall factor on the wall term (``boxes[].viscosity_factors``)."""
        b = state.boundary
        register_wall_fields(b)
        self.factor_max = float(to_host(b["viscosity_factor"]).max()) if b.n else 1.0

    def diffusion_bound(self, state: SimState) -> float:
        """The explicit diffusion condition of Morris et al. 1997 [s] for the larger of the
        fluid's and the walls' viscosity (the walls' times the no-slip extrapolation's beta_max
        and the largest per-wall factor): the longest stable (sub-)step."""
        nu_b = self.nu_boundary * max(self.beta_max, 1.0) * self.factor_max
        return viscous_time_step(max(self.nu, nu_b), state.r)

    def max_time_step(self, state: SimState) -> float:
        """``substeps`` times the longest sub-step, half the diffusion condition (with
        ``substeps`` 1: the condition; module docstring, "Sub-steps")."""
        bound = self.diffusion_bound(state)
        return bound if self.substeps == 1 else self.substeps * SUBSTEP_SHARE * bound

    def substeps_of(self, state: SimState, dt: float) -> int:
        """The viscous sub-steps of a step dt: 1 within the diffusion condition, else
        ``ceil(dt / (SUBSTEP_SHARE condition))``, at most ``substeps``."""
        bound = self.diffusion_bound(state)
        if not dt > bound:
            return 1
        return min(self.substeps, math.ceil(dt / (SUBSTEP_SHARE * bound) * (1.0 - 1e-12)))

    def apply(self, state: SimState, dt: float) -> None:
        """Add the viscous acceleration to ``state.fluid['a']``, in sub-steps where dt exceeds
        the diffusion condition (module docstring)."""
        f = state.fluid
        n = self.substeps_of(state, dt)
        if n == 1:
            self._accelerate(state, f["v"], f["a"])
            return
        total = arrays.zeros(f["a"].shape, f["a"].dtype, like=f["a"])  # sum_k a(v_k)
        v = f["v"]
        for k in range(n):
            self._accelerate(state, v, total)
            if k < n - 1:  # v_{k+1} = v_0 + (dt / n) sum_k a(v_k)
                v = arrays.axpy_into(f["v"], dt / n, total)
        arrays.axpy(f["a"], 1.0 / n, total)

    def _accelerate(self, state: SimState, v: Any, a: Any) -> None:
        """Add the viscous acceleration of the fluid velocities v to a (both (dim, N))."""
        f, b = state.fluid, state.boundary
        register_wall_fields(b)
        walls = (b["x"], b["v"], b["V"], b["wall_normal"], b["wall_distance"],
                 b["viscosity_factor"], state.nl_fb.offsets, state.nl_fb.indices, self.nu,
                 self.nu_boundary, self.beta_max, self.eps, state.rho0, state.h, state.kid,
                 state.dim, state.pair_period, a)
        g = state.pair_grads  # the step's cached V_j grad W_ij (a solver that iterates on them)
        gw = g.gw if g is not None else arrays.empty((state.dim, 0), f.dtype, like=f["x"])
        launch(standard_body, f.n, f["x"], v, f["m"], f["rho0"], f["rho"],
               state.nl_ff.offsets, state.nl_ff.indices, gw, g is not None, *walls)
