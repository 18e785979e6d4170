"""Elastic solids (survey, "Material models"): one paper per file.

* :mod:`sphkit.solids.becker2009` -- corotated SPH, explicit (SPlisHSPlasH elasticityMethod 1),
  with Ganzenmüller 2015's zero-energy-mode control;
* :mod:`sphkit.solids.peer2018` -- implicit corotated linear elasticity (elasticityMethod 2) on
  the shared matrix-free CG;
* :mod:`sphkit.solids.kugelstadt2021` -- operator-split implicit corotated elasticity with a
  pre-factorised constant matrix and implicit zero-energy-mode control (elasticityMethod 3);
* :mod:`sphkit.solids.kee2023` -- hyperelastic solids (corotated or stable neo-Hookean),
  backward Euler as a minimisation by projected Newton or L-BFGS (elasticityMethod 4).

Shared machinery (not methods): :mod:`sphkit.solids.base` (the corotated solid both models
derive from), :mod:`sphkit.solids.rest` (rest configuration, rest lists, pinned particles),
:mod:`sphkit.solids.gradients` (gradient weights), :mod:`sphkit.solids.corotation` (the
compiled corotated passes, whose force pass kee2023 reuses with its own stresses) and
:mod:`sphkit.solids.operators` (sparse gradient and zero-energy-mode matrices) and
:mod:`sphkit.solids.hyperelastic` (energy densities, stresses and projected Hessians of
isotropic hyperelastic solids, the pieces of a Newton step) and
:mod:`sphkit.solids.plasticity` (von Mises plasticity, radial return).
"""
