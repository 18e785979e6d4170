"""``sphkit dataset`` and ``sphkit sweep``: LagrangeBench's HDF5 layout, the metadata its
loader reads, the frame statistics, reproducible variants, bad ``--vary`` specs, reruns that
compute only the missing variants, and a Dask worker killed during a task."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from sphkit.cli import build_parser, main  # noqa: E402
from sphkit.io.datasets import (  # noqa: E402
    FLUID,
    SOLID_WALL,
    iter_trajectories,
    read_dataset,
    split_counts,
)
from sphkit.scene.files import load_scene  # noqa: E402
from sphkit.scene.variants import default_specs, parse_vary, sample_values  # noqa: E402

#: a tiny 2D WCSPH tank: 50-200 fluid and ~230 wall particles, 6 frames
TINY = {
    "name": "tiny",
    "configuration": {"dim": 2, "particle_radius": 0.02, "gravity": [0.0, -9.81],
                      "time": {"until": 0.1, "dt": 0.001, "dt_max": 0.005},
                      "pressure": {"method": "wcsph", "stiffness": 50000.0}},
    "materials": [{"id": "water", "viscosity": {"method": "standard", "coefficient": 0.01}}],
    "fluid_blocks": [{"start": [0.04, 0.04], "end": [0.6, 0.6], "material": "water"}],
    "boxes": [{"min": [0.0, 0.0], "max": [1.2, 1.0], "layers": 2}],
    "output": {"fps": 50.0},
}

#: every metadata key LagrangeBench reads, with the file that reads it (tumaer/lagrangebench)
LAGRANGEBENCH_KEYS = {
    "bounds": "lagrangebench/runner.py, case_setup/case.py (physical_feature_builder)",
    "periodic_boundary_conditions": "case_setup/case.py, runner.py, models/utils.py",
    "default_connectivity_radius": "case_setup/case.py (neighbour cutoff), runner.py",
    "num_particles_max": "case_setup/case.py, data/data.py (matscipy padding)",
    "vel_mean": "data/utils.py (get_dataset_stats)",
    "vel_std": "data/utils.py (get_dataset_stats)",
    "acc_mean": "data/utils.py (get_dataset_stats)",
    "acc_std": "data/utils.py (get_dataset_stats)",
    "dt": "runner.py, evaluate/metrics.py (dt * write_every)",
    "write_every": "runner.py, evaluate/metrics.py (dt * write_every)",
    "dx": "evaluate/metrics.py (e_kin)",
    "dim": "runner.py, evaluate/metrics.py",
    # written by data_gen/lagrangebench_data/gen_dataset.py (and data_gen/gns_data's
    # reading_utils.py reads sequence_length)
    "sequence_length_train": "data_gen/lagrangebench_data/gen_dataset.py",
    "sequence_length_test": "data_gen/lagrangebench_data/gen_dataset.py",
    "num_trajs_train": "data_gen/lagrangebench_data/gen_dataset.py",
    "num_trajs_test": "data_gen/lagrangebench_data/gen_dataset.py",
    "sequence_length": "data_gen/gns_data/reading_utils.py",
}


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("scene") / "tiny.json"
    path.write_text(json.dumps(TINY))
    return path


@pytest.fixture(scope="module")
def dataset(scene_file: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ds") / "tiny-ds"
    rc = main(["dataset", str(scene_file), "--count", "5", "--seed", "3", "--workers", "0",
               "--out", str(out), "-q"])
    assert rc == 0
    return out


def test_layout_shapes_and_dtypes(dataset: Path) -> None:
    """train/valid/test.h5 with groups 00000, 00001, ...: position float32 (T, N, 2),
    particle_type int32 (N,), fluid (0) first, then the static walls (1), which do not move."""
    md, keys = read_dataset(dataset)
    assert [len(keys[s]) for s in ("train", "valid", "test")] == [3, 1, 1]
    for split, names in keys.items():
        assert names == [f"{j:05d}" for j in range(len(names))]
        with h5py.File(dataset / f"{split}.h5", "r") as f:
            for name in names:
                x, pt = f[name]["position"], f[name]["particle_type"]
                assert x.dtype == np.float32 and pt.dtype == np.int32
                t, n, dim = x.shape
                assert (t, dim) == (md["num_frames"], 2) and pt.shape == (n,)
                assert n <= md["num_particles_max"]
                ptype = pt[:]
                nf = int((ptype == FLUID).sum())
                assert 20 < nf < n and set(np.unique(ptype)) == {FLUID, SOLID_WALL}
                assert np.all(ptype[:nf] == FLUID)  # fluid first, then walls
                walls = x[:][:, nf:]
                assert np.array_equal(walls[0], walls[-1])
                # a fixed particle order: no fluid particle jumps between frames
                step = np.abs(np.diff(x[:][:, :nf], axis=0)).max()
                assert step < 0.05
    assert md["num_frames"] == 6 and md["sequence_length"] == 5


def test_fluid_is_sorted_by_id(dataset: Path, scene_file: Path) -> None:
    """The first frame of a trajectory is the variant's start state, fluid sorted by its id
    (sphkit reorders the fluid along a z-curve while it runs), then the walls."""
    from sphkit.scene.variants import variant_scene
    from sphkit.simulation import Simulation

    md, _ = read_dataset(dataset)
    t = md["sphkit"]["trajectories"][0]
    sim = Simulation(variant_scene(load_scene(scene_file), t["values"]))
    first = []
    sim.run(until=1e-9, on_frame=lambda s, k: first.append(  # the first neighbour search
        s.positions[np.argsort(s.ids)].astype(np.float32)) if k == 0 else None)  # reorders
    with h5py.File(dataset / "train.h5", "r") as f:
        x0 = f[t["key"]]["position"][0]
    nf = sim.fluid.n
    assert np.array_equal(x0[:nf], first[0])
    assert x0.shape[0] == nf + sim.boundary.n


def test_metadata_has_every_key_lagrangebench_reads(dataset: Path) -> None:
    md, _ = read_dataset(dataset)
    missing = {k: src for k, src in LAGRANGEBENCH_KEYS.items() if k not in md}
    assert not missing, missing
    dim = md["dim"]
    assert dim == 2
    assert np.array(md["bounds"]).shape == (dim, 2)
    assert md["periodic_boundary_conditions"] == [False, False]
    for key in ("vel_mean", "vel_std", "acc_mean", "acc_std"):
        assert len(md[key]) == dim and all(np.isfinite(md[key]))
    assert md["dt"] * md["write_every"] == pytest.approx(1 / 50)
    assert md["dx"] == pytest.approx(0.04)
    assert md["default_connectivity_radius"] == pytest.approx(0.058)  # 1.45 dx, 2 digits
    assert md["sequence_length_train"] == md["sequence_length_test"] == 5
    assert md["num_trajs_train"] == 3 and md["num_trajs_test"] == 1
    # the box holds every particle: the outer faces of the two wall layers
    np.testing.assert_allclose(md["bounds"], [[-0.08, 1.28], [-0.08, 1.08]], atol=1e-12)
    prov = md["sphkit"]
    assert prov["seed"] == 3 and prov["vary_defaulted"] and prov["failed"] == []
    assert prov["scene"]["name"] == "tiny"
    assert set(prov["versions"]) >= {"sphkit", "numpy", "numba", "h5py"}
    assert [t["variant"] for t in prov["trajectories"]] == [0, 1, 2, 3, 4]
    assert json.loads((dataset / "metadata.json").read_text()) == md


def test_statistics_match_the_positions(dataset: Path) -> None:
    """vel/acc mean and std recomputed here from train.h5 (LagrangeBench's definition: frame
    differences of the fluid, mean of per-trajectory means) agree with the metadata."""
    md, _ = read_dataset(dataset)
    per_v, per_a = [], []
    for _key, x, pt in iter_trajectories(dataset, "train"):
        xf = x[:, pt == 0].astype(np.float64)
        v = xf[1:] - xf[:-1]
        a = v[1:] - v[:-1]
        per_v.append(v.reshape(-1, 2))
        per_a.append(a.reshape(-1, 2))
    vm = np.mean([v.mean(axis=0) for v in per_v], axis=0)
    am = np.mean([a.mean(axis=0) for a in per_a], axis=0)
    vs = np.sqrt(np.mean([((v - vm) ** 2).mean(axis=0) for v in per_v], axis=0))
    acs = np.sqrt(np.mean([((a - am) ** 2).mean(axis=0) for a in per_a], axis=0))
    assert md["vel_mean"] == pytest.approx(vm.tolist(), rel=1e-9, abs=1e-15)
    assert md["acc_mean"] == pytest.approx(am.tolist(), rel=1e-9, abs=1e-15)
    assert md["vel_std"] == pytest.approx(vs.tolist(), rel=1e-9)
    assert md["acc_std"] == pytest.approx(acs.tolist(), rel=1e-9)
    assert md["vel_mean"][1] < 0  # the fluid falls: a length per frame, downwards


def test_variants_are_reproducible(dataset: Path, scene_file: Path) -> None:
    """Same seed, same values; variant k's values do not depend on --count; the dataset's
    trajectories carry the values drawn for their variant."""
    base = load_scene(scene_file)
    specs = [parse_vary("fluid_blocks.0.end.0=0.32:0.6", base),
             parse_vary("fluid_blocks[0].end[1]=0.32:0.6", base),
             parse_vary("boxes.0.layers=1,2,3", base)]
    assert specs[1].path == "fluid_blocks.0.end.1" and specs[2].integer
    a = [sample_values(specs, 7, k) for k in range(6)]
    assert a == [sample_values(specs, 7, k) for k in range(6)]
    assert a[0] != sample_values(specs, 8, 0) and a[0] != a[1]
    assert all(isinstance(v["boxes.0.layers"], int) for v in a)
    md, _ = read_dataset(dataset)
    default = default_specs(base)
    np.testing.assert_allclose([(d.low, d.high) for d in default], [(0.32, 0.6)] * 2)
    for t in md["sphkit"]["trajectories"]:
        assert t["values"] == sample_values(default, 3, t["variant"])
    with h5py.File(dataset / "valid.h5", "r") as f:
        assert f["00000"].attrs["variant"] == 3


@pytest.mark.parametrize("spec, words", [
    ("nonexistent.path=0:1", ["'nonexistent'", "no field"]),
    ("fluid_blocks.4.end.0=0:1", ["fluid_blocks.4", "list index"]),
    ("materials.0.viscosity.coefficient=nan:1", ["materials.0.viscosity.coefficient",
                                                 "finite number"]),
    ("materials.0.viscosity.coefficient=0.1:inf", ["coefficient", "finite number"]),
    ("configuration.particle_radius=-0.02:-0.01", ["particle_radius", "greater than 0"]),
    ("materials.0.id=0:1", ["materials.0.id", "a number"]),
    ("configuration.time.until", ["expected PATH=LO:HI"]),
    ("configuration.time.until=2:1", ["reversed"]),
])
def test_bad_vary_exits_2_naming_the_path(spec: str, words: list[str], scene_file: Path,
                                          tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    rc = main(["dataset", str(scene_file), "--count", "2", "--workers", "0",
               "--vary", spec, "--out", str(tmp_path / "bad")])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert not (tmp_path / "bad" / "train.h5").exists()


@pytest.mark.parametrize("flags, words", [
    (["--split", "nan,0.1,0.1"], ["--split", "'nan,0.1,0.1'", "three fractions"]),
    (["--split", "0.8,0.2"], ["--split", "three fractions"]),
    (["--fps", "inf"], ["--fps", "'inf'", "positive number"]),
    (["--until", "nan"], ["--until", "'nan'", "positive number"]),
    (["--count", "0"], ["--count", "'0'"]),
    (["--workers", "-1"], ["--workers -1", "0 or more"]),
    (["--seed", "x"], ["--seed", "'x'"]),
])
def test_bad_flags_exit_2_naming_the_flag(flags: list[str], words: list[str], scene_file: Path,
                                          tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    """Garbage in a flag of ``dataset`` and ``sweep`` (NaN, Infinity, wrong count or type):
    exit 2, the flag and the value named, no traceback."""
    for cmd in ("dataset", "sweep"):
        if cmd == "sweep" and flags[0] == "--split":
            continue  # a dataset's flag only
        rc = main([cmd, str(scene_file), "--count", "2", "--workers", "0", "--vary",
                   "materials.0.viscosity.coefficient=0.001:0.01", "--out",
                   str(tmp_path / cmd), *flags])
        err = capsys.readouterr().err
        assert rc == 2, (cmd, err)
        assert "Traceback" not in err
        for w in words:
            assert w in err, (cmd, w, err)


def test_missing_scene_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["dataset", str(tmp_path / "none.json"), "--count", "2", "--workers", "0",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "none.json" in err and "Traceback" not in err


def test_scene_with_emitters_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                        ) -> None:
    scene = dict(TINY, emitters=[{"position": [0.5, 0.5], "width": 0.1,
                                  "material": "water"}])
    path = tmp_path / "emit.json"
    path.write_text(json.dumps(scene))
    assert main(["dataset", str(path), "--count", "2", "--workers", "0",
                 "--out", str(tmp_path / "o")]) == 2
    assert "emitters" in capsys.readouterr().err


def test_scene_with_more_fluids_than_particle_types_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A dataset gives each fluid material a particle type (FLUID and LagrangeBench's free 4-8):
    a seventh fluid is refused before anything runs, naming ``materials`` (exit 2)."""
    mats = [{"id": f"m{k}", "density0": 1000.0 - 100.0 * k} for k in range(7)]
    blocks = [{"start": [0.04 + 0.16 * k, 0.04], "end": [0.16 + 0.16 * k, 0.3],
               "material": f"m{k}"} for k in range(7)]
    path = tmp_path / "seven.json"
    path.write_text(json.dumps(dict(TINY, materials=mats, fluid_blocks=blocks)))
    assert main(["dataset", str(path), "--count", "1", "--workers", "0",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "materials: 7 fluid materials; a dataset labels at most 6" in err
    assert "Traceback" not in err and not (tmp_path / "o").exists()


def test_split_counts() -> None:
    assert split_counts(20, [0.8, 0.1, 0.1]) == (16, 2, 2)
    assert split_counts(5, [0.8, 0.1, 0.1]) == (3, 1, 1)
    assert split_counts(2, [0.8, 0.1, 0.1]) == (2, 0, 0)
    assert split_counts(10, [1, 0, 0]) == (10, 0, 0)


def test_rerun_computes_only_the_missing_variants(scene_file: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """A run stopped midway leaves some variant files: the rerun (here with a larger --count)
    computes only the others and keeps the finished files untouched."""
    out = tmp_path / "ds"
    args = ["dataset", str(scene_file), "--seed", "1", "--workers", "0", "--out", str(out)]
    assert main([*args, "--count", "4"]) == 0
    capsys.readouterr()
    variants = out / "variants"
    (variants / "variant-00001.h5").unlink()
    (variants / "variant-00003.h5").unlink()  # as if the run had been killed before them
    # a half-written file of a killed task is a hidden temporary, never the final name
    (variants / ".variant-00003.h5.tmp-1-abc").write_bytes(b"partial")
    kept = {k: os.stat(variants / f"variant-{k:05d}.h5").st_mtime_ns for k in (0, 2)}
    assert main([*args, "--count", "5"]) == 0
    err = capsys.readouterr().err
    assert "2 already complete, 3 to compute" in err
    computed = sorted(int(line.split()[2]) for line in err.splitlines() if "] variant " in line)
    assert computed == [1, 3, 4]
    assert {k: os.stat(variants / f"variant-{k:05d}.h5").st_mtime_ns for k in (0, 2)} == kept
    md, keys = read_dataset(out)
    assert sum(len(v) for v in keys.values()) == 5
    # another end time makes every variant a new one
    assert main([*args, "--count", "2", "--until", "0.06"]) == 0
    assert "0 already complete, 2 to compute" in capsys.readouterr().err


def test_sweep_runs_variants_like_run(scene_file: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sw"
    args = ["sweep", str(scene_file), "--count", "2", "--workers", "0", "--out", str(out),
            "--vary", "materials.0.viscosity.coefficient=0.001:0.05", "--fps", "25"]
    assert main(args) == 0
    doc = json.loads((out / "sweep.json").read_text())
    assert [v["status"] for v in doc["variants"]] == ["finished", "finished"]
    for v in doc["variants"]:
        m = json.loads((out / v["folder"] / "manifest.json").read_text())
        assert m["status"] == "finished" and len(m["frames"]) == 3
        nu = m["scene"]["materials"][0]["viscosity"]["coefficient"]
        assert nu == v["values"]["materials.0.viscosity.coefficient"]
    capsys.readouterr()
    assert main(args) == 0
    assert "2 already complete, 0 to compute" in capsys.readouterr().err


def test_killed_worker_task_is_redone(scene_file: Path, tmp_path: Path) -> None:
    """A LocalCluster of 2 worker processes; the task of variant 0 kills its own worker
    (SIGKILL) the first time it runs: the nanny restarts the worker, the scheduler runs the
    task again, and the dataset has every variant."""
    pytest.importorskip("distributed")
    from sphkit.cli.dataset import make_dataset

    out, marker = tmp_path / "ds", tmp_path / "killed"
    args = build_parser().parse_args(["dataset", str(scene_file), "--count", "4",
                                      "--workers", "2", "--out", str(out), "-q"])
    args.log_session = None
    assert make_dataset(args, kill_once=(str(marker), 0)) == 0
    killed_pid = int(marker.read_text())
    with h5py.File(out / "variants" / "variant-00000.h5", "r") as f:
        meta = json.loads(f.attrs["sphkit"])
    assert meta["pid"] != killed_pid  # redone by another worker process
    md, keys = read_dataset(out)
    assert sum(len(v) for v in keys.values()) == 4
    assert sorted(t["variant"] for t in md["sphkit"]["trajectories"]) == [0, 1, 2, 3]


def test_recorder_orders_fluid_walls_and_bodies() -> None:
    """Fluid by id, then static walls (1), then each moving body's particles with its type
    (kinematic 2, dynamic 3), the same order in every frame although the sets get permuted."""
    from sphkit.core.particles import ParticleSet
    from sphkit.io.datasets import MOVING_WALL, RIGID_BODY, TrajectoryRecorder

    fluid = ParticleSet(2)
    fluid.add(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]))
    bd = ParticleSet(2)
    bd.register("rigid_body", "scalar", np.int64)
    bd.add(np.array([[5.0, 0], [6, 0], [7, 0], [8, 0], [9, 0]]), rigid_body=0)
    bd["rigid_body"][:] = [2, 0, 1, 0, 2]
    rec = TrajectoryRecorder(fluid, bd, {1: MOVING_WALL, 2: RIGID_BODY})
    assert rec.particle_type.tolist() == [0, 0, 0, 1, 1, 2, 3, 3]
    rec.record(fluid, bd, 0)
    fluid.permute(np.array([2, 0, 1]))
    fluid.view("x")[:] += 0.5
    bd.view("x")[:] += 0.25
    rec.record(fluid, bd, 1)
    x = rec.array()
    assert x.dtype == np.float32 and x.shape == (2, 8, 2)
    assert x[0, :, 0].tolist() == [0, 1, 2, 6, 8, 7, 5, 9]
    assert x[1, :, 0].tolist() == [0.5, 1.5, 2.5, 6.25, 8.25, 7.25, 5.25, 9.25]
    assert rec.extent["walls"] == [[5.0, 0.0], [9.25, 0.25]]
    fluid.add(np.array([[3.0, 0.0]]))
    with pytest.raises(ValueError, match="fixed count"):
        rec.record(fluid, bd, 2)


def test_several_fluids_get_a_particle_type_per_phase() -> None:
    """Two fluids in one dataset were both labelled FLUID (0), so a learned simulator could not
    tell them apart: the first phase keeps 0 and phase k >= 1 gets 3 + k (types LagrangeBench's
    NodeType leaves free below its SIZE 9), in the recorder's id order, and every phase counts
    as fluid in the velocity statistics."""
    from sphkit.core.particles import ParticleSet
    from sphkit.io.datasets import (
        TrajectoryRecorder,
        fluid_types,
        frame_statistics,
        is_fluid,
    )

    fluid = ParticleSet(2)
    fluid.register("phase", "scalar", np.int64)
    fluid.add(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]))
    fluid["phase"][:] = [0, 1, 0, 2]
    fluid.permute(np.array([3, 1, 0, 2]))  # the recorder stores the fluid by id
    bd = ParticleSet(2)
    bd.add(np.array([[5.0, 0.0]]))
    rec = TrajectoryRecorder(fluid, bd, {})
    assert rec.particle_type.tolist() == [0, 4, 0, 5, 1]
    assert is_fluid(rec.particle_type).tolist() == [True, True, True, True, False]
    with pytest.raises(ValueError, match="fluid phase 6: a dataset labels at most 6"):
        fluid_types(np.array([0, 6]))
    # only the second phase moves (0.1 per frame along x): its velocity is in the statistics
    x = np.zeros((3, 5, 2), np.float32)
    x[:, 1, 0] = [0.0, 0.1, 0.2]
    stats = frame_statistics([(x, rec.particle_type)])
    assert stats["vel_mean"][0] == pytest.approx(0.1 / 4, rel=1e-6)


