"""Scene front ends: built-in scenes, sphkit JSON/YAML, SPlisHSPlasH JSON translation."""

from __future__ import annotations

import copy
import json
import math
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
import yaml
from _wheel import wheel_scene

from sphkit.geometry.sampling import dense_block, lattice_block
from sphkit.scene.files import builtin_scenes, load_scene
from sphkit.scene.paths import resolve_scene_path
from sphkit.scene.schema import Scene, SceneError
from sphkit.scene.splishsplash import from_splishsplash

# -- built-in scenes ------------------------------------------------------------------------------


def test_builtin_scenes_listed_and_loadable() -> None:
    scenes = builtin_scenes()
    assert {"dambreak-3d", "dambreak-2d", "hydrostatic-2d"} <= set(scenes)
    for name, description in scenes.items():
        assert description and "\n" not in description
        scene = load_scene(name)
        assert scene.name == name
        assert scene.source and Path(scene.source).is_file()
        assert scene.fluid_blocks and scene.boxes


def _n_fluid(scene: Scene) -> int:
    r = scene.configuration.particle_radius
    return sum(len(lattice_block(b.start, b.end, r)) for b in scene.fluid_blocks)


def test_builtin_scene_sizes() -> None:
    big = load_scene("dambreak-3d")
    assert big.configuration.dim == 3 and _n_fluid(big) >= 20_000
    small = load_scene("dambreak-2d")
    assert small.configuration.dim == 2 and _n_fluid(small) <= 5_000
    assert small.configuration.time.until == 2.0
    hydro = load_scene("hydrostatic-2d")
    assert hydro.configuration.pressure.equation == "tait"
    assert _n_fluid(hydro) <= 5_000


def test_unknown_builtin_lists_known_names() -> None:
    with pytest.raises(SceneError, match="dambreak-2d") as info:
        load_scene("no-such-scene")
    assert "no-such-scene" in str(info.value)


# -- sphkit JSON / YAML ---------------------------------------------------------------------------


def _own_scene() -> dict[str, Any]:
    data = load_scene("dambreak-2d").model_dump(mode="json")
    for key in ("name", "source"):
        data.pop(key)
    return data


@pytest.mark.parametrize("suffix", [".json", ".yaml", ".yml"])
def test_own_format_round_trip(tmp_path: Path, suffix: str) -> None:
    data = _own_scene()
    path = tmp_path / f"my-scene{suffix}"
    text = json.dumps(data) if suffix == ".json" else yaml.safe_dump(data)
    path.write_text(text)
    scene = load_scene(path)
    assert scene.name == "my-scene"  # the file stem, since the file does not name it
    assert scene.source == str(path.resolve())
    back = scene.model_dump(mode="json")
    for key in ("name", "source"):
        back.pop(key)
    assert back == data
    assert load_scene(str(path)) == scene


def test_own_format_keeps_its_name_and_accepts_dicts(tmp_path: Path) -> None:
    data = _own_scene() | {"name": "named"}
    path = tmp_path / "file.json"
    path.write_text(json.dumps(data))
    assert load_scene(path).name == "named"
    scene = load_scene(data)
    assert scene.name == "named" and scene.source is None
    assert load_scene(scene) is scene


def test_bad_field_names_path_value_and_expectation(tmp_path: Path) -> None:
    data = _own_scene()
    data["configuration"]["particle_radius"] = -0.1
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert "configuration.particle_radius" in msg
    assert "-0.1" in msg
    assert "greater than 0" in msg
    assert "bad.json" in msg


def test_bad_nested_fields(tmp_path: Path) -> None:
    data = _own_scene()
    data["fluid_blocks"][0]["end"] = [0.5, -1.0]
    data["configuration"]["time"]["cfl_factor"] = "fast"
    data["materials"][0]["colour"] = "blue"
    with pytest.raises(SceneError) as info:
        load_scene(data)
    msg = str(info.value)
    assert "fluid_blocks[0]" in msg and "must exceed start" in msg
    assert "configuration.time.cfl_factor" in msg and "'fast'" in msg
    assert "materials[0].colour" in msg and "unknown field" in msg


def test_syntax_errors_give_the_line(tmp_path: Path) -> None:
    bad_json = tmp_path / "bad.json"
    bad_json.write_text('{\n  "name": "x",\n  "configuration": {,\n}\n')
    with pytest.raises(SceneError, match=r"bad\.json.*invalid JSON at line 3"):
        load_scene(bad_json)
    bad_yaml = tmp_path / "bad.yaml"
    bad_yaml.write_text("name: x\nconfiguration:\n  dim: 2\n   particle_radius: [1\n")
    with pytest.raises(SceneError, match=r"bad\.yaml.*invalid YAML at line \d"):
        load_scene(bad_yaml)
    top_list = tmp_path / "list.yaml"
    top_list.write_text("- 1\n- 2\n")
    with pytest.raises(SceneError, match="expected a mapping"):
        load_scene(top_list)


def test_missing_files(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="not found"):
        load_scene(tmp_path / "missing.json")
    with pytest.raises(SceneError, match="directory"):
        load_scene(tmp_path)
    data = _own_scene() | {"meshes": [{"geometry_file": "nowhere.obj"}]}
    path = tmp_path / "with-mesh.json"
    path.write_text(json.dumps(data))
    with pytest.raises(SceneError, match=r"meshes\[0\]\.geometry_file.*nowhere\.obj"):
        load_scene(path)


# -- SPlisHSPlasH ---------------------------------------------------------------------------------


@pytest.fixture
def sph_dir(tmp_path: Path) -> Path:
    models = tmp_path / "models"
    models.mkdir()
    trimesh.creation.box(extents=[1.0, 1.0, 1.0]).export(models / "UnitBox.obj")
    (tmp_path / "scenes").mkdir()
    return tmp_path / "scenes"


