"""The bounds sphkit puts on what a scene or a command line may ask for (no imports, so that
the command line reads them without loading the scene model).

Every one of them is named in the error that refuses a value beyond it.
"""

from __future__ import annotations

#: the most frames per simulated second a scene (``output.fps``) or ``--fps`` may ask for; a
#: frame is written at most once per time step anyway
MAX_FPS = 1e6
#: the default particle budget (``configuration.max_particles``, ``sphkit run --max-particles``):
#: fluid, wall and emitter particles a scene may need, estimated before anything is allocated
MAX_PARTICLES = 20_000_000
#: how many characters of a value an error message repeats
CLIP = 80
#: the largest scene file read (bytes): scenes are a few kilobytes, particles live in files
MAX_SCENE_BYTES = 16 * 2**20
#: the most nodes (mappings, lists, values) a YAML scene may expand to through its aliases
MAX_YAML_NODES = 100_000
