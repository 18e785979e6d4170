"""``sphkit run --format bgeo``, logging, ``sphkit surface`` and ``sphkit render``."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sphkit.cli import main
from sphkit.core.particles import ParticleSet
from sphkit.io.frames import FrameWriter, read_frame
from sphkit.io.manifest import Manifest, read_manifest

HAVE_SPLASHSURF = importlib.util.find_spec("pysplashsurf") is not None
HAVE_MPL = importlib.util.find_spec("matplotlib") is not None

#: a compact 3D blob: a lattice cube of 4 x 4 x 4 particles (r = 0.02 m, faces at 0.10 and
#: 0.26 m) falling in a box; 0.04 s at 50 frames/s = frames 0, 1, 2
BLOB = {
    "name": "blob",
    "configuration": {"dim": 3, "particle_radius": 0.02, "time": {"until": 0.04}},
    "fluid_blocks": [{"start": [0.1, 0.1, 0.1], "end": [0.26, 0.26, 0.26]}],
    "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.4, 0.4, 0.4]}],
    "output": {"fps": 50, "formats": ["bgeo", "vtk"]},
}


@pytest.fixture(scope="module")
def blob_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("blob")
    scene = folder / "blob.json"
    scene.write_text(json.dumps(BLOB))
    out = folder / "out"
    assert main(["run", str(scene), "--out", str(out), "--verbose"]) == 0
    return out


def test_run_writes_bgeo_frames_and_log(blob_run: Path) -> None:
    m = read_manifest(blob_run)
    assert m["output"]["formats"] == ["bgeo", "vtk"]
    for rec in m["frames"]:
        bgeo, vtu = (read_frame(blob_run / f) for f in rec["files"])
        assert rec["files"][0] == f"frame_{rec['frame']:05d}.bgeo"
        for key in ("position", "velocity", "density", "pressure", "id"):
            np.testing.assert_array_equal(bgeo[key], vtu[key].astype(bgeo[key].dtype))
    log = (blob_run / "sphkit.log").read_text()
    assert "INFO sphkit.cli: scene 'blob': 64 fluid" in log
    assert "INFO sphkit.cli: frame 2 t=" in log and "finished: 3 frame(s)" in log
    assert "DEBUG sphkit.cli: step StepStats(step=1," in log  # --verbose: every step


def test_unknown_format_names_flag_and_value(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "dambreak-2d", "--format", "vtk,xyz"]) == 2
    err = capsys.readouterr().err
    assert "--format" in err and "unknown format 'xyz'" in err and "bgeo" in err


def test_unknown_attribute_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = dict(BLOB, output={"attributes": ["velocity", "vorticity"]})
    path = tmp_path / "s.json"
    path.write_text(json.dumps(scene))
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "output.attributes: got 'vorticity'" in err and "density" in err


def test_quiet_and_verbose_are_exclusive_for_post_commands(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["render", str(tmp_path), "--quiet", "--verbose"]) == 2
    assert "not allowed with argument" in capsys.readouterr().err


def _points_inside(vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Generalised winding number of a closed triangle mesh at ``points`` (1 inside, 0 outside;
    van Oosterom & Strackee's solid angle of each triangle, summed)."""
    t = vertices[triangles]  # (T, 3, 3)
    a = t[None, :, 0] - points[:, None]
    b = t[None, :, 1] - points[:, None]
    c = t[None, :, 2] - points[:, None]
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    det = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("ptk,ptk->pt", a, b) * lc
           + np.einsum("ptk,ptk->pt", b, c) * la + np.einsum("ptk,ptk->pt", c, a) * lb)
    return np.abs(2.0 * np.arctan2(det, den).sum(axis=1) / (4.0 * np.pi))