def test_without_the_extra_exits_2(scene_file: Path, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in ("h5py", "distributed")
                        else real(name, *a))
    assert main(["dataset", str(scene_file), "--count", "2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "install sphkit[dataset]" in err and "h5py" in err and "Traceback" not in err


def test_exact_frames_land_on_frame_times(scene_file: Path) -> None:
    """Simulation.run(exact_frames=True), as the dataset runs its variants: every frame is the
    state at k / fps itself (a frame written at the first step after k / fps would be up to a
    step late, which at high frame rates is as large as a frame's change of velocity), and
    landing only shortens steps: the CFL number max|v| dt / 2r never exceeds the CFL step's
    0.4 * cfl_factor (round-off allowance 1e-9)."""
    from sphkit.simulation import Simulation

    sim = Simulation(load_scene(scene_file))
    fps = 50.0
    times: list[tuple[int, float]] = []
    cfl: list[float] = []
    sim.run(until=0.1, fps=fps, exact_frames=True,
            on_frame=lambda s, k: times.append((k, s.time)),
            on_step=lambda s, st: cfl.append(st.cfl))
    assert [k for k, _ in times] == list(range(6))
    assert all(t == k / fps for k, t in times)  # bit-exact: the landing step sets the time
    tc = sim.scene.configuration.time
    assert max(cfl) <= 0.4 * tc.cfl_factor + 1e-9


def test_splishsplash_scene_varies_in_its_own_field_names(tmp_path: Path) -> None:
    """A SPlisHSPlasH file is varied by the paths its users write (``Materials.0.Standard
    viscosity.viscosity``, ``FluidBlocks.0.end.1``, a field it leaves to the default), beside
    sphkit's own paths; each variant is the file with the value set, translated as ``sphkit
    run`` translates it; a field sphkit does not use for the scene is refused by name."""
    import trimesh

    from sphkit.cli.ensemble import plan
    from sphkit.scene.files import scene_from_dict
    from sphkit.scene.schema import SceneError

    trimesh.creation.box(extents=[1.0, 1.0, 1.0]).export(tmp_path / "UnitBox.obj")
    raw = {"Configuration": {"sim2D": True, "particleRadius": 0.025, "simulationMethod": 0,
                             "boundaryHandlingMethod": 0},
           "Materials": [{"id": "Fluid", "viscosityMethod": 1,
                          "Standard viscosity": {"viscosity": 0.01}}],
           "RigidBodies": [{"geometryFile": "UnitBox.obj", "isWall": True,
                            "translation": [0, 1, 0], "scale": [2, 2, 1]}],
           "FluidBlocks": [{"start": [-0.9, 0.05, -0.5], "end": [0.0, 0.8, 0.5]}]}
    path = tmp_path / "sph.json"
    path.write_text(json.dumps(raw))

    def planned(*vary: str):
        argv = ["sweep", str(path), "--count", "3", "--until", "0.05", "--workers", "0"]
        for v in vary:
            argv += ["--vary", v]
        return plan(build_parser().parse_args(argv), "sweep")

    p = planned("Materials.0.Standard viscosity.viscosity=0.02:0.04",
                "FluidBlocks[0].end[1]=0.5:0.7", "Configuration.stiffness=1000:5000",
                "configuration.time.cfl_factor=0.3:0.5")
    assert [s.native for s in p.specs] == [True, True, True, False]
    assert p.specs[1].path == "FluidBlocks.0.end.1"
    assert p.specs[0].as_dict()["format"] == "splishsplash"
    for _k, values, scene in p.variants:
        edited = json.loads(json.dumps(raw))
        edited["Materials"][0]["Standard viscosity"]["viscosity"] = values[p.specs[0].path]
        edited["FluidBlocks"][0]["end"][1] = values["FluidBlocks.0.end.1"]
        edited["Configuration"]["stiffness"] = values["Configuration.stiffness"]
        expected = scene_from_dict(edited, path)
        assert scene["materials"][0]["viscosity"]["coefficient"] == pytest.approx(
            values[p.specs[0].path])
        assert scene["fluid_blocks"][0]["end"] == pytest.approx(expected.fluid_blocks[0].end)
        assert scene["configuration"]["pressure"]["stiffness"] == pytest.approx(
            values["Configuration.stiffness"])
        # sphkit's own path and the command's end time on top of the translated file
        assert scene["configuration"]["time"]["cfl_factor"] == pytest.approx(
            values["configuration.time.cfl_factor"])
        assert scene["configuration"]["time"]["until"] == 0.05
    # sphkit's WCSPH reads no DFSPH block; a misspelt field changes nothing either
    for spec, path_named in (("Configuration.DFSPH.maxIterations=50:200",
                              "Configuration.DFSPH"),
                             ("Materials.0.viscosty=0.01:0.02", "Materials.0.viscosty")):
        if path_named == "Configuration.DFSPH":
            raw["Configuration"]["DFSPH"] = {"maxIterations": 100}
            path.write_text(json.dumps(raw))
        with pytest.raises(SceneError, match="give the same scene") as err:
            planned(spec)
        assert path_named in str(err.value)
    with pytest.raises(SceneError, match="SPlisHSPlasH file's blocks") as err:
        planned("Fluidd.viscosity=0.01:0.02")
    assert "'Fluidd'" in str(err.value)
    # a number the file writes as 2 is a float field where sphkit reads one (an emitter's
    # velocity), an integer field where it takes integers only (maxIterations); a sweep runs
    # an emitting scene, a dataset (fixed particle counts) refuses it
    raw["Configuration"]["simulationMethod"] = 4
    raw["Configuration"]["DFSPH"] = {"maxIterations": 100}
    raw["Emitters"] = [{"width": 3, "height": 3, "translation": [-0.5, 1.2, 0.0],
                        "velocity": 2, "type": 0, "emitEndTime": 1}]
    path.write_text(json.dumps(raw))
    p = planned("Emitters.0.velocity=1:3", "Configuration.DFSPH.maxIterations=50:200")
    assert [s.integer for s in p.specs] == [False, True]
    assert all(isinstance(v["Configuration.DFSPH.maxIterations"], int)
               and v["Emitters.0.velocity"] != int(v["Emitters.0.velocity"])
               for _k, v, _s in p.variants)
    assert [sc["emitters"][0]["velocity"] for _k, _v, sc in p.variants] == pytest.approx(
        [v["Emitters.0.velocity"] for _k, v, _s in p.variants])
    with pytest.raises(SceneError, match="integer field"):
        planned("Configuration.DFSPH.maxIterations=50.5:200")
    args = build_parser().parse_args(["dataset", str(path), "--count", "2", "--workers", "0"])
    with pytest.raises(SceneError, match="emitters"):
        plan(args, "dataset")
