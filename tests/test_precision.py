"""``configuration.precision`` / ``sphkit run --precision``: float32 storage of the particle
fields and the cached pair values."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sphkit.cli import main
from sphkit.io.frames import read_frame
from sphkit.io.manifest import read_manifest

#: 2D DFSPH dam break, 20 x 10 = 200 particles of radius 1 cm against the left wall of a box,
#: 0.1 s (about 25 steps) with one frame at the end
SCENE = {
    "name": "precision",
    "configuration": {"dim": 2, "particle_radius": 0.01, "time": {"until": 0.1},
                      "pressure": {"method": "dfsph"}},
    "fluid_blocks": [{"start": [0.02, 0.02], "end": [0.42, 0.22]}],
    "boxes": [{"min": [0.0, 0.0], "max": [0.8, 0.5]}],
    "output": {"fps": 10, "formats": ["vtk"]},
}


def _run(tmp_path: Path, precision: str) -> tuple[dict, dict]:
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(SCENE))
    out = tmp_path / precision
    assert main(["run", str(path), "--out", str(out), "--quiet", "--precision", precision]) == 0
    manifest = read_manifest(out)
    last = read_frame(out / manifest["frames"][-1]["files"][0])
    return manifest, last


def test_float32_dam_break_stays_close_to_float64(tmp_path: Path) -> None:
    m64, f64 = _run(tmp_path, "float64")
    m32, f32 = _run(tmp_path, "float32")
    # the choice is recorded: in the manifest and in the scene it holds
    assert m32["precision"] == "float32" and m32["scene"]["configuration"]["precision"] == \
        "float32"
    assert m64["precision"] == "float64"
    assert f32["position"].dtype == np.float32 and f64["position"].dtype == np.float64
    t64, t32 = m64["frames"][-1]["time"], m32["frames"][-1]["time"]
    # the CFL steps follow the velocities, so the runs end their last step 1e-5 s apart (0.001 r
    # of travel at 1 m/s): the same frame
    assert t32 == pytest.approx(t64, abs=1e-4)
    x64 = f64["position"][np.argsort(f64["id"])]
    x32 = f32["position"][np.argsort(f32["id"])].astype(np.float64)
    r = SCENE["configuration"]["particle_radius"]
    # Both runs stop their pressure iterations at the same tolerance (0.01 % average
    # compression), not at the same iterate, so the solves differ by up to that tolerance
    # rather than by float32's 6e-8, and the collapse amplifies it. Measured after 0.1 s
    # (21 steps): float32 moves particles by up to 0.042 r (0.020 r on 2026-12-04, mean height
    # 2.2e-4 r; 3.9e-4 r before); in float64,
    # halving the tolerance (0.005 %) moves them by 0.061 r (mean height 9.6e-4 r). So the
    # bound: float32 changes the result less than a plausible change of the solver tolerance,
    # with a factor of about 2 of margin; a float32 solve that lost its accuracy (a
    # cancellation in the sources) would be off by a good fraction of r.
    assert np.max(np.abs(x32 - x64)) < 0.1 * r
    assert abs(x32[:, 1].mean() - x64[:, 1].mean()) < 2e-3 * r


def test_pair_cache_in_float32_over_float64_fields(monkeypatch: pytest.MonkeyPatch,
                                                   tmp_path: Path) -> None:
    """``configuration.pair_cache``: the pressure solvers' cached pair gradients in float32
    while the fields stay float64; "auto" takes float32 exactly where the cache in float64
    would not fit in the last-level cache."""
    from sphkit.core import solver
    from sphkit.scene.files import load_scene
    from sphkit.simulation import Simulation

    def run(pair_cache: str) -> tuple[np.ndarray, Simulation, set]:
        scene = json.loads(json.dumps(SCENE))
        scene["configuration"]["pair_cache"] = pair_cache
        path = tmp_path / f"{pair_cache}.json"
        path.write_text(json.dumps(scene))
        sim = Simulation(load_scene(path))
        seen = set()  # the cache's type in each pressure solve
        solve = sim.pressure.solve

        def spy(state, dt):  # noqa: ANN001, ANN202 - the solver's own signature
            seen.add(state.pair_grads.gw.dtype)
            return solve(state, dt)

        sim.pressure.solve = spy
        while sim.time < 0.1 - 1e-9:
            sim.step()
        return sim.fluid["x"][:, np.argsort(sim.fluid["id"])].copy(), sim, seen

    x64, sim64, t64 = run("float64")
    x32, sim32, t32 = run("float32")
    assert t64 == {np.dtype(np.float64)} and t32 == {np.dtype(np.float32)}
    assert sim32.fluid["x"].dtype == np.float64
    r = SCENE["configuration"]["particle_radius"]
    # float32 rounding of the cache (relative 6e-8) is far below the solver's tolerance (0.01 %
    # average compression), so the runs differ as runs at two tolerances do (the bound of
    # test_float32_dam_break_stays_close_to_float64, which also stores the fields in float32);
    # measured: 2.5e-7 r at most, 1.6e-8 r in the mean height (the same iterations in both)
    assert np.max(np.abs(x32 - x64)) < 0.1 * r
    assert abs(x32[1].mean() - x64[1].mean()) < 2e-3 * r
    # auto: the fields' type while the float64 cache fits in the last-level cache ...
    values = 2 * sim64.state.nl_ff.indices.shape[0]  # dim x pairs
    monkeypatch.setattr(solver, "last_level_cache", lambda: 8 * values)
    assert solver.pair_cache_dtype("auto", values, np.float64) == np.float64
    # ... and float32 beyond it: the auto run is then the float32 run, bit for bit
    monkeypatch.setattr(solver, "last_level_cache", lambda: 8 * values - 8)
    assert solver.pair_cache_dtype("auto", values, np.float64) == np.float32
    monkeypatch.setattr(solver, "last_level_cache", lambda: 0)
    xa, _, ta = run("auto")
    assert ta == {np.dtype(np.float32)} and np.array_equal(xa, x32)
    # float32 fields keep a float32 cache whatever the size
    assert solver.pair_cache_dtype("auto", 1, np.float32) == np.float32
