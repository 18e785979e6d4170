"""Checkpoints and restarts: a resumed run equals the uninterrupted one bit for bit (CPU, same
thread count); SIGTERM stops ``sphkit run`` after a step with valid frames and a checkpoint, and
``--resume`` finishes the run; ParticleSet growth keeps every field and unique ids."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sphkit.cli import main
from sphkit.core.particles import ParticleSet
from sphkit.io.checkpoint import list_checkpoints, read_checkpoint
from sphkit.io.frames import read_frame
from sphkit.io.manifest import read_manifest
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation


def _scene(method: str, **extra: object) -> Scene:
    """2D dam break, 15 x 15 = 225 particles of r = 0.02 m in a 1 x 0.6 m box; z-sort every 7
    steps so that resumed runs start between reorderings."""
    d: dict = {
        "configuration": {"dim": 2, "particle_radius": 0.02, "zsort_every": 7,
                          "pressure": {"method": method}},
        "boxes": [{"min": [0.0, 0.0], "max": [1.0, 0.6]}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.3, 0.3]}],
    }
    d.update(extra)
    return Scene.model_validate(d)


def _assert_same_state(a: Simulation, b: Simulation) -> None:
    assert (a.time, a.step_count, a.dt, a._frame) == (b.time, b.step_count, b.dt, b._frame)
    for ps_a, ps_b in ((a.fluid, b.fluid), (a.boundary, b.boundary)):
        assert sorted(ps_a.fields) == sorted(ps_b.fields)
        for name in ps_a.fields:  # exact: same arithmetic in the same order
            np.testing.assert_array_equal(ps_a[name], ps_b[name], err_msg=name)


@pytest.mark.parametrize("method, extra", [
    # DFSPH with Weiler's implicit viscosity: warm starts kappa, kappa_v and weiler_dv carry over
    ("dfsph", {"materials": [{"viscosity": {"method": "weiler2018", "coefficient": 0.01}}]}),
    ("wcsph", {}),
])
def test_resumed_run_equals_uninterrupted_bit_for_bit(tmp_path: Path, method: str,
                                                      extra: dict) -> None:
    T = 0.1  # 20 DFSPH / ~120 WCSPH steps: several z-sorts on both sides of T/2
    full = Simulation(_scene(method, **extra))
    full.run(until=T, fps=50)
    half = Simulation(_scene(method, **extra))
    half.run(until=T / 2, fps=50)
    path = half.save_checkpoint(tmp_path / "checkpoints" / "checkpoint_000000001.npz")
    resumed = Simulation.from_checkpoint(tmp_path)  # the newest in the folder
    assert resumed.step_count == half.step_count and resumed._frame == half._frame
    resumed.run(until=T, fps=50)
    _assert_same_state(full, resumed)
    assert read_checkpoint(path).meta["scene"] == full.scene.model_dump(mode="json")


def test_particle_set_grows_by_doubling_and_keeps_fields() -> None:
    ps = ParticleSet(2)
    ps.register("v", "vector")
    ps.register("p")
    ps.register("hist", "vector3", fill=np.nan)
    rng = np.random.default_rng(1)
    x_all, v_all, caps = [], [], set()
    for k in range(60):
        m = int(rng.integers(1, 7))
        x, v = rng.random((m, 2)), rng.random((m, 2))
        ps.add(x, name="emitter", v=v, p=float(k))
        x_all.append(x)
        v_all.append(v)
        caps.add(ps.capacity)
        assert ps["x"].flags.c_contiguous and ps["v"].flags.c_contiguous
    np.testing.assert_array_equal(ps.view("x"), np.concatenate(x_all))
    np.testing.assert_array_equal(ps.view("v"), np.concatenate(v_all))
    assert np.all(np.isnan(ps["hist"]))  # new particles get the field's fill value
    np.testing.assert_array_equal(ps["id"], np.arange(ps.n))
    # capacity doubles: about log2(n) reallocations for ~200 particles in 60 adds
    assert len(caps) <= int(np.log2(ps.n)) + 1
    assert [(o.name, o.start, o.end) for o in ps.objects] == [("emitter", 0, ps.n)]
    ps.permute(rng.permutation(ps.n))
    ps.add(np.zeros((3, 2)), name="more")
    assert len(np.unique(ps["id"])) == ps.n and ps["id"].max() == ps.n - 1


def test_state_without_an_optional_field_restores_its_fill() -> None:
    """A checkpoint of an older version lacks a field added since: an ``optional`` field (one
    whose fill is what the older version did, e.g. the walls' ``viscosity_factor`` 1) restores
    as its fill; a missing field that is not optional is still refused, naming it."""
    old = ParticleSet(2)
    old.register("v", "vector")
    old.add(np.array([[0.0, 1.0], [2.0, 3.0]]), name="walls", v=np.ones((2, 2)))
    meta, arrays = old.state()
    new = ParticleSet(2)
    new.register("v", "vector")
    new.register("viscosity_factor", fill=1.0, optional=True)
    new.set_state(meta, arrays)
    np.testing.assert_array_equal(new["viscosity_factor"], [1.0, 1.0])
    np.testing.assert_array_equal(new.view("x"), old.view("x"))
    strict = ParticleSet(2)
    strict.register("p")
    with pytest.raises(ValueError, match=r"lacks the field\(s\) \['p'\]"):
        strict.set_state(meta, arrays)


def test_empty_like_keeps_every_field_with_its_fill() -> None:
    """A set rebuilt by hand from :meth:`ParticleSet.empty_like` has the same fields, and a
    particle added to it without a value gets each field's fill (the validation scripts that
    rebuilt walls without the fills had a wall viscosity factor of 0, not 1)."""
    ps = ParticleSet(2, np.float32)
    ps.register("viscosity_factor", fill=1.0, optional=True)
    ps.register("hist", "vector3", np.float64, fill=np.nan)
    new = ps.empty_like()
    assert new.dim == 2 and new.dtype == np.float32 and new.n == 0
    assert new.specs == ps.specs and new.specs is not ps.specs
    new.add(np.zeros((1, 2)), name="one")
    assert new["viscosity_factor"][0] == 1.0 and np.all(np.isnan(new["hist"]))


# -- the command line ------------------------------------------------------------------------
TINY = {
    "name": "tiny",
    "configuration": {"dim": 2, "particle_radius": 0.01, "time": {"until": 0.1},
                      "pressure": {"method": "dfsph"}},
    "fluid_blocks": [{"start": [0.1, 0.1], "end": [0.5, 0.3]}],
    "boxes": [{"min": [0.0, 0.0], "max": [0.6, 0.5]}],
    "output": {"fps": 40, "formats": ["vtk", "bgeo"]},
}


def _frames_equal(a: Path, b: Path, names: list[str]) -> None:
    for name in names:
        fa, fb = read_frame(a / name), read_frame(b / name)
        for key in fa:
            np.testing.assert_array_equal(fa[key], fb[key], err_msg=f"{name} {key}")


def test_cli_resume_appends_frames_equal_to_uninterrupted(tmp_path: Path) -> None:
    scene = tmp_path / "tiny.json"
    scene.write_text(json.dumps(TINY))
    full, part = tmp_path / "full", tmp_path / "part"
    assert main(["run", str(scene), "--out", str(full), "--quiet"]) == 0
    assert main(["run", str(scene), "--out", str(part), "--until", "0.05",
                 "--checkpoint-every", "0.02", "--quiet"]) == 0
    # checkpoints at the steps reaching 0.02 and 0.04 s and at the end; the newest 2 are kept
    assert len(list_checkpoints(part)) == 2
    # the run ends with the first step at or after 0.05 s (steps of 1 ms, then 5 ms)
    assert 0.05 <= read_manifest(part)["checkpoint"]["time"] < 0.05 + 0.005
    assert main(["run", "--resume", str(part), "--until", "0.1", "--quiet"]) == 0
    ma, mb = read_manifest(full), read_manifest(part)
    assert [f["frame"] for f in mb["frames"]] == [f["frame"] for f in ma["frames"]] == [0, 1, 2,
                                                                                          3, 4]
    assert mb["status"] == "finished" and len(mb["resumed"]) == 1
    assert mb["resumed"][0]["frame"] == 2
    assert mb["run_stats"] == ma["run_stats"]
    _frames_equal(full, part, [n for f in ma["frames"] for n in f["files"]])
    series = json.loads((part / "frame.vtu.series").read_text())["files"]
    assert [e["name"] for e in series] == [f"frame_{k:05d}.vtu" for k in range(5)]


def test_scene_checkpoint_interval(tmp_path: Path) -> None:
    """``output.checkpoint_every`` in the scene writes checkpoints as ``--checkpoint-every``
    (SPlisHSPlasH's enableStateExport with stateExportFPS 50 reads as 0.02 s); the flag wins;
    a new run into the folder removes the old run's checkpoints."""
    from sphkit.scene.splishsplash import from_splishsplash

    sph = from_splishsplash({"Configuration": {"enableStateExport": True, "stateExportFPS": 50},
                             "FluidBlocks": [{"start": [0, 0, 0], "end": [0.1, 0.1, 0.1]}]})
    assert sph.output.checkpoint_every == 0.02
    scene = tmp_path / "tiny.json"
    scene.write_text(json.dumps(dict(TINY, output=dict(TINY["output"], checkpoint_every=0.02))))
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--until", "0.03", "--quiet"]) == 0
    first = list_checkpoints(out)
    assert len(first) == 2  # at 0.02 s and at the end
    assert main(["run", str(scene), "--out", str(out), "--until", "0.01", "--quiet",
                 "--checkpoint-every", "1"]) == 0
    # only the end (the flag's interval): a rerun into the folder removed the earlier run's
    # checkpoints, which have more steps and would be the ones --resume picks
    again = list_checkpoints(out)
    assert len(again) == 1 and again[0] not in first


def test_cli_resume_rejects_a_scene_and_a_folder_without_checkpoint(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--resume", str(tmp_path), "dambreak-2d"]) == 2
    assert "expected only --until" in capsys.readouterr().err
    (tmp_path / "manifest.json").write_text(json.dumps({"frames": [], "output": {}}))
    assert main(["run", "--resume", str(tmp_path)]) == 2
    assert "no checkpoint found" in capsys.readouterr().err


def test_sigterm_stops_after_a_step_then_resume_finishes(tmp_path: Path) -> None:
    """A subprocess gets SIGTERM once it wrote frame 2; it must exit 143 after a complete step
    with readable frames, a consistent manifest and a checkpoint; --resume finishes the run with
    the frame count of an uninterrupted run (until 0.5 s at 40 frames/s: 21 frames)."""
    scene = dict(TINY, configuration=dict(TINY["configuration"], time={"until": 0.5}))
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(scene))
    out = tmp_path / "out"
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    src = str(Path(__file__).resolve().parent.parent / "src")
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.Popen([sys.executable, "-m", "sphkit", "run", str(path), "--out", str(out),
                             "--quiet"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 240
    frames: list = []
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            frames = read_manifest(out)["frames"]
        except (OSError, ValueError):
            frames = []
        if len(frames) >= 3:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the run finished before it could be signalled"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err.decode()
    assert b"--resume" in err
    m = read_manifest(out)
    assert m["status"] == "interrupted" and "SIGTERM" in m["message"]
    ck = read_checkpoint(out)
    assert ck.frame == m["frames"][-1]["frame"] < 20  # stopped mid-run
    assert ck.step_count == m["last_step"]["step"]
    for rec in m["frames"]:  # every frame on disk is complete
        for name in rec["files"]:
            assert read_frame(out / name)["position"].shape == (200, 3)
    assert not [p for p in out.iterdir() if ".tmp-" in p.name]
    assert main(["run", "--resume", str(out), "--quiet"]) == 0
    m = read_manifest(out)
    assert m["status"] == "finished"
    assert [f["frame"] for f in m["frames"]] == list(range(21))
    last = read_frame(out / m["frames"][-1]["files"][0])
    assert last["position"].shape == (200, 3) and np.all(np.isfinite(last["position"]))