def _sph_scene(**config: Any) -> dict[str, Any]:
    return {
        "Configuration": {
            "particleRadius": 0.025,
            "simulationMethod": 0,
            "boundaryHandlingMethod": 0,
            "gravitation": [0, -9.81, 0],
            "timeStepSize": 0.002,
            "cflMethod": 0,
            "stopAt": 3.0,
            "dataExportFPS": 30,
            "numberOfStepsPerRenderUpdate": 4,
            "cameraPosition": [0, 2, 5],
            "pause": True,
            "DFSPH": {"maxError": 0.05},
            "WCSPH": {"stiffness": 50000, "exponent": 7},
            **config,
        },
        "Materials": [
            {"id": "Fluid", "density0": 998, "viscosityMethod": 1, "colorMapType": 1,
             "Standard viscosity": {"viscosity": 0.02, "viscosityBoundary": 0.1}},
        ],
        "RigidBodies": [
            {"geometryFile": "../models/UnitBox.obj", "translation": [0, 1.5, 0],
             "rotationAxis": [1, 0, 0], "rotationAngle": 0, "scale": [4, 3, 1.5],
             "color": [0.1, 0.4, 0.6, 1.0], "isDynamic": False, "isWall": True,
             "mapInvert": True, "mapThickness": 0.0, "mapResolution": [40, 30, 15]},
        ],
        "FluidBlocks": [
            {"denseMode": 0, "start": [-0.5, 0.0, -0.5], "end": [0.5, 1.0, 0.5],
             "translation": [-1.45, 0.05, 0.0], "scale": [1, 1, 1],
             "initialVelocity": [1.0, 0.0, 0.0]},
        ],
    }


def _splishsplash_block_positions(block: dict[str, Any], r: float, dim: int) -> np.ndarray:
    """SPlisHSPlasH's createFluidBlocks (denseMode 0), written out independently."""
    scale = np.array(block.get("scale", [1, 1, 1]), float)
    trans = np.array(block.get("translation", [0, 0, 0]), float)
    lo = scale * np.array(block["start"], float) + trans
    hi = scale * np.array(block["end"], float) + trans
    diam = 2 * r
    steps = [math.floor((hi[a] - lo[a]) / diam + 0.5) - 1 for a in range(3)]
    if dim == 2:
        steps[2] = 1
    start = lo + diam
    pts = [start + diam * np.array([j, k, l]) for j in range(steps[0]) for k in range(steps[1])
           for l in range(steps[2])]
    return np.array(pts)[:, :dim]


def _sorted(points: np.ndarray) -> np.ndarray:
    return points[np.lexsort(points.T[::-1])]


