"""Output files: atomic writes, frames (VTU, PLY) and the run manifest."""

from __future__ import annotations

import json
import os
from pathlib import Path
from types import SimpleNamespace

import meshio
import numpy as np
import pytest

from sphkit.core.particles import ParticleSet
from sphkit.io.atomic import atomic_open, atomic_path, atomic_write, atomic_write_text
from sphkit.io.frames import FrameWriter, frame_arrays, read_frame
from sphkit.io.manifest import Manifest, read_manifest
from sphkit.scene.schema import Scene


def _fake_sim(dim: int, n: int = 50, seed: int = 0, dtype: str = "float64") -> SimpleNamespace:
    """An object with what the writers read: fluid (x, v, rho, p, id), time, dim, step_count."""
    rng = np.random.default_rng(seed)
    fluid = ParticleSet(dim, dtype)
    fluid.register("v", "vector")
    fluid.register("rho")
    fluid.register("p")
    fluid.add(rng.random((n, dim)), v=rng.normal(size=(n, dim)), rho=1000 + rng.random(n),
              p=rng.random(n) * 1e3)
    # reorder as the z-curve sort does, so that ids are not in storage order
    fluid.permute(rng.permutation(n))
    return SimpleNamespace(fluid=fluid, time=0.04, dim=dim, step_count=7, dt=1e-3, last=None)


def _listing(folder: Path) -> list[str]:
    return sorted(os.listdir(folder))


# -- atomic writes -----------------------------------------------------------------------------
def test_atomic_write_replaces_file_and_leaves_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "a.txt"
    target.write_text("old")
    atomic_write(target, lambda p: p.write_text("new"))
    assert target.read_text() == "new"
    assert _listing(tmp_path) == ["a.txt"]


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_atomic_write_failure_keeps_old_file_and_removes_temp(tmp_path: Path, exc: type) -> None:
    target = tmp_path / "a.txt"
    target.write_text("old")

    def writer(p: Path) -> None:
        p.write_text("partial")
        raise exc("boom")

    with pytest.raises(exc):
        atomic_write(target, writer)
    assert target.read_text() == "old"
    assert _listing(tmp_path) == ["a.txt"]


def test_atomic_write_failure_creates_no_file(tmp_path: Path) -> None:
    target = tmp_path / "new.bin"
    with pytest.raises(ValueError), atomic_open(target, "wb") as f:
        f.write(b"partial")
        raise ValueError("boom")
    assert _listing(tmp_path) == []


def test_atomic_path_temp_is_hidden_sibling(tmp_path: Path) -> None:
    with atomic_path(tmp_path / "f.vtu") as tmp:
        assert tmp.parent == tmp_path
        assert tmp.name.startswith(".f.vtu.tmp-")
        tmp.write_bytes(b"x")
    assert _listing(tmp_path) == ["f.vtu"]


