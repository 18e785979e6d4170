"""The ``sphkit`` command: arguments, scene errors, a tiny run, an unstable run, an interrupt."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sphkit.backend import cuda_available
from sphkit.cli import main
from sphkit.cli.common import COMPILING
from sphkit.io.frames import FrameWriter, read_frame
from sphkit.io.manifest import read_manifest

#: 2D, 20 x 10 = 200 fluid particles falling freely in a box (0.1 m from its walls);
#: 0.05 s at 40 frames/s = frames 0, 1, 2
TINY = {
    "name": "tiny",
    "configuration": {"dim": 2, "particle_radius": 0.01, "time": {"until": 0.05}},
    "fluid_blocks": [{"start": [0.1, 0.1], "end": [0.5, 0.3]}],
    "boxes": [{"min": [0.0, 0.0], "max": [0.6, 0.5]}],
    "output": {"fps": 40, "formats": ["vtk", "ply"]},
}


def _scene_file(folder: Path, scene: dict, name: str = "scene.json") -> Path:
    path = folder / name
    path.write_text(json.dumps(scene))
    return path


# -- command line without a simulation -----------------------------------------------------------
def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("sphkit ")


def test_scenes_lists_dambreak_3d(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = {line.split()[0] for line in lines}
    assert "dambreak-3d" in names
    assert all(len(line.split(maxsplit=1)) == 2 for line in lines)  # each has a description


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--format", "xyz"], ["--format", "'xyz'", "vtk, ply"]),
        (["--format", "vtk,obj"], ["--format", "'vtk,obj'", "vtk, ply"]),
        (["--fps", "-1"], ["--fps", "'-1'", "positive number"]),
        (["--fps", "abc"], ["--fps", "'abc'", "positive number"]),
        (["--until", "0"], ["--until", "'0'", "positive number"]),
        (["--until", "inf"], ["--until", "'inf'", "positive number"]),
        (["--frobnicate"], ["--frobnicate"]),
        (["--device", "gpu"], ["--device", "'gpu'", "'auto', 'cpu', 'cuda'"]),
        (["--device", "nan"], ["--device", "'nan'", "'auto', 'cpu', 'cuda'"]),
    ],
)
def test_bad_flags_exit_2_naming_flag_value_expectation(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, flags: list[str],
        named: list[str]) -> None:
    assert main(["run", "dambreak-3d", "--out", str(tmp_path), *flags]) == 2
    err = capsys.readouterr().err
    for text in named:
        assert text in err
    assert list(tmp_path.iterdir()) == []  # nothing was run or written


def test_no_command_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().err


def test_bad_scene_file_exits_2_naming_the_field(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad = dict(TINY, configuration={"dim": 2, "particle_radius": -0.01})
    path = _scene_file(tmp_path, bad)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "particle_radius" in err and "-0.01" in err
    assert not (tmp_path / "out").exists()


def test_unknown_scene_exits_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["run", "no-such-scene", "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert "no-such-scene" in capsys.readouterr().err


def test_module_entry_point() -> None:
    proc = subprocess.run([sys.executable, "-m", "sphkit", "--version"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("sphkit ")


def test_console_shows_a_repeated_warning_three_times_and_counts_the_rest(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A solver that misses its tolerance step after step (SPlisHSPlasH's CoilingModel with
    Bender 2017 viscosity: 377 warnings in a second) fills the console with one kind of
    warning: the console shows three of a kind, the log file all of them, and the command's
    end says how many it left out. Python warnings (a scene field sphkit ignores) read as
    ``WARNING: message`` lines, without Python's file, line and source display, and go to the
    log file too, also when they come before it exists."""
    import logging
    import warnings

    from sphkit.io.log import command_logging, get_logger

    # pytest records warnings in every test; a plain writer is what the command meets
    monkeypatch.setattr(warnings, "_showwarnmsg_impl", lambda msg: None)
    log = get_logger("test")
    with command_logging() as session:
        warnings.warn("scene 'x': ignored 1 field(s): Configuration.scriptFile", stacklevel=1)
        session.add_file(tmp_path)
        for step in range(10):
            log.warning("viscosity: no convergence in 100 iterations at step %d: error %.3g",
                        step, 0.05 + step * 1e-4)
        log.warning("a warning of another kind")
        log.error("an error at step %d", 11)
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "WARNING: scene 'x': ignored 1 field(s): Configuration.scriptFile"
    assert not any("UserWarning" in line or "warnings.warn" in line for line in err)
    shown = [line for line in err if "no convergence" in line and "more like" not in line]
    assert [line.split("step ")[1][:1] for line in shown] == ["0", "1", "2"]
    assert "[shown 3 times" in shown[2] and "[shown" not in shown[1]
    assert "WARNING: a warning of another kind" in err
    assert "ERROR: an error at step 11" in err
    summary = [line for line in err if "more like" in line]
    assert len(summary) == 1 and summary[0].startswith("WARNING: 7 more like ")
    assert str(tmp_path / "sphkit.log") in summary[0]
    text = (tmp_path / "sphkit.log").read_text()
    assert text.count("no convergence") == 10 and "[shown" not in text
    assert "ignored 1 field(s)" in text.splitlines()[0]
    # where warnings are recorded (catch_warnings(record=True), pytest), they stay recorded
    monkeypatch.undo()
    with warnings.catch_warnings(record=True) as caught, command_logging():
        warnings.warn("recorded, not logged", stacklevel=1)
    assert [str(w.message) for w in caught] == ["recorded, not logged"]
    assert "recorded, not logged" not in capsys.readouterr().err
    assert logging.getLogger("sphkit").handlers == []


