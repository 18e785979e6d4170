"""Elastic solids (survey, "Material models"): one paper per file.

* :mod:`sphkit.solids.becker2009` -- corotated SPH, explicit (SPlisHSPlasH elasticityMethod 1),
  with Ganzenmüller 2015's zero-energy-mode control.

Shared machinery (not methods): :mod:`sphkit.solids.rest` (rest configuration, rest lists,
pinned particles) and :mod:`sphkit.solids.corotation` (the compiled corotated passes).
"""
