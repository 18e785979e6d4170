"""The default boundary pressure of each boundary model: resolved from the registry when a scene
is validated (sphkit and SPlisHSPlasH scenes alike), recorded in the manifest, and what it buys
in a 2D column at rest with SPlisHSPlasH's default settings.

The choice and its measurements: validation/README.md, "Boundary pressure defaults".
"""

from __future__ import annotations

import json
import logging
import warnings
from pathlib import Path

import numpy as np
import pytest

from sphkit import registry
from sphkit.io.manifest import Manifest
from sphkit.scene.schema import Scene
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation

UNIT_BOX = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
G = 9.81


def test_every_boundary_model_names_a_default_that_acts_on_it() -> None:
    """The registry's default of each boundary model is a boundary pressure for its kind."""
    for m in registry.methods("boundary"):
        bp = registry.get("boundary_pressure", registry.default_boundary_pressure(m.name))
        assert m.kind in bp.boundary, (m.name, bp.name)
    assert registry.default_boundary_pressure("akinci2012") == "mls"
    assert registry.default_boundary_pressure("koschier2017") == "hydrostatic"
    assert registry.default_boundary_pressure("bender2019") == "hydrostatic"


def test_moving_bodies_change_the_density_maps_default_only() -> None:
    """With a dynamic or kinematic body in the scene, density maps mirror (their hydrostatic
    wall pressure is not stable next to moving maps, tests/test_rigid_maps.py's paddle); the
    other models keep their default, and a choice the scene makes is kept."""
    body = {"geometry_file": "body.obj", "angular_velocity": [0.0, 1.0, 0.0]}
    for meshes, method, expected in (([body], "koschier2017", "mirror"),
                                     ([{**body, "angular_velocity": None, "dynamic": True}],
                                      "koschier2017", "mirror"),
                                     ([{"geometry_file": "wall.obj"}], "koschier2017",
                                      "hydrostatic"),
                                     ([body], "bender2019", "hydrostatic"),
                                     ([body], "akinci2012", "mls")):
        scene = Scene.model_validate({"configuration": {"boundary": {"method": method}},
                                      "meshes": meshes})
        assert scene.configuration.boundary.pressure == expected, (method, meshes)
    scene = Scene.model_validate({"configuration": {"boundary": {
        "method": "koschier2017", "pressure": "hydrostatic"}}, "meshes": [body]})
    assert scene.configuration.boundary.pressure == "hydrostatic"


def _scene(boundary: dict) -> Scene:
    return Scene.model_validate({"configuration": {"dim": 2, "boundary": boundary}})


def test_scene_resolves_the_default_and_keeps_an_explicit_choice(tmp_path: Path) -> None:
    """Absent or null: the model's default; a named one (mirror) stays; a dumped scene
    validates to the same pressure; the manifest records the resolved one."""
    assert _scene({}).configuration.boundary.pressure == "mls"
    assert _scene({"pressure": None}).configuration.boundary.pressure == "mls"
    for maps in ("koschier2017", "bender2019"):
        assert _scene({"method": maps}).configuration.boundary.pressure == "hydrostatic"
        assert _scene({"method": maps, "pressure": "mirror"}).configuration.boundary.pressure \
            == "mirror"
    scene = _scene({"method": "bender2019"})
    again = Scene.model_validate(scene.model_dump(mode="json"))
    assert again.configuration.boundary.pressure == "hydrostatic"
    Manifest(tmp_path, scene, command=["test"])
    data = json.loads((tmp_path / "manifest.json").read_text())
    assert data["scene"]["configuration"]["boundary"]["pressure"] == "hydrostatic"


@pytest.mark.parametrize(("bhm", "expected"), [(0, "mls"), (1, "hydrostatic"),
                                                (2, "hydrostatic")])
def test_splishsplash_scenes_get_the_default(bhm: int, expected: str) -> None:
    """SPlisHSPlasH has no boundary pressure setting: its scenes take sphkit's default of the
    boundary model their boundaryHandlingMethod names."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = from_splishsplash(_splishsplash_column(bhm, 0.02))
    assert scene.configuration.boundary.pressure == expected


def _splishsplash_column(bhm: int, r: float, width: float = 0.6, height: float = 0.5) -> dict:
    """A 2D column in SPlisHSPlasH's format with its default settings (DFSPH, maxError
    0.01 %, 100 iterations, CFL factor 0.5, dt at most 5 ms), standard viscosity 0.01 as its
    shipped scenes, UnitBox.obj walls as its scenes write them, and the fluid block shifted by
    r off the walls as DamBreakModel_2D.json (first particle 3r off the walls and floor);
    validation/hydrostatic.py's ``splishsplash`` column."""
    return {
        "Configuration": {"sim2D": True, "particleRadius": r, "boundaryHandlingMethod": bhm},
        "Materials": [{"id": "Fluid", "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": str(UNIT_BOX), "translation": [0, 0.4, 0],
                         "scale": [width, 0.8, 1.0], "isDynamic": False, "isWall": True,
                         "mapInvert": True, "mapThickness": 0.0}],
        "FluidBlocks": [{"denseMode": 0, "start": [-width / 2, 0.0, -0.5],
                         "end": [width / 2 - 2 * r, height, 0.5], "translation": [r, r, 0.0]}],
    }


