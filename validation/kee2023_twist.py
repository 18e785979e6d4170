"""SPlisHSPlasH's ``Beam_Kee23_validation.json`` (Kee et al. 2023, elasticityMethod 4) in
SPlisHSPlasH and in sphkit: the twist wave along the beam.

    python validation/kee2023_twist.py [--steps 10] [--threads 1]

The scene, unchanged (only ``stopAt`` and the particle file's absolute path are set for the
wheel): a 4 m beam (7822 particles, r = 2.5 cm; E 5 MPa, nu 0.45, alpha 1, stable neo-Hookean,
Newton with CG, no line search), both ends pinned by fixed boxes, the left end turned at
-5 rad/s about the beam's axis by a velocity animation field (its pinned particles move with
the velocity the field writes, in both codes), no pressure (WCSPH stiffness 0), gravity, fixed
2 ms steps. After ``--steps`` steps the table gives, per 0.25 m slab along the beam, the
angular velocity about the axis (y = 0.5, z = 0), ``omega_x = sum (dy v_z - dz v_y) / sum
(dy^2 + dz^2)``, for SPlisHSPlasH (the pysplishsplash wheel, run headless in a subprocess as
benchmarks/vs_splishsplash.py does), sphkit with its defaults (quadratic gradient weights, rest
lists of 1.5 h, particle volumes, Smith et al.'s remapped Lamé parameters) and sphkit with
SPlisHSPlasH's discretisation (``gradient_correction="linear"``, ``rest_support=1``,
``rest_volume="kernel_sum"``; the Lamé remap stays). Wall times per step are indicative only.
Results: validation/README.md, "kee2023".
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sphkit.scene.splishsplash import wheel

SCENE = "Beam_Kee23_validation.json"
SLABS = np.arange(-2.0, 2.0, 0.25)

RUNNER = r"""
import sys, json, tempfile, time
import numpy as np
import pysplishsplash as sph
base = sph.Exec.SimulatorBase()
base.init(["x", "--no-gui", "--output-dir", tempfile.mkdtemp(), "--no-cache", sys.argv[1]], "x")
out = {"t": [], "wall": []}
t0 = [time.perf_counter()]
def cb():
    sim = sph.Simulation.getCurrent()
    fm = sim.getFluidModel(0)
    n = fm.numActiveParticles()
    out["x"] = np.asarray(fm.getFieldBuffer("position")).reshape(-1, 3)[:n].tolist()
    out["v"] = np.asarray(fm.getFieldBuffer("velocity")).reshape(-1, 3)[:n].tolist()
    out["t"].append(float(sph.TimeManager.getCurrent().getTime()))
    now = time.perf_counter()
    out["wall"].append(now - t0[0])
    t0[0] = now
