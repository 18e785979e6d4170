"""Rigid-body output: the moving bodies' meshes at their pose, one file per frame and format.

SPlisHSPlasH exports its rigid bodies beside the particles (``enableRigidBodyExport``,
``enableRigidBodyOBJExport``, ``enableRigidBodyVTKExport``); ParaView, Houdini and Blender then
show a floating box or a paddle with the fluid instead of a hole in it. sphkit writes the
scene's moving meshes (kinematic and dynamic, :mod:`sphkit.boundary.rigid`) with the pose of
each frame, ``x = R x_body + c`` (the bodies' ``rotation`` R and ``position`` c that the
manifest records; ``x_body`` the mesh vertex's position at t = 0 minus the body's centre then,
where R is the identity), all bodies of a frame in one file, atomically:

* ``"vtk"`` -- ``bodies_00042.vtu``, triangles with the cell data ``body`` (1-based, the
  order of the bodies in the manifest's ``rigid_bodies``, the boundary field ``rigid_body``),
  and ``bodies.vtu.series`` (ParaView's file series with the simulated times);
* ``"obj"`` -- ``bodies_00042.obj``, one object (``o meshes[k]``) per body (Houdini, Blender);
* ``"ply"`` -- ``bodies_00042.ply``, binary PLY with faces and the vertex property ``body``
  (:func:`write_body_ply`).

Static walls do not move and are not written (their meshes are the scene's files). In 2D the
bodies' 3D meshes are written (their z = 0 section is what the simulation samples). The frame
records of the manifest list the files under ``body_files``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from sphkit.io.atomic import atomic_open, atomic_path, atomic_write_text

#: body output format -> file extension
BODY_FORMATS: dict[str, str] = {"vtk": ".vtu", "obj": ".obj", "ply": ".ply"}

#: the body format written by default beside each particle format (``output.body_formats``
#: unset): VTK beside VTK, PLY beside PLY, OBJ beside Houdini's BGEO
DEFAULT_BODY_FORMAT: dict[str, str] = {"vtk": "vtk", "ply": "ply", "bgeo": "obj",
                                       "bgeo.gz": "obj"}


def body_formats(frame_formats: Sequence[str], chosen: Sequence[str] | None) -> list[str]:
    """The body formats of a run: ``chosen`` (the scene's ``output.body_formats``), else the
    defaults for its particle ``frame_formats``, each once."""
    names = list(chosen) if chosen is not None else [DEFAULT_BODY_FORMAT[f]
                                                     for f in frame_formats]
    return list(dict.fromkeys(names))


class BodyWriter:
    """Writes the moving bodies of a simulation at their pose, one file per frame and format.

    ``meshes``: each body's triangle mesh at t = 0 (vertices (V, 3), faces (F, 3)) in the order
    of ``sim.rigid.bodies``; ``centres``: each body's centre c at t = 0; ``names`` the bodies'
    names (``meshes[k]``)."""

    def __init__(self, out_dir: str | os.PathLike[str], formats: Sequence[str],
                 meshes: Sequence[Any], centres: Sequence[np.ndarray], names: Sequence[str],
                 prefix: str = "bodies") -> None:
        for f in formats:
            if f not in BODY_FORMATS:
                raise ValueError(f"body format {f!r}; expected one of {', '.join(BODY_FORMATS)}")
        self.out_dir = Path(out_dir)
        self.formats = list(formats)
        self.prefix = prefix
        self.local = [np.asarray(m.vertices, dtype=np.float64) - np.asarray(c, dtype=np.float64)
                      for m, c in zip(meshes, centres, strict=True)]
        self.faces = [np.asarray(m.faces, dtype=np.int64) for m in meshes]
        self.names = list(names)
        self._series: list[dict[str, Any]] = []

    @classmethod
    def of(cls, sim: Any, out_dir: str | os.PathLike[str],
           formats: Sequence[str]) -> BodyWriter | None:
        """The writer of ``sim``'s moving bodies (None: no moving body or no format)."""
        rigid = getattr(sim, "rigid", None)
        bodies = getattr(rigid, "bodies", None) or []
        if not bodies or not formats:
            return None
        return cls(out_dir, formats, rigid.meshes, [b.origin for b in bodies],
                   [b.name for b in bodies])

    def path(self, frame: int, fmt: str) -> Path:
        """The file of ``frame`` in ``fmt``: ``<out_dir>/bodies_00042.vtu``."""
        return self.out_dir / f"{self.prefix}_{frame:05d}{BODY_FORMATS[fmt]}"

    @property
    def series_path(self) -> Path:
        """ParaView's file-series index of the VTK body files."""
        return self.out_dir / f"{self.prefix}.vtu.series"

    def posed(self, bodies: Sequence[Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All bodies' vertices at their pose ``R x_body + c`` (V, 3), their faces (F, 3)
        numbered into them, and each face's 1-based body number (F,)."""
        points, faces, tags, start = [], [], [], 0
        for k, (body, local, tri) in enumerate(zip(bodies, self.local, self.faces,
                                                   strict=True)):
            points.append(local @ np.asarray(body.R).T + np.asarray(body.c))
            faces.append(tri + start)
            tags.append(np.full(len(tri), k + 1, dtype=np.int32))
            start += len(local)
        return np.concatenate(points), np.concatenate(faces), np.concatenate(tags)

    def write(self, sim: Any, frame: int) -> list[Path]:
        """Write the bodies of ``sim`` (``sim.rigid.bodies``, ``sim.time``) as frame ``frame``
        in every format; return the paths."""
        points, faces, tags = self.posed(sim.rigid.bodies)
        paths = []
        for fmt in self.formats:
            path = self.path(frame, fmt)
            if fmt == "obj":
                self._write_obj(path, points, faces, tags, frame, float(sim.time))
            elif fmt == "ply":
                write_body_ply(path, points, faces, tags,
                               comment=f"sphkit bodies frame {frame} time {float(sim.time)!r} s")
            else:  # vtk
                mesh = meshio.Mesh(points, [("triangle", faces)], cell_data={"body": [tags]})
                with atomic_path(path) as tmp:
                    meshio.write(tmp, mesh, file_format="vtu", binary=True, compression=None)
                self._series = [e for e in self._series if e["name"] != path.name]
                self._series.append({"name": path.name, "time": float(sim.time)})
                atomic_write_text(self.series_path, json.dumps(
                    {"file-series-version": "1.0", "files": self._series}, indent=1) + "\n")
            paths.append(path)
        return paths

    def _write_obj(self, path: Path, points: np.ndarray, faces: np.ndarray, tags: np.ndarray,
                   frame: int, time: float) -> None:
        with atomic_open(path, "w") as f:
            f.write(f"# sphkit rigid bodies, frame {frame}, time {time!r} s\n")
            np.savetxt(f, points, fmt="v %.9g %.9g %.9g")
            for k, name in enumerate(self.names):
                f.write(f"o {name}\n")
                np.savetxt(f, faces[tags == k + 1] + 1, fmt="f %d %d %d")

    def resume_after(self, frame: int) -> None:
        """Continue a series whose frames up to ``frame`` are on disk (a resumed run)."""
        try:
            entries = json.loads(self.series_path.read_text(encoding="utf-8")).get("files", [])
        except (OSError, ValueError, AttributeError):
            entries = []
        keep = {self.path(k, "vtk").name for k in range(frame + 1)}
        self._series = [e for e in entries if e.get("name") in keep]


def write_body_ply(path: str | os.PathLike[str], points: np.ndarray, faces: np.ndarray,
                   tags: np.ndarray, comment: str | None = None) -> Path:
    """Triangles as a binary little-endian PLY, atomically: the vertices (``double x, y, z``
    and ``int body``, the 1-based number of the body the vertex belongs to: the bodies share
    no vertex) and the faces (``vertex_indices``, 32-bit). ``tags``: each face's body number.
    meshio's PLY writer drops cell data and prints a warning for 64-bit indices; its reader
    (and ParaView's, Blender's, trimesh's) reads this file with ``body`` as point data."""
    points = np.asarray(points, dtype="<f8").reshape(-1, 3)
    faces = np.asarray(faces)
    if faces.size and (faces.min() < 0 or faces.max() >= len(points)):
        raise ValueError(f"body PLY: face indices {faces.min()}..{faces.max()} outside the "
                         f"{len(points)} vertices")
    vert = np.empty(len(points), dtype=np.dtype([("x", "<f8", (3,)), ("body", "<i4")]))
    vert["x"] = points
    vert["body"] = 0
    vert["body"][faces.ravel()] = np.repeat(np.asarray(tags), 3)
    rec = np.empty(len(faces), dtype=np.dtype([("n", "u1"), ("v", "<i4", (3,))]))  # packed
    rec["n"] = 3
    rec["v"] = faces
    header = ["ply", "format binary_little_endian 1.0"]
    if comment:
        header += [f"comment {line}" for line in comment.splitlines()]
    header += [f"element vertex {len(points)}", "property double x", "property double y",
               "property double z", "property int body", f"element face {len(faces)}",
               "property list uchar int vertex_indices", "end_header\n"]
    with atomic_open(path, "wb") as f:
        f.write("\n".join(header).encode("ascii"))
        f.write(vert.tobytes())
        f.write(rec.tobytes())
    return Path(path)
