"""What the pairwise surface tension models share (survey Sec. 5.4): a cohesion coefficient and
an adhesion coefficient to the boundary.

:class:`CohesionAdhesion` is the base of Becker & Teschner 2007, Akinci et al. 2013 and He et al.
2014 (:mod:`sphkit.surface_tension.becker2007`, :mod:`.akinci2013`, :mod:`.he2014`): each reads
a material's ``surface_tension`` part (SPlisHSPlasH's ``surfaceTension`` and
``surfaceTensionBoundary``), checks both coefficients, and in 2D and 3D only reads the boundary
volumes ``V`` in its adhesion term. The methods' own fields are registered by their ``init``
after the base's.
"""

from __future__ import annotations

from typing import Any

from sphkit.core.methods import NonPressureForce
from sphkit.core.params import checked_number
from sphkit.core.state import SimState


class CohesionAdhesion(NonPressureForce):
    """``coefficient``: the cohesion (surface tension) coefficient of the model;
    ``boundary_coefficient``: its adhesion to the boundary (units: the model's docstring)."""

    @classmethod
    def from_config(cls, p: Any) -> CohesionAdhesion:
        """The model of a material's ``surface_tension`` (scene model)."""
        return cls(p.coefficient, p.boundary_coefficient)

    def __init__(self, coefficient: float = 0.05, boundary_coefficient: float = 0.01) -> None:
        what = f"surface tension ({self.name})"
        self.coefficient = checked_number(f"{what}: coefficient", coefficient)
        self.boundary_coefficient = checked_number(f"{what}: boundary_coefficient",
                                                   boundary_coefficient)

    def init(self, state: SimState) -> None:
        """Check the dimension (2 or 3) and register the boundary volumes ``V`` the adhesion
        term reads."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"surface tension ({self.name}): dimension {state.dim}; expected 2 or 3")
        if "V" not in state.boundary:
            state.boundary.register("V")
