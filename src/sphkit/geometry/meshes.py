"""Triangle meshes: mesh files placed in the scene, and sections of meshes with the plane z = 0.

:func:`load_mesh` reads OBJ, PLY, STL, ... files (trimesh) and places them as SPlisHSPlasH does,
``x = R (s * x0) + t`` (:func:`sphkit.geometry.rotations.rotation_matrix`). A 2D scene uses the
section of each mesh with z = 0: :func:`section_segments` gives its segments as they come,
:func:`oriented_section` oriented with the solid on their left, and
:func:`section_mass_properties` the area, centroid and polar moment of the enclosed region
(Green's theorem), the mass properties of a 2D rigid body per metre of depth.
:func:`open_flux` tells whether a mesh that is not watertight still encloses a volume (cracks
along seams that do not join topologically).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sphkit.geometry import GeometryError
from sphkit.geometry.rotations import rotation_matrix

if TYPE_CHECKING:  # trimesh is imported where a mesh is read (35 MB, 1.6 s to import)
    import trimesh

ArrayLike = Sequence[float] | np.ndarray
#: the farthest a placed mesh vertex may lie from the origin [m]
MAX_COORDINATE = 1e9


def _read_triangles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a mesh file, without materials or textures.

    ``trimesh.load(..., force="mesh")`` copies the visuals, which needs Pillow for textured OBJ
    files; reading the geometry (and a scene's node transforms) directly does not.
    """
    import trimesh

    loaded = trimesh.load(path)
    if isinstance(loaded, trimesh.Trimesh):
        return np.array(loaded.vertices, dtype=np.float64), np.array(loaded.faces, dtype=np.int64)
    vertices, faces, offset = [], [], 0
    if isinstance(loaded, trimesh.Scene):
        for node in loaded.graph.nodes_geometry:
            transform, name = loaded.graph[node]
            geom = loaded.geometry[name]
            if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
                continue
            v = np.asarray(geom.vertices, dtype=np.float64)
            vertices.append(v @ transform[:3, :3].T + transform[:3, 3])
            faces.append(np.asarray(geom.faces, dtype=np.int64) + offset)
            offset += len(v)
    if not faces:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    return np.concatenate(vertices), np.concatenate(faces)


def _check_stl(p: Path) -> None:
    """An ``.stl`` file is ASCII (``solid ...``) or binary: 80 header bytes, a triangle count n
    and 50 bytes per triangle; anything else is refused naming the file."""
    if p.suffix.lower() != ".stl":
        return
    try:
        size = p.stat().st_size
        with open(p, "rb") as f:
            head = f.read(84)
    except OSError as err:
        raise GeometryError(f"mesh file {str(p)!r}: cannot be read ({err.strerror})") from None
    if head.lstrip()[:5].lower() == b"solid" and size != 84 + 50 * int.from_bytes(
            head[80:84], "little"):
        return  # ASCII STL (binary files may start with "solid" too: their size tells)
    n = int.from_bytes(head[80:84], "little") if len(head) == 84 else -1
    if n < 0 or size != 84 + 50 * n:
        raise GeometryError(
            f"mesh file {str(p)!r}: not an STL file: neither ASCII ('solid ...') nor binary "
            f"({size} bytes; a binary STL of {max(n, 0)} triangles has "
            f"{84 + 50 * max(n, 0)} bytes)")


def load_mesh(
    path: str | Path,
    translation: ArrayLike = (0.0, 0.0, 0.0),
    rotation_axis: ArrayLike = (1.0, 0.0, 0.0),
    rotation_angle: float = 0.0,
    scale: ArrayLike | float = (1.0, 1.0, 1.0),
) -> trimesh.Trimesh:
    """Load a triangle mesh (OBJ, PLY, STL, ...) and place it in the scene.

    The transformation follows SPlisHSPlasH (``StaticBoundarySimulator``): the vertices are
    scaled when the file is read, then rotated by ``rotation_angle`` radians about
    ``rotation_axis``, then translated: ``x = R (s * x0) + t``.

    Args:
        path: mesh file.
        translation: translation t [m].
        rotation_axis: rotation axis (any length > 0; normalized here).
        rotation_angle: rotation angle [rad].
        scale: per-axis scale factors s (a number scales uniformly); none may be zero.

    Returns:
        A new :class:`trimesh.Trimesh` without visuals, duplicate vertices merged and
        duplicate faces kept once.

    Raises:
        GeometryError: naming the file: missing, unreadable, without triangles, or a bad
            transform.
    """
    import trimesh

    p = Path(path)
    if not p.is_file():
        raise GeometryError(f"mesh file {str(p)!r}: not found")
    _check_stl(p)
    try:
        vertices, faces = _read_triangles(p)
    except ImportError:  # trimesh guesses the text encoding of undecodable files with an extra
        raise GeometryError(f"mesh file {str(p)!r}: cannot be read as a triangle mesh: it is "
                            "neither a binary mesh nor UTF-8 text (a damaged or foreign file?)"
                            ) from None
    except Exception as err:  # trimesh raises many exception types for bad files
        raise GeometryError(
            f"mesh file {str(p)!r}: cannot be read as a triangle mesh ({str(err)[:200]})"
        ) from None
    if len(faces) == 0:
        raise GeometryError(f"mesh file {str(p)!r}: contains no triangles (not a triangle mesh)")
    s = np.broadcast_to(np.asarray(scale, dtype=np.float64).ravel(), (3,)).copy()
    if not np.all(np.isfinite(s)) or np.any(s == 0.0):
        raise GeometryError(f"mesh file {str(p)!r}: scale {s.tolist()} must be finite and "
                            "non-zero")
    t = np.asarray(translation, dtype=np.float64).ravel()
    if t.size != 3 or not np.all(np.isfinite(t)):
        raise GeometryError(f"mesh file {str(p)!r}: translation {t.tolist()} must be 3 finite "
                            "numbers")
    ax = np.asarray(rotation_axis, dtype=np.float64).ravel()
    if ax.size != 3:
        raise GeometryError(f"mesh file {str(p)!r}: rotation axis must have 3 components, "
                            f"got {ax.tolist()}")
    angle = float(rotation_angle)
    if angle != 0.0 and not np.linalg.norm(ax) > 0.0:
        raise GeometryError(f"mesh file {str(p)!r}: rotation axis {ax.tolist()} has zero "
                            "length")
    rot = rotation_matrix(ax, angle)
    # without visuals (texture seams split vertices); duplicate vertices merged
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces)
    unique = mesh.unique_faces()
    if not unique.all():  # a triangle listed more than once (SPlisHSPlasH's older sphere.obj
        # lists each three times) is one face: its area, samples and volume count once
        mesh.update_faces(unique)
        mesh.remove_unreferenced_vertices()
    transform = np.eye(4)
    transform[:3, :3] = rot @ np.diag(s)
    transform[:3, 3] = t
    mesh.apply_transform(transform)
    reach = float(np.max(np.abs(mesh.vertices))) if len(mesh.vertices) else 0.0
    if not reach <= MAX_COORDINATE:  # trimesh's geometry fails on overflowing coordinates
        raise GeometryError(
            f"mesh file {str(p)!r}: placed with scale {s.tolist()} and translation "
            f"{t.tolist()}, its vertices reach {reach:.3g} m; expected a mesh within "
            f"{MAX_COORDINATE:g} m of the origin")
    return mesh


