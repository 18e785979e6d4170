"""BGEO files (against files SPlisHSPlasH wrote), particle files as fluid, frame attributes."""

from __future__ import annotations

import gzip
import importlib.util
import json
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import meshio
import numpy as np
import pytest

from sphkit.core.particles import ParticleSet
from sphkit.io.bgeo import BgeoError, read_bgeo, write_bgeo
from sphkit.io.frames import FrameFormatError, FrameWriter, read_frame, write_ply, write_vtu
from sphkit.io.particle_files import (
    ParticleFileError,
    load_fluid_particles,
    place_particles,
    read_particle_file,
)
from sphkit.scene.files import load_scene, scene_from_dict
from sphkit.scene.schema import SceneError
from sphkit.scene.splishsplash import wheel

DATA = Path(__file__).parent / "data" / "splishsplash"


def _fake_sim(dim: int, n: int = 40, seed: int = 0) -> SimpleNamespace:
    rng = np.random.default_rng(seed)
    fluid = ParticleSet(dim, "float64")
    fluid.register("v", "vector")
    fluid.register("rho")
    fluid.register("p")
    fluid.register("a", "vector")
    fluid.add(rng.random((n, dim)), v=rng.normal(size=(n, dim)), rho=1000 + rng.random(n),
              p=rng.random(n) * 1e3, a=rng.normal(size=(n, dim)))
    fluid.permute(rng.permutation(n))
    return SimpleNamespace(fluid=fluid, time=0.04, dim=dim, step_count=3, dt=1e-3, last=None)


# -- BGEO against SPlisHSPlasH ------------------------------------------------------------------
@pytest.mark.parametrize("k, t", [(1, 0.005), (2, 0.055), (3, 0.1)])
def test_reads_splishsplash_partio_export(k: int, t: float) -> None:
    """SPlisHSPlasH's frames of 36 particles in uniform motion at v = (1, 0.5, 0) m/s from its
    lattice (first particle at start + 2r = 0.05 m, spacing 2r = 0.05 m; see data/README.md):
    x = lattice + v t with the frame times 0.005, 0.055, 0.1 s."""
    path = DATA / f"ballistic_{k}.bgeo"
    with open(path, "rb") as f:
        assert f.read(2) == b"\x1f\x8b"  # SPlisHSPlasH gzips its .bgeo files
    d = read_bgeo(path)
    assert list(d) == ["position", "id", "velocity", "density", "pressure"]
    assert d["position"].dtype == np.float32 and d["id"].dtype == np.int32
    np.testing.assert_array_equal(np.sort(d["id"]), np.arange(36))
    np.testing.assert_array_equal(d["velocity"], np.tile([1.0, 0.5, 0.0], (36, 1)))
    # the lattice fluid is light (SPlisHSPlasH's mass 0.8 (2r)^3), density clamped to rho0
    np.testing.assert_array_equal(d["density"], 1000.0)
    np.testing.assert_array_equal(d["pressure"], 0.0)
    start = d["position"] - np.array([1.0, 0.5, 0.0]) * t
    lattice = np.stack(np.meshgrid(0.05 * np.arange(1, 5), 0.05 * np.arange(1, 4),
                                   0.05 * np.arange(1, 4), indexing="ij"), -1).reshape(-1, 3)
    key = np.lexsort(np.round(start / 0.05).T[::-1])
    ref = np.lexsort(np.round(lattice / 0.05).T[::-1])
    # tolerance: float32 positions of size <= 0.3 m carry rounding errors of ~3e-8 m
    np.testing.assert_allclose(start[key], lattice[ref], atol=1e-6)


