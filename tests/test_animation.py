"""Animation fields (SPlisHSPlasH's AnimationFields): a region imposes its expression on the
particles inside it after every step; expressions are parsed, never evaluated as Python."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sphkit.scene.expressions import ExpressionError, compile_expression
from sphkit.scene.schema import Scene, SceneError
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation


def test_expressions_follow_tinyexpr_and_refuse_python() -> None:
    env = {"t": 0.5, "dt": 0.01, "x": np.array([1.0, 2.0]), "y": 0.0, "z": 0.0, "vx": 0.0,
           "vy": 0.0, "vz": 0.0, "valuex": 0.0, "valuey": 0.0, "valuez": 0.0}
    f = compile_expression("cos(2*t)*0.1 + x^2 - log(100) + ln(e) + atan2(1, 1) * 4 / pi")
    np.testing.assert_allclose(f(env), math.cos(1.0) * 0.1 + np.array([1.0, 4.0]) - 2 + 1 + 1)
    for bad in ("__import__('os').system('x')", "x.real", "open", "[1, 2]", "lambda: 1",
                "cos(x", "sin(x, key=1)", "True"):
        with pytest.raises(ExpressionError):
            compile_expression(bad)


def _scene(expression: list[str], field: str = "velocity") -> Scene:
    # WCSPH without viscosity or walls: the passes tests/test_wcsph.py's elliptical drop
    # compiles too (the fields act after the step, whatever the solver)
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": 0.01, "gravity": [0.0, 0.0],
                          "pressure": {"method": "wcsph", "equation": "tait", "exponent": 7.0},
                          "time": {"dt_max": 0.002},
                          "start": {"relax": False, "hydrostatic": False, "settle": False}},
        "materials": [{"viscosity": {"method": "none"}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.4, 0.2]}],
        "animation_fields": [{"field": field, "shape": "box", "translation": [0.1, 0.1, 0.0],
                              "scale": [0.1, 0.1, 1.0], "expression": expression}],
    })


def test_a_box_imposes_its_velocity_on_the_particles_inside() -> None:
    # v_x = 0.1 cos(2 t) inside the box 0.05 <= x, y <= 0.15, after every step at the step's
    # end time; v_y reads the new v_x (components are set in order, as SPlisHSPlasH's); the
    # rest of the fluid (at rest, no gravity) moves only as the pressure pushes it: the right
    # half of the block, 0.1 m and more from the box, far below the imposed speed
    sim = Simulation(_scene(["cos(2*t)*0.1", "valuex * 0.5", ""]))
    for _ in range(10):
        sim.step()
    x, v = sim.positions, sim.velocities
    inside = np.all(np.abs(x - 0.1) < 0.05, axis=1)
    assert inside.sum() > 20
    np.testing.assert_allclose(v[inside, 0], 0.1 * math.cos(2 * sim.time), rtol=1e-12)
    np.testing.assert_allclose(v[inside, 1], 0.05 * math.cos(2 * sim.time), rtol=1e-12)
    far = x[:, 0] > 0.25
    speed = np.linalg.norm(v[far], axis=1).mean()
    print(f"mean speed 0.1 m and more from the box: {speed:.4f} m/s")
    assert speed < 0.2 * 0.1 * abs(math.cos(2 * sim.time)), speed


def test_bad_expression_is_refused_naming_splishsplash_field() -> None:
    data = {"Configuration": {"sim2D": True},
            "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0.5]}],
            "AnimationFields": [{"particleField": "velocity", "expression_x": "sin(t",
                                 "expression_y": "__import__('os')"}]}
    with pytest.raises(SceneError, match=r"AnimationFields\[0\]"):
        from_splishsplash(data)
    data["AnimationFields"][0].update(expression_x="", expression_y="", particleField="density")
    with pytest.raises(SceneError, match=r"AnimationFields\[0\]\.particleField: 'density'"):
        from_splishsplash(data)