def section_segments(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """The section of a mesh with the plane z = 0 as 2D segments a[e] -> b[e], each (E, 2)."""
    import trimesh

    segs = trimesh.intersections.mesh_plane(mesh, plane_normal=[0.0, 0.0, 1.0],
                                            plane_origin=[0.0, 0.0, 0.0])
    if len(segs) == 0:
        return np.empty((0, 2)), np.empty((0, 2))
    s = np.asarray(segs, dtype=np.float64)[:, :, :2]
    return s[:, 0].copy(), s[:, 1].copy()


def oriented_section(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """The section of a mesh with the plane z = 0 as 2D segments a -> b (E, 2), oriented so
    that the solid lies on their left (counter-clockwise loops), from the faces' normals."""
    import trimesh

    segs, faces = trimesh.intersections.mesh_plane(mesh, plane_normal=[0.0, 0.0, 1.0],
                                                   plane_origin=[0.0, 0.0, 0.0],
                                                   return_faces=True)
    if len(segs) == 0:
        return np.empty((0, 2)), np.empty((0, 2))
    s = np.asarray(segs, dtype=np.float64)[:, :, :2]
    a, b = s[:, 0].copy(), s[:, 1].copy()
    n = np.asarray(mesh.face_normals, dtype=np.float64)[faces, :2]  # outward
    d = b - a
    flip = d[:, 1] * n[:, 0] - d[:, 0] * n[:, 1] < 0.0  # the right normal (dy, -dx) points out
    a[flip], b[flip] = b[flip].copy(), a[flip].copy()
    return a, b


def section_mass_properties(mesh: trimesh.Trimesh) -> tuple[float, np.ndarray, float]:
    """Area [m^2], centroid (2,) and polar moment of area about the centroid [m^4] of the
    section of a closed mesh with z = 0 (Green's theorem over its oriented segments)."""
    a, b = oriented_section(mesh)
    cr = a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]
    area = 0.5 * float(cr.sum())
    if not area > 0.0:
        return 0.0, np.zeros(2), 0.0
    cx = float(((a[:, 0] + b[:, 0]) * cr).sum()) / (6.0 * area)
    cy = float(((a[:, 1] + b[:, 1]) * cr).sum()) / (6.0 * area)
    j = float(((a[:, 0] ** 2 + a[:, 0] * b[:, 0] + b[:, 0] ** 2 + a[:, 1] ** 2
                + a[:, 1] * b[:, 1] + b[:, 1] ** 2) * cr).sum()) / 12.0
    return area, np.array([cx, cy]), j - area * (cx * cx + cy * cy)


def open_flux(mesh: trimesh.Trimesh) -> float:
    """How far the volume of ``mesh`` by the divergence theorem depends on the origin: the net
    vector area ``|sum_f A_f n_f|`` (zero for a closed surface) times the mesh's diagonal over
    its volume. A mesh that is not watertight but whose faces close geometrically (seams of
    unjoined edges, T-junctions: zero net vector area) encloses a well-defined volume, and its
    mass properties are exact (0 here); a real hole of area A gives about ``A L / V``. Infinite
    when the volume is not positive."""
    va = (np.asarray(mesh.area_faces)[:, None] * np.asarray(mesh.face_normals)).sum(axis=0)
    vol = float(mesh.volume)
    if not vol > 0.0:
        return float("inf")
    return float(np.linalg.norm(va)) * float(np.linalg.norm(mesh.extents)) / vol