def test_written_stream_equals_splishsplash_bytes(tmp_path: Path) -> None:
    """Reading SPlisHSPlasH's dam-break frame and writing it again gives partio's exact bytes."""
    src = DATA / "dambreak_1.bgeo"
    d = read_bgeo(src)
    assert len(d["position"]) == 245  # 7 x 5 x 7 particles of dambreak.json
    out = write_bgeo(tmp_path / "a.bgeo", d)
    assert out.read_bytes() == gzip.decompress(src.read_bytes())
    gz = write_bgeo(tmp_path / "a.bgeo.gz", d)
    assert gz.read_bytes()[:2] == b"\x1f\x8b"
    e = read_bgeo(gz)
    assert list(e) == list(d)
    for key in d:
        np.testing.assert_array_equal(e[key], d[key])


@pytest.mark.skipif(importlib.util.find_spec("pysplashsurf") is None,
                    reason="pysplashsurf (an independent BGEO reader) is not installed")
def test_agrees_with_pysplashsurf_reader(tmp_path: Path) -> None:
    from pysplashsurf.bgeo import readbgeo_to_meshio

    rng = np.random.default_rng(3)
    arrays = {"position": rng.normal(size=(50, 3)), "velocity": rng.normal(size=(50, 3)),
              "density": rng.random(50) * 1000, "id": np.arange(50, dtype=np.int64)}
    path = write_bgeo(tmp_path / "x.bgeo", arrays, compressed=True)
    for f in (path, DATA / "dambreak_1.bgeo"):
        m = readbgeo_to_meshio(str(f))
        ours = read_bgeo(f)
        np.testing.assert_array_equal(np.asarray(m.points), ours["position"])
        for key, value in m.point_data.items():
            np.testing.assert_array_equal(np.asarray(value).reshape(ours[key].shape), ours[key])