# -- runs --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Run the tiny scene once (the first run compiles the kernels); keep what it printed."""
    folder = tmp_path_factory.mktemp("tiny")
    path = _scene_file(folder, TINY)
    out = folder / "out"
    old_err = sys.stderr
    sys.stderr = io.StringIO()  # not a terminal: plain log lines
    try:
        code = main(["run", str(path), "--out", str(out)])
        err = sys.stderr.getvalue()
    finally:
        sys.stderr = old_err
    return {"code": code, "err": err, "out": out, "scene": path}


def test_tiny_run_writes_frames_and_manifest(tiny_run: dict) -> None:
    assert tiny_run["code"] == 0, tiny_run["err"]
    out: Path = tiny_run["out"]
    manifest = read_manifest(out)
    assert manifest["status"] == "finished" and manifest["message"] is None
    # Numba's compilations of the run are timed; the first one is said (a cold cache: every
    # pass; a warm one: none)
    assert manifest["compile_seconds"] >= 0.0
    assert (COMPILING in tiny_run["err"]) == (manifest["compile_seconds"] > 0.0)
    frames = manifest["frames"]
    assert [f["frame"] for f in frames] == [0, 1, 2]
    assert frames[-1]["time"] >= 0.05 - 1e-9
    assert manifest["scene"]["name"] == "tiny"
    # --device auto: the GPU where one is found (every method of the scene runs there), else
    # the CPU
    assert manifest["device"] == ("cuda" if cuda_available() else "cpu")
    assert manifest["last_step"]["step"] == frames[-1]["step"] > 0
    for rec in frames:
        assert rec["files"] == [f"frame_{rec['frame']:05d}.vtu", f"frame_{rec['frame']:05d}.ply"]
        vtu, ply = (read_frame(out / name) for name in rec["files"])
        assert vtu["position"].shape == (200, 3) == ply["position"].shape
        assert np.all(vtu["position"][:, 2] == 0.0)  # 2D padded with z = 0
        for key in ("position", "velocity", "density", "pressure", "id"):
            np.testing.assert_array_equal(vtu[key], ply[key])
        np.testing.assert_array_equal(vtu["id"], np.arange(200))
    # free fall, recorded in the frames: y drops by g t^2 / 2, v_y = -g t (t = frame time)
    first, last = (read_frame(out / frames[k]["files"][0]) for k in (0, 2))
    t = frames[2]["time"]
    drop = first["position"][:, 1] - last["position"][:, 1]
    np.testing.assert_allclose(drop, 9.81 * t**2 / 2, rtol=0.05)
    np.testing.assert_allclose(last["velocity"][:, 1], -9.81 * t, rtol=0.01)
    # the manifest's max displacement is that between frames 1 and 2
    middle = read_frame(out / frames[1]["files"][0])
    moved = np.linalg.norm(last["position"] - middle["position"], axis=1).max()
    assert frames[0]["max_displacement"] is None
    assert frames[2]["max_displacement"] == pytest.approx(moved, rel=1e-12)
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [n for f in frames for n in f["files"]] + ["frame.vtu.series", "manifest.json",
                                                   "sphkit.log"])


