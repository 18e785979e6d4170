"""Rigid bodies coupled two-way with the fluid through boundary particles: Akinci et al. 2012,
"Versatile rigid-fluid coupling for incompressible SPH", ACM TOG 31(4).

A body is a closed triangle mesh whose surface is sampled into boundary particles (one layer,
:func:`sphkit.geometry.mesh_sampling.sample_mesh_surface`). Three kinds:

* static: the particles never move (handled as any static wall);
* kinematic: a prescribed motion, constant velocity ``v`` of the pivot ``c0`` and constant
  angular velocity ``omega`` about it: ``x(t) = c0 + v t + R(t) (x(0) - c0)``,
  ``R(t) = exp([omega] t)``; the boundary velocity is ``v + omega x (x - c(t))``;
* dynamic: mass ``M = rho V`` and inertia tensor (body frame, about the centre of mass) of the
  closed mesh (trimesh mass properties), moved by gravity, the fluid and contacts.

Particles of a moving body keep the Akinci volume of Eq. (4) computed once in its body frame from
its own particles only, ``V_b = 1 / sum_k W_bk`` (the sum over the body's particles; the sampling
does not change as the body moves; :func:`sphkit.boundary.akinci2012.boundary_volumes`). Each step
their positions and velocities (boundary fields ``x``, ``v``; the solvers read ``v`` in their
divergence terms) follow the body's pose, and the boundary grid is rebuilt.

Density and volume maps (:mod:`sphkit.boundary.maps`, "Moving rigid bodies"): a body has no
particles of its own; each step the map model writes one virtual boundary particle per fluid
particle near the body (boundary fields ``x``, ``V``, ``v`` the body's surface velocity,
``rigid_body`` the body's number, ``pressure_mirror`` 0), and :meth:`RigidBodies.fluid_forces`
and :meth:`RigidBodies.response` sum the same reactions over them (the solvers treat a
virtual particle as any boundary particle, so momentum is conserved to round-off as well). The
contact points of such a body are its mesh vertices only; :meth:`RigidBodies.place` leaves the
virtual particles to the map model.

2D: a body is the section of its mesh with z = 0 and moves in the xy-plane; vectors stay 3D
internally with z = 0 (angular velocity (0, 0, w)), mass and polar moment per metre of depth
come from the section (:func:`sphkit.geometry.meshes.section_mass_properties`), its contact
points are the ends of the section's segments, and the compiled passes read and write the (2, N)
fields. Measured (tests/test_rigid_2d.py): momentum exchange to round-off, a floating square 0.48
submerged, a heavy square (density 2000) sinks and rests flat on the floor.

The package, one concern a module:

* :mod:`sphkit.boundary.rigid.bodies` -- :class:`RigidBody`, and :class:`RigidBodies`: set-up,
  poses, time integration and checkpoint state;
* :mod:`sphkit.boundary.rigid.coupling` -- the fluid's force and torque on the bodies, the
  strong coupling of the pressure solves and the bodies' predicted velocities (the base class
  :class:`~sphkit.boundary.rigid.coupling.FluidCoupling` of :class:`RigidBodies`);
* :mod:`sphkit.boundary.rigid.contacts` -- contacts with walls and between bodies (projected
  Gauss-Seidel; the base class :class:`~sphkit.boundary.rigid.contacts.BodyContacts`);
* :mod:`sphkit.boundary.rigid.joints_catto2005` -- hinge joints with target-velocity motors,
  solved with the contacts by sequential impulses (Catto 2005; the base class
  :class:`~sphkit.boundary.rigid.joints_catto2005.BodyJoints`);
* :mod:`sphkit.boundary.rigid.construction` -- bodies from meshes (mass properties) and their
  particles moved into the mesh (:data:`INSET`, :func:`inset_samples`).
"""

from __future__ import annotations

from sphkit.boundary.rigid.bodies import RigidBodies, RigidBody
from sphkit.boundary.rigid.construction import (
    INSET,
    body_from_mesh,
    inset_depth,
    inset_samples,
)
from sphkit.boundary.rigid.contacts import body_sdf, box_wall, mesh_wall
from sphkit.boundary.rigid.joints_catto2005 import Joint, hinge

__all__ = ["INSET", "Joint", "RigidBodies", "RigidBody", "body_from_mesh", "body_sdf", "box_wall",
           "hinge", "inset_depth", "inset_samples", "mesh_wall"]