def test_round_trip_types_and_detail(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    n = 30
    arrays = {"position": rng.normal(size=(n, 3)), "velocity": rng.normal(size=(n, 3)),
              "uv": rng.random((n, 2)).astype(np.float32), "density": rng.random(n),
              "id": rng.permutation(n).astype(np.int64), "flag": rng.random(n) > 0.5}
    for name in ("p.bgeo", "p.bgeo.gz"):
        d, detail = read_bgeo(write_bgeo(tmp_path / name, arrays), detail=True)
        assert detail == {}
        assert list(d) == list(arrays)
        for key, a in arrays.items():
            expected = a.astype(np.int32) if a.dtype.kind in "ib" else a.astype(np.float32)
            np.testing.assert_array_equal(d[key], expected)
    # the empty set, also with attributes (a run whose fluid is all gone: reshape(0, -1) failed)
    d = read_bgeo(write_bgeo(tmp_path / "e.bgeo", {"position": np.zeros((0, 3))}))
    assert d["position"].shape == (0, 3)
    d = read_bgeo(write_bgeo(tmp_path / "e2.bgeo", {"position": np.zeros((0, 3)),
                                                    "velocity": np.zeros((0, 3)),
                                                    "density": np.zeros(0),
                                                    "id": np.zeros(0, dtype=np.int64)}))
    assert d["velocity"].shape == (0, 3) and d["density"].shape == (0,)
    assert d["id"].shape == (0,)


def test_bgeo_errors_name_file_and_problem(tmp_path: Path) -> None:
    bad = tmp_path / "bad.bgeo"
    bad.write_bytes(b"hello world, not geometry")
    with pytest.raises(BgeoError, match="bad.bgeo.*b'hell'.*expected b'Bgeo'"):
        read_bgeo(bad)
    new = tmp_path / "new.bgeo"
    new.write_bytes(b"\x7fNSJ" + b"\0" * 40)
    with pytest.raises(BgeoError, match="JSON-based BGEO"):
        read_bgeo(new)
    good = write_bgeo(tmp_path / "g.bgeo", {"position": np.ones((5, 3)), "d": np.ones(5)})
    data = good.read_bytes()
    (tmp_path / "t.bgeo").write_bytes(data[:-30])
    with pytest.raises(BgeoError, match="ends early"):
        read_bgeo(tmp_path / "t.bgeo")
    (tmp_path / "v.bgeo").write_bytes(data[:5] + (4).to_bytes(4, "big") + data[9:])
    with pytest.raises(BgeoError, match="version 4; expected 5"):
        read_bgeo(tmp_path / "v.bgeo")
    with pytest.raises(ValueError, match="'id' holds integers up to 4294967296"):
        write_bgeo(tmp_path / "i.bgeo", {"position": np.ones((1, 3)),
                                         "id": np.array([2**32])})
    with pytest.raises(ValueError, match="'x' of shape \\(4,\\); expected \\(5,\\)"):
        write_bgeo(tmp_path / "s.bgeo", {"position": np.ones((5, 3)), "x": np.ones(4)})


@pytest.mark.parametrize("dim", [2, 3])
def test_frame_writer_bgeo_matches_vtk(tmp_path: Path, dim: int) -> None:
    sim = _fake_sim(dim)
    w = FrameWriter(tmp_path, ["vtk", "bgeo", "bgeo.gz", "ply"], dim)
    paths = w.write(sim, 0)
    assert [p.name for p in paths] == ["frame_00000.vtu", "frame_00000.bgeo",
                                       "frame_00000.bgeo.gz", "frame_00000.ply"]
    vtu, bgeo, bgz = (read_frame(p) for p in paths[:3])
    assert paths[2].read_bytes()[:2] == b"\x1f\x8b"
    for key in ("position", "velocity", "density", "pressure", "id"):
        np.testing.assert_array_equal(bgeo[key], vtu[key].astype(bgeo[key].dtype))
        np.testing.assert_array_equal(bgz[key], bgeo[key])


def test_frame_attributes_select_fields(tmp_path: Path) -> None:
    sim = _fake_sim(3)
    w = FrameWriter(tmp_path, ["bgeo", "vtk"], 3,
                    attributes=["velocity", "acceleration"])
    bgeo, vtu = (read_frame(p) for p in w.write(sim, 0))
    assert list(bgeo) == ["position", "velocity", "acceleration", "id"]
    assert sorted(vtu) == sorted(bgeo)
    order = sim.fluid.order_by_id()
    np.testing.assert_allclose(bgeo["acceleration"], sim.fluid.view("a")[order], rtol=1e-6)
    with pytest.raises(ValueError, match="output.attributes: got 'vorticity'.*expected one of"):
        FrameWriter(tmp_path, ["vtk"], 3, attributes=["vorticity"]).write(sim, 1)


def test_ply_holds_the_phase_of_several_fluids_as_int(tmp_path: Path) -> None:
    """A multiphase run's frames carry each particle's ``phase`` as int64; PLY has no 64-bit
    integer, and ``sphkit run --format ply`` of SPlisHSPlasH's DoubleDamBreakMultiPhase stopped
    with a traceback. Integer fields are written as PLY 'int' where they fit, and a value that
    does not fit is refused naming the field and the formats that hold it."""
    n = 5
    arrays = {"position": np.arange(3.0 * n).reshape(n, 3), "id": np.arange(n, dtype=np.int64),
              "phase": np.array([0, 1, 2, 1, 0], dtype=np.int64),
              "rest_density": np.array([1000.0, 500, 250, 500, 1000])}
    back = read_frame(write_ply(tmp_path / "f.ply", arrays))
    assert back["phase"].dtype == np.int32
    np.testing.assert_array_equal(back["phase"], arrays["phase"])
    np.testing.assert_array_equal(back["rest_density"], arrays["rest_density"])
    arrays["phase"][2] = 2**40
    with pytest.raises(FrameFormatError, match="field 'phase' holds values up to 1099511627776"
                       ".*use the vtk or bgeo format"):
        write_ply(tmp_path / "g.ply", arrays)
    assert not (tmp_path / "g.ply").exists()


# -- the wheel itself -------------------------------------------------------------------------
def _wheel_data() -> Path:
    folder = wheel.data_folder()
    if folder is None:
        pytest.skip("pysplishsplash is not installed, or its wheel ships no data folder")
    return folder


_RUNNER = """
import sys
import pysplishsplash as sph
base = sph.Exec.SimulatorBase()
base.init(["x", "--no-gui", "--output-dir", sys.argv[2], "--no-cache", sys.argv[1]], "x")
base.run()
"""


def _run_splishsplash(scene: Path, out: Path) -> list[Path]:
    _wheel_data()
    res = subprocess.run([sys.executable, "-c", _RUNNER, str(scene.resolve()), str(out)],
                         env=wheel.subprocess_env(), capture_output=True, text=True, timeout=120)
    files = sorted((out / "partio").glob("*.bgeo"))
    if res.returncode != 0 and not files:
        pytest.skip(f"the pysplishsplash wheel did not run here: {res.stderr[-300:]}")
    return files


def test_splishsplash_reads_sphkit_bgeo_and_places_it_as_sphkit(tmp_path: Path) -> None:
    """sphkit writes a particle file; SPlisHSPlasH loads it as a FluidModel (scaled, rotated,
    translated) and exports its first frame; sphkit's own placement of the same scene agrees.
    No gravity, no walls and an under-dense lattice: nothing moves in the one step before."""
    g = np.stack(np.meshgrid(*[0.05 * np.arange(3)] * 3, indexing="ij"), -1).reshape(-1, 3)
    g = g + np.array([0.1, 0.2, 0.3])
    write_bgeo(tmp_path / "block.bgeo", {"position": g, "velocity": np.full_like(g, 7.0)})
    scene = {
        "Configuration": {"particleRadius": 0.025, "simulationMethod": 0,
                          "gravitation": [0, 0, 0], "cflMethod": 0, "timeStepSize": 0.001,
                          "stopAt": 0.001, "enablePartioExport": True,
                          "particleAttributes": "velocity"},
        "FluidModels": [{"particleFile": "block.bgeo", "translation": [1.0, 2.0, 3.0],
                         "scale": [2.0, 2.0, 2.0], "rotationAxis": [0, 1, 1],
                         "rotationAngle": 0.7}],
    }
    path = tmp_path / "fm.json"
    path.write_text(json.dumps(scene))
    files = _run_splishsplash(path, tmp_path / "out")
    assert files, "SPlisHSPlasH wrote no partio file"
    theirs = read_bgeo(files[0])
    # SPlisHSPlasH replaces the file's velocities by initialVelocity (0)
    np.testing.assert_array_equal(theirs["velocity"], 0.0)
    ours = load_scene(path)
    assert ours.output.formats == ["bgeo"] and ours.output.attributes == ["velocity"]
    ff = ours.fluid_files[0]
    x, v = load_fluid_particles(tmp_path / ff.file, 3, translation=ff.translation,
                                scale=ff.scale, rotation_axis=ff.rotation_axis,
                                rotation_angle=ff.rotation_angle)
    np.testing.assert_array_equal(v, 0.0)
    # SPlisHSPlasH keeps the file's order (ids 0..26); float32 output: atol 1e-6 m
    order = np.argsort(theirs["id"])
    np.testing.assert_allclose(theirs["position"][order], x, atol=1e-6)


def test_splishsplash_run_matches_committed_reference(tmp_path: Path) -> None:
    """The committed reference files are what the installed wheel writes for ballistic.json."""
    files = _run_splishsplash(DATA / "ballistic.json", tmp_path / "out")
    assert [f.name for f in files] == [f"ParticleData_Fluid_{k}.bgeo" for k in (1, 2, 3)]
    for k, f in enumerate(files, start=1):
        ref, new = read_bgeo(DATA / f"ballistic_{k}.bgeo"), read_bgeo(f)
        for key in ref:
            np.testing.assert_array_equal(new[key], ref[key])


# -- particle files as fluid --------------------------------------------------------------------
def test_particle_file_formats_read_alike(tmp_path: Path) -> None:
    sim = _fake_sim(3, n=25)
    from sphkit.io.frames import frame_arrays

    arrays = frame_arrays(sim.fluid)
    files = [write_bgeo(tmp_path / "a.bgeo", arrays), write_ply(tmp_path / "a.ply", arrays),
             write_vtu(tmp_path / "a.vtu", arrays)]
    legacy = tmp_path / "a.vtk"
    cells = [("vertex", np.arange(25).reshape(-1, 1))]
    meshio.write(legacy, meshio.Mesh(arrays["position"], cells,
                                     point_data={"velocity": arrays["velocity"]}),
                 file_format="vtk", binary=True)
    files.append(legacy)
    for f in files:
        d = read_particle_file(f)
        tol = 1e-6 if f.suffix == ".bgeo" else 0  # BGEO stores float32
        np.testing.assert_allclose(d["position"], arrays["position"], atol=tol)
        np.testing.assert_allclose(d["velocity"], arrays["velocity"], atol=tol * 10)
    with pytest.raises(ParticleFileError, match="unknown format; expected a name ending in"):
        read_particle_file(tmp_path / "a.xyz")
    with pytest.raises(ParticleFileError, match="not found"):
        read_particle_file(tmp_path / "missing.ply")


def test_place_particles_scale_rotate_translate() -> None:
    p = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    # 90 degrees about z: (1,0,0) -> (0,1,0), (0,2,0) -> (-2,0,0); then scale 3, translate
    out = place_particles(p, [1.0, 1.0, 1.0], 3.0, [0, 0, 5], np.pi / 2)
    np.testing.assert_allclose(out, [[1.0, 4.0, 1.0], [-5.0, 1.0, 1.0]], atol=1e-12)


def _block_file(tmp_path: Path, r: float, spacing: float, name: str = "blob.bgeo") -> np.ndarray:
    g = np.stack(np.meshgrid(*[spacing * np.arange(4)] * 3, indexing="ij"), -1).reshape(-1, 3)
    write_bgeo(tmp_path / name, {"position": g, "velocity": np.tile([0.5, 0.0, 0.0], (64, 1))})
    return g


def test_scene_fluid_files_build_the_fluid(tmp_path: Path) -> None:
    """A file of 64 particles at spacing 2r becomes fluid where the scene places it, with the
    lattice mass of a fluid block, and the initial velocity v0 + omega x (x - centre)."""
    from sphkit.simulation import Simulation

    r = 0.025
    g = _block_file(tmp_path, r, 2 * r)
    (tmp_path / "sub").mkdir()
    scene = {
        "name": "from-file",
        "configuration": {"dim": 3, "particle_radius": r},
        "fluid_files": [{"file": "../blob.bgeo", "translation": [0.2, 0.3, 0.4],
                         "velocity": [0.0, -1.0, 0.0], "angular_velocity": [0.0, 0.0, 2.0]}],
        "boxes": [{"min": [0, 0, 0], "max": [1, 1, 1]}],
    }
    path = tmp_path / "sub" / "scene.json"
    path.write_text(json.dumps(scene))
    sim = Simulation.from_scene(path)
    order = sim.fluid.order_by_id()
    x = sim.positions[order]
    np.testing.assert_allclose(x, g + [0.2, 0.3, 0.4], atol=1e-7)
    c = x.mean(axis=0)
    expect_v = np.array([0.0, -1.0, 0.0]) + np.cross([0.0, 0.0, 2.0], x - c)
    np.testing.assert_allclose(sim.velocities[order], expect_v, atol=1e-12)
    block = Simulation.from_scene({**scene, "fluid_files": [],
                                   "fluid_blocks": [{"start": [0.1, 0.1, 0.1],
                                                     "end": [0.3, 0.3, 0.3]}]})
    # the start-up sets each mass so that its summation density is the start density; the
    # file's float32 positions sit off the lattice by ~1e-8 relative, which moves the masses of
    # the particles with a filled kernel by ~1e-7: equal to the block's lattice mass to 1e-6
    assert np.unique(block.fluid["m"]).size == 1
    np.testing.assert_allclose(sim.fluid["m"], block.fluid["m"][0], rtol=1e-6)
    # the file's own velocities, when asked for
    scene["fluid_files"][0].update(use_file_velocity=True, velocity=None, angular_velocity=None)
    path.write_text(json.dumps(scene))
    np.testing.assert_allclose(Simulation.from_scene(path).velocities, [[0.5, 0.0, 0.0]] * 64,
                               rtol=1e-7)


def test_fluid_file_errors_and_spacing_warning(tmp_path: Path) -> None:
    from sphkit.simulation import Simulation

    _block_file(tmp_path, 0.025, 0.1, "sparse.bgeo")
    base = {"configuration": {"dim": 3, "particle_radius": 0.025}}
    with pytest.raises(SceneError, match=r"fluid_files\[0\].file: got 'nope.bgeo': expected an "
                                         "existing particle file"):
        scene_from_dict({**base, "fluid_files": [{"file": "nope.bgeo"}]}, tmp_path / "s.json")
    with pytest.raises(SceneError, match=r"fluid_files\[0\].file: got 'a.txt': expected a "
                                         "particle file ending in"):
        scene_from_dict({**base, "fluid_files": [{"file": "a.txt"}]}, tmp_path / "s.json")
    path = tmp_path / "s.json"
    path.write_text(json.dumps({**base, "fluid_files": [{"file": "sparse.bgeo"}]}))
    with pytest.warns(UserWarning, match="0.1 m apart.*not the 2r = 0.05 m"):
        Simulation.from_scene(path)


def test_splishsplash_fluid_models_translation(tmp_path: Path) -> None:
    _block_file(tmp_path, 0.025, 0.05)
    (tmp_path / "shape.obj").write_text("v 0 0 0\n")
    cfg = {"particleRadius": 0.025, "particleAttributes": "density;velocity",
           "enableVTKExport": True, "enablePartioExport": True}
    fm = {"particleFile": "blob.bgeo", "translation": [1, 2, 3], "scale": [2, 2, 2],
          "rotationAxis": [0, 0, 1], "rotationAngle": 0.5, "id": "Water",
          "initialVelocity": [0, 1, 0], "visMesh": ""}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no field is reported as unknown
        scene = scene_from_dict({"Configuration": cfg, "FluidModels": [fm]},
                                tmp_path / "scene.json")
    f = scene.fluid_files[0]
    assert (f.file, f.translation, f.scale, f.rotation_axis, f.rotation_angle, f.material,
            f.velocity) == ("blob.bgeo", [1, 2, 3], 2.0, [0, 0, 1], 0.5, "Water", [0, 1, 0])
    assert [m.id for m in scene.materials] == ["Water"]
    assert scene.output.formats == ["vtk", "bgeo"]
    assert scene.output.attributes == ["density", "velocity"]
    # an OBJ particleFile is a closed mesh to fill with fluid, not a particle file
    mesh_scene = scene_from_dict({"Configuration": cfg,
                                  "FluidModels": [{"particleFile": "shape.obj"}]},
                                 tmp_path / "scene.json")
    assert mesh_scene.fluid_files == []
    assert [m.geometry_file for m in mesh_scene.fluid_meshes] == ["shape.obj"]
    with pytest.raises(SceneError, match=r"FluidModels\[0\].particleFile: got 'x.bgeo': "
                                         "expected an existing particle file"):
        scene_from_dict({"Configuration": cfg, "FluidModels": [{"particleFile": "x.bgeo"}]},
                        tmp_path / "scene.json")
    with pytest.warns(UserWarning, match="scales particle files uniformly by the first"):
        scene_from_dict({"Configuration": cfg,
                         "FluidModels": [{**fm, "scale": [2, 1, 1]}]}, tmp_path / "scene.json")