def test_atomic_write_errors_name_the_problem(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no file"):
        atomic_write(tmp_path / "a", lambda p: None)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        atomic_write_text(tmp_path / "missing" / "a", "x")
    assert _listing(tmp_path) == []


# -- frames ------------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("fmt", ["vtk", "ply"])
def test_frame_round_trip(tmp_path: Path, dim: int, fmt: str) -> None:
    sim = _fake_sim(dim)
    writer = FrameWriter(tmp_path, [fmt], dim)
    (path,) = writer.write(sim, 3)
    assert path.name == ("frame_00003.vtu" if fmt == "vtk" else "frame_00003.ply")

    f = sim.fluid
    order = np.argsort(f["id"])
    back = read_frame(path)
    # positions and velocities padded to 3D with z = 0; sorted by id; bit-identical
    expect_x = np.zeros((f.n, 3))
    expect_x[:, :dim] = f.view("x")[order]
    expect_v = np.zeros((f.n, 3))
    expect_v[:, :dim] = f.view("v")[order]
    np.testing.assert_array_equal(back["position"], expect_x)
    np.testing.assert_array_equal(back["velocity"], expect_v)
    np.testing.assert_array_equal(back["density"], f["rho"][order])
    np.testing.assert_array_equal(back["pressure"], f["p"][order])
    np.testing.assert_array_equal(back["id"], np.arange(f.n))

    # plain meshio reads it too (what ParaView/other tools see)
    mesh = meshio.read(path)
    np.testing.assert_array_equal(mesh.points, expect_x)
    if fmt == "vtk":
        assert mesh.cells[0].type == "vertex" and len(mesh.cells[0].data) == f.n
    assert _listing(tmp_path) == sorted(
        [path.name] + (["frame.vtu.series"] if fmt == "vtk" else []))


def test_ply_header_is_binary_little_endian_vertex_only(tmp_path: Path) -> None:
    sim = _fake_sim(3, n=10, dtype="float32")
    (path,) = FrameWriter(tmp_path, ["ply"], 3).write(sim, 0)
    data = path.read_bytes()
    header = data[: data.index(b"end_header\n")].decode().splitlines()
    assert header[1] == "format binary_little_endian 1.0"
    assert "element vertex 10" in header
    assert not any(line.startswith("element face") for line in header)
    props = [line.split()[1:] for line in header if line.startswith("property")]
    assert props == [["float", "x"], ["float", "y"], ["float", "z"], ["float", "vx"],
                     ["float", "vy"], ["float", "vz"], ["float", "density"],
                     ["float", "pressure"], ["int", "id"]]
    # 10 vertices of 8 float32 + 1 int32
    assert len(data) - len("\n".join(header)) - len("\nend_header\n") == 10 * 9 * 4


def test_frame_writer_both_formats_series_and_displacement(tmp_path: Path) -> None:
    sim = _fake_sim(2, n=20)
    writer = FrameWriter(tmp_path, ["vtk", "ply"], 2)
    paths0 = writer.write(sim, 0)
    assert [p.suffix for p in paths0] == [".vtu", ".ply"]
    assert writer.max_displacement is None
    sim.fluid["x"][0, :] += 0.5  # every particle moves 0.5 m along x ...
    sim.fluid["x"][1, 3] += 1.2  # ... and one also 1.2 m along y
    sim.time = 0.08
    writer.write(sim, 1)
    assert writer.max_displacement == pytest.approx(np.hypot(0.5, 1.2), rel=1e-12)
    series = json.loads(writer.series_path.read_text())
    assert series["files"] == [{"name": "frame_00000.vtu", "time": 0.04},
                               {"name": "frame_00001.vtu", "time": 0.08}]


def test_empty_frame_round_trip(tmp_path: Path) -> None:
    sim = _fake_sim(3, n=0)
    for path in FrameWriter(tmp_path, ["vtk", "ply"], 3).write(sim, 0):
        back = read_frame(path)
        assert back["position"].shape == (0, 3)
        assert back["velocity"].shape == (0, 3)
        assert back["density"].shape == (0,) and back["id"].shape == (0,)


def test_frame_errors_name_the_problem(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="'xyz'.*vtk, ply"):
        FrameWriter(tmp_path, ["xyz"], 3)
    fluid = ParticleSet(3)
    fluid.add(np.zeros((2, 3)))
    with pytest.raises(KeyError, match=r"no field\(s\) \['v', 'rho', 'p'\]"):
        frame_arrays(fluid)


# -- manifest ----------------------------------------------------------------------------------
def test_manifest_is_valid_json_through_a_run(tmp_path: Path) -> None:
    scene = Scene(name="tiny")
    sim = _fake_sim(3, n=5)
    m = Manifest(tmp_path, scene, command=["sphkit", "run", "tiny"],
                 output={"formats": ["vtk"], "fps": 25.0})
    data = read_manifest(tmp_path)
    assert data["status"] == "running" and data["frames"] == []
    assert data["scene"] == scene.model_dump(mode="json")
    assert data["command"] == ["sphkit", "run", "tiny"]
    assert data["sphkit_version"]
    assert set(data["versions"]) >= {"python", "numpy", "numba", "scipy", "meshio", "pydantic"}

    m.add_frame(sim, 0, [tmp_path / "frame_00000.vtu"])
    sim.last = SimpleNamespace(step=7, time=0.04, dt=1e-3, n_fluid=5, max_velocity=float("inf"),
                               cfl=0.1, density_error_avg=0.001, density_error_max=0.01)
    m.add_frame(sim, 1, [tmp_path / "frame_00001.vtu"], max_displacement=0.01)
    m.finish("unstable", "max velocity too high", stats=sim.last)

    text = (tmp_path / "manifest.json").read_text()
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert data["status"] == "unstable" and data["message"] == "max velocity too high"
    assert data["ended"] is not None
    f0, f1 = data["frames"]
    assert f0["files"] == ["frame_00000.vtu"] and f0["density_error_avg"] is None
    assert f0["n_fluid"] == 5 and f0["max_velocity"] > 0
    assert f1["max_velocity"] is None  # inf is not JSON: recorded as null
    assert f1["density_error_max"] == 0.01 and f1["max_displacement"] == 0.01
    assert f1["step"] == 7 and f1["time"] == 0.04
    assert data["last_step"]["step"] == 7
    assert _listing(tmp_path) == ["manifest.json"]
    with pytest.raises(ValueError, match="'done'.*running, finished"):
        m.finish("done")


def test_manifest_solver_statistics(tmp_path: Path) -> None:
    sim = _fake_sim(2, n=5)
    m = Manifest(tmp_path, Scene(name="tiny"))
    assert read_manifest(tmp_path)["run_stats"] is None  # no step yet
    steps = [
        SimpleNamespace(step=1, time=0.001, dt=1e-3, n_fluid=5, max_velocity=1.0, cfl=0.1,
                        density_error_avg=0.0004, density_error_max=0.01, iterations=3,
                        divergence_iterations=1, divergence_error=0.002),
        SimpleNamespace(step=2, time=0.002, dt=1e-3, n_fluid=5, max_velocity=1.0, cfl=0.1,
                        density_error_avg=0.0002, density_error_max=0.03, iterations=6,
                        divergence_iterations=2, divergence_error=0.001, rejected=2),
        # a step of a solver that reports no divergence solve, and a non-finite error
        SimpleNamespace(step=3, time=0.003, dt=1e-3, n_fluid=5, max_velocity=1.0, cfl=0.1,
                        density_error_avg=float("nan"), density_error_max=0.02, iterations=3),
    ]
    for stats in steps:
        m.add_step(stats)
    sim.last = steps[1]
    m.add_frame(sim, 1, [tmp_path / "frame_00001.vtu"])
    data = read_manifest(tmp_path)
    (frame,) = data["frames"]
    assert (frame["iterations"], frame["divergence_iterations"]) == (6, 2)
    assert frame["divergence_error"] == 0.001
    assert data["last_step"]["iterations"] == 6
    assert data["last_step"]["divergence_iterations"] == 2
    rs = data["run_stats"]
    assert rs["steps"] == 3
    assert rs["mean_iterations"] == pytest.approx(4.0) and rs["max_iterations"] == 6
    assert rs["mean_divergence_iterations"] == pytest.approx(1.0)  # absent counts as 0
    assert rs["mean_divergence_error"] == pytest.approx(0.001)
    assert rs["mean_density_error"] == pytest.approx(0.0003)  # the NaN step is left out
    assert rs["max_density_error"] == pytest.approx(0.03)
    assert rs["rejected"] == 2  # steps computed again (time.retries); absent counts as 0
    sim.last = steps[2]
    m.finish("finished", stats=sim.last)
    data = read_manifest(tmp_path)
    assert data["last_step"]["iterations"] == 3
    assert "divergence_iterations" not in data["last_step"]  # not reported by that step
    assert data["run_stats"]["steps"] == 3


def test_compile_watch_times_each_outermost_compilation_and_says_the_first() -> None:
    # Two functions compiled for the first time (cache=False: nothing to load), the second
    # calling a third that compiles while the second's types are inferred (a nest): three
    # compilations of which two are outermost; on_first runs once, as the first starts; after
    # stop() nothing more is counted.
    import numba

    from sphkit.io.compiling import CompileWatch

    @numba.njit(cache=False)
    def inner(a):  # noqa: ANN001, ANN202
        return a * 2.0

    @numba.njit(cache=False)
    def outer(a):  # noqa: ANN001, ANN202
        return inner(a) + 1.0

    @numba.njit(cache=False)
    def alone(a):  # noqa: ANN001, ANN202
        return a - 1.0

    said = []
    watch = CompileWatch(on_first=lambda: said.append(watch.count)).start()
    try:
        assert outer(1.0) == 3.0 and alone(1.0) == 0.0
    finally:
        watch.stop()
    assert said == [0]  # once, before the first compilation was counted
    assert watch.count == 2 and watch.seconds > 0.0
    seconds = watch.seconds
    assert alone(2.5) == 1.5 and outer(0.5) == 2.0  # compiled already: no compilation
    assert alone(2) == 1  # a new signature compiles, but the watch is stopped
    assert (watch.count, watch.seconds) == (2, seconds)
