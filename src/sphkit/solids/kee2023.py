"""Hyperelastic SPH solids by optimisation (SPlisHSPlasH ``elasticityMethod`` 4).

Kee, Um, Kang & Han 2023, "An Optimization-based SPH Solver for Simulation of Hyperelastic
Solids", Computer Graphics Forum 42(2): 225-233 (Eurographics 2023), as SPlisHSPlasH's
``Elasticity_Kee2023.cpp`` implements it (PR #372, pysplishsplash 2.19; ``reference/methods.md``
N4; the paper's text was not at hand, so the formulas here follow SPlisHSPlasH's code and carry
no equation numbers of the paper). Backward Euler written as a minimisation (an "optimization
time integrator"): the end-of-step positions of the solid are

    x' = argmin E(x),  E(x) = 1/2 |x - x~|_M^2 + dt^2 [ sum_i V0_i Psi(F_i(x)) + U_z(x) ]

with ``x~ = x + dt (v + dt a)`` (``a``: the other accelerations of the stage: gravity,
viscosity, ...), a total Lagrangian deformation gradient ``F_i = I + sum_j (u_j - u_i) G_ij^T``
(``u = x - x0``; the weights ``G_ij`` of :mod:`sphkit.solids.gradients`: SPlisHSPlasH takes the
kernel-gradient-corrected ones, ``V0_j L_i grad W(x0_i - x0_j)``,
``gradient_correction="linear"``; sphkit's default is the quadratic fit) and an isotropic energy
density ``Psi(F)`` (``material_model``):

* ``corotated`` (SPlisHSPlasH's default): ``Psi = mu |F - R|^2 + lambda/2 (tr(R^T F) - 3)^2``,
  R the rotation of F's polar decomposition (signed SVD); in small strains Hooke's law
  ``sigma = 2 mu eps + lambda tr(eps) I``, the model of the corotated solids;
* ``stable_neo_hookean`` (Smith, de Goes & Kim 2018, "Stable Neo-Hookean Flesh Simulation",
  Eq. 14): ``Psi = mu'/2 (I_C - 3) + lambda'/2 (J - a)^2 - mu'/2 log(I_C + 1)``,
  ``a = 1 + 3 mu' / (4 lambda')``, stable under inversion. Its small-strain shear modulus is
  ``3 mu'/4`` and its Lamé lambda ``lambda' - 5 mu'/8``, so sphkit sets ``mu' = 4 mu / 3``,
  ``lambda' = lambda + 5 mu / 6`` (Smith et al. 2018, Sec. 3.4), which makes E and nu mean
  what they mean for the other models. SPlisHSPlasH passes mu and lambda unchanged: its
  neo-Hookean material is 25 % softer in shear than its E and nu say.

The first Piola-Kirchhoff stress is ``P = U diag(dPsi/dsigma) V^T``; the elastic force is the
gradient of the discrete energy, ``f_i = sum_j (V0_i P_i G_ij - V0_j P_j G_ji)`` (the pass of
:mod:`sphkit.solids.corotation` with ``P`` in place of ``R sigma``; SPlisHSPlasH's
``-V_i sum_j V_j (P_i L_i + P_j L_j) grad W_ij``). The energy is invariant under translations
and rotations of x, so its forces have no net force and no torque at any state (to round-off,
tests/test_solids_kee2023.py): the step keeps linear momentum, and changes angular momentum
only by backward Euler's own ``dt sum m v' x v``, to the minimisation's tolerance. This needs
symmetric rest lists, which :mod:`sphkit.solids.rest` keeps with ``max_neighbors`` too (the
SPlisHSPlasH pull request that added the method found its one-sided caps broke the
conservation and symmetrised them by adding the missing reverse pairs; sphkit keeps the mutual
pairs).

Zero-energy modes (``alpha``): the quadratic term ``U_z = alpha mu / 2 sum_(i,j) V0_i V0_j
W(x0_ij) / |x0_ij|^2 |x_ij - F_i x0_ij|^2`` (SPlisHSPlasH's ``H^T K H``, Kugelstadt et al.
2021's implicit control with ``mu`` for E), a constant matrix (:mod:`sphkit.solids.operators`).

Solvers (``solver``), each iteration stopping when no particle moves by more than
``max_position_change`` [m] (maxError) or after ``max_iterations`` (maxIterations):

* ``newton``: projected Newton, ``(M + dt^2 (K + Z)) dx = -grad E``, K the Hessian of the
  elastic energy with each particle's 9 x 9 ``d^2 Psi / dF^2`` projected to its positive
  part through the analytic eigensystem of an isotropic energy (scaling modes from the 3 x 3
  Hessian in the singular values, twist and flip modes with eigenvalues
  ``(psi_a +- psi_b) / (sigma_a +- sigma_b)``; Smith et al. 2019, "Analytic eigensystems for
  isotropic distortion energies"); solved matrix-free by the shared CG
  (:func:`sphkit.core.krylov.cg`, ``cg_max_iterations``/``cg_tolerance``: maxIterationsCG,
  tolCG) with SPlisHSPlasH's 3 x 3 block-Jacobi preconditioner. SPlisHSPlasH projects the
  terms of the Hessian one by one (and drops the volume term's curvature in the corotated
  model); the minimiser is the same, the number of iterations to reach it may differ (not
  compared);
* ``lbfgs`` (SPlisHSPlasH's default): L-BFGS (window ``lbfgs_window``, lbfgsWindowSize)
  whose initial Hessian is the constant ``M + dt^2 ((2 mu + lambda) sum_c D_c^T V0 D_c + Z)``
  (one scalar matrix per material, factorised once per time step by scipy's sparse LU, as
  :mod:`sphkit.solids.kugelstadt2021`; SPlisHSPlasH: a sparse Cholesky), the history cleared
  every step. Far from a bent beam's Hessian: a cantilever's static sag takes it its 100
  iterations a step.

Accuracy (validation/README.md, "kee2023"): converged, the model gives the cantilever numbers
of :mod:`sphkit.solids.becker2009` and :mod:`sphkit.solids.peer2018` on the same
discretisation (clamped plate's first mode -9.5 % at 4 layers, 3D sag +18.1 %) for both
energies; SPlisHSPlasH's stopping test (1e-6 m) leaves L-BFGS under-converged on the slow
plate (-13.0 %).

Both take a backtracking Armijo line search when ``line_search`` (useLineSearch: parameter
``armijo`` c1 = lsArmijoParam, step factor ``line_search_beta`` = lsBeta, at most
``line_search_iterations`` = maxLSIterations); a search that fails ends the step's iteration.

Pinned particles (``fixed_boxes``; SPlisHSPlasH: fixedBoxMin/Max and fixedBox2Min/Max) are
kinematic, as SPlisHSPlasH's ``Fixed`` particles: they leave the solve and move with their
own velocity, ``x' = x + dt v``, which is zero unless an animation field sets it (the twisted
beam of ``Beam_Kee23_validation.json`` turns one end this way; the other elasticity models put
their pinned particles back at rest). The solid's acceleration of the stage becomes
``(v' - v) / dt`` with ``v' = (x' - x) / dt``; the pressure solver then acts on the result. No
time-step bound of its own.
"""

