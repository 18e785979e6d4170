"""Rigid bodies: their state, poses and time integration (:class:`RigidBody`,
:class:`RigidBodies`; the method is described in :mod:`sphkit.boundary.rigid`).

Kinematic bodies follow their prescribed motion, ``c(t) = c0 + v t`` and
``R(t) = exp([omega] t)`` (:func:`sphkit.geometry.rotations.rotation_exp`).

Dynamic bodies are advanced with symplectic Euler on linear and angular momentum:
``v += dt (F / M + g)``, ``omega += dt I_w^-1 (T - omega x I_w omega)`` with the world inertia
``I_w = R I R^T``, then contacts, then ``c += dt v``, ``R <- exp([omega] dt) R``.

Each step :meth:`RigidBodies.place` moves the bodies' boundary particles to the new poses. The
motion state (centres, rotations, velocities, last forces) goes into checkpoints as plain lists
(:meth:`RigidBodies.state`), so that a restored run continues bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from sphkit.boundary.akinci2012 import boundary_volumes
from sphkit.boundary.rigid.contacts import BodyContacts
from sphkit.boundary.rigid.coupling import FluidCoupling
from sphkit.boundary.rigid.joints_catto2005 import BodyJoints, Joint
from sphkit.core.methods import BoundaryModel
from sphkit.core.state import SimState
from sphkit.core.timestep import max_speed
from sphkit.geometry.rotations import rotation_exp

_JIT = dict(cache=True, fastmath=True)


@numba.njit(parallel=True, **_JIT)
def _pose(xl, body, c, R, v, w, x, bv):
    """World positions and velocities of the particles of moving bodies (body id > 0):
    ``x = c + R x_l``, ``v_b = v + omega x (R x_l)``; c, v, w, R 3D, the fields (dim, N) (2D:
    the third coordinate is 0, the body turns about z)."""
    dim = x.shape[0]
    for b in numba.prange(x.shape[1]):
        k = body[b] - 1
        if k < 0:
            continue
        l2 = xl[2, b] if dim == 3 else 0.0
        r0 = R[k, 0, 0] * xl[0, b] + R[k, 0, 1] * xl[1, b] + R[k, 0, 2] * l2
        r1 = R[k, 1, 0] * xl[0, b] + R[k, 1, 1] * xl[1, b] + R[k, 1, 2] * l2
        r2 = R[k, 2, 0] * xl[0, b] + R[k, 2, 1] * xl[1, b] + R[k, 2, 2] * l2
        x[0, b] = c[k, 0] + r0
        x[1, b] = c[k, 1] + r1
        bv[0, b] = v[k, 0] + w[k, 1] * r2 - w[k, 2] * r1
        bv[1, b] = v[k, 1] + w[k, 2] * r0 - w[k, 0] * r2
        if dim == 3:
            x[2, b] = c[k, 2] + r2
            bv[2, b] = v[k, 2] + w[k, 0] * r1 - w[k, 1] * r0


@dataclass
class RigidBody:
    """One moving body (kinematic or dynamic); vectors in world coordinates, SI units.

    ``c`` is the centre of mass (dynamic) or the pivot (kinematic), ``R`` the rotation from the
    body frame, ``v`` / ``omega`` the velocity of c and the angular velocity. ``force`` and
    ``torque`` (about c) are the fluid's on the body in the last step."""

    name: str
    dynamic: bool
    c: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    mass: float = 0.0  #: [kg] (dynamic)
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  #: body frame [kg m^2]
    friction: float = 0.5
    restitution: float = 0.0  #: of its contacts (the normal speed it leaves a contact with)
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    c0: np.ndarray | None = None  #: kinematic: pivot at t = 0
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: np.ndarray = field(default_factory=lambda: np.zeros(3))
    #: the last step's statistics of the joints the body takes part in (:class:`Joint.stats`)
    joints: list[dict] = field(default_factory=list)
    #: c at t = 0, where R is the identity: a mesh vertex v of the scene is at
    #: ``R (v - origin) + c`` (kept through checkpoints: it is the construction's)
    origin: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.origin is None:
            self.origin = np.array(self.c, dtype=np.float64)

    def world_inertia(self) -> np.ndarray:
        """``I_w = R I R^T`` [kg m^2]."""
        return self.R @ self.inertia @ self.R.T

    def stats(self) -> dict:
        """Plain-dict state for step statistics (lists of floats): the pose is ``position`` (c)
        and ``rotation`` (R, row-major 3x3), so that a point of the body is at
        ``x = R x_body + c`` (``x_body``: its position in the body frame, which is the scene
        placement at t = 0 minus the t = 0 position). A body with joints lists them in
        ``joints``: each joint's ``relative_angular_velocity`` about its axis (``(w_A - w_B) .
        a`` [rad/s]), its point ``force`` on its first body [N] and, with a motor, its
        ``target_velocity`` and ``motor_torque`` [N m]
        (:meth:`sphkit.boundary.rigid.joints_catto2005.Joint.stats`)."""
        out = {"name": self.name, "force": self.force.tolist(), "torque": self.torque.tolist(),
               "position": self.c.tolist(), "rotation": self.R.tolist(),
               "velocity": self.v.tolist(), "angular_velocity": self.omega.tolist()}
        if self.joints:
            out["joints"] = self.joints
        return out


