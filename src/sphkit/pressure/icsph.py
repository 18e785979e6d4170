"""Implicit compressible SPH (ICSPH), the pressure solver of Gissler et al.'s snow model.

Gissler, Henne, Band, Peer, Teschner 2020, "An implicit compressible SPH solver for snow
simulation", ACM TOG 39(4), Sec. 4 (the compressible pressure solve; the elastoplastic shear
solve of the snow model is not part of it), as SPlisHSPlasH's ``TimeStepICSPH`` implements it
(``simulationMethod`` 6). With the fluid's *current* volumes ``V_j = m_j / rho_j`` (not the rest
volumes of the other solvers) and ``v* = v + dt a_nonp``:

* advected density (Eq. 6): ``rho_adv,i = rho_i + dt rho_i (sum_j V_j (v*_i - v*_j) . grad W_ij
  + sum_b V_b (v*_i - v_b) . grad W_ib)``;
* pressure gradient (Eq. 7): ``grad p_i = sum_j V_j (p_i + p_j) grad W_ij
  + psi sum_b V_b p_i grad W_ib``, with a boundary factor psi (SPlisHSPlasH's ``m_psi`` = 1.5;
  see "Boundary factor" below for sphkit's default 1);
* the compressible pressure Poisson equation (Eq. 5), with the Lame parameter lambda [Pa]:
  ``-(rho0 / lambda) p_i + dt^2 lap p_i = rho0 - rho_adv,i``, where
  ``lap p_i = sum_j V_j (grad p_j - grad p_i) . grad W_ij - sum_b V_b grad p_i . grad W_ib``
  (the divergence of the gradient above): at rest it is the state equation
  ``rho = rho0 (1 + p / lambda)`` (:meth:`ICSPH.compressed_density`);
* its diagonal (Eq. 8) ``a_ii = -rho0 / lambda - dt^2 sum_j V_j^2 |grad W_ij|^2
  - dt^2 (sum_j V_j grad W_ij + psi sum_b V_b grad W_ib) . (sum_j V_j grad W_ij
  + sum_b V_b grad W_ib)`` (SPlisHSPlasH: ``V_i V_j`` in the middle term; equal for equal
  volumes);
* relaxed Jacobi, omega = 0.5, ``p_i <- p_i + omega (rho0 - rho_adv,i - (A p)_i) / a_ii``,
  clamped to p >= 0 when ``clamping`` (SPlisHSPlasH ``pressureClamping``, default on); the
  pressure of the last step is the start of the next (SPlisHSPlasH keeps it);
* after the solve, SPlisHSPlasH's pressure acceleration
  ``a_i = -sum_j V_j (p_i rho0 / rho_i^2 + p_j rho0 / rho_j^2) grad W_ij
  - sum_b V_b p_i rho0 / rho_i^2 grad W_ib`` (SPlisHSPlasH: no psi; sphkit: the same psi as
  the solve, plus the mirrored share m_b of the boundary coupling where a model sets one).

**On sphkit's engine.** The loop is :func:`sphkit.core.solver.jacobi_ppe` in normalized units
``q = p / rho0`` [m^2/s^2], ``k = q``: the engine's pressure acceleration of k is
``-grad p / rho0`` with Eq. 7's gradient when the mirror weights are ``m_b + psi - 1``, its
``A q`` is ``lap q``, and the compressible term enters as the engine's diagonal shift
``rho0 / lambda`` (residual ``s - dt^2 lap q + (rho0 / lambda) q`` with ``s = 1 - rho_adv /
rho0``); the diagonal is :meth:`sphkit.core.solver.PairGradients.diagonal` with the same psi.
The pair gradients are computed with the current volumes (:class:`PairGradients` ``volumes``).

**Error measure.** SPlisHSPlasH stops when the *signed* average of the residual
``-(rho0 - rho_adv - A p)`` is at most ``maxError`` % of rho0 (expanded particles offset
compressed ones); sphkit's engine averages only the compressive part ``max(-r_i, 0)``, which is
never smaller, so sphkit may take more iterations for the same ``max_error``. The error is that
of the compressible equation: the fluid is *meant* to be compressed by ``p / lambda`` (about
8 % at the bottom of a 0.8 m column with SPlisHSPlasH's scene value lambda = 1e5 Pa), and the
density error measures the departure from that.

**Boundary factor.** Eq. 7's psi multiplies the boundary share of the gradient. SPlisHSPlasH
uses psi = 1.5 with boundary particles (Akinci 2012) and 1 with volume maps, and only in the
solve: its final acceleration has no psi, so its solve expects a boundary push half again as
large as the one it applies. sphkit's solvers do not branch on the boundary model; the boundary
model's mirror weights ``m_b`` already carry its share of the pressure (0 for single surface
layers and maps, 1 for the boxes' lattice walls, :mod:`sphkit.core.ppe`), so sphkit's default is
psi = 1 (the coupling's boundary term, as the other solvers), and a psi set in the scene
(``icsph_psi``) enters the solve *and* the acceleration: the boundary weight ``1 + m_b``
becomes ``psi + m_b``. Measured on a 2D column with lambda = 1e12 Pa
(incompressible limit, max_error 0.05 %, ``validation/README.md``): psi = 1.5 in the solve only
(SPlisHSPlasH) let the compression reach 0.098 %, psi = 1.5 in both 0.061 %, psi = 1 0.052 %.

**Warm start.** As SPlisHSPlasH, each solve starts from the last step's pressure, in full. In the
incompressible limit that makes the column bounce (steps where it lifts off and every pressure
is 0, then 2-9 iterations to catch it); IISPH's half warm start keeps the same column calm at
13-16 iterations (measured, ``validation/README.md``). For a compressible lambda the last
pressure is the state of the fluid and the full warm start is the better guess.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sphkit.core.methods import BoundaryReaction, PressureSolver
from sphkit.core.ppe import kappa_accel_cached
from sphkit.core.solver import IterationControl, PairGradients, SolverStats, jacobi_ppe
from sphkit.core.state import SimState


def rest_density(state: SimState) -> float:
    """The rest density rho0 [kg/m^3] of the fluid: the one place this solver reads it (a
    per-particle field ``rho0`` will replace the scalar here)."""
    return state.rho0


class ICSPH(PressureSolver):
    """Implicit compressible SPH: relaxed Jacobi (omega = 0.5) on the compressible PPE."""

    name = "icsph"

    @classmethod
    def from_config(cls, p: Any) -> ICSPH:
        """The ICSPH of a scene's ``configuration.pressure`` (scene model)."""
        return cls(max_error=p.max_error, min_iterations=p.min_iterations,
                   max_iterations=p.max_iterations, lame_lambda=p.icsph_lambda,
                   clamping=p.icsph_clamping, psi=p.icsph_psi)

    def __init__(self, max_error: float = 0.01, min_iterations: int | None = None,
                 max_iterations: int = 100, lame_lambda: float = 200000.0,
                 clamping: bool = True, psi: float = 1.0, omega: float = 0.5) -> None:
        """``max_error`` in percent of rho0 (SPlisHSPlasH maxError); ``lame_lambda`` [Pa] the
        stiffness lambda (SPlisHSPlasH ``lambda``, default 200000); ``clamping``: p >= 0
        (``pressureClamping``); ``psi``: the boundary factor of Eq. 7 (dimensionless; 1: the
        boundary coupling's own term)."""
        if not lame_lambda > 0:
            raise ValueError(f"pressure.icsph_lambda: {lame_lambda!r}; expected a stiffness "
                             "lambda > 0 [Pa]")
        if min_iterations is None:
            min_iterations = min(2, max_iterations)
        self.control = IterationControl("ICSPH", min_iterations, max_iterations,
                                        max_error / 100.0)
        self.lame_lambda = float(lame_lambda)
        self.clamping = bool(clamping)
        self.psi = float(psi)
        self.omega = float(omega)

    def init(self, state: SimState) -> None:
        """Register the pressure field (p [Pa]; the next solve starts from it)."""
        state.fluid.register("p")

    def compressed_density(self, p: np.ndarray, rho0: np.ndarray) -> np.ndarray:
        """The state equation at rest, ``rho = rho0 (1 + p / lambda)`` [kg/m^3]."""
        return np.asarray(rho0, dtype=float) * (1.0 + np.asarray(p, dtype=float)
                                                / self.lame_lambda)

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Pressure solve on v* = v + dt a; adds the pressure acceleration to a."""
        f = state.fluid
        rho0 = rest_density(state)
        rho = f["rho"]
        grads = PairGradients(state, volumes=f["m"] / rho)  # current volumes V_j = m_j / rho_j
        div = grads.velocity_divergence(f["v"] + dt * f["a"])
        s = 1.0 - rho * (1.0 + dt * div) / rho0  # 1 - rho_adv / rho0
        shift = rho0 / self.lame_lambda  # [s^2/m^2]
        denom = shift + dt * dt * grads.diagonal(self.psi - 1.0)  # -a_ii [s^2/m^2]
        scale = np.where(denom > 1e-5, 1.0 / np.where(denom > 0, denom, 1.0), 0.0)
        q = f["p"] / rho0  # warm start: the last step's pressure, as SPlisHSPlasH
        mirror = state.coupling.mirror(state)
        _a, its, avg, mx, ok = jacobi_ppe(
            state, self.control, q, None, s.astype(f.dtype), scale.astype(f.dtype), dt * dt,
            self.omega, None, grads=grads, shift=shift, clamp=self.clamping,
            mirror=mirror + (self.psi - 1.0))
        p = q * rho0
        f["p"] = p
        # SPlisHSPlasH's computePressureAccels, k_i = p_i rho0 / rho_i^2, with the same
        # boundary factor as the solve (module docstring)
        k = self._kappa(state)
        a = np.empty_like(f["a"])
        nl, nb = state.nl_ff, state.nl_fb
        kb = state.coupling.boundary_kappa(state)
        kappa_accel_cached(k, kb(k), nl.offsets, nl.indices, nb.offsets, nb.indices,
                           mirror + (self.psi - 1.0), grads.gw, grads.gwb, state.dim, a,
                           phase=kb.phase)
        f["a"] += a
        return SolverStats(iterations=its, density_error_avg=avg, density_error_max=mx,
                           converged=ok)

    def _kappa(self, state: SimState) -> np.ndarray:
        f = state.fluid
        return f["p"] * rest_density(state) / f["rho"] ** 2

    def boundary_reaction(self, state: SimState) -> BoundaryReaction:
        """The boundary term of the final acceleration: ``k_i = p_i rho0 / rho_i^2`` times
        psi, mirrored share included (``psi (1 + m_b)`` instead of the solve's ``psi + m_b``:
        the same where m_b = 0)."""
        return BoundaryReaction(self._kappa(state) * self.psi, 1.0)
