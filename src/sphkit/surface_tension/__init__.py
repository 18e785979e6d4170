"""Surface tension and adhesion models (survey Sec. 5.4): non-pressure forces at free surfaces."""

from sphkit.surface_tension.akinci2013 import Akinci2013
from sphkit.surface_tension.becker2007 import BeckerTeschner2007
from sphkit.surface_tension.he2014 import He2014
from sphkit.surface_tension.jeske2023 import Jeske2023
from sphkit.surface_tension.mueller2003 import Mueller2003
from sphkit.surface_tension.zorilla2020 import ZorillaRitter2020

__all__ = ["Akinci2013", "BeckerTeschner2007", "He2014", "Jeske2023", "Mueller2003",
           "ZorillaRitter2020"]
