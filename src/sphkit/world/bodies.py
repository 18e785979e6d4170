"""The rigid bodies of a world: the scene's kinematic and dynamic meshes, and the static walls
that dynamic bodies collide with (:mod:`sphkit.boundary.rigid`)."""

from __future__ import annotations

import numpy as np

from sphkit.boundary.rigid import RigidBodies, body_from_mesh, box_wall, inset_depth, mesh_wall
from sphkit.boundary.rigid.joints_catto2005 import hinge
from sphkit.core.state import SimState
from sphkit.scene.schema import Scene, SceneError
from sphkit.world.meshes import SceneMeshes
from sphkit.world.walls import gravity_axis, moving_meshes


def rigid_bodies(state: SimState, scene: Scene, meshes: SceneMeshes) -> RigidBodies:
    """The moving bodies of the scene (boundary field ``rigid_body`` numbers them from 1 in
    the order of :func:`sphkit.world.walls.moving_meshes`) and their joints, not yet
    initialised."""
    bodies = []
    moving = moving_meshes(scene)
    for k in moving:
        mb = scene.meshes[k]
        try:
            bodies.append(body_from_mesh(f"meshes[{k}]", meshes.mesh(k), mb.dynamic, mb.density,
                                         mb.velocity, mb.angular_velocity,
                                         mb.rotation_center, mb.friction, state.dim,
                                         mb.restitution))
        except ValueError as e:
            raise SceneError(f"meshes[{k}].geometry_file: {mb.geometry_file!r}: {e}") from None
    walls = []
    if any(b.dynamic for b in bodies):
        dim = state.dim
        up = gravity_axis(state) if np.any(state.gravity) else 2
        for k, box in enumerate(scene.boxes):
            lo = list(box.min) + [-np.inf] * (3 - dim)  # 2D: no walls along z
            hi = list(box.max) + [np.inf] * (3 - dim)
            walls.append((box_wall(lo, hi, up if box.open_top else None), f"boxes[{k}]"))
        for k, mb in enumerate(scene.meshes):
            if k not in moving:
                walls.append((mesh_wall(meshes.mesh(k), mb.invert, state.r), f"meshes[{k}]"))
    joints = []
    for k, jc in enumerate(scene.joints):  # a static mesh is fixed in space: body -1
        a, b = (moving.index(i) if i in moving else -1 for i in jc.bodies)
        m = jc.motor
        pos = list(jc.position[:2]) + [0.0] if state.dim == 2 else jc.position  # the plane
        joints.append(hinge(f"joints[{k}]", bodies, a, b, pos, jc.axis,
                            None if m is None else m.target_velocity,
                            None if m is None else m.target_sequence,
                            False if m is None else m.repeat))
    return RigidBodies(bodies, walls, margin=inset_depth(state.dim) * state.r,
                       meshes=[meshes.mesh(k) for k in moving], joints=joints,
                       contact_tolerance=scene.configuration.contact_tolerance)
