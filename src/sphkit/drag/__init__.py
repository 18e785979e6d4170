"""Air drag models (survey Sec. 5.5): forces of the surrounding air on surface particles."""

from sphkit.drag.gissler2017 import Gissler2017
from sphkit.drag.macklin2014 import Macklin2014

__all__ = ["Gissler2017", "Macklin2014"]
