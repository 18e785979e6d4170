"""Implicit viscosity of Peer, Ihmsen, Cornelis & Teschner 2015 (survey Sec. 5.2).

Peer, Ihmsen, Cornelis, Teschner 2015, "An implicit viscosity formulation for SPH fluids", ACM
TOG 34(4), as SPlisHSPlasH's ``Viscosity_Peer2015`` (2.19, viscosityMethod 3) implements it. The
paper's equation numbers could not be checked here; the formulas are those of
``reference/methods.md`` (I5) and of SPlisHSPlasH's source, written out in full.

Instead of integrating a viscous force, the method prescribes a target velocity gradient and
reconstructs the velocity field that has it:

1. velocity gradient ``G_i = (1 / rho_i) sum_j m_j (v_j - v_i) (x) grad W_ij``;
2. decomposition ``G = R + V + S`` into spin ``R = (G - G^T) / 2``, expansion
   ``V = (div v / d) I`` and shear ``S = (G + G^T) / 2 - V``; target
   ``T_i = R_i + V_i + xi S_i`` with ``xi = 1 - nu`` and the **dimensionless** viscosity
   ``nu`` in [0, 1] (1 removes all shear in one step). The expansion, which the pressure solver
   introduces against density errors, is kept, so that pressure and viscosity do not fight;
   SPlisHSPlasH leaves V out where ``rho_i < rho0`` and ``div v_i <= 0`` (the free surface
   must not be compressed further), and so does sphkit;
3. reconstruction from the first-order Taylor expansion ``v_i = v_j + (T_i + T_j)/2 x_ij``
   averaged with the weights ``m_j W_ij``: for every velocity component a sparse linear system

       d_i v_i - sum_j m_j W_ij v_j = sum_j m_j (T_i + T_j)/2 x_ij W_ij,
       d_i = sum_j m_j W_ij + rho0 sum_b V_b W_ib,

   symmetric positive (semi-)definite for equal masses, solved by the shared conjugate gradient
   (:func:`sphkit.core.krylov.cg`) with the Jacobi preconditioner ``diag = d_i``, warm-started
   with the current velocities, at most ``max_iterations`` (``viscoMaxIter``, default 50)
   iterations per component, tolerance ``max_error`` (``viscoMaxError``, default 0.01) on the
   relative residual. ``d_i`` is this method's own density sum without the self term, evaluated
   here in float64 (SPlisHSPlasH recomputes it because the system "is very sensitive to small
   deviations"). A component whose solve needs no iteration keeps the current velocities
   (SPlisHSPlasH's rule: a zero right-hand side of a uniform flow leaves it as it is).

The new velocities are applied as the acceleration ``a_i += (v_new - v_i) / dt``. Walls enter only
through the boundary term of ``d_i``: they pull the reconstructed velocity towards zero, i.e.
they act as static no-slip walls (SPlisHSPlasH's form; there is no separate wall viscosity).

Properties (tested): a uniform velocity is unchanged (zero right-hand side); the spin is kept, so
a rigid rotation is preserved where the SPH gradient of the rotation is exact (full
neighbourhoods); the shear is removed at the rate ``nu`` per step whatever the time step, so
``nu`` is not a physical viscosity and the damping depends on the step size (the survey: "fast but
damps strongly, unsuitable for low viscosity"); even ``nu = 0`` smooths the velocity (the
reconstruction is not the identity), as in SPlisHSPlasH. Linear momentum is not conserved
exactly: the system fixes the velocities only up to a constant per component (without walls), and
CG keeps the d-weighted mean ``sum_i d_i v_i`` of its start, which equals the momentum only where
``d_i`` is uniform (away from the free surface); the tests measure the difference.

Dimension: ``V = (div v / d) I`` uses the dimension d of the simulation; SPlisHSPlasH always uses
1/3 (its 2D runs are 3D with z = 0), which in 2D counts a third of an isotropic expansion as shear.
"""

from __future__ import annotations

from typing import Any

from sphkit.core.krylov import KrylovStats
from sphkit.core.methods import NonPressureForce
from sphkit.core.state import SimState
from sphkit.core.viscous import add_velocity_change, reconstruct_velocity, target_gradients


class Peer2015(NonPressureForce):
    """Velocity reconstruction from a target gradient; ``nu`` dimensionless in [0, 1].

    After :meth:`apply`, ``stats`` holds the CG iterations (summed over the velocity components,
    as SPlisHSPlasH counts them) and the largest relative residual of the step.
    """

    name = "peer2015"

    @classmethod
    def from_config(cls, p: Any) -> Peer2015:
        """The Peer2015 of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.max_iterations or 50, p.max_error)

    def __init__(self, nu: float, max_iterations: int = 50, max_error: float = 0.01) -> None:
        if not 0.0 <= nu <= 1.0:
            raise ValueError(f"viscosity: {nu!r}; expected a dimensionless factor in [0, 1]")
        if max_iterations < 1 or not 0 < max_error < 1:
            raise ValueError(f"viscosity: max_iterations {max_iterations!r}, max_error "
                             f"{max_error!r}; expected >= 1 and in (0, 1)")
        self.nu = float(nu)
        self.max_iterations = int(max_iterations)
        self.max_error = float(max_error)
        self.stats = KrylovStats()

    def apply(self, state: SimState, dt: float) -> None:
        """Reconstruct the velocities and add the change as an acceleration to ``a``."""
        f = state.fluid
        if f.n == 0:
            self.stats = KrylovStats()
            return
        _G, T = target_gradients(state, 1.0 - self.nu, spin=True)
        vnew, self.stats = reconstruct_velocity(state, T, self.max_error, self.max_iterations,
                                       "Peer 2015 viscosity")
        add_velocity_change(f["v"], vnew, 1.0 / dt, f["a"], vnew, False)
