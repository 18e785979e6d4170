"""What the air drag models share: a coefficient and the air's velocity (survey Sec. 5.5).

:class:`AirDrag` is the base of :class:`sphkit.drag.macklin2014.Macklin2014` and
:class:`sphkit.drag.gissler2017.Gissler2017`: both read a material's ``drag`` part (SPlisHSPlasH's
``drag`` coefficient and sphkit's ``air_velocity``), check the coefficient and hand their
compiled passes the air velocity as three components.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sphkit.core.methods import NonPressureForce
from sphkit.core.params import checked_number


class AirDrag(NonPressureForce):
    """``coefficient``: the model's drag coefficient (its unit is ``unit``);
    ``air_velocity``: velocity of the surrounding air [m/s] (default at rest)."""

    #: the coefficient's unit, for the error message
    unit = ""

    @classmethod
    def from_config(cls, p: Any) -> AirDrag:
        """The model of a material's ``drag`` (scene model)."""
        return cls(p.coefficient, p.air_velocity)

    def __init__(self, coefficient: float = 0.01,
                 air_velocity: list[float] | np.ndarray | None = None) -> None:
        self.coefficient = checked_number(f"drag ({self.name}): coefficient", coefficient,
                                          expected=f"a finite number >= 0 {self.unit}".rstrip())
        self.air_velocity = None if air_velocity is None else np.asarray(air_velocity, float)

    def air(self, dim: int) -> np.ndarray:
        """The air velocity as three components (0 beyond ``dim``; all 0 for air at rest)."""
        va = np.zeros(3)
        if self.air_velocity is not None:
            va[:dim] = self.air_velocity[:dim]
        return va
