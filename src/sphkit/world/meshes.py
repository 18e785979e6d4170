"""The meshes a scene names, each loaded once per world.

A scene names mesh files in ``meshes`` (walls and rigid bodies) and ``fluid_meshes`` (fluid
filling a mesh). Walls, maps, rigid bodies and their contact walls all need the same placed
mesh; :class:`SceneMeshes` loads each entry the first time it is asked for and keeps it, with
the paths resolved against the scene file's folder as the scene loader resolves them.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sphkit.geometry.meshes import load_mesh
from sphkit.scene.paths import resolve_scene_path
from sphkit.scene.schema import Scene

if TYPE_CHECKING:
    import trimesh


class SceneMeshes:
    """``mesh(k)``: ``scene.meshes[k]`` placed in the scene; ``fluid_mesh(k)``: the same for
    ``scene.fluid_meshes[k]`` (trimesh, loaded on first use)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self._meshes: dict[tuple[str, int], trimesh.Trimesh] = {}

    def path(self, file: str) -> Path:
        """A file named in the scene, resolved against the scene file's folder."""
        return resolve_scene_path(self.scene, file)

    def _load(self, kind: str, k: int, m) -> trimesh.Trimesh:
        key = (kind, k)
        if key not in self._meshes:
            self._meshes[key] = load_mesh(self.path(m.geometry_file), m.translation,
                                                   m.rotation_axis, m.rotation_angle, m.scale)
        return self._meshes[key]

    def mesh(self, k: int) -> trimesh.Trimesh:
        """``scene.meshes[k]`` placed in the scene."""
        return self._load("meshes", k, self.scene.meshes[k])

    def fluid_mesh(self, k: int) -> trimesh.Trimesh:
        """``scene.fluid_meshes[k]`` placed in the scene."""
        return self._load("fluid_meshes", k, self.scene.fluid_meshes[k])

    def particle_estimates(self, r: float, dim: int,
                           walls: bool) -> list[tuple[str, float]]:
        """The particles the scene's meshes will need, from their areas and bounding boxes
        (for :func:`sphkit.scene.checks.check_budget`, before anything is sampled): wall
        samples of ``meshes`` (with ``walls``, a particle boundary model) about ``2r`` apart
        on the surface (2D: along the section, at most the bounding box's perimeter), and the
        lattice of ``fluid_meshes`` over their bounding boxes."""
        d = 2.0 * r
        out = []
        if walls:
            for k in range(len(self.scene.meshes)):
                mesh = self.mesh(k)
                if dim == 3:
                    n = float(mesh.area) / (d * d)
                else:
                    ext = np.ptp(mesh.bounds[:, :2], axis=0)
                    n = 2.0 * float(ext.sum()) / d
                out.append((f"meshes[{k}]", max(n, 1.0)))
        for k in range(len(self.scene.fluid_meshes)):
            ext = np.ptp(self.fluid_mesh(k).bounds[:, :dim], axis=0)
            out.append((f"fluid_meshes[{k}]", math.prod(max(1.0, float(e) / d) for e in ext)))
        return out