class RigidBodies(FluidCoupling, BodyContacts, BodyJoints):
    """The moving bodies of a scene, their boundary particles (boundary fields ``rigid_body``:
    1-based body number, 0 for static walls; ``x_body``: position in the body frame) and the
    walls they collide with. The coupling to the fluid comes from the base class
    :class:`~sphkit.boundary.rigid.coupling.FluidCoupling`, the contacts from
    :class:`~sphkit.boundary.rigid.contacts.BodyContacts`, the joints from
    :class:`~sphkit.boundary.rigid.joints_catto2005.BodyJoints`.

    Args:
        bodies: the bodies, numbered 1.. in this order in the boundary field ``rigid_body``.
        walls: static obstacles for contacts as ``(distance(p (3, K)) -> (K,), name)``, where
            the distance is positive in free space, negative inside the wall.
        meshes: the closed mesh of each body as placed in the scene at t = 0 (trimesh): its
            vertices are contact points and its signed distance (a lattice in the body frame)
            is what other bodies collide with. Without meshes the bodies only meet the walls.
        margin: distance [m] the particles keep from the walls: the depth they were moved into
            the mesh (:func:`sphkit.boundary.rigid.construction.inset_samples`), so that the
            mesh surface stops at the wall.
        contact_iterations: Gauss-Seidel sweeps over the contact points and joints per step.
        contact_tolerance: the gap [m] the meshes keep from the walls and from each other, on
            top of ``margin`` (scene ``configuration.contact_tolerance``; SPlisHSPlasH's
            PositionBasedDynamics ``contactTolerance``).
        joints: hinges between the bodies (:func:`sphkit.boundary.rigid.joints_catto2005.hinge`;
            body index -1: a static wall); two moving bodies joined by one do not collide.
    """

    def __init__(self, bodies: list[RigidBody], walls: list | None = None,
                 margin: float = 0.0, contact_iterations: int = 20,
                 meshes: list | None = None, joints: list[Joint] | None = None,
                 contact_tolerance: float = 0.0) -> None:
        self.bodies = bodies
        self.contact_tolerance = float(contact_tolerance)
        self.joints = joints or []
        self.meshes = meshes or []
        self.margin = margin
        self.walls = walls or []
        self.contact_iterations = contact_iterations
        self._ab: np.ndarray | None = None  # _boundary_accel's buffer
        #: the bodies whose motion stopped being finite in the last :meth:`advance` (names;
        #: the simulation's stability guard stops the run naming them)
        self.diverged: list[str] = []
        self.boundary_model: BoundaryModel | None = None  # rebuilt when the bodies moved

    def divergence(self) -> str:
        """What the simulation's stability guard says of :attr:`diverged` ('' for none)."""
        if not self.diverged:
            return ""
        return f"the motion of the rigid body {', '.join(self.diverged)} is not finite"

    def bind(self, boundary_model: BoundaryModel, state: SimState) -> None:
        """The boundary model whose structures follow the bodies (after :meth:`init`): it
        learns the bodies (maps query the moving meshes in the bodies' frames) and is rebuilt
        now and whenever :meth:`advance` has moved them."""
        self.boundary_model = boundary_model
        if self.bodies:
            boundary_model.bind_bodies(self.bodies)
            boundary_model.rebuild(state)

    def max_speed(self, state: SimState) -> float:
        """The fastest boundary particle [m/s] when bodies move (0 without bodies), for the
        CFL condition."""
        return max_speed(state.boundary["v"], None) if self.bodies else 0.0

    @property
    def any_dynamic(self) -> bool:
        """Whether any body is dynamic (moved by the fluid, gravity and contacts)."""
        return any(b.dynamic for b in self.bodies)

    # -- setup ----------------------------------------------------------------------------------
    def init(self, state: SimState) -> None:
        """Body-frame coordinates and Akinci volumes of each body's own particles; velocities."""
        bd = state.boundary
        bd.register("x_body", "vector")
        body = bd["rigid_body"]  # (the static walls' volumes are the boundary model's)
        for k, rb in enumerate(self.bodies):
            sel = np.flatnonzero(body == k + 1)
            xs = bd["x"][:, sel]
            dim = state.dim
            bd["x_body"][:, sel] = rb.R[:dim, :dim].T @ (xs - rb.c[:dim, None])
            xl = np.ascontiguousarray(bd["x_body"][:, sel])
            bd["V"][sel] = boundary_volumes(xl, state.h, state.kid, state.dim)
        self._sel = [np.flatnonzero(body == k + 1) for k in range(len(self.bodies))]
        # bodies without particles (density / volume maps): the map model writes the virtual
        # boundary particles' positions and velocities each step, place() leaves them alone
        self._particles = bool(np.any(body > 0))
        self._init_contacts(state)
        self.place(state)

    def place(self, state: SimState) -> None:
        """Boundary positions and velocities from the bodies' poses."""
        if not self.bodies or not self._particles:
            return
        bd = state.boundary
        c = np.array([b.c for b in self.bodies])
        R = np.array([b.R for b in self.bodies])
        v = np.array([b.v for b in self.bodies])
        w = np.array([b.omega for b in self.bodies])
        _pose(bd["x_body"], bd["rigid_body"], c, R, v, w, bd["x"], bd["v"])

    # -- checkpoints ----------------------------------------------------------------------------
    def state(self) -> list[dict]:
        """The bodies' motion state (JSON-ready; floats round-trip exactly)."""
        return [{"c": b.c.tolist(), "R": b.R.tolist(), "v": b.v.tolist(),
                 "omega": b.omega.tolist(), "force": b.force.tolist(),
                 "torque": b.torque.tolist()} for b in self.bodies]

    def set_state(self, state: list[dict]) -> None:
        """Restore :meth:`state` (the boundary fields are restored with the particle set)."""
        if len(state) != len(self.bodies):
            raise ValueError(f"{len(state)} rigid body state(s) for {len(self.bodies)} bodies")
        for b, s in zip(self.bodies, state, strict=True):
            b.c, b.R, b.v, b.omega = (np.array(s[k], dtype=np.float64)
                                      for k in ("c", "R", "v", "omega"))
            b.force = np.array(s["force"], dtype=np.float64)
            b.torque = np.array(s["torque"], dtype=np.float64)

    # -- time integration -----------------------------------------------------------------------
    def advance(self, state: SimState, dt: float, time: float) -> None:
        """Move the bodies from ``time`` to ``time + dt`` and place their particles: forces,
        then the contacts and joints of all bodies at once (:meth:`_contact_rows`,
        :meth:`_constrain`), then the poses; then the
        bound boundary model is rebuilt (nothing happens without bodies)."""
        self.diverged = []
        if not self.bodies:
            return
        g = np.zeros(3)
        g[: state.dim] = state.gravity
        Iinv = np.zeros((len(self.bodies), 3, 3))
        for k, b in enumerate(self.bodies):
            if b.dynamic:
                Iw = b.world_inertia()
                Iinv[k] = np.linalg.inv(Iw)
                b.v = b.v + dt * (b.force / b.mass + g)
                b.omega = b.omega + dt * (Iinv[k] @ (b.torque - np.cross(b.omega, Iw @ b.omega)))
        if self.any_dynamic:  # contacts and joints
            v = np.array([b.v for b in self.bodies], dtype=np.float64)
            w = np.array([b.omega for b in self.bodies], dtype=np.float64)
            inv_m = np.array([1.0 / b.mass if b.dynamic else 0.0 for b in self.bodies])
            rows = self._contact_rows(state, v, w, dt)
            self._constrain(rows, inv_m, Iinv, v, w, dt, time, state.dim)
            for k, b in enumerate(self.bodies):
                if b.dynamic:
                    b.v, b.omega = v[k].copy(), w[k].copy()
                if self.joints:
                    b.joints = self.joint_stats(k)
        for b in self.bodies:
            if not b.dynamic:
                b.R = rotation_exp(b.omega, time + dt)
                b.c = b.c0 + b.v * (time + dt)
                continue
            b.c = b.c + dt * b.v
            R = rotation_exp(b.omega, dt) @ b.R
            if not np.all(np.isfinite(R)) or not np.all(np.isfinite(b.c)):
                self.diverged.append(b.name)  # its particles stay; the step's guard stops
                continue
            u, _s, vt = np.linalg.svd(R)  # keep R orthonormal
            b.R = u @ vt
        if self.diverged:
            return
        self.place(state)
        if self.bodies and self.boundary_model is not None:  # the boundary grid follows
            self.boundary_model.rebuild(state)
