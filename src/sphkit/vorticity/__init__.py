"""Vorticity models (survey Sec. 5.3): non-pressure forces that restore or create vortices."""

from sphkit.vorticity.confinement import VorticityConfinement
from sphkit.vorticity.micropolar_bender2017 import MicropolarBender2017

__all__ = ["MicropolarBender2017", "VorticityConfinement"]
