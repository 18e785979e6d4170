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
angular momentum too; the corotated force is not central (it follows ``R sigma grad W``, not
``x_ij``), and keeps angular momentum only as far as the kernel's moment
``sum_j V0_j grad W(x0_ji) x0_ij^T`` is the identity (interior particles of a regular lattice),
which tests/test_solids.py measures.
"""

from __future__ import annotations

from typing import ClassVar

from sphkit.solids.base import CorotatedSolid


class Becker2009(CorotatedSolid):
    """Explicit corotated SPH elasticity (module docstring): the base's elastic and hourglass
    accelerations, applied as they are, with the explicit time-step bound."""

    name: ClassVar[str] = "becker2009"