base.setTimeStepCB(cb)
base.run()
print("SPHKIT-STATE " + json.dumps(out), flush=True)
"""


def profile(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """omega_x per slab of :data:`SLABS` (x, v: (n, 3))."""
    out = []
    for lo in SLABS:
        s = (x[:, 0] >= lo) & (x[:, 0] < lo + 0.25)
        dy, dz = x[s, 1] - 0.5, x[s, 2]
        out.append(float((dy * v[s, 2] - dz * v[s, 1]).sum() / (dy * dy + dz * dz).sum()))
    return np.array(out)


def run_splishsplash(folder: Path, steps: int, threads: int) -> dict:
    """The scene in the wheel for ``steps`` steps: the last positions and velocities."""
    data = json.loads((folder / SCENE).read_text())
    data["Configuration"]["stopAt"] = steps * data["Configuration"]["timeStepSize"] * (1 - 1e-6)
    for fm in data["FluidModels"]:
        fm["particleFile"] = str((folder / fm["particleFile"]).resolve())
    work = Path(tempfile.mkdtemp(prefix="sphkit-kee23-"))
    (work / "scene.json").write_text(json.dumps(data))
    (work / "run.py").write_text(RUNNER)
    env = wheel.subprocess_env(str(threads))
    res = subprocess.run([sys.executable, str(work / "run.py"), str(work / "scene.json")],
                         env=env, capture_output=True, text=True, timeout=3600)
    for line in res.stdout.splitlines():
        if line.startswith("SPHKIT-STATE "):
            st = json.loads(line[len("SPHKIT-STATE "):])
            return {"x": np.array(st["x"]), "v": np.array(st["v"]), "t": st["t"][-1],
                    "wall": float(np.mean(st["wall"][1:] or st["wall"]))}
    raise RuntimeError(f"SPlisHSPlasH run failed: {res.stderr.strip()[-300:]}")


def run_sphkit(folder: Path, steps: int, splishsplash_choices: bool) -> dict:
    """The scene in sphkit for ``steps`` steps."""
    from sphkit.scene.files import load_scene
    from sphkit.simulation import Simulation

    scene = load_scene(str(folder / SCENE))
    if splishsplash_choices:
        el = scene.materials[0].elasticity
        scene.materials[0].elasticity = el.model_copy(update={
            "gradient_correction": "linear", "rest_volume": "kernel_sum", "rest_support": 1.0})
    sim = Simulation(scene)
    walls, iters, cgs = [], [], []
    for _ in range(steps):
        t0 = time.perf_counter()
        sim.step()
        walls.append(time.perf_counter() - t0)
        st = sim.solids[0].solve_stats
        iters.append(st["iterations"])
        cgs.append(st["cg_iterations"])
    f = sim.fluid
    return {"x": f["x"].T.copy(), "v": f["v"].T.copy(), "t": sim.time,
            "wall": float(np.mean(walls[1:] or walls)), "iterations": float(np.mean(iters)),
            "cg": float(np.mean(cgs))}


def main() -> None:
    from sphkit.cli.compat import wheel_scene_folder

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=10, help="time steps of 2 ms")
    ap.add_argument("--threads", type=int, default=1, help="SPlisHSPlasH's OpenMP threads")
    a = ap.parse_args()
    folder = wheel_scene_folder()
    if folder is None:
        raise SystemExit("no pysplishsplash wheel: nothing to compare with")
    folder = Path(folder)
    sps = run_splishsplash(folder, a.steps, a.threads)
    ours = run_sphkit(folder, a.steps, False)
    theirs = run_sphkit(folder, a.steps, True)
    print(f"{SCENE}, {a.steps} steps (t = {ours['t']:.3f} s; SPlisHSPlasH t = {sps['t']:.3f} s)")
    print(f"wall per step: SPlisHSPlasH {sps['wall']:.2f} s ({a.threads} thread(s)); sphkit "
          f"{ours['wall']:.2f} s ({ours['iterations']:.1f} Newton iterations, {ours['cg']:.0f} "
          f"CG iterations a step); sphkit with SPlisHSPlasH's discretisation {theirs['wall']:.2f}"
          f" s ({theirs['iterations']:.1f}, {theirs['cg']:.0f})")
    p_s, p_o, p_t = (profile(r["x"], r["v"]) for r in (sps, ours, theirs))
    print("| slab x [m] | omega_x SPlisHSPlasH [rad/s] | sphkit | sphkit, SPlisHSPlasH's "
          "discretisation |")
    print("|---|---|---|---|")
    for lo, a_, b, c in zip(SLABS, p_s, p_o, p_t, strict=True):
        print(f"| {lo:+.2f} .. {lo + 0.25:+.2f} | {a_:+.4f} | {b:+.4f} | {c:+.4f} |")
    for name, r in (("SPlisHSPlasH", sps), ("sphkit", ours), ("sphkit, SPlisHSPlasH's", theirs)):
        lo, hi = r["x"].min(axis=0), r["x"].max(axis=0)
        print(f"{name}: bounding box {np.round(lo, 4).tolist()} .. {np.round(hi, 4).tolist()}")


if __name__ == "__main__":
    main()