def test_tiny_run_logs_plain_lines(tiny_run: dict) -> None:
    err: str = tiny_run["err"]
    assert "200 fluid" in err
    for k in range(3):
        assert f"[frame {k}]" in err
    assert "finished: 3 frame(s)" in err


def test_rerun_with_flags_replaces_previous_frames(tiny_run: dict, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    scene = str(tiny_run["scene"])
    assert main(["run", scene, "--out", str(out), "--quiet"]) == 0
    assert len(list(out.glob("frame_*"))) == 6  # frames 0..2 as vtu and ply
    code = main(["run", scene, "--out", str(out), "--until", "0.025", "--fps", "40",
                 "--format", "ply", "--quiet"])
    assert code == 0
    assert capsys.readouterr().err == ""  # --quiet
    manifest = read_manifest(out)
    assert manifest["scene"]["configuration"]["time"]["until"] == 0.025
    assert manifest["output"]["formats"] == ["ply"]
    # the earlier run's frames 0..2 (vtu + ply) and its series file are gone
    assert sorted(p.name for p in out.iterdir()) == [
        "frame_00000.ply", "frame_00001.ply", "manifest.json", "sphkit.log"]


def test_unstable_run_exits_3_and_keeps_frame_0(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    scene = json.loads(json.dumps(TINY))
    scene["configuration"]["max_velocity"] = 1e-3  # gravity exceeds it in the first step
    path = _scene_file(tmp_path, scene)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 3
    err = capsys.readouterr().err
    assert "step" in err and "max velocity" in err
    manifest = read_manifest(out)
    assert manifest["status"] == "unstable"
    assert manifest["compile_seconds"] >= 0.0  # recorded however the run ends
    assert "max velocity" in manifest["message"]
    assert manifest["last_step"]["max_velocity"] > 1e-3
    assert [f["frame"] for f in manifest["frames"]] == [0]
    assert read_frame(out / "frame_00000.vtu")["position"].shape == (200, 3)


def test_interrupt_exits_130_and_records_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    original = FrameWriter.write

    def write(self: FrameWriter, sim: object, frame: int) -> list[Path]:
        if frame == 1:
            raise KeyboardInterrupt
        return original(self, sim, frame)

    monkeypatch.setattr(FrameWriter, "write", write)
    out = tmp_path / "out"
    assert main(["run", str(_scene_file(tmp_path, TINY)), "--out", str(out), "--quiet"]) == 130
    assert "interrupted" in capsys.readouterr().err
    manifest = read_manifest(out)
    assert manifest["status"] == "interrupted"
    assert [f["frame"] for f in manifest["frames"]] == [0]
    # no half-written frame 1 and no temporary files
    assert sorted(p.name for p in out.iterdir()) == [
        "frame.vtu.series", "frame_00000.ply", "frame_00000.vtu", "manifest.json",
        "sphkit.log"]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stream = _Terminal()
    monkeypatch.setattr(sys, "stderr", stream)
    path = _scene_file(tmp_path, TINY)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--until", "0.025"]) == 0
    text = stream.getvalue()
    assert "particles" in text and "steps/s" in text and "finished" in text


# -- pressure-solver statistics in the progress and the manifest ---------------------------------
def test_tiny_run_records_solver_iterations(tiny_run: dict) -> None:
    manifest = read_manifest(tiny_run["out"])
    f0, *later = manifest["frames"]
    assert f0["iterations"] is None and f0["divergence_iterations"] is None  # no step yet
    for rec in later:  # WCSPH: one "iteration" per step, no divergence solve
        assert rec["iterations"] == 1
        assert rec["divergence_iterations"] == 0 and rec["divergence_error"] == 0.0
    assert manifest["last_step"]["iterations"] == 1
    rs = manifest["run_stats"]
    assert rs["steps"] == manifest["last_step"]["step"]
    assert rs["mean_iterations"] == 1.0 and rs["max_iterations"] == 1
    assert rs["mean_divergence_iterations"] == 0.0 and rs["mean_divergence_error"] == 0.0
    assert 0.0 <= rs["mean_density_error"] <= rs["max_density_error"]
    assert "iters 1" in tiny_run["err"] and "  div " not in tiny_run["err"]
    assert "mean 1 pressure iterations per step" in tiny_run["err"]


def _with_solver_stats(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Make every step report DFSPH-like statistics: pressure iterations 2, 3, 4, 2, 3, 4, ...
    and 1 divergence iteration with error 0.002; return the list of reported iterations."""
    from types import SimpleNamespace

    from sphkit.simulation import Simulation

    original = Simulation.step
    reported: list[int] = []

    def step(self: Simulation, *args):  # noqa: ANN002, ANN202
        stats = original(self, *args)
        fields = {k: v for k, v in vars(stats).items()
                  if k not in ("iterations", "divergence_iterations", "divergence_error")}
        reported.append(2 + len(reported) % 3)
        fake = SimpleNamespace(**fields, iterations=reported[-1], divergence_iterations=1,
                               divergence_error=0.002)
        self.last = fake
        return fake

    monkeypatch.setattr(Simulation, "step", step)
    return reported


def test_run_records_iterative_solver_stats(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    reported = _with_solver_stats(monkeypatch)
    out = tmp_path / "out"
    assert main(["run", str(_scene_file(tmp_path, TINY)), "--out", str(out),
                 "--until", "0.025"]) == 0
    err = capsys.readouterr().err
    manifest = read_manifest(out)
    last_frame = manifest["frames"][-1]
    assert last_frame["iterations"] == reported[-1]
    assert last_frame["divergence_iterations"] == 1 and last_frame["divergence_error"] == 0.002
    rs = manifest["run_stats"]
    assert rs["steps"] == len(reported)
    assert rs["mean_iterations"] == pytest.approx(np.mean(reported))
    assert rs["max_iterations"] == max(reported)
    assert rs["mean_divergence_iterations"] == 1.0
    assert rs["mean_divergence_error"] == pytest.approx(0.002)
    # the log lines show the mean iterations since the previous line, and "div" when > 0
    assert "iters " in err and "div 1" in err
    assert f"mean {np.mean(reported):.3g} pressure iterations per step" in err


def test_progress_shows_iterations_since_the_last_update() -> None:
    from types import SimpleNamespace

    from sphkit.cli.progress import _PlainReporter

    stream = io.StringIO()
    rep = _PlainReporter(1.0, stream)
    last = SimpleNamespace(density_error_avg=0.0004, max_velocity=1.0, iterations=5,
                           divergence_iterations=0)
    sim = SimpleNamespace(fluid=SimpleNamespace(n=10), dt=1e-3, last=last, time=0.5,
                          step_count=3)
    assert "iters 5" in rep.stats_text(sim)  # nothing counted yet: the last step's
    assert "div" not in rep.stats_text(sim)
    for k in (2, 3, 7):
        rep.count_step(SimpleNamespace(iterations=k, divergence_iterations=k - 1))
    text = rep.stats_text(sim)
    assert "iters 4" in text and "div 3" in text and "rho err avg 0.04%" in text
    assert "iters 5" in rep.stats_text(sim)  # the window was consumed
    rep.count_step(SimpleNamespace(iterations=3))  # no divergence field: counts as 0
    assert "iters 3" in rep.stats_text(sim) and "div" not in rep.stats_text(sim)
    sim.last = None
    assert "iters" not in rep.stats_text(sim)  # before the first step


def test_run_writes_the_moving_bodies_at_their_pose(tmp_path: Path) -> None:
    """A kinematic paddle turning at pi rad/s about its centre (0.3, 0.3): each frame's
    ``bodies_*.vtu``, ``bodies_*.obj`` and ``bodies_*.ply`` hold its mesh turned by pi t about
    z, which is the prescribed motion (exact up to the float printing of OBJ, 1e-8 m, and the
    rotation's round-off), the PLY with the body's number as vertex data (meshio's PLY writer
    dropped it); the manifest lists them; a rerun into the folder without bodies removes
    them."""
    import meshio
    import trimesh

    trimesh.creation.box(extents=[0.2, 0.04, 0.1]).export(tmp_path / "paddle.obj")
    scene = {"name": "paddle", "configuration": {"dim": 2, "particle_radius": 0.01,
                                                 "time": {"until": 0.05}},
             "fluid_blocks": [{"start": [0.02, 0.02], "end": [0.3, 0.1]}],
             "boxes": [{"min": [0, 0], "max": [0.6, 0.6]}],
             "meshes": [{"geometry_file": str(tmp_path / "paddle.obj"),
                         "translation": [0.3, 0.3, 0.0], "angular_velocity": [0, 0, np.pi]}],
             "output": {"fps": 50, "formats": ["vtk", "bgeo", "ply"]}}
    path = tmp_path / "paddle.json"
    path.write_text(json.dumps(scene))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    man = read_manifest(out)
    rest = trimesh.load(tmp_path / "paddle.obj").vertices
    for rec in man["frames"]:
        k, t = rec["frame"], rec["time"]
        assert rec["body_files"] == [f"bodies_{k:05d}.vtu", f"bodies_{k:05d}.obj",
                                     f"bodies_{k:05d}.ply"]
        c, s = np.cos(np.pi * t), np.sin(np.pi * t)
        want = rest @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + [0.3, 0.3, 0.0]
        got = meshio.read(out / rec["body_files"][0]).points
        np.testing.assert_allclose(got, want, atol=1e-12)
        obj = trimesh.load(out / rec["body_files"][1], force="mesh", process=False)
        np.testing.assert_allclose(obj.vertices, want, atol=1e-8)
        ply = meshio.read(out / rec["body_files"][2])  # with the body number, no warning
        np.testing.assert_allclose(ply.points, want, atol=1e-12)
        assert set(ply.point_data["body"]) == {1} and len(ply.cells[0].data) == 12
    assert json.loads((out / "bodies.vtu.series").read_text())["files"][-1]["time"] == t
    scene["meshes"] = []
    path.write_text(json.dumps(scene))
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    assert not list(out.glob("bodies_*")) and not (out / "bodies.vtu.series").exists()
    from sphkit.scene.splishsplash import from_splishsplash

    sph = from_splishsplash({"Configuration": {"enableRigidBodyVTKExport": True,
                                               "enableRigidBodyExport": True},
                             "FluidBlocks": [{"start": [0, 0, 0], "end": [0.1, 0.1, 0.1]}]})
    assert sph.output.body_formats == ["vtk", "obj"]