@pytest.mark.skipif(not HAVE_SPLASHSURF, reason="pysplashsurf is not installed")
def test_surface_meshes_close_around_the_blob(blob_run: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    import trimesh

    assert main(["surface", str(blob_run), "--format", "obj,ply,vtk"]) == 0
    index = json.loads((blob_run / "surface" / "surface.json").read_text())
    assert index["parameters"]["particle_radius"] == 0.02  # from the run's manifest
    assert [r["frame"] for r in index["frames"]] == [0, 1, 2]
    for rec in index["frames"]:
        obj, ply, vtu = (blob_run / "surface" / f for f in rec["files"])
        mesh = trimesh.load(obj, process=False)
        again = trimesh.load(ply, process=False)
        np.testing.assert_allclose(again.vertices, mesh.vertices, rtol=1e-6)  # PLY: float32
        np.testing.assert_array_equal(again.faces, mesh.faces)
        assert mesh.is_watertight and mesh.is_winding_consistent
        # every particle centre is enclosed; points 2r outside the particles are not
        frame = read_frame(blob_run / f"frame_{rec['frame']:05d}.bgeo")["position"]
        inside = _points_inside(mesh.vertices, mesh.faces, frame.astype(float))
        np.testing.assert_allclose(inside, 1.0, atol=1e-6)
        lo, hi = frame.min(axis=0), frame.max(axis=0)
        outside = np.array([lo - 0.04, hi + 0.04, [lo[0] - 0.04, hi[1], hi[2]]])
        np.testing.assert_allclose(_points_inside(mesh.vertices, mesh.faces, outside), 0.0,
                                   atol=1e-6)
    # frame 0 is the lattice cube: particle centres 0.12 .. 0.24 m, the fluid's faces one radius
    # further out at 0.10 and 0.26 m. The iso-surface (threshold 0.6) lies within r/4 of them;
    # it rounds edges and corners, so it encloses 80-100% of the cube's 0.16^3 m^3.
    m0 = trimesh.load(blob_run / "surface" / "surface_00000.obj", process=False)
    np.testing.assert_allclose(m0.bounds, [[0.10] * 3, [0.26] * 3], atol=0.005)
    assert 0.8 * 0.16**3 < m0.volume < 0.16**3
    assert "3 mesh(es)" in capsys.readouterr().err
    assert "INFO sphkit.cli: surface: 3 frame(s)" in (blob_run / "sphkit.log").read_text()


@pytest.mark.skipif(not (HAVE_SPLASHSURF and HAVE_MPL),
                    reason="pysplashsurf or matplotlib is not installed")
def test_render_3d_draws_the_surface_meshes(blob_run: Path) -> None:
    from PIL import Image

    assert main(["surface", str(blob_run), "--frames", "0:3:2", "-q"]) == 0
    out = blob_run / "r3"
    assert main(["render", str(blob_run), "--out", str(out), "--video", "gif",
                 "--size", "320x240", "-q"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "frame_00000.png", "frame_00001.png", "frame_00002.png", "preview.gif"]
    with Image.open(out / "frame_00000.png") as im:
        assert im.size == (320, 240)
    with Image.open(out / "preview.gif") as gif:
        assert gif.n_frames == 3
    log = (blob_run / "sphkit.log").read_text()
    assert "(3D, surface meshes)" in log


def _two_phase_run(folder: Path) -> Path:
    """A 3D run folder of one frame: two lattice cubes of 5 x 5 x 5 particles (r = 0.02 m), the
    left one phase 0, the right one phase 1 (several fluids' ``phase`` attribute), as PLY."""
    fluid = ParticleSet(3, "float64")
    for name in ("rho", "p"):
        fluid.register(name)
    fluid.register("v", "vector")
    fluid.register("phase", "scalar", np.int64)
    g = np.stack(np.meshgrid(*[np.arange(5)] * 3, indexing="ij"), -1).reshape(-1, 3)
    x = 0.1 + 0.04 * g
    fluid.add(np.concatenate([x, x + [0.3, 0.0, 0.0]]), v=np.zeros((250, 3)), rho=1000.0,
              p=0.0)
    fluid["phase"][125:] = 1
    sim = SimpleNamespace(fluid=fluid, time=0.0, dim=3, step_count=0, dt=1e-3, last=None)
    writer = FrameWriter(folder, ["ply"], 3, extra_fields=("phase",))
    man = Manifest(folder, {"name": "two", "configuration": {"dim": 3, "particle_radius": 0.02},
                            "materials": [{"density0": 1000.0}, {"density0": 500.0}]},
                   output={"dim": 3, "fps": 10.0, "formats": ["ply"]})
    man.add_frame(sim, 0, writer.write(sim, 0))
    man.finish("finished")
    return folder


@pytest.mark.skipif(not (HAVE_SPLASHSURF and HAVE_MPL),
                    reason="pysplashsurf or matplotlib is not installed")
def test_surface_by_phase_gives_each_fluid_its_mesh(tmp_path: Path, blob_run: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """``--by-phase``: one closed mesh per phase around that phase's particles only (a renderer
    gives each liquid its material), listed per phase in surface.json and drawn by ``sphkit
    render`` in a colour per phase; a run of one fluid is refused naming the flag."""
    import trimesh

    from sphkit.io.preview import PHASE_COLORS, merged_meshes

    run = _two_phase_run(tmp_path / "two")
    assert main(["surface", str(run), "--by-phase", "-q"]) == 0
    rec = json.loads((run / "surface" / "surface.json").read_text())["frames"][0]
    assert rec["files"] == ["surface_00000_phase0.obj", "surface_00000_phase1.obj"]
    pos = read_frame(run / "frame_00000.ply")
    for entry, shift in zip(rec["phases"], (0.0, 0.3), strict=True):
        assert entry["n_particles"] == 125
        mesh = trimesh.load(run / "surface" / entry["files"][0], process=False)
        assert mesh.is_watertight
        # each mesh is its own cube (centres 0.10 .. 0.26 m, shifted by 0.3 m along x)
        np.testing.assert_allclose(mesh.bounds[:, 0], [0.08 + shift, 0.28 + shift], atol=0.01)
        mine = pos["position"][pos["phase"] == entry["phase"]]
        np.testing.assert_allclose(_points_inside(mesh.vertices, mesh.faces, mine), 1.0,
                                   atol=1e-6)
    v, t, c = merged_meshes([(0, np.zeros((3, 3)), np.array([[0, 1, 2]])),
                             (1, np.ones((3, 3)), np.array([[0, 1, 2]]))])
    assert t.tolist() == [[0, 1, 2], [3, 4, 5]]
    np.testing.assert_allclose(c, [PHASE_COLORS[0], PHASE_COLORS[1]])
    assert main(["render", str(run), "--out", str(run / "r"), "--video", "none",
                 "--size", "160x120", "-q"]) == 0
    assert (run / "r" / "frame_00000.png").is_file()
    capsys.readouterr()
    assert main(["surface", str(blob_run), "--by-phase", "--frames", "0"]) == 2  # one fluid
    assert "--by-phase: frame 0 (frame_00000.bgeo) has no 'phase' attribute" in (
        capsys.readouterr().err)


def test_surface_needs_a_3d_run_and_a_manifest(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["surface", str(tmp_path)]) == 2
    assert "no manifest.json" in capsys.readouterr().err
    (tmp_path / "manifest.json").write_text(json.dumps(
        {"output": {"dim": 2}, "frames": [], "scene": {}}))
    assert main(["surface", str(tmp_path)]) == 2
    assert "a 2D run; surface reconstruction needs a 3D run" in capsys.readouterr().err


def test_surface_without_pysplashsurf(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "manifest.json").write_text(json.dumps(
        {"output": {"dim": 3}, "frames": [], "scene": {}}))
    monkeypatch.setitem(sys.modules, "pysplashsurf", None)
    assert main(["surface", str(tmp_path)]) == 2
    assert "pip install 'sphkit[surface]'" in capsys.readouterr().err


# -- 2D previews from hand-made frames (no simulation needed) ----------------------------------
def _run_2d(folder: Path, attributes: list[str] | None = None) -> Path:
    """A run folder of 3 frames of 100 particles on a 10 x 10 lattice, with pressure rising
    linearly with depth (the hydrostatic picture the preview should show)."""
    fluid = ParticleSet(2, "float64")
    for name in ("v",):
        fluid.register(name, "vector")
    for name in ("rho", "p"):
        fluid.register(name)
    g = np.stack(np.meshgrid(np.arange(10), np.arange(10), indexing="ij"), -1).reshape(-1, 2)
    x = 0.05 + 0.1 * g
    fluid.add(x, v=np.zeros((100, 2)), rho=1000.0, p=1000.0 * 9.81 * (1.0 - x[:, 1]))
    sim = SimpleNamespace(fluid=fluid, time=0.0, dim=2, step_count=0, dt=1e-3, last=None)
    writer = FrameWriter(folder, ["vtk"], 2, attributes=attributes)
    man = Manifest(folder, {"name": "flat", "configuration": {"dim": 2, "particle_radius": 0.05,
                                                               "gravity": [0, -9.81]},
                            "materials": [{"density0": 1000.0}]},
                   output={"dim": 2, "fps": 10.0, "formats": ["vtk"]})
    for k in range(3):
        sim.time = 0.1 * k
        fluid["v"][1] = -sim.time
        man.add_frame(sim, k, writer.write(sim, k))
    man.finish("finished")
    return folder


@pytest.mark.skipif(not HAVE_MPL, reason="matplotlib is not installed")
def test_render_2d_colours_by_pressure(tmp_path: Path) -> None:
    from PIL import Image

    run = _run_2d(tmp_path / "run")
    assert main(["render", str(run), "--color", "pressure", "--video", "gif",
                 "--cmap", "gray", "--range", "0,20000", "--size", "400x400", "-q"]) == 0
    out = run / "render"
    assert sorted(p.name for p in out.iterdir()) == [
        "frame_00000.png", "frame_00001.png", "frame_00002.png", "preview.gif"]
    im = np.asarray(Image.open(out / "frame_00000.png").convert("L"), dtype=float)
    assert im.shape == (400, 400)
    # pressure grows with depth from 490 to 9320 Pa; the grey map over [0, 20000] Pa draws them
    # from black to mid-grey (luminance 6 to 119 of 255), on a white background: in the middle
    # columns of the picture, the block's bottom rows are brighter than its top rows
    rows = [r for r in range(im.shape[0]) if im[r, 150:250].mean() < 150]  # the block's rows
    top, bottom = im[rows[3], 150:250].mean(), im[rows[-4], 150:250].mean()
    assert bottom > top + 60
    log = (run / "sphkit.log").read_text()
    assert "coloured by pressure in [" in log


@pytest.mark.skipif(not HAVE_MPL, reason="matplotlib is not installed")
def test_render_names_a_missing_colour_field(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    run = _run_2d(tmp_path / "run", attributes=["velocity"])
    assert main(["render", str(run), "--color", "pressure"]) == 2
    err = capsys.readouterr().err
    assert "--color pressure" in err and "no 'pressure' attribute" in err


@pytest.mark.skipif(not HAVE_MPL, reason="matplotlib is not installed")
def test_render_mp4_needs_ffmpeg(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    import sphkit.io.preview as preview

    run = _run_2d(tmp_path / "run")
    monkeypatch.setattr(preview, "ffmpeg_path", lambda: None)
    assert main(["render", str(run), "--video", "mp4"]) == 2
    assert "--video mp4 needs the ffmpeg program" in capsys.readouterr().err


@pytest.mark.skipif(not HAVE_SPLASHSURF, reason="pysplashsurf is not installed")
def test_surface_of_the_default_dam_break_output(tmp_path: Path) -> None:
    """The issue's case: ``sphkit surface`` on the output of the default scene (the 3D dam break,
    24,000 particles; here its first two frames, t = 0 and 0.04 s) gives per-frame meshes that
    trimesh loads, watertight and consistently wound, around the water column: the block's
    particle centres span 0.03 + r .. 0.93 - r etc. (r = 15 mm), so the fluid's faces are at
    0.03 / 0.93, 1.23, 0.63 m; the reconstructed surface lies within r of them (one particle
    radius: splashsurf's iso-surface at threshold 0.6 rounds edges and corners)."""
    import trimesh

    out = tmp_path / "dam"
    assert main(["run", "--until", "0.04", "--out", str(out), "--quiet"]) == 0
    assert main(["surface", str(out), "--format", "obj", "--quiet"]) == 0
    index = json.loads((out / "surface" / "surface.json").read_text())
    assert [r["frame"] for r in index["frames"]] == [0, 1]
    for rec in index["frames"]:
        mesh = trimesh.load(out / "surface" / rec["files"][0], process=False)
        assert len(mesh.faces) > 1000
        assert mesh.is_watertight and mesh.is_winding_consistent
        np.testing.assert_allclose(mesh.bounds, [[0.03, 0.03, 0.03], [0.93, 1.23, 0.63]],
                                   atol=0.015)


@pytest.mark.skipif(not HAVE_MPL, reason="matplotlib is not installed")
def test_previews_draw_the_rigid_bodies(tmp_path: Path) -> None:
    """A body file of a frame (sphkit.io.bodies) is drawn: in 2D as filled triangles in the
    xy-plane (one polygon per triangle, at the file's vertices), in 3D as a shaded mesh."""
    import meshio
    import trimesh
    from matplotlib.collections import PolyCollection
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from sphkit.io.preview import PreviewRenderer, RenderSettings, load_mesh

    box = trimesh.creation.box(extents=[0.2, 0.1, 0.1])
    box.apply_translation([0.3, 0.2, 0.0])
    meshio.write(tmp_path / "b.vtu", meshio.Mesh(box.vertices, [("triangle", box.faces)]))
    verts, tris = load_mesh(tmp_path / "b.vtu")
    assert np.allclose(verts, box.vertices) and np.array_equal(tris, box.faces)
    arrays = {"position": np.array([[0.1, 0.1, 0.0]]), "velocity": np.zeros((1, 3))}
    bounds = np.array([[0.0, 0.0, 0.0], [0.6, 0.6, 0.6]])
    for dim, kind in ((2, PolyCollection), (3, Poly3DCollection)):
        r = PreviewRenderer(dim, 0.01, 1, bounds, RenderSettings(color="velocity"))
        r.draw(arrays, 0.0, bodies=(verts, tris))
        drawn = [c for c in r.fig.axes[0].collections if type(c) is kind]
        assert len(drawn) == 1 and len(drawn[0].get_facecolor()) in (1, len(tris))
        if dim == 2:  # one polygon per triangle, in the xy-plane
            paths = drawn[0].get_paths()
            assert len(paths) == len(tris)
            np.testing.assert_allclose(paths[0].vertices[:3], verts[tris[0]][:, :2])
        else:  # one shaded colour per triangle
            assert len(drawn[0].get_facecolor()) == len(tris)
        r.close()
