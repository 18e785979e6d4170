"""Surface reconstruction: a triangle mesh of the fluid surface from particle positions.

Uses splashsurf (Löschner, Böttcher, Jeske, Bender: "Weighted Laplacian Smoothing for Surface
Reconstruction of Particle-based Fluids", VMV 2023) through its Python package ``pysplashsurf``
(optional: ``pip install sphkit[surface]``). splashsurf interpolates the SPH "colour field"
(the normalised particle density, cubic spline kernel) on a marching-cubes grid and extracts its
iso-surface, then optionally smooths the mesh with its weighted Laplacian smoothing.

Parameters, as splashsurf names them; lengths in multiples of the particle radius r:

=========================  =======  ===========================================================
``particle_radius``        --       r [m] (``sphkit surface`` takes it from the run's manifest)
``smoothing_length``       2.0      kernel smoothing length h / r (compact support 2h = 4r, as
                                    sphkit's and SPlisHSPlasH's kernels)
``cube_size``              0.5      marching-cubes cell edge / r
``iso_surface_threshold``  0.6      iso value of the colour field (1 inside the fluid)
``mesh_smoothing_iters``   25       iterations of the weighted Laplacian mesh smoothing (0: off)
``mesh_cleanup``           False    marching-cubes clean-up (Moore & Warren 1992)
=========================  =======  ===========================================================

The defaults are those of splashsurf's README example. Meshes are written as OBJ, PLY (binary)
or VTK XML (``.vtu``), atomically.
"""

from __future__ import annotations

import logging
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sphkit.io.atomic import atomic_path, atomic_write_bytes

logger = logging.getLogger("sphkit.io")

#: mesh format name -> file extension
MESH_FORMATS: dict[str, str] = {"obj": ".obj", "ply": ".ply", "vtk": ".vtu"}


class SurfaceUnavailable(ImportError):
    """pysplashsurf is not installed."""


@dataclass
class SurfaceParameters:
    """splashsurf's reconstruction parameters (see the module docstring)."""

    particle_radius: float
    rest_density: float = 1000.0
    smoothing_length: float = 2.0
    cube_size: float = 0.5
    iso_surface_threshold: float = 0.6
    mesh_smoothing_iters: int = 25
    mesh_cleanup: bool = False

    def __post_init__(self) -> None:
        for name in ("particle_radius", "rest_density", "smoothing_length", "cube_size",
                     "iso_surface_threshold"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"surface parameter {name}: got {v!r}; expected a number > 0")
        if self.mesh_smoothing_iters < 0:
            raise ValueError(
                f"surface parameter mesh_smoothing_iters: got {self.mesh_smoothing_iters!r}; "
                "expected an integer >= 0"
            )

    def as_dict(self) -> dict:
        """Plain-dict form (for the surface manifest)."""
        return asdict(self)


def _pysplashsurf():
    try:
        import pysplashsurf
    except ImportError:
        raise SurfaceUnavailable(
            "surface reconstruction needs pysplashsurf: pip install 'sphkit[surface]' "
            "(or pip install pysplashsurf)"
        ) from None
    return pysplashsurf


def reconstruct_surface(points: np.ndarray, params: SurfaceParameters, *,
                        threads: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The surface mesh of the particles ``points`` (N, 3): vertices (V, 3) float64 and
    triangles (T, 3) int64. No particles give an empty mesh.

    Raises:
        SurfaceUnavailable: pysplashsurf is not installed.
    """
    pss = _pysplashsurf()
    x = np.ascontiguousarray(points, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"surface reconstruction: points of shape {x.shape}; expected (N, 3)")
    if len(x) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    mesh_with_data, _ = pss.reconstruction_pipeline(
        x,
        particle_radius=params.particle_radius,
        rest_density=params.rest_density,
        smoothing_length=params.smoothing_length,
        cube_size=params.cube_size,
        iso_surface_threshold=params.iso_surface_threshold,
        mesh_smoothing_iters=params.mesh_smoothing_iters or None,
        mesh_smoothing_weights=True,
        mesh_cleanup=params.mesh_cleanup,
        multi_threading=threads,
    )
    mesh = mesh_with_data.mesh
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    triangles = np.asarray(mesh.triangles, dtype=np.int64)
    logger.debug("surface of %d particles: %d vertices, %d triangles", len(x), len(vertices),
                 len(triangles))
    return vertices, triangles


def write_mesh(path: str | os.PathLike[str], vertices: np.ndarray, triangles: np.ndarray,
               fmt: str | None = None) -> Path:
    """Write a triangle mesh atomically as OBJ, PLY (binary) or VTK XML (``fmt``: a name of
    :data:`MESH_FORMATS`; default from the file extension); return ``path``."""
    p = Path(path)
    if fmt is None:
        ext = p.suffix.lower()
        fmt = next((k for k, v in MESH_FORMATS.items() if v == ext), None)
        if fmt is None:
            raise ValueError(
                f"mesh file {str(p)!r}: unknown extension; expected "
                f"{', '.join(MESH_FORMATS.values())}"
            )
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if fmt == "obj":
        lines = ["# sphkit surface mesh"]
        lines += [f"v {a!r} {b!r} {c!r}" for a, b, c in v.tolist()]
        lines += [f"f {a} {b} {c}" for a, b, c in (f + 1).tolist()]
        atomic_write_bytes(p, ("\n".join(lines) + "\n").encode("ascii"))
    elif fmt == "ply":
        header = (
            "ply\nformat binary_little_endian 1.0\ncomment sphkit surface mesh\n"
            f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
        )
        face = np.empty(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        face["n"] = 3
        face["i"] = f
        atomic_write_bytes(p, header.encode("ascii") + v.astype("<f4").tobytes()
                           + face.tobytes())
    elif fmt == "vtk":
        import meshio

        with atomic_path(p) as tmp:
            cells = [("triangle", f)] if len(f) else []
            meshio.write(tmp, meshio.Mesh(v, cells), file_format="vtu", binary=True,
                         compression=None)
    else:
        raise ValueError(f"mesh format {fmt!r}; expected one of {', '.join(MESH_FORMATS)}")
    return p
