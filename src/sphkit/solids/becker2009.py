"""Corotated SPH for elastic solids, explicit (SPlisHSPlasH ``elasticityMethod`` 1).

Becker, Ihmsen & Teschner 2009, "Corotated SPH for deformable solids", Eurographics Workshop on
Natural Phenomena: the linear (Cauchy) strain of the displacement measured in each particle's
corotated frame, Hooke's law, and forces from the stresses of both particles of a pair (Eq.
6-12 of the paper; the discrete form of SPlisHSPlasH's ``Elasticity_Becker2009.cpp``, see
:mod:`sphkit.solids.corotation` for the formulas and where sphkit differs); zero-energy
(hourglass) modes damped by Ganzenmüller 2015 with the factor ``alpha``. The displacement
gradient takes the weights of :mod:`sphkit.solids.gradients` (``gradient_correction``:
SPlisHSPlasH's plain SPH gradient ``none``, the corrected ``linear`` one of Bonet & Lok 1999,
or sphkit's default ``quadratic``, exact for the quadratic displacement of a bent beam), and
the rest volumes are the particles' own (``rest_volume``, see :mod:`sphkit.solids.rest`);
with a corrected gradient and these volumes a stretched bar pulls with ``E eps A`` to 1e-4
whatever its width (tests/test_solids.py).

The force is explicit, so the step must resolve the elastic waves: :meth:`max_time_step` is
``0.4 * 2r / c`` with the P-wave speed ``c = sqrt((lambda + 2 mu) / rho0)`` (the acoustic
condition WCSPH uses; SPlisHSPlasH bounds nothing, and its Beam scenes use the implicit
models).

Conservation: the pair forces are antisymmetric on symmetric rest lists, so the elastic and
hourglass forces keep linear momentum to round-off; the hourglass force is central, so it keeps
angular momentum too; the corotated force is not central (it follows ``R sigma G``, not
``x_ij``): its torques sum to ``sum_i V0_i skew(H_i sigma_i R_i^T)`` with ``H_i = sum_j x_ji
G_ij^T`` the deformation gradient. With Becker's rotation of the moment matrix (``rotation =
"moment"``, the default) ``R^T H`` is not symmetric, and angular momentum drifts at second order
in the strain (2.5e-6 over 200 steps of a spinning block, tests/test_solids.py). With
``rotation="gradient"`` R is the polar rotation of H (converged), ``R^T H = S`` is symmetric
and commutes with sigma, so every particle's torque vanishes: the force is then the exact
gradient of the rotation-invariant energy ``sum_i V0_i (mu |S_i - I|^2 + lambda/2 tr(S_i -
I)^2)`` (with a linearly consistent ``gradient_correction``, ``sum_j x0_ji G_ij^T = I``), and
linear and angular momentum (1e-13) and, to symplectic Euler's O(dt^2), the energy
(:meth:`~sphkit.solids.base.CorotatedSolid.strain_energy`) are kept.

Plasticity (``yield_stress``, ``hardening``; sphkit's own): the corotated strain of each step
is returned onto the von Mises yield surface (:mod:`sphkit.solids.plasticity`) before Hooke's
law; the plastic strain is kept per particle.
"""

from __future__ import annotations

from typing import ClassVar

from sphkit.solids.base import CorotatedSolid


class Becker2009(CorotatedSolid):
    """Explicit corotated SPH elasticity (module docstring): the base's elastic and hourglass
    accelerations, applied as they are, with the explicit time-step bound."""

    name: ClassVar[str] = "becker2009"