def _settled_column(bhm: int, tmp_path: Path, r: float = 0.02, until: float = 2.0,
                    average: float = 1.0) -> dict:
    """Run the column; pressures and positions averaged per particle over the last
    ``average`` s: the slope of p over y in the middle 80 % of the height (in rho0 g), and how
    much more pressure (in % of rho0 g H) the particles within 3r of a side wall carry than
    the ones farther in at the same height."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = from_splishsplash(_splishsplash_column(bhm, r))
    scene.configuration.boundary.map_cache_dir = str(tmp_path)
    logging.disable(logging.WARNING)
    try:
        sim = Simulation(scene)
        sim.run(until=until - average)
        n = sim.fluid.n
        p_sum, x_sum, k = np.zeros(n), np.zeros((n, 2)), [0]

        def acc(s: Simulation, st) -> None:
            o = s.fluid.order_by_id()
            p_sum[:] += s.pressures[o]
            x_sum[:] += s.positions[o]
            k[0] += 1

        sim.run(until=until, on_step=acc)
    finally:
        logging.disable(logging.NOTSET)
    p, x = p_sum / k[0], x_sum / k[0]
    y = x[:, 1]
    lo, top = y.min(), y.max()
    mid = (y > lo + 0.1 * (top - lo)) & (y < lo + 0.9 * (top - lo))
    slope = -np.polyfit(y[mid], p[mid], 1)[0] / (1000.0 * G)
    wall = (x[:, 0] < x[:, 0].min() + 2 * r) | (x[:, 0] > x[:, 0].max() - 2 * r)
    dev = (p - 1000.0 * G * (top + r - y)) / (1000.0 * G * (top - lo + 2 * r))
    return {"slope": slope, "wall": 100 * (dev[mid & wall].mean() - dev[mid & ~wall].mean()),
            "pressure": scene.configuration.boundary.pressure,
            "vmean": float(np.linalg.norm(sim.velocities, axis=1).mean())}


@pytest.mark.parametrize(("bhm", "expected"), [(0, "mls"), (2, "hydrostatic")])
def test_default_boundary_pressure_holds_the_column_next_to_the_walls(
        bhm: int, expected: str, tmp_path: Path) -> None:
    """A 2D column at rest, SPlisHSPlasH format and default settings (DFSPH), coarse (r = 2 cm,
    10 rows, 156 particles), 5 s, averages over the last 4 s; Akinci walls from the box mesh
    (default: MLS) and volume maps (default: hydrostatic wall pressure).

    With the mirrored boundary pressure a side wall carries none of the weight of the fluid
    beside it, so the particles within 3r of a wall sit at a pressure higher than the fluid
    farther in by (measured, widths 0.5 / 0.6 / 0.7 m) +21 / +24 / +24 % of rho0 g H (Akinci)
    and +17 / +15 / +16 % (volume maps); the slope over the whole width hides this (0.99-1.07)
    and the inner fluid's is off by 6-9 %. With the defaults: wall excess -0.4 / -0.3 / -0.8 %
    (MLS) and -1.5 / -3.8 / -4.0 % (hydrostatic), bound here 6 %; slope 0.981 / 0.985 / 1.011
    (MLS) and 0.993 / 0.999 / 1.011 (hydrostatic), bound 3 % (the issue's 2 % plus the 1-2 %
    that single coarse columns scatter with the width and the start; validation/README.md,
    "Boundary pressure defaults"). Why 4 s: one second's average of this column scatters by
    2-4 % as its 10 rows rearrange (0.6 m, 2026-12-04, windows 1-2 / 2-3 / 3-4 / 4-5 s: MLS
    0.975 / 0.962 / 0.963 / 0.981; volume maps, with the mirrored share at the floor corners,
    0.970 / 1.000 / 0.996 / 0.996); over 1-5 s MLS 0.972 and volume maps 1.001 (wall -0.2 and
    -2.2 %)."""
    res = _settled_column(bhm, tmp_path, until=5.0, average=4.0)
    assert res["pressure"] == expected
    assert res["vmean"] < 0.1  # at rest (measured 0.001-0.03 m/s; free fall sqrt(2 g H) 3 m/s)
    assert abs(res["wall"]) < 6.0, res
    assert abs(res["slope"] - 1.0) < 0.03, res