def test_splishsplash_translation(sph_dir: Path) -> None:
    data = _sph_scene()
    path = sph_dir / "dam.json"
    path.write_text(json.dumps(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # GUI fields and other solvers' blocks: no warning
        scene = load_scene(path)
    cfg = scene.configuration
    assert scene.name == "dam" and scene.source == str(path.resolve())
    assert cfg.dim == 3 and cfg.particle_radius == 0.025 and cfg.kernel == "cubic"
    assert cfg.gravity == [0.0, -9.81, 0.0]
    assert cfg.time.cfl is False and cfg.time.dt == 0.002 and cfg.time.until == 3.0
    assert cfg.pressure.method == "wcsph" and cfg.pressure.equation == "tait"
    assert cfg.pressure.stiffness == 50000.0 and cfg.pressure.exponent == 7.0
    assert cfg.pressure.acoustic_cfl is False  # a fixed step is reproduced as it is
    assert cfg.boundary.method == "akinci2012"
    assert scene.output.fps == 30.0
    (mat,) = scene.materials
    assert mat.id == "Fluid" and mat.density0 == 998.0
    assert mat.viscosity.method == "standard"
    assert mat.viscosity.coefficient == 0.02 and mat.viscosity.boundary_coefficient == 0.1
    (mesh,) = scene.meshes
    assert mesh.geometry_file == "../models/UnitBox.obj"
    assert resolve_scene_path(scene, mesh.geometry_file).is_file()
    assert mesh.scale == [4.0, 3.0, 1.5] and mesh.translation == [0.0, 1.5, 0.0]
    assert mesh.invert is True
    (block,) = scene.fluid_blocks
    assert block.material == "Fluid" and block.velocity == [1.0, 0.0, 0.0]
    # the same particles as SPlisHSPlasH's regular sampling: 19^3, first at lo + 2r
    ours = lattice_block(block.start, block.end, cfg.particle_radius)
    theirs = _splishsplash_block_positions(data["FluidBlocks"][0], 0.025, 3)
    assert len(ours) == len(theirs) == 19**3
    np.testing.assert_allclose(_sorted(ours), _sorted(theirs), atol=1e-12)


def _splishsplash_dense_positions(lo: np.ndarray, hi: np.ndarray, r: float, mode: int,
                                  dim: int) -> np.ndarray:
    """SPlisHSPlasH's createFluidBlocks for denseMode 1 and 2, its loops written out."""
    diam, eps = 2 * r, 1e-9
    xshift, yshift = diam, diam
    if mode == 1:
        yshift = math.sqrt(3.0) * r + eps
    else:
        xshift = math.sqrt(6.0) * diam / 3.0 + eps
        yshift = math.sqrt(3.0) * r + eps
    diff = hi - lo
    diff[0] -= diam if mode == 1 else xshift
    diff[2] -= diam
    sx = math.floor(diff[0] / xshift + 0.5) - 1
    sy = math.floor(diff[1] / yshift + 0.5) - 1
    sz = math.floor(diff[2] / diam + 0.5) - 1
    start = lo + diam
    if dim == 2:
        sz, start[2] = 1, 0.0
    pts = []
    for j in range(sx):
        for k in range(sy):
            for m in range(sz):
                p = np.array([j * xshift, k * yshift, m * diam]) + start
                if mode == 1:
                    p += [0, 0, r] if k % 2 == 0 else [r, 0, 0]
                else:
                    p += [0, 0, r]
                    shift = np.zeros(3)
                    if j % 2 and dim == 3:
                        shift[2] += diam / (2.0 * (-1 if k % 2 else 1))
                    if k % 2 == 0:
                        shift[0] += xshift / 2.0
                    p += shift
                pts.append(p)
    return np.array(pts)[:, :dim]


@pytest.mark.parametrize("mode", [1, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_splishsplash_dense_modes_place_splishsplash_particles(sph_dir: Path, mode: int,
                                                               dim: int) -> None:
    data = _sph_scene(sim2D=dim == 2)
    block = {"denseMode": mode, "start": [-0.5, 0.0, -0.5], "end": [0.5, 1.0, 0.5],
             "translation": [-1.45, 0.05, 0.0]}
    data["FluidBlocks"] = [block]
    scene = from_splishsplash(data, sph_dir / "dense.json")
    (b,) = scene.fluid_blocks
    assert b.lattice == {1: "layered", 2: "close_packed"}[mode]
    ours = dense_block(b.start, b.end, 0.025, b.lattice)
    lo = np.array(block["start"], float) + block["translation"]
    hi = np.array(block["end"], float) + block["translation"]
    theirs = _splishsplash_dense_positions(lo, hi, 0.025, mode, dim)
    assert len(ours) == len(theirs) > 0
    np.testing.assert_allclose(_sorted(ours), _sorted(theirs), atol=1e-12)


def test_splishsplash_2d_uses_first_two_components(sph_dir: Path) -> None:
    data = _sph_scene(sim2D=True, kernel=4, gradKernel=4)
    block = {"start": [-2.0, 0.0, -1.0], "end": [-0.5, 1.5, 1.0], "translation": [0.025, 0.025, 0]}
    data["FluidBlocks"] = [block]
    scene = from_splishsplash(data, sph_dir / "dam2d.json")
    cfg = scene.configuration
    assert cfg.dim == 2 and cfg.gravity == [0.0, -9.81] and cfg.kernel == "cubic"
    (b,) = scene.fluid_blocks
    assert len(b.start) == 2 and b.velocity is None
    ours = lattice_block(b.start, b.end, 0.025)
    theirs = _splishsplash_block_positions(block, 0.025, 2)
    assert len(ours) == len(theirs) == 29 * 29
    np.testing.assert_allclose(_sorted(ours), _sorted(theirs), atol=1e-12)


def test_splishsplash_defaults_when_absent() -> None:
    scene = from_splishsplash({
        "Configuration": {"simulationMethod": 0},
        "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0.5], "id": "water"}],
    })
    cfg = scene.configuration
    assert cfg.particle_radius == 0.025 and cfg.dim == 3
    assert cfg.gravity == [0.0, -9.81, 0.0]
    t = cfg.time
    assert (t.cfl, t.cfl_factor, t.dt, t.dt_min, t.dt_max) == (True, 0.5, 0.001, 1e-4, 0.005)
    assert cfg.pressure.stiffness == 50.0 and cfg.pressure.exponent == 7.0
    assert cfg.pressure.acoustic_cfl is True
    assert [(m.id, m.density0, m.viscosity.method) for m in scene.materials] == [
        ("water", 1000.0, "none")
    ]
    assert scene.meshes == []


def test_splishsplash_older_flat_parameters_and_xsph() -> None:
    scene = from_splishsplash({
        "Configuration": {"simulationMethod": 0, "stiffness": 20000, "exponent": 1,
                          "cflMethod": 2, "cflFactor": 1},
        "Materials": [
            {"id": "A", "viscosityMethod": 1, "viscosity": 0.05, "XSPH": {"xsph": 0.2}},
            {"id": "B", "XSPH": {"xsph": 0.1, "xsphBoundary": 0.05}},
        ],
        "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0.5], "id": "A"}],
    })
    assert scene.configuration.pressure.stiffness == 20000.0
    assert scene.configuration.pressure.exponent == 1.0
    assert scene.configuration.time.cfl is True and scene.configuration.time.cfl_factor == 1.0
    a, b = scene.materials
    assert (a.viscosity.method, a.viscosity.coefficient) == ("standard", 0.05)
    assert (a.viscosity.xsph, a.viscosity.xsph_boundary) == (0.2, 0.0)  # XSPH beside it
    assert (b.viscosity.method, b.viscosity.coefficient) == ("xsph", 0.1)
    assert b.viscosity.boundary_coefficient == 0.05


def test_splishsplash_older_flat_elasticity() -> None:
    # scenes before 2.16 (SPlisHSPlasH 560a87c's Beam.json) write the elastic parameters flat in
    # the material; 2.19 moved them into the method's block. Both read alike; with a block,
    # flat keys are not read (and are reported as unknown)
    block = {"youngsModulus": 5e6, "poissonsRatio": 0.33, "alpha": 0.1, "maxNeighbors": 15,
             "fixedBoxMin": [-10, -10, -10], "fixedBoxMax": [-1.5, 10, 10]}
    base = {"id": "Fluid", "elasticityMethod": 3}
    flat = from_splishsplash({"Materials": [{**base, **block}]})
    named = from_splishsplash({"Materials": [{**base, "Kugelstadt et al. 2021": block}]})
    for scene in (flat, named):
        e = scene.materials[0].elasticity
        assert (e.method, e.youngs_modulus, e.poisson_ratio, e.alpha, e.max_neighbors) == (
            "kugelstadt2021", 5e6, 0.33, 0.1, 15)
        assert [(b.min, b.max) for b in e.fixed_boxes] == [([-10, -10, -10], [-1.5, 10, 10])]
    with pytest.warns(UserWarning, match=r"Materials\[0\]\.youngsModulus"):
        both = from_splishsplash({"Materials": [{**base, "youngsModulus": 1e3,
                                                 "Kugelstadt et al. 2021": block}]})
    assert both.materials[0].elasticity.youngs_modulus == 5e6
    with pytest.raises(SceneError, match=r"Materials\[0\]\.poissonsRatio"):
        from_splishsplash({"Materials": [{**base, "poissonsRatio": "x"}]})


def test_splishsplash_method_numbers_before_2_12_and_2_13() -> None:
    # SPlisHSPlasH 2.12 took XSPH out of viscosityMethod (3-7 became 2-6), 2.13 put Jeske et al.
    # 2023 at surfaceTensionMethod 4 (Zorilla, Ritter et al. 2020 moved to 5); files carry no
    # version. Flat materials (before 2.16) are renumbered where the file shows its numbering
    # (SPlisHSPlasH's own scenes at 560a87c: ViscousBunny 7, BucklingModel_Peer2016 5 with the
    # Omega keys, the ZR2020 scenes 4 with surfTZR* keys) and noted where it cannot tell
    def read(material: dict, **cfg: Any) -> tuple[Any, list[str]]:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = from_splishsplash({"Configuration": cfg, "Materials": [material]})
        return scene, [str(w.message) for w in caught]

    def visc(material: dict) -> tuple[str, bool]:
        scene, notes = read(material)
        return scene.materials[0].viscosity.method, any("viscosityMethod" in n for n in notes)

    omega = {"viscoMaxIterOmega": 50, "viscoMaxErrorOmega": 0.01}
    assert visc({"viscosityMethod": 7, "viscosity": 1}) == ("weiler2018", True)
    # before 2.10 Weiler's and Takahashi's viscosity was dynamic (SPlisHSPlasH's scenes: 5000 ->
    # 5): read as kinematic, with a note when it is implausibly large
    _, notes = read({"viscosityMethod": 6, "viscosity": 5000, "viscosityBoundary": 4000})
    assert any("before 2.10 it was the dynamic viscosity" in n for n in notes)
    _, notes = read({"viscosityMethod": 6, "viscosity": 5, "viscosityBoundary": 4})
    assert not any("dynamic viscosity" in n for n in notes)
    assert visc({"viscosityMethod": 5, "viscosity": 0.01, **omega}) == ("peer2016", True)
    assert visc({"viscosityMethod": 5, "viscosity": 0.01}) == ("takahashi2015", True)  # noted
    assert visc({"viscosityMethod": 4, "viscosity": 0.01, **omega}) == ("peer2016", False)
    assert visc({"viscosityMethod": 6, "viscosity": 1, "viscosityBoundary": 1}) == (
        "weiler2018", False)
    assert visc({"viscosityMethod": 3, "viscosity": 0.01, "xsph": 0.0}) == ("peer2015", False)
    assert visc({"viscosityMethod": 1, "viscosity": 0.01}) == ("standard", False)
    assert visc({"viscosityMethod": 3, "Peer et al. 2015": {"viscosity": 0.01}}) == (
        "peer2015", False)  # 2.16's form: numbers as they are
    scene, notes = read({"viscosityMethod": 3, "viscosity": 0.01})
    assert scene.materials[0].viscosity.method == "peer2015"
    assert any("before 2.12, 3 was Bender and Koschier 2017 (now 2)" in n for n in notes)
    # a scene in 2.16's form elsewhere (a solver block) is 2.16's: no note for a bare material
    scene, notes = read({"viscosityMethod": 3}, DFSPH={"maxError": 0.05})
    assert scene.materials[0].viscosity.method == "peer2015"
    assert not any("viscosityMethod" in n for n in notes)

    zr = {"surfaceTensionMethod": 4, "surfaceTension": 0.1, "surfTZRd": 28, "surfTZRd-offset": 3,
          "surfTZRnormal-mode": 1}
    scene, notes = read(zr)
    st = scene.materials[0].surface_tension
    assert (st.method, st.coefficient, st.zorilla2020.classifier_d, st.zorilla2020.d_offset,
            st.zorilla2020.normal_mode) == ("zorilla2020", 0.1, 28.0, 3.0, "mc")
    assert not any("ignored" in n for n in notes)
    scene, notes = read({"surfaceTensionMethod": 4, "surfaceTension": 0.1})
    assert scene.materials[0].surface_tension.method == "jeske2023"
    assert any("before 2.13, 4 was Zorilla" in n for n in notes)
    # a number that is a list is named, not hashed (the long fuzz run, seed 31: TypeError)
    for key in ("surfaceTensionMethod", "elasticityMethod", "viscosityMethod"):
        with pytest.raises(SceneError, match=rf"Materials\[0\]\.{key}"):
            from_splishsplash({"Materials": [{key: [1.5, 2.0]}]})
    # projective fluids' stiffness was the flat stiffnessPF (a flat stiffness is WCSPH's)
    scene, notes = read({}, simulationMethod=5, stiffness=50, stiffnessPF=25000)
    assert scene.configuration.pressure.pf_stiffness == 25000.0
    assert not any("ignored" in n for n in notes)


def test_splishsplash_scenes_before_the_materials_array(tmp_path: Path) -> None:
    # until 2020 a fluid's parameters were a top-level object named by its id (SPlisHSPlasH at
    # ffe47dc: "Fluid": {...}; DoubleDamBreakMultiPhase: "first_fluid", ...), particle files had
    # one scale number and emitters (0d1656a) a direction, a velocity vector and emitsPerSecond
    data_dir = Path(__file__).parent / "data" / "splishsplash"
    shutil.copy(data_dir / "ballistic_1.bgeo", tmp_path / "drop.bgeo")
    scene = {
        "Configuration": {"particleRadius": 0.025, "density0": 1000},
        "Fluid": {"viscosity": 0.02, "viscosityMethod": 1},
        "heavy": {"density0": 2000, "viscosity": 0.03, "viscosityMethod": 1,
                  "maxEmitterParticles": 123},
        "FluidBlocks": [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2]}],
        "FluidModels": [{"particleFile": "drop.bgeo", "scale": 2, "id": "heavy"}],
        "Emitters": [{"width": 4, "height": 2, "translation": [0.9, 1.0, 0.0],
                      "direction": [-1, 0, 0], "velocity": [-2, 0, 0], "emitsPerSecond": 40,
                      "type": 0, "id": "heavy"}],
    }
    path = tmp_path / "old.json"
    path.write_text(json.dumps(scene))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = load_scene(path)
    texts = " ".join(str(w.message) for w in caught)
    ignored = [str(w.message).split("support yet: ")[1] for w in caught
               if "support yet: " in str(w.message)]
    assert ignored == ["Configuration.density0"]  # the material objects are read, not ignored
    mats = {m.id: m for m in sc.materials}
    assert (mats["Fluid"].viscosity.coefficient, mats["heavy"].density0,
            mats["heavy"].viscosity.coefficient) == (0.02, 2000.0, 0.03)
    assert sc.fluid_files[0].scale == 2.0
    (e,) = sc.emitters
    # emits along -x at 2 m/s (40 layers of 2r = 0.05 m a second, as written), the layer's
    # width 4 x 2r along z and height 2 x 2r along y, the heavy fluid's cap
    from sphkit.geometry.rotations import rotation_matrix

    rot = rotation_matrix(e.rotation_axis, e.rotation_angle)
    np.testing.assert_allclose(rot[:, 0], [-1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(abs(rot[:, 2]), [0.0, 0.0, 1.0], atol=1e-12)
    assert (e.velocity, e.width, e.height, e.max_particles) == (2.0, 0.2, 0.1, 123)
    assert "emitsPerSecond" not in texts  # 40 = 2 / (2 r): nothing to note
    # a velocity that is not along the direction has no later form: named
    scene["Emitters"][0]["velocity"] = [0, 2, 0]
    with pytest.raises(SceneError, match=r"Emitters\[0\]\.velocity: got \[0, 2, 0\]"):
        from_splishsplash(scene, path)
    # garbage in the older emitter's fields is named (a string speed had given the bare
    # "could not convert string to float")
    for key, bad in (("velocity", "x"), ("emitsPerSecond", "fast"), ("direction", [0, 0, 0]),
                     ("direction", [float("nan"), 1, 0])):
        scene["Emitters"][0] = {"direction": [1, 0, 0], "velocity": 2, key: bad}
        with pytest.raises(SceneError, match=rf"Emitters\[0\]\.{key}: got"):
            from_splishsplash(scene, path)
    # 2018 (09c39a4): one fluid, its parameters in Configuration, numbered as before 2.12
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = from_splishsplash({
            "Configuration": {"particleRadius": 0.025, "density0": 800, "viscosityMethod": 7,
                              "viscosity": 1.5, "viscosityBoundary": 0.5},
            "FluidBlocks": [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2]}]})
    (m,) = sc.materials
    assert (m.id, m.density0, m.viscosity.method, m.viscosity.coefficient,
            m.viscosity.boundary_coefficient) == ("Fluid", 800.0, "weiler2018", 1.5, 0.5)
    assert not any("support yet" in str(w.message) for w in caught)
    # before October 2019 boundary particles were the only boundary method: a wall without map
    # keys and no boundaryHandlingMethod is a container of boundary particles (since, the
    # default is volume maps and such a wall would be solid)
    box = tmp_path / "UnitBox.obj"
    trimesh.creation.box(extents=[1.0, 1.0, 1.0]).export(box)
    old_walls = {"Configuration": {"particleRadius": 0.025},
                 "RigidBodies": [{"geometryFile": "UnitBox.obj", "isWall": True,
                                  "scale": [2, 2, 2]}],
                 "FluidBlocks": [{"start": [-0.5, -0.9, -0.5], "end": [0.5, 0.0, 0.5]}]}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = from_splishsplash(old_walls, tmp_path / "walls.json")
    assert any("before October 2019" in str(w.message) for w in caught)
    assert sc.configuration.boundary.method == "akinci2012" and sc.meshes[0].invert
    old_walls["RigidBodies"][0]["mapInvert"] = True  # a map key: a scene of maps
    sc = from_splishsplash(old_walls, tmp_path / "walls.json")
    assert sc.configuration.boundary.method == "bender2019" and sc.meshes[0].invert


# SPlisHSPlasH's defaults of the iterative solvers: TimeStep.cpp (minIterations 2, maxIterations
# 100, maxError 0.01 %), TimeStepPCISPH.cpp (minIterations 3), TimeStepDFSPH.cpp (maxIterationsV
# 100, maxErrorV 0.1 %, divergence solver on), TimeStepPBF.cpp (velocityUpdateMethod 0); also read
# back from pysplishsplash 2.19's time-step objects.
_SOLVER_DEFAULTS = {
    1: ("pcisph", 3), 2: ("pbf", 2), 3: ("iisph", 2), 4: ("dfsph", 2),
}


def _solver_scene(method: int, block: dict[str, Any] | None = None, **flat: Any) -> dict:
    config = {"cflMethod": 1, "cflFactor": 1, "cflMaxTimeStepSize": 0.005, **flat}
    data = _sph_scene(simulationMethod=method, **config)
    names = {1: "PCISPH", 2: "PBF", 3: "IISPH", 4: "DFSPH"}
    data["Configuration"].pop("DFSPH")
    if block is not None:
        data["Configuration"][names[method]] = block
    return data


@pytest.mark.parametrize("method", [1, 2, 3, 4])
def test_splishsplash_iterative_solver_defaults(sph_dir: Path, method: int) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = from_splishsplash(_solver_scene(method), sph_dir / "dam.json")
    p = scene.configuration.pressure
    name, min_iterations = _SOLVER_DEFAULTS[method]
    assert p.method == name
    assert (p.min_iterations, p.max_iterations, p.max_error) == (min_iterations, 100, 0.01)
    assert (p.max_iterations_v, p.max_error_v, p.divergence_solver) == (100, 0.1, True)
    assert p.pbf_velocity_update == "first_order"
    t = scene.configuration.time
    assert (t.cfl, t.cfl_factor, t.dt_max) == (True, 1.0, 0.005)


def test_splishsplash_pcisph_parameters(sph_dir: Path) -> None:
    block = {"minIterations": 4, "maxIterations": 50, "maxError": 0.1}
    p = from_splishsplash(_solver_scene(1, block), sph_dir / "dam.json").configuration.pressure
    assert (p.method, p.min_iterations, p.max_iterations, p.max_error) == ("pcisph", 4, 50, 0.1)


def test_splishsplash_pbf_parameters(sph_dir: Path) -> None:
    block = {"minIterations": 1, "maxIterations": 20, "maxError": 0.05, "velocityUpdateMethod": 1}
    p = from_splishsplash(_solver_scene(2, block), sph_dir / "dam.json").configuration.pressure
    assert (p.method, p.min_iterations, p.max_iterations, p.max_error) == ("pbf", 1, 20, 0.05)
    assert p.pbf_velocity_update == "second_order"
    assert p.pbf_s_corr is False  # SPlisHSPlasH's PBF has no artificial pressure


def test_splishsplash_iisph_parameters(sph_dir: Path) -> None:
    block = {"minIterations": 0, "maxIterations": 30, "maxError": 0.02}
    p = from_splishsplash(_solver_scene(3, block), sph_dir / "dam.json").configuration.pressure
    assert (p.method, p.min_iterations, p.max_iterations, p.max_error) == ("iisph", 0, 30, 0.02)


def test_splishsplash_dfsph_parameters(sph_dir: Path) -> None:
    block = {"minIterations": 3, "maxIterations": 80, "maxError": 0.05, "maxIterationsV": 40,
             "maxErrorV": 0.2, "enableDivergenceSolver": False}
    p = from_splishsplash(_solver_scene(4, block), sph_dir / "dam.json").configuration.pressure
    assert (p.method, p.min_iterations, p.max_iterations, p.max_error) == ("dfsph", 3, 80, 0.05)
    assert (p.max_iterations_v, p.max_error_v, p.divergence_solver) == (40, 0.2, False)


def test_splishsplash_default_method_is_dfsph(sph_dir: Path) -> None:
    data = _sph_scene()
    del data["Configuration"]["simulationMethod"]
    p = from_splishsplash(data, sph_dir / "dam.json").configuration.pressure
    assert (p.method, p.min_iterations, p.max_error) == ("dfsph", 2, 0.05)  # its DFSPH block


def test_splishsplash_solver_flat_keys_and_unknown_block_keys(sph_dir: Path) -> None:
    # scenes before 2.16: flat keys in Configuration; the block wins where it sets a key
    data = _solver_scene(4, {"maxError": 0.02, "maxIterationsV": 10, "bogus": 1},
                         maxError=0.3, minIterations=5, maxErrorV=0.5,
                         enableDivergenceSolver=0)
    with pytest.warns(UserWarning, match=r"Configuration\.DFSPH\.bogus") as record:
        scene = from_splishsplash(data, sph_dir / "dam.json")
    # the flat key the block shadows is named (SPlisHSPlasH 2.16+ reads only the block)
    assert len(record) == 2
    assert ("Configuration.maxError: 0.3 is not used: Configuration.DFSPH.maxError = 0.02 "
            "sets it") in str(record[1].message)
    p = scene.configuration.pressure
    assert (p.max_error, p.min_iterations, p.max_error_v) == (0.02, 5, 0.5)
    assert (p.max_iterations_v, p.divergence_solver) == (10, False)


def test_splishsplash_cfl_with_iteration_control(sph_dir: Path) -> None:
    """cflMethod 2 is read as the CFL step with iteration control (no warning); 1 without."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = from_splishsplash(_solver_scene(3, cflMethod=2), sph_dir / "dam.json")
    assert scene.configuration.time.cfl and scene.configuration.time.iteration_control
    scene = from_splishsplash(_solver_scene(3, cflMethod=1), sph_dir / "dam.json")
    assert scene.configuration.time.cfl and not scene.configuration.time.iteration_control


def test_benchmark_scenes_share_their_settings() -> None:
    folder = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes"
    scenes = {name: load_scene(folder / f"dambreak_{name}.json")
              for name in ("wcsph", "pcisph", "pbf", "iisph", "dfsph")}
    for name, scene in scenes.items():
        cfg = scene.configuration
        assert cfg.pressure.method == name
        assert cfg.particle_radius == 0.025 and cfg.boundary.method == "akinci2012"
        assert scene.fluid_blocks == scenes["wcsph"].fluid_blocks
        assert scene.meshes == scenes["wcsph"].meshes
        assert scene.materials == scenes["wcsph"].materials
        if name != "wcsph":
            p, t = cfg.pressure, cfg.time
            assert (p.max_error, p.max_iterations) == (0.05, 100)
            assert p.min_iterations == (3 if name == "pcisph" else 2)
            assert (t.cfl, t.cfl_factor, t.dt_max, t.until) == (True, 1.0, 0.005, 1.0)
    assert scenes["dfsph"].configuration.pressure.max_error_v == 0.1


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        ({"Configuration": {"simulationMethod": 9}},
         r"Configuration\.simulationMethod: 9 \(unknown method\) is not supported yet; "
         r"supported: 0 \(WCSPH\), 1 \(PCISPH\), 2 \(PBF\), 3 \(IISPH\), 4 \(DFSPH\), "
         r"5 \(Projective Fluids\), 6 \(ICSPH\)"),
        ({"Configuration": {"simulationMethod": 6, "ICSPH": {"lambda": 0}}},
         r"Configuration\.ICSPH\.lambda: got 0: expected a number > 0"),
        ({"Configuration": {"simulationMethod": 5, "Projective Fluids": {"stiffness": -1}}},
         r"Configuration\.Projective Fluids\.stiffness: got -1: expected a number > 0"),
        ({"Configuration": {"simulationMethod": 2, "PBF": {"velocityUpdateMethod": 2}}},
         r"Configuration\.PBF\.velocityUpdateMethod: got 2: expected 0 \(first order\) or 1"),
        ({"Configuration": {"simulationMethod": 4, "DFSPH": {"maxError": -0.05}}},
         r"Configuration\.DFSPH\.maxError: got -0\.05: expected a number > 0"),
        ({"Configuration": {"simulationMethod": 4, "DFSPH": {"maxErrorV": "small"}}},
         r"Configuration\.DFSPH\.maxErrorV: got 'small': expected a finite number"),
        ({"Configuration": {"simulationMethod": 3, "IISPH": {"maxIterations": 0}}},
         r"Configuration\.IISPH\.maxIterations \(sphkit configuration\.pressure\.max_iter"),
        ({"Configuration": {"simulationMethod": 1, "PCISPH": {"minIterations": 2.5}}},
         r"Configuration\.PCISPH\.minIterations: got 2\.5: expected an integer"),
        ({"Configuration": {"simulationMethod": 1, "maxError": 500}},
         r"Configuration\.maxError \(sphkit configuration\.pressure\.max_error\)"),
        ({"Configuration": {"simulationMethod": 4, "PCISPH": []}},
         None),  # another solver's block is not read: this loads
        ({"Configuration": {"boundaryHandlingMethod": 3}},
         r"Configuration\.boundaryHandlingMethod: 3 \(Nogina and Sellan 2026\)"),
        ({"RigidBodies": {"mapResolution": [20, 20]}},
         r"RigidBodies\[0\]\.mapResolution: got \[20, 20\]: expected a list of 3 positive"),
        ({"Configuration": {"kernel": 1, "gradKernel": 3}}, r"gradKernel: 3 \(spiky\) differs"),
        ({"Configuration": {"particleRadius": -0.1}},
         r"Configuration\.particleRadius: got -0\.1: expected a number > 0"),
        ({"Configuration": {"gravitation": [0, -9.81]}},
         r"Configuration\.gravitation: got \[0, -9\.81\]: expected a list of 3"),
        ({"Configuration": {"cflFactor": 3}}, r"Configuration\.cflFactor.*less than or equal"),
        ({"Materials": {"vorticityMethod": 3}},
         r"Materials\[0\]\.vorticityMethod: 3 \(Liu et al\. 2021 vorticity refinement\) is not "
         r"supported yet"),
        ({"Materials": {"viscosityMethod": 7}},
         r"Materials\[0\]\.viscosityMethod: 7 \(unknown method\) is not supported yet"),
        ({"Materials": {"surfaceTensionMethod": 6}},
         r"Materials\[0\]\.surfaceTensionMethod: 6 \(unknown method\) is not supported yet"),
        ({"Materials": {"XSPH": {"xsph": 1.5}}}, r"Materials\[0\]\.XSPH\.xsph .*1\.5"),
        ({"RigidBodies": {"isDynamic": True, "density": -5}},
         r"RigidBodies\[0\]\.density: got -5: expected a number > 0"),
        ({"RigidBodies": {"geometryFile": "../models/Missing.obj"}},
         r"RigidBodies\[0\]\.geometryFile: got '\.\./models/Missing\.obj'"),
        ({"FluidBlocks": {"denseMode": 3}},
         r"FluidBlocks\[0\]\.denseMode: got 3: expected 0 \(regular lattice\), 1"),
        ({"FluidBlocks": {"end": [-0.6, 1.0, 0.5]}}, r"FluidBlocks\[0\]\.end.*exceed start"),
        ({"Emitters": [{"type": 2}]}, r"Emitters\[0\]\.type: got 2: expected 0 \(box\)"),
        ({"FluidModels": [{"particleFile": "a.bgeo"}]},
         r"FluidModels\[0\]\.particleFile: got 'a\.bgeo': expected an existing particle file"),
    ],
)
def test_splishsplash_unsupported_and_invalid(sph_dir: Path, edit, expected) -> None:
    data = _sph_scene()
    for key, change in edit.items():
        if isinstance(change, list):
            data[key] = change
        elif key == "Configuration":
            data[key].update(change)
            data[key] = {k: v for k, v in data[key].items() if v is not None}
        else:
            data[key][0].update(change)
    if expected is None:
        from_splishsplash(data, sph_dir / "dam.json")
        return
    with pytest.raises(SceneError, match=expected):
        from_splishsplash(data, sph_dir / "dam.json")


def test_splishsplash_contact_tolerance(sph_dir: Path) -> None:
    """PositionBasedDynamics' ``Simulation.contactTolerance`` becomes the skin the dynamic
    bodies' contacts keep (``configuration.contact_tolerance``): read where given, PBD's
    default 0.01 m where a scene with a dynamic body leaves it out, 0 without dynamic bodies
    (nothing collides), and a negative value is refused naming the field."""
    data = _sph_scene()
    assert from_splishsplash(data, sph_dir / "dam.json").configuration.contact_tolerance == 0.0
    data["RigidBodies"].append({"geometryFile": "../models/UnitBox.obj", "isDynamic": True,
                                "density": 500, "translation": [0, 0.5, 0],
                                "scale": [0.2, 0.2, 0.2]})
    scene = from_splishsplash(data, sph_dir / "dam.json")
    assert scene.configuration.contact_tolerance == 0.01
    data["Simulation"] = {"contactTolerance": 0.05, "maxIter": 5}
    assert from_splishsplash(data, sph_dir / "dam.json").configuration.contact_tolerance == 0.05
    data["Simulation"]["contactTolerance"] = -0.05
    with pytest.raises(SceneError, match=r"Simulation\.contactTolerance: got -0\.05"):
        from_splishsplash(data, sph_dir / "dam.json")


def test_splishsplash_unknown_fields_give_one_warning(sph_dir: Path) -> None:
    data = _sph_scene(mysteryOption=3, scriptFile="hooks.py")
    data["Materials"][0]["strangeness"] = 1
    data["FluidBlocks"][0]["weird"] = True
    data["Extras"] = []
    with pytest.warns(UserWarning) as record:
        scene = from_splishsplash(data, sph_dir / "dam.json")
    assert len(record) == 1
    msg = str(record[0].message)
    for field in ("Configuration.mysteryOption", "Configuration.scriptFile",
                  "Materials[0].strangeness", "FluidBlocks[0].weird", "Extras"):
        assert field in msg
    for quiet in ("cameraPosition", "pause", "DFSPH", "colorMapType", "mapResolution"):
        assert quiet not in msg
    assert scene.fluid_blocks


def test_splishsplash_file_detection_and_json_errors(sph_dir: Path) -> None:
    path = sph_dir / "scene.json"
    path.write_text(json.dumps(_sph_scene()))
    assert load_scene(path).meshes[0].invert
    path.write_text('{"Configuration": {\n"simulationMethod": 0,,\n}}')
    with pytest.raises(SceneError, match="line 2"):
        load_scene(path)


# -- the scenes shipped with the pysplishsplash wheel ---------------------------------------------


def _wheel_scenes() -> Path:
    return wheel_scene("DamBreakModel.json").parent


def _as_wcsph(data: dict[str, Any]) -> dict[str, Any]:
    data = copy.deepcopy(data)
    data["Configuration"].update(simulationMethod=0, boundaryHandlingMethod=0, cflMethod=0,
                                 timeStepSize=0.001, WCSPH={"stiffness": 50000, "exponent": 7})
    return data


def test_wheel_dambreak_3d() -> None:
    folder = _wheel_scenes()
    path = folder / "DamBreakModel.json"
    # as shipped: DFSPH with volume maps (SPlisHSPlasH's default boundaryHandlingMethod 2)
    as_shipped = load_scene(path)
    assert as_shipped.configuration.boundary.method == "bender2019"
    (m0,) = as_shipped.meshes
    assert m0.invert and m0.map_resolution == json.loads(path.read_text())["RigidBodies"][0].get(
        "mapResolution", [20, 20, 20])
    shipped = json.loads(path.read_text())
    shipped["Configuration"]["boundaryHandlingMethod"] = 0
    dfsph = from_splishsplash(shipped, path).configuration
    p = dfsph.pressure
    assert (p.method, p.min_iterations, p.max_iterations, p.max_error) == ("dfsph", 2, 100, 0.05)
    assert (p.max_iterations_v, p.max_error_v, p.divergence_solver) == (100, 0.1, True)
    assert (dfsph.time.cfl, dfsph.time.cfl_factor, dfsph.time.dt_max) == (True, 1.0, 0.005)
    data = _as_wcsph(json.loads(path.read_text()))
    scene = from_splishsplash(data, path)
    assert scene.name == "DamBreakModel"
    assert scene.configuration.time.dt == 0.001 and not scene.configuration.time.cfl
    assert scene.materials[0].viscosity.method == "standard"
    (mesh,) = scene.meshes
    assert resolve_scene_path(scene, mesh.geometry_file).is_file()
    (b,) = scene.fluid_blocks
    ours = lattice_block(b.start, b.end, scene.configuration.particle_radius)
    theirs = _splishsplash_block_positions(data["FluidBlocks"][0], 0.025, 3)
    assert len(ours) == len(theirs) == 19**3
    np.testing.assert_allclose(_sorted(ours), _sorted(theirs), atol=1e-12)


def test_wheel_dambreak_2d() -> None:
    folder = _wheel_scenes()
    path = folder / "DamBreakModel_2D.json"
    data = _as_wcsph(json.loads(path.read_text()))
    # The shipped 2D dam break uses the micropolar vorticity model (vorticityMethod 1).
    scene = from_splishsplash(data, path)
    vort = scene.materials[0].vorticity
    assert (vort.method, vort.coefficient, vort.viscosity_omega, vort.inertia_inverse) == (
        "micropolar", 0.1, 0.05, 0.5)
    assert scene.configuration.dim == 2
    (b,) = scene.fluid_blocks
    ours = lattice_block(b.start, b.end, scene.configuration.particle_radius)
    theirs = _splishsplash_block_positions(data["FluidBlocks"][0], 0.025, 2)
    assert len(ours) == len(theirs) == 29 * 29
    np.testing.assert_allclose(_sorted(ours), _sorted(theirs), atol=1e-12)


def test_empty_splishsplash_scene_runs_with_no_particles() -> None:
    # SPlisHSPlasH's Empty.json is a Configuration alone; its GUI opens it. sphkit warns and
    # runs it with 0 particles (a scene whose blocks hold no particle stays an error)
    from sphkit.simulation import Simulation

    scene = from_splishsplash({"Configuration": {"simulationMethod": 4}})
    with pytest.warns(UserWarning, match="runs with 0 particles"):
        sim = Simulation(scene)
    for _ in range(3):
        st = sim.step()
    assert sim.fluid.n == 0 and st.step == 3 and sim.time > 0.0


def test_animated_body_without_its_script_stays_in_place(sph_dir: Path) -> None:
    # SPlisHSPlasH animates an isAnimated body only from the scene's Python script; sphkit
    # does not run it: the body loads as a boundary in place, with a warning that says so
    data = _sph_scene()
    data["RigidBodies"].append({"geometryFile": "../models/UnitBox.obj", "isAnimated": True,
                                "translation": [0.5, 0.5, 0.0], "scale": [0.2, 0.2, 0.2]})
    with pytest.warns(UserWarning, match=r"RigidBodies\[1\]\.isAnimated: true.*scriptFile"):
        scene = from_splishsplash(data, sph_dir / "animated.json")
    body = scene.meshes[1]
    assert not body.dynamic and body.velocity is None and body.angular_velocity is None
    data["RigidBodies"][1]["isDynamic"] = True
    with pytest.raises(SceneError, match=r"RigidBodies\[1\]\.isAnimated: got True: expected "
                                         r"false for a dynamic body"):
        from_splishsplash(data, sph_dir / "animated.json")


def test_poly6_for_the_pressure_is_warned_about(sph_dir: Path) -> None:
    """poly6's gradient vanishes as two particles close in (the pairing instability;
    validation/README.md, "Kernels other than the cubic spline": the built-in 3D dam break's
    closest pairs fall to 0.01-0.1 r and DFSPH stops as unstable at 0.2 s): a 3D scene with it
    is warned about, naming the field as written (SPlisHSPlasH's ``kernel`` 2 too); the
    other kernels and 2D scenes, where SPlisHSPlasH reads 2 as the cubic spline, are not."""
    from sphkit.world.build import kernel_warning

    for number, warned in ((2, True), (0, False), (1, False), (3, False)):
        data = _sph_scene(kernel=number, gradKernel=number)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            note = kernel_warning(from_splishsplash(data, sph_dir / "dam.json"))
        assert (note is not None) == warned, number
        if warned:
            assert note.startswith("Configuration.kernel") and "pairs" in note
    data = _sph_scene(kernel=2, gradKernel=2, sim2D=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert kernel_warning(from_splishsplash(data, sph_dir / "dam.json")) is None


@pytest.mark.parametrize("data,field", [
    ({"fluid_blocks": [{"start": [0, 0, 0], "end": [1, 1, 1],
                        "angular_velocity": [math.nan, 0, 0]}]},
     r"fluid_blocks\[0\]\.angular_velocity\[0\]: got nan"),
    ({"fluid_blocks": [{"start": [0, 0, 0], "end": [1, 1, 1], "angular_velocity": "x"}]},
     r"fluid_blocks\[0\]\.angular_velocity: got 'x'"),
    ({"fluid_blocks": [{"start": [0, 0, 0], "end": [1, 1, 1], "angular_velocity": [0, 1]}]},
     r"fluid_blocks\[0\]\.angular_velocity: got \[0, 1\].*3 components"),
    ({"fluid_meshes": [{"geometry_file": "a.obj", "lattice": "hex"}]},
     r"fluid_meshes\[0\]\.lattice: got 'hex'"),
    ({"materials": [{"viscosity": {"method": "standard", "coefficient": 0.01,
                                   "xsph": math.inf}}]},
     r"materials\[0\]\.viscosity\.xsph: got inf"),
    ({"materials": [{"viscosity": {"method": "none", "xsph": 0.1}}]},
     r"materials\[0\]\.viscosity: .*xsph 0\.1.*method is 'none'"),
])
def test_new_fields_refuse_garbage_by_name(data: dict, field: str) -> None:
    """The fields added for SPlisHSPlasH's initialAngularVelocity, mesh denseMode and XSPH
    beside a viscosity reject NaN, Infinity, wrong types and lengths, naming the field."""
    with pytest.raises(SceneError, match=field):
        load_scene(data)
