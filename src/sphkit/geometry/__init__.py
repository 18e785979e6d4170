"""Geometry of a scene, with no SPH in it: meshes, sections, signed distances, grids, rotations.

* :mod:`sphkit.geometry.meshes` -- mesh files placed in the scene (:func:`~sphkit.geometry.
  meshes.load_mesh`), sections of meshes with the plane z = 0 and their mass properties;
* :mod:`sphkit.geometry.sampling` -- points on lattices: blocks and box walls;
* :mod:`sphkit.geometry.mesh_sampling` -- points on the surface or in the volume of meshes;
* :mod:`sphkit.geometry.sdf` -- signed distance fields of meshes, 2D sections and boxes on
  lattices; :mod:`sphkit.geometry.cache` their disk cache;
* :mod:`sphkit.geometry.grids` -- cubic serendipity and multilinear interpolation on lattices,
  quadrature over a ball;
* :mod:`sphkit.geometry.rotations` -- rotation matrices (Rodrigues' formula) and their
  compiled application.

Nothing here knows particles, kernels or scenes: the modules take arrays and numbers in SI units
and raise :class:`GeometryError` for bad input (a mesh file that cannot be read, a face too large
to sample), which the world builder reports as a scene error naming the field.
"""

from __future__ import annotations


class GeometryError(ValueError):
    """Geometry that cannot be loaded or sampled; the message names the file and the problem."""
