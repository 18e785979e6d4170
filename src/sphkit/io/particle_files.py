"""Particle files as fluid initial states: BGEO (partio/Houdini), PLY and VTK/VTU point clouds.

A scene's ``fluid_files`` (SPlisHSPlasH's ``FluidModels`` with a ``particleFile``) name a file
of particle positions, optionally with velocities, that becomes fluid. The file is placed as
SPlisHSPlasH places it (``Utilities/PartioReaderWriter.cpp``, ``SimulatorBase::initFluidData``):

    x = R(axis, angle) (s x_file) + translation

with one uniform scale factor ``s`` (SPlisHSPlasH uses the first component of its ``scale``
vector) and the rotation by ``angle`` radians about ``axis``. The particles' initial velocity is
``v0 + omega x (x - x_c)`` with ``x_c`` the mean position of the file's particles, also as
SPlisHSPlasH does (it overwrites the velocities stored in the file); sphkit's own scenes may
keep the file's ``velocity`` attribute instead (``use_file_velocity``).

Formats, by the file name:

============================  ======================================================
``.bgeo``, ``.bgeo.gz``,      classic BGEO, plain or gzip-compressed
``.bhclassic``, ``.geo.gz``   (:mod:`sphkit.io.bgeo`); ``position`` and ``velocity``
``.ply``                      PLY point cloud (meshio): ``x y z``, velocity from
                              ``vx vy vz`` or ``velocity_x ..``
``.vtu``, ``.vtk``, ``.vtp``  VTK XML or legacy (meshio): the points, velocity from the
                              point data ``velocity`` (or ``v``)
============================  ======================================================

The frames sphkit writes are such files, so a frame of one run can start another. The mass of
the particles is that of the scene's lattice (spacing 2r), so the file should be sampled at that
spacing; :func:`spacing_warning` says when it is not.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from sphkit.geometry.rotations import rotation_matrix
from sphkit.io.bgeo import read_bgeo

logger = logging.getLogger("sphkit.io")

#: file name endings read by :func:`read_particle_file`, and the reader used
PARTICLE_FILE_SUFFIXES: dict[str, str] = {
    ".bgeo": "bgeo", ".bgeo.gz": "bgeo", ".bhclassic": "bgeo", ".bhclassic.gz": "bgeo",
    ".ply": "ply", ".vtu": "vtu", ".vtk": "vtk", ".vtp": "vtp",
}
_VELOCITY_NAMES = ("velocity", "v", "vel")


class ParticleFileError(ValueError):
    """A particle file that cannot be read; the message names the file and the problem."""


def particle_file_kind(path: str | os.PathLike[str]) -> str | None:
    """The reader for ``path`` by its name ('bgeo', 'ply', 'vtu', 'vtk', 'vtp'), or None."""
    name = Path(path).name.lower()
    for suffix in sorted(PARTICLE_FILE_SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return PARTICLE_FILE_SUFFIXES[suffix]
    return None


def _join_components(pd: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """PLY properties ``vx vy vz`` and ``<name>_x _y _z`` -> (N, 3) arrays."""
    out: dict[str, np.ndarray] = {}
    groups = {"velocity": ("vx", "vy", "vz")}
    for name in list(pd):
        if name.endswith("_x"):
            base = name[:-2]
            groups[base] = (name, f"{base}_y", f"{base}_z")
    used: set[str] = set()
    for base, comps in groups.items():
        if all(c in pd for c in comps):
            out[base] = np.column_stack([np.asarray(pd[c]) for c in comps])
            used.update(comps)
    for name, a in pd.items():
        if name not in used:
            out[name] = np.asarray(a)
    return out


def read_particle_file(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read a particle file: ``{"position": (N, 3), "velocity": (N, 3) if present, ...}``.

    Raises:
        ParticleFileError: the file is missing, its format is unknown (the message lists the
            known endings) or it cannot be parsed.
    """
    p = Path(path)
    kind = particle_file_kind(p)
    if kind is None:
        raise ParticleFileError(
            f"particle file {str(p)!r}: unknown format; expected a name ending in "
            f"{', '.join(PARTICLE_FILE_SUFFIXES)}"
        )
    if not p.is_file():
        raise ParticleFileError(f"particle file {str(p)!r}: not found")
    try:
        if kind == "bgeo":
            data = read_bgeo(p)
            assert isinstance(data, dict)
        else:
            import meshio

            try:
                mesh = meshio.read(p, file_format=kind)
            except Exception as e:  # meshio raises many kinds of errors on bad input
                raise ParticleFileError(
                    f"particle file {str(p)!r}: cannot be read as {kind.upper()}: {e}"
                ) from None
            data = {"position": np.asarray(mesh.points, dtype=float)}
            data.update(_join_components(dict(mesh.point_data)))
    except OSError as e:
        raise ParticleFileError(f"particle file {str(p)!r}: {e.strerror or e}") from None
    except ValueError as e:
        if isinstance(e, ParticleFileError):
            raise
        raise ParticleFileError(str(e)) from None
    pos = data["position"]
    if pos.ndim != 2 or pos.shape[1] not in (2, 3):
        raise ParticleFileError(
            f"particle file {str(p)!r}: positions of shape {pos.shape}; expected (N, 3)"
        )
    if pos.shape[1] == 2:
        data["position"] = np.column_stack([pos, np.zeros(len(pos))])
    if "velocity" not in data:
        for alias in _VELOCITY_NAMES[1:]:
            if alias in data and np.ndim(data[alias]) == 2:
                data["velocity"] = data.pop(alias)
                break
    v = data.get("velocity")
    if v is not None and (v.ndim != 2 or v.shape[0] != len(pos) or v.shape[1] not in (2, 3)):
        raise ParticleFileError(
            f"particle file {str(p)!r}: velocity of shape {v.shape}; expected ({len(pos)}, 3)"
        )
    if not np.all(np.isfinite(data["position"])):
        raise ParticleFileError(f"particle file {str(p)!r}: positions that are NaN or infinite")
    return data


