"""Hinge joints and target-velocity motors between rigid bodies
(sphkit.boundary.rigid.joints_catto2005: sequential impulses, Catto 2005).

The dynamics tests drive :class:`~sphkit.boundary.rigid.RigidBodies` directly, without fluid
(bodies without boundary particles, as with volume maps); one scene test with a tiny fluid
checks the scene model end to end and a checkpoint restart.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from _wheel import wheel_scene

from sphkit.boundary.rigid import RigidBodies, RigidBody
from sphkit.boundary.rigid.joints_catto2005 import BETA, hinge, sequence_value
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.scene.files import load_scene
from sphkit.scene.schema import Scene, SceneError
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation

G = 9.81


def _state(g=(0.0, -G, 0.0)) -> SimState:
    dim = len(g)
    f, b = ParticleSet(dim), ParticleSet(dim)
    b.register("V", "scalar")
    b.register("v", "vector")
    b.register("rigid_body", "scalar", np.int64)
    return SimState(fluid=f, boundary=b, dim=dim, h=0.1, kid=0, r=0.025, rho0=1000.0,
                    gravity=np.array(g, dtype=np.float64))


def _box(name: str, c, m: float, ext) -> RigidBody:
    """A dynamic box of mass m [kg] and extents ext [m] centred at c."""
    a, b, d = ext
    inertia = m / 12.0 * np.diag([b * b + d * d, a * a + d * d, a * a + b * b])
    return RigidBody(name, True, np.array(c, dtype=np.float64), np.zeros(3), np.zeros(3),
                     mass=m, inertia=inertia)


def _bodies(bodies, joints, g=(0.0, -G, 0.0)) -> tuple[RigidBodies, SimState]:
    st = _state(g)
    rb = RigidBodies(bodies, joints=joints)
    rb.init(st)
    return rb, st


def test_pendulum_stays_on_its_hinge() -> None:
    """A rod (1 m, 2 kg) hinged at one end to a static body (the world) about z, released
    horizontal under gravity: its end stays on the hinge and the energy is kept. Bound: the
    rotation ``exp([w] dt)`` moves the anchor off the hinge by about ``w^2 r dt^2 / 2`` per step
    (the chord of the anchor's circle about the centre, r = 0.5 m), which Baumgarte takes back
    at the rate BETA per step, so the drift settles at ``w^2 r dt^2 / (2 BETA)`` with ``w^2 <=
    2 M g d / I_pivot`` (energy; d = 0.5 m, I_pivot = M L^2 / 3); twice that is allowed."""
    rod = _box("rod", [0.5, 0.0, 0.0], 2.0, (1.0, 0.1, 0.1))
    rb, st = _bodies([rod], [])
    rb.joints = [hinge("j", rb.bodies, 0, -1, [0, 0, 0], [0, 0, 1])]
    dt, L = 1e-3, 1.0
    w2 = 2.0 * 2.0 * G * 0.5 / (2.0 * L * L / 3.0)
    bound = 2.0 * w2 * 0.5 * dt * dt / (2.0 * BETA)
    err, lowest = 0.0, 0.0
    for i in range(1000):
        rb.advance(st, dt, i * dt)
        err = max(err, float(np.linalg.norm(rod.c + rod.R @ rb.joints[0].anchor_a)))
        lowest = min(lowest, float(rod.c[1]))
    assert err < bound, (err, bound)
    assert lowest < -0.49  # it swung down to hang below the hinge
    energy = (0.5 * rod.mass * rod.v @ rod.v + 0.5 * rod.omega @ rod.world_inertia() @ rod.omega
              + rod.mass * G * rod.c[1])
    assert abs(energy) < 0.01 * rod.mass * G * 0.5  # released at 0 J: within 1 % of M g d
    assert abs(rod.c[2]) < 1e-12 and np.allclose(rod.omega[:2], 0.0, atol=1e-12)  # in plane


def test_velocity_motor_holds_its_target() -> None:
    """A rod driven by a motor about a horizontal axis through its end, under gravity and an
    applied torque, turns at the target within 1 % from the first step on (the motor row is
    solved last in every sweep, so it holds its target to round-off)."""
    rod = _box("rod", [0.5, 0.0, 0.0], 2.0, (1.0, 0.1, 0.1))
    rb, st = _bodies([rod], [])
    rb.joints = [hinge("j", rb.bodies, 0, -1, [0, 0, 0], [0, 0, 1], target_velocity=3.0)]
    dt = 2e-3
    for i in range(500):
        rod.torque = np.array([0.3, 0.0, 5.0])  # the fluid's, say: kept for the step
        rb.advance(st, dt, i * dt)
        s = rod.stats()["joints"][0]
        assert s["relative_angular_velocity"] == pytest.approx(3.0, rel=1e-2)
        assert s["target_velocity"] == 3.0
    assert s["relative_angular_velocity"] == pytest.approx(3.0, rel=1e-9)
    assert np.linalg.norm(rod.c + rod.R @ rb.joints[0].anchor_a) < 1e-3  # on the hinge
    assert rb.joints[0].torque != 0.0  # the motor works against gravity and the torque


def test_2d_hinge_and_motor() -> None:
    """2D (bodies in the xy-plane, turning about z): a rod hinged at its end swings on its
    hinge (the same drift bound as in 3D); with a motor it turns at the target."""
    rod = RigidBody("rod", True, np.array([0.5, 0.0, 0.0]), np.zeros(3), np.zeros(3), mass=2.0,
                    inertia=np.eye(3) * 2.0 / 12.0)  # per metre of depth, polar moment on all
    rb, st = _bodies([rod], [], g=(0.0, -G))
    rb.joints = [hinge("j", rb.bodies, 0, -1, [0, 0, 0], [0, 0, 1])]
    dt = 1e-3
    w2 = 2.0 * 2.0 * G * 0.5 / (2.0 / 3.0)
    err = 0.0
    for i in range(600):
        rb.advance(st, dt, i * dt)
        err = max(err, float(np.linalg.norm(rod.c + rod.R @ rb.joints[0].anchor_a)))
    assert err < 2.0 * w2 * 0.5 * dt * dt / (2.0 * BETA)
    assert rod.c[1] < -0.3 and rod.c[2] == 0.0 and rod.omega[0] == rod.omega[1] == 0.0
    rb.joints = [hinge("m", rb.bodies, 0, -1, rod.c + rod.R @ rb.joints[0].anchor_a,
                       [0, 0, 1], target_velocity=-2.0)]
    for i in range(200):
        rb.advance(st, dt, i * dt)
    assert rod.omega[2] == pytest.approx(-2.0, rel=1e-9)


def test_hinge_between_dynamic_bodies_conserves_angular_momentum() -> None:
    """Two dynamic rods joined end to end by a hinge about z with a motor (an internal torque),
    no gravity, the pair thrown and spun: the total linear momentum and the angular momentum
    about z (about the origin) are conserved, while the motor sets the relative angular
    velocity. The joint's impulses are equal and opposite, applied at the two anchors, so they
    change the angular momentum only by ``(x_A - x_B) x lambda`` per step (the anchors' drift
    times the point impulse; bodies turning about z only have no gyroscopic term): the change
    is bounded by the sum of ``|x_A - x_B| |lambda|`` over the steps (measured: 3.1e-6 of 0.96,
    within the bound 1.4e-5)."""
    a = _box("a", [-0.5, 0.0, 0.0], 1.0, (1.0, 0.1, 0.1))
    b = _box("b", [0.5, 0.0, 0.0], 3.0, (1.0, 0.2, 0.1))
    a.v = np.array([0.3, 0.1, 0.0])
    b.omega = np.array([0.0, 0.0, 1.0])
    b.v = np.array([0.0, 0.5, 0.0])
    rb, st = _bodies([a, b], [], g=(0.0, 0.0, 0.0))
    rb.joints = [hinge("j", rb.bodies, 0, 1, [0, 0, 0], [0, 0, 1], target_velocity=2.0)]

    def momenta() -> tuple[np.ndarray, float]:
        p = sum(x.mass * x.v for x in (a, b))
        lz = sum((x.mass * np.cross(x.c, x.v) + x.world_inertia() @ x.omega)[2] for x in (a, b))
        return p, float(lz)

    def drift() -> float:
        jt = rb.joints[0]
        return float(np.linalg.norm(a.c + a.R @ jt.anchor_a - (b.c + b.R @ jt.anchor_b)))

    dt = 2e-3
    rb.advance(st, dt, 0.0)  # the joint acts: momenta from here on are the pair's
    p0, l0 = momenta()
    bound = 0.0
    for i in range(1, 400):
        d = drift()
        rb.advance(st, dt, i * dt)
        bound += d * float(np.linalg.norm(rb.joints[0].force)) * dt
    p1, l1 = momenta()
    np.testing.assert_allclose(p1, p0, rtol=1e-9, atol=1e-12)
    assert abs(l1 - l0) <= bound + 1e-12, (l1 - l0, bound)
    assert bound < 1e-4 * abs(l0)  # the drift stays small
    assert (a.omega - b.omega)[2] == pytest.approx(2.0, rel=1e-9)
    assert drift() < 1e-4


def test_target_sequence_values() -> None:
    """PositionBasedDynamics' targetSequence: linear between the time / value pairs, the first
    value before, the last after; repeated with period t_last - t0."""
    seq = [0.0, -5.0, 1.0, 5.0, 2.0, -5.0]
    for t, want in ((0.0, -5.0), (0.25, -2.5), (0.5, 0.0), (1.0, 5.0), (1.5, 0.0),
                    (2.0, -5.0), (7.0, -5.0)):
        assert sequence_value(seq, t, repeat=False) == pytest.approx(want, abs=1e-12)
    for t, want in ((2.5, 0.0), (3.0, 5.0), (4.25, -2.5), (10.75, 2.5)):
        assert sequence_value(seq, t, repeat=True) == pytest.approx(want, abs=1e-12)
    assert sequence_value([1.0, 2.0, 3.0, 4.0], 0.0, repeat=True) == 2.0  # before t0
    assert sequence_value([1.0, 2.0, 3.0, 4.0], 4.0, repeat=True) == 3.0  # wraps to 2.0 s


def _scene(tmp_path: Path, joints, motor_mesh=True) -> dict:
    f = tmp_path / "paddle.obj"
    trimesh.creation.box(extents=[0.12, 0.025, 0.05]).export(f)
    g = tmp_path / "post.obj"
    trimesh.creation.box(extents=[0.05, 0.05, 0.05]).export(g)
    return {
        "configuration": {"dim": 3, "particle_radius": 0.0125,
                          "time": {"until": 0.1, "dt_max": 0.005},
                          "pressure": {"method": "dfsph"}},
        "materials": [{"id": "water"}],
        "fluid_blocks": [{"start": [0.0, 0.0, 0.0], "end": [0.1, 0.1, 0.1],
                          "material": "water"}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.3, 0.3, 0.3], "open_top": True}],
        "meshes": [{"geometry_file": str(g), "translation": [0.2, 0.05, 0.15]},
                   {"geometry_file": str(f), "translation": [0.2, 0.1, 0.15],
                    "dynamic": motor_mesh, "density": 800.0}],
        "joints": joints,
    }


def test_scene_motor_and_checkpoint(tmp_path: Path) -> None:
    """A paddle hinged to a static post (a mesh wall) with a repeating target sequence in a
    tiny tank: it turns at the sequence's value at the middle of the step, reports it in the
    step statistics, and a run
    continued from a checkpoint equals the uninterrupted one bit for bit (the motor's target is
    a function of the time; the joint keeps no other state)."""
    joint = {"bodies": [1, 0], "position": [0.2, 0.1, 0.15], "axis": [0, 1, 0],
             "motor": {"target_sequence": [0.0, 0.0, 0.05, 4.0], "repeat": True}}
    scene = Scene.model_validate(_scene(tmp_path, [joint]))
    full = Simulation(scene)
    full.run(until=0.1, fps=50)
    s = full.last.rigid_bodies[0]["joints"][0]
    want = sequence_value([0.0, 0.0, 0.05, 4.0], full.time - 0.5 * full.last.dt, repeat=True)
    assert s["target_velocity"] == pytest.approx(want, abs=1e-12)
    assert s["relative_angular_velocity"] == pytest.approx(want, abs=1e-9)
    half = Simulation(scene)
    half.run(until=0.05, fps=50)
    half.save_checkpoint(tmp_path / "checkpoints" / "checkpoint_000000001.npz")
    resumed = Simulation.from_checkpoint(tmp_path)
    resumed.run(until=0.1, fps=50)
    assert (full.time, full.step_count) == (resumed.time, resumed.step_count)
    for name in ("c", "R", "v", "omega", "force", "torque"):
        np.testing.assert_array_equal(getattr(full.rigid.bodies[0], name),
                                      getattr(resumed.rigid.bodies[0], name), err_msg=name)
    np.testing.assert_array_equal(full.fluid["x"], resumed.fluid["x"])


def test_joint_scene_errors(tmp_path: Path) -> None:
    """Scene errors name the field, the value and what was expected."""
    base = {"bodies": [1, 0], "position": [0.2, 0.1, 0.15], "axis": [0, 1, 0]}
    cases = [
        ({**base, "bodies": [1, 5]}, "joints[0].bodies"),
        ({**base, "axis": [0, 0, 0]}, "joints[0].axis"),
        ({**base, "position": [0, 0, float("nan")]}, "joints[0].position"),
        ({**base, "motor": {"target_velocity": 1.0, "target_sequence": [0, 1]}},
         "joints[0].motor"),
        ({**base, "motor": {"target_sequence": [0, 1, 0, 2]}}, "joints[0].motor"),
    ]
    for joint, field in cases:
        with pytest.raises((SceneError, ValueError), match=r"joints"):
            Scene.model_validate(_scene(tmp_path, [joint]))
        try:
            Scene.model_validate(_scene(tmp_path, [joint]))
        except ValueError as e:
            assert field.split("[0]")[0] in str(e)
    with pytest.raises(ValueError, match="at least one dynamic"):
        Scene.model_validate(_scene(tmp_path, [base], motor_mesh=False))


def test_splishsplash_motor_scenes_load() -> None:
    """MotorScene and MotorScene2 of the wheel translate: the paddle (RigidBodies[1]) hinged
    to the static box (RigidBodies[0], a wall); PositionBasedDynamics drives w_1 - w_2 =
    -target a, so sphkit's target_velocity (of (w_A - w_B) . a) is -target."""
    s1 = load_scene(wheel_scene("MotorScene.json"))
    (j,) = s1.joints
    assert j.bodies == [1, 0] and j.axis == [0.0, 1.0, 0.0] and j.position == [0.0, 0.0, 0.0]
    assert j.motor.target_velocity == 6.0 and s1.meshes[1].dynamic and not s1.meshes[0].dynamic
    s2 = load_scene(wheel_scene("MotorScene2.json"))
    m = s2.joints[0].motor
    assert m.target_sequence == [0.0, 5.0, 1.0, -5.0, 2.0, 5.0] and m.repeat


def test_splishsplash_joint_translation_errors(tmp_path: Path) -> None:
    """HingeJoints translate without a motor; an unknown body id is named."""
    obj = tmp_path / "b.obj"
    trimesh.creation.box(extents=[0.1, 0.1, 0.1]).export(obj)
    data = {"Configuration": {"particleRadius": 0.025},
            "RigidBodies": [{"id": 3, "geometryFile": str(obj), "isDynamic": True},
                            {"id": 7, "geometryFile": str(obj), "translation": [1, 0, 0]}],
            "HingeJoints": [{"bodyID1": 3, "bodyID2": 7, "position": [0.5, 0, 0],
                             "axis": [0, 0, 1]}]}
    s = from_splishsplash(data)
    assert s.joints[0].bodies == [0, 1] and s.joints[0].motor is None
    data["HingeJoints"][0]["bodyID2"] = 9
    with pytest.raises(SceneError, match=r"HingeJoints\[0\]\.bodyID2: got 9"):
        from_splishsplash(data)
    data["TargetAngleMotorHingeJoints"] = [{"bodyID1": 3, "bodyID2": 7}]
    with pytest.raises(SceneError, match="TargetAngleMotorHingeJoints"):
        from_splishsplash(data)
    # a check across fields (a 2D hinge turns about z) names the SPlisHSPlasH field too: a 3D
    # scene turned 2D by sim2D (MotorScene.json's motor axis is y)
    del data["TargetAngleMotorHingeJoints"]
    data["HingeJoints"][0].update(bodyID2=7, axis=[0, 1, 0])
    data["Configuration"]["sim2D"] = True
    with pytest.raises(SceneError, match=r"HingeJoints\[0\]\.axis \(sphkit joints\[0\]\.axis\)"
                                         r": \[0\.0, 1\.0, 0\.0\]: in 2D bodies turn about z"):
        from_splishsplash(data)