from __future__ import annotations

import logging
import math
from typing import Any, ClassVar

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from sphkit.core.krylov import KrylovStats, cg
from sphkit.core.state import SimState
from sphkit.solids.base import ImplicitCorotatedSolid
from sphkit.solids.corotation import forces, lame
from sphkit.solids.hyperelastic import (
    MATERIAL_MODELS,
    block_apply,
    block_jacobi,
    gradients,
    hessian_apply,
    material,
)
from sphkit.solids.operators import (
    gradient_laplacian,
    gradient_operators,
    zero_energy_operator,
)

log = logging.getLogger("sphkit")

_JIT = dict(cache=True, fastmath=True)

SOLVERS = ("newton", "lbfgs")


@numba.njit(parallel=True, **_JIT)
def _kinematic(x, v, pos, fixed, tx, tv, dim):
    """Pinned particles at their kinematic targets: ``x = tx``, ``v = tv`` (slot columns)."""
    for q in numba.prange(fixed.shape[0]):
        s = fixed[q]
        i = pos[s]
        for d in range(dim):
            x[d, i] = tx[d, s]
            v[d, i] = tv[d, s]


class Kee2023(ImplicitCorotatedSolid):
    """Hyperelastic SPH solid, backward Euler as a minimisation (module docstring)."""

    name: ClassVar[str] = "kee2023"

    @classmethod
    def from_config(cls, config: Any) -> Kee2023:
        """From a material's ``elasticity`` (as :class:`ImplicitCorotatedSolid`, plus
        ``solver``, ``material_model``, ``max_position_change``, ``cg_max_iterations``,
        ``cg_tolerance``, ``lbfgs_window``, ``line_search``, ``line_search_iterations``,
        ``armijo``, ``line_search_beta``)."""
        out = super().from_config(config)
        out.configure(solver=config.solver, material_model=config.material_model,
                      max_position_change=config.max_position_change,
                      cg_max_iterations=config.cg_max_iterations,
                      cg_tolerance=config.cg_tolerance, lbfgs_window=config.lbfgs_window,
                      line_search=config.line_search,
                      line_search_iterations=config.line_search_iterations,
                      armijo=config.armijo, line_search_beta=config.line_search_beta)
        return out

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.configure()
        self.D: list[sp.csr_matrix] = []
        self.Z = sp.csr_matrix((0, 0))  #: alpha mu Z^T W Z (scalar, n x n)
        self.Klap = sp.csr_matrix((0, 0))  #: sum_c D_c^T V0 D_c
        self._lu: Any = None
        self._dt = -1.0
        self._free = np.zeros(0, np.int64)
        self._target_x = np.zeros((3, 0))
        self._target_v = np.zeros((3, 0))
        #: the last step's solve: outer iterations, CG iterations, line-search trials,
        #: largest position change of the last iteration [m], energy decrease
        self.solve_stats: dict[str, float] = {}

    def configure(self, solver: str = "lbfgs", material_model: str = "corotated",
                  max_position_change: float = 1e-6, cg_max_iterations: int = 100,
                  cg_tolerance: float = 1e-4, lbfgs_window: int = 5, line_search: bool = True,
                  line_search_iterations: int = 20, armijo: float = 1e-4,
                  line_search_beta: float = 0.5) -> None:
        """Set the solver's parameters (SPlisHSPlasH's defaults; see the module docstring)."""
        if solver not in SOLVERS:
            raise ValueError(f"elasticity.solver: {solver!r}; expected one of {SOLVERS}")
        if material_model not in MATERIAL_MODELS:
            raise ValueError(f"elasticity.material_model: {material_model!r}; expected one of "
                             f"{tuple(MATERIAL_MODELS)}")
        if not max_position_change > 0:
            raise ValueError(f"elasticity.max_position_change: {max_position_change!r}; "
                             "expected a length > 0 [m]")
        if not 0.0 < armijo < 0.5:
            raise ValueError(f"elasticity.armijo: {armijo!r}; expected a number in (0, 0.5)")
        if not 0.0 < line_search_beta < 1.0:
            raise ValueError(f"elasticity.line_search_beta: {line_search_beta!r}; expected a "
                             "number in (0, 1)")
        self.solver = solver
        self.material_model = material_model
        self.max_position_change = float(max_position_change)
        self.cg_max_iterations = int(cg_max_iterations)
        self.cg_tolerance = float(cg_tolerance)
        self.lbfgs_window = int(lbfgs_window)
        self.line_search = bool(line_search)
        self.line_search_iterations = int(line_search_iterations)
        self.armijo = float(armijo)
        self.line_search_beta = float(line_search_beta)
        # the energy's own Lamé parameters (stable neo-Hookean: Smith et al. 2018's remap)
        mu, lam = lame(self.youngs_modulus, self.poisson_ratio)
        if material_model == "stable_neo_hookean":
            self.psi_mu, self.psi_lam = 4.0 * mu / 3.0, lam + 5.0 * mu / 6.0
        else:
            self.psi_mu, self.psi_lam = mu, lam
        self.snh_a = 1.0 + 0.75 * self.psi_mu / self.psi_lam if self.psi_lam != 0 else 1.0

    def init(self, state: SimState) -> None:
        """The base's rest configuration and gradient weights, the constant operators; pinned
        particles start at rest."""
        super().init(state)
        rest = self.rest
        dim = state.dim
        off, idx = rest.lists.offsets, rest.lists.indices
        self.D = gradient_operators(off, idx, self.G, dim)
        self.Klap = gradient_laplacian(self.D, rest.V0)
        if self.alpha > 0:
            self.Z = (self.alpha * self.mu * zero_energy_operator(
                rest.x0, rest.V0, off, idx, self.D, rest.h, state.kid, dim)).tocsr()
        else:
            self.Z = sp.csr_matrix((rest.n, rest.n))
        self._free = np.flatnonzero(~rest.pinned)
        self._fixed_mask = rest.pinned.astype(np.int64)
        self._zdiag = np.ascontiguousarray(self.Z.diagonal())
        self._ids = np.arange(rest.n, dtype=np.int64)
        self._ones = np.ones(rest.n)
        self._dt, self._lu = -1.0, None
        n = rest.n
        self._F = np.zeros((n, 9))
        self._P = np.zeros((n, 9))
        self._H = np.zeros((n, 81))
        self._psi = np.zeros(n)
        self._f = np.zeros((3, n))
        if state.time == 0.0 and rest.fixed.size:  # kinematic pinned particles start at rest
            state.fluid["v"][:, rest.pos[rest.fixed]] = 0.0

    def max_time_step(self, state: SimState) -> float:
        """Implicit: no bound of its own."""
        return math.inf

    # -- the objective ----------------------------------------------------------------------

    def _energy(self, x: np.ndarray, xt: np.ndarray, dt2: float, hessian: bool,
                gradient: bool) -> tuple[float, np.ndarray | None]:
        """``E(x)`` and (``gradient``) ``grad E`` (3, n) at the slot-ordered positions x;
        fills the stresses and (``hessian``) the projected Hessians."""
        rest = self.rest
        F = self._F
        gradients(x - rest.x0, rest.lists.offsets, rest.lists.indices, self.G, F)
        F[:, 0] += 1.0
        F[:, 4] += 1.0
        F[:, 8] += 1.0
        material(F, self.psi_mu, self.psi_lam, self.snh_a, MATERIAL_MODELS[self.material_model],
                 hessian, self._P, self._psi, self._H)
        d = x - xt
        # the zero-energy-mode energy of the displacement: Z x0 = 0 where the gradient weights
        # are exact for linear fields on the rest vectors, not next to the face clamp
        # (elasticity.clamp "face"), whose moved samples would give the rest state a force
        ux = x - rest.x0
        zx = [self.Z @ ux[a] for a in range(self.dim)] if self.alpha > 0 else None
        e = 0.5 * float(np.einsum("an,n,an->", d, rest.m, d))
        e += dt2 * float(rest.V0 @ self._psi)
        if zx is not None:
            e += 0.5 * dt2 * sum(float(ux[a] @ zx[a]) for a in range(self.dim))
        if not gradient:
            return e, None
        f = self._elastic_force(self._P, x)
        g = rest.m * d - dt2 * f
        if zx is not None:
            for a in range(self.dim):
                g[a] += dt2 * zx[a]
        g[:, rest.fixed] = 0.0
        g[self.dim:] = 0.0
        return e, g

    def _elastic_force(self, P: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``f_i = sum_j (V0_i P_i G_ij - V0_j P_j G_ji)`` (3, n)."""
        rest = self.rest
        f = self._f
        f[...] = 0.0
        forces(x, self._ids, rest.x0, rest.V0, self._ones, rest.lists.offsets,
               rest.lists.indices, self.G, self.rev, rest.h, self.kid, self.dim, P, P, 0.0, f)
        return f.copy()

    # -- the directions ---------------------------------------------------------------------

    def _newton_direction(self, g: np.ndarray, dt2: float) -> tuple[np.ndarray, int]:
        """``dx`` of ``(M + dt^2 (K + Z)) dx = -g`` by block-Jacobi CG; its iterations."""
        rest = self.rest
        dim, n = self.dim, rest.n
        off, idx = rest.lists.offsets, rest.lists.indices
        pinned = rest.fixed
        Binv = np.zeros((n, 9))
        block_jacobi(off, idx, self.G, self.rev, rest.V0, self._H, dt2, rest.m,
                     dt2 * self._zdiag, dim, self._fixed_mask, Binv)
        Y = np.zeros((3, n))
        dF = np.zeros((n, 9))
        dP = np.zeros((n, 9))

        def matvec(y: np.ndarray, out: np.ndarray) -> None:
            yv = y.reshape(dim, n)
            Y[:dim] = yv
            Y[:, pinned] = 0.0
            gradients(Y, off, idx, self.G, dF)
            hessian_apply(self._H, dF, dP)
            f = self._elastic_force(dP, Y)
            o = out.reshape(dim, n)
            for a in range(dim):
                o[a] = rest.m * Y[a] - dt2 * f[a]
                if self.alpha > 0:
                    o[a] += dt2 * (self.Z @ Y[a])
            o[:, pinned] = yv[:, pinned]

        def precond(r: np.ndarray, z: np.ndarray) -> None:
            block_apply(Binv, r.reshape(dim, n), z.reshape(dim, n), dim)

        b = -g[:dim]
        sol, stats = cg(matvec, np.ascontiguousarray(b).ravel(), np.zeros(dim * n),
                        precond=precond, tol=self.cg_tolerance, max_iter=self.cg_max_iterations,
                        name="kee2023 Newton", step=self.step, warn=False)
        dx = np.zeros((3, n))
        dx[:dim] = sol.reshape(dim, n)
        dx[:, pinned] = 0.0
        return dx, stats.iterations

    def _factorise(self, dt: float) -> None:
        """LU of the L-BFGS initial Hessian on the free particles."""
        rest = self.rest
        mu, lam = self.mu, self.lam
        A = sp.diags(rest.m) + dt * dt * ((2.0 * mu + lam) * self.Klap + self.Z)
        fr = self._free
        self._lu = splu(A.tocsr()[fr][:, fr].tocsc()) if fr.size else None
        self._dt = dt

    def _h0(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros_like(q)
        if self._lu is not None:
            fr = self._free
            for a in range(self.dim):
                out[a, fr] = self._lu.solve(np.ascontiguousarray(q[a, fr]))
        return out

    def _lbfgs_direction(self, g: np.ndarray, hist: list) -> np.ndarray:
        """The two-loop recursion over the step's secant pairs ``(s, y, 1 / y.s)``."""
        q = g.copy()
        alphas = []
        for s, y, rho in reversed(hist):
            a = rho * float(np.vdot(s, q))
            alphas.append(a)
            q -= a * y
        r = self._h0(q)
        for (s, y, rho), a in zip(hist, reversed(alphas), strict=True):
            beta = rho * float(np.vdot(y, r))
            r += (a - beta) * s
        return -r

    # -- the step ---------------------------------------------------------------------------

    def apply(self, state: SimState, dt: float) -> None:
        """Minimise E for the end-of-step positions; the solid's acceleration becomes
        ``(v' - v) / dt``; pinned particles take their kinematic targets."""
        rest = self.rest
        if rest is None or rest.n == 0:
            return
        f = state.fluid
        self.dim, self.kid, self.step = state.dim, state.kid, state.step
        dim, n = state.dim, rest.n
        pos = rest.update(state)
        pinned = rest.fixed
        x = np.zeros((3, n))
        v = np.zeros((3, n))
        x[:dim] = f["x"][:, pos]
        v[:dim] = f["v"][:, pos]
        xt = x + dt * v
        xt[:dim] += dt * dt * f["a"][:, pos]
        xt[:, pinned] = x[:, pinned] + dt * v[:, pinned]  # kinematic: no acceleration
        self._target_x, self._target_v = xt[:, pinned].copy(), v[:, pinned].copy()
        if self.solver == "lbfgs" and dt != self._dt:
            self._factorise(dt)
        dt2 = dt * dt
        xk = xt.copy()
        hist: list = []
        e, g = self._energy(xk, xt, dt2, self.solver == "newton", True)
        g0 = float(np.linalg.norm(g)) or 1.0
        its = cg_its = ls_its = 0
        step_max, step, failed = 0.0, 0.0, False
        while its < self.max_iterations:
            its += 1
            if self.solver == "newton":
                d, k = self._newton_direction(g, dt2)
                cg_its += k
            else:
                d = self._lbfgs_direction(g, hist)
            step_max = float(np.abs(d).max()) if d.size else 0.0
            slope = float(np.vdot(g, d))
            if slope >= 0.0:  # not a descent direction (a CG stopped early): steepest descent
                d = -self._h0(g) if self.solver == "lbfgs" else -g / rest.m
                slope = float(np.vdot(g, d))
            step = 1.0
            if self.line_search:
                for _ in range(self.line_search_iterations):
                    ls_its += 1
                    e_try, _ = self._energy(xk + step * d, xt, dt2, False, False)
                    if e_try <= e + self.armijo * step * slope:
                        break
                    step *= self.line_search_beta
                else:
                    step = 0.0
            if step == 0.0:  # no sufficient decrease along d: stop at xk
                failed = True
                self._energy(xk, xt, dt2, False, False)  # F, P of xk for the output
                break
            x_new = xk + step * d
            e_new, g_new = self._energy(x_new, xt, dt2, self.solver == "newton", True)
            if self.solver == "lbfgs" and self.lbfgs_window > 0:
                s_k, y_k = x_new - xk, g_new - g
                ys = float(np.vdot(y_k, s_k))
                if ys > 1e-300:
                    hist.append((s_k, y_k, 1.0 / ys))
                    if len(hist) > self.lbfgs_window:
                        hist.pop(0)
            xk, e, g = x_new, e_new, g_new
            if step * step_max < self.max_position_change:
                break
        converged = not failed and step * step_max < self.max_position_change
        if not converged:
            log.warning("kee2023: no convergence in %d iterations at step %d: last position "
                        "change %.3g m (max_position_change %.3g m)%s", its, state.step,
                        step * step_max, self.max_position_change,
                        "; the line search found no decrease" if failed else "")
        self.stats = KrylovStats(its, float(np.linalg.norm(g)) / g0, converged)
        self.solve_stats = {"iterations": its, "cg_iterations": cg_its,
                            "line_search_trials": ls_its, "max_change": step_max}
        # von Mises stress of sigma = P F^T / J at the solution (output)
        self._von_mises(state, pos)
        vnew = (xk[:dim] - x[:dim]) / dt
        vnew[:, pinned] = v[:dim, pinned]
        f["a"][:, pos] = (vnew - v[:dim]) / dt

    def _von_mises(self, state: SimState, pos: np.ndarray) -> None:
        F = self._F.reshape(-1, 3, 3)
        P = self._P.reshape(-1, 3, 3)
        J = np.linalg.det(F)
        J = np.where(np.abs(J) > 1e-12, J, 1e-12)
        s = np.einsum("nab,ncb->nac", P, F) / J[:, None, None]
        d = s - np.einsum("naa->n", s)[:, None, None] * np.eye(3) / 3.0
        state.fluid["solid_stress"][pos] = np.sqrt(1.5 * np.einsum("nab,nab->n", d, d))

    def constrain(self, state: SimState) -> None:
        """Pinned particles at their kinematic targets ``x + dt v`` with their velocity."""
        rest = self.rest
        if rest is None or not rest.fixed.size or self._target_x.shape[1] != rest.fixed.size:
            return
        f = state.fluid
        pos = rest.update(state)
        _kinematic(f["x"], f["v"], pos, rest.fixed, self._scatter(self._target_x),
                   self._scatter(self._target_v), state.dim)

    def _scatter(self, cols: np.ndarray) -> np.ndarray:
        out = np.zeros((3, self.rest.n))
        out[:, self.rest.fixed] = cols
        return out