def place_particles(points: np.ndarray, translation: list[float] | np.ndarray, scale: float,
                    rotation_axis: list[float] | np.ndarray, rotation_angle: float) -> np.ndarray:
    """``R (scale x) + translation`` for every row of ``points`` (N, 3) -> (N, 3) float64."""
    x = np.asarray(points, dtype=float) * float(scale)
    R = rotation_matrix(rotation_axis, rotation_angle)
    return x @ R.T + np.asarray(translation, dtype=float)


def initial_velocity(x: np.ndarray, velocity: list[float] | np.ndarray | None,
                     angular_velocity: list[float] | np.ndarray | None) -> np.ndarray:
    """``v0 + omega x (x - mean(x))`` for positions ``x`` (N, 3) -> (N, 3)."""
    v = np.zeros_like(x, dtype=float)
    if velocity is not None:
        v += np.asarray(velocity, dtype=float)[None, :]
    if angular_velocity is not None and np.any(angular_velocity) and len(x):
        v += np.cross(np.asarray(angular_velocity, dtype=float)[None, :], x - x.mean(axis=0))
    return v


def median_spacing(points: np.ndarray) -> float | None:
    """Median distance from a particle to its nearest neighbour (None below 2 particles)."""
    if len(points) < 2:
        return None
    from scipy.spatial import cKDTree

    d, _ = cKDTree(points).query(points, k=2)
    return float(np.median(d[:, 1]))


def spacing_warning(points: np.ndarray, r: float, what: str, tol: float = 0.1) -> str | None:
    """A message when the particles' median nearest-neighbour distance differs from 2r by more
    than ``tol`` (relative): their lattice mass would then give the wrong density."""
    s = median_spacing(points)
    if s is None or abs(s / (2.0 * r) - 1.0) <= tol:
        return None
    return (
        f"{what}: the particles are {s:.4g} m apart (median nearest-neighbour distance), not the "
        f"2r = {2 * r:.4g} m of the scene's particle radius; their mass assumes 2r, so the fluid "
        f"starts at about {100 * (2 * r / s) ** points.shape[1]:.0f}% of its rest density"
    )


def load_fluid_particles(path: str | os.PathLike[str], dim: int, *,
                         translation: list[float] | None = None, scale: float = 1.0,
                         rotation_axis: list[float] | None = None, rotation_angle: float = 0.0,
                         velocity: list[float] | None = None,
                         angular_velocity: list[float] | None = None,
                         use_file_velocity: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Read ``path`` and place its particles; return positions and velocities, each (N, dim).

    See the module docstring for the placement and the velocities. In 2D the z components are
    dropped (the particles should lie in the plane z = 0).

    Raises:
        ParticleFileError: the file cannot be read, or ``use_file_velocity`` is set and the file
            has no velocity.
    """
    data = read_particle_file(path)
    x = place_particles(data["position"], translation or [0.0, 0.0, 0.0], scale,
                        rotation_axis or [1.0, 0.0, 0.0], rotation_angle)
    if use_file_velocity:
        if "velocity" not in data:
            raise ParticleFileError(
                f"particle file {str(path)!r}: no velocity attribute, but the scene asks for "
                "the file's velocities (use_file_velocity); attributes: "
                f"{', '.join(k for k in data if k != 'position')}"
            )
        vf = np.asarray(data["velocity"], dtype=float)
        if vf.shape[1] == 2:
            vf = np.column_stack([vf, np.zeros(len(vf))])
        v = vf @ rotation_matrix(rotation_axis or [1.0, 0.0, 0.0], rotation_angle).T
        v = v + initial_velocity(x, velocity, angular_velocity)
    else:
        v = initial_velocity(x, velocity, angular_velocity)
    logger.info("read %d particles from %s", len(x), path)
    return x[:, :dim].copy(), v[:, :dim].copy()
