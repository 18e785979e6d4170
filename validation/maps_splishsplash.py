"""The 2D hydrostatic column of validation/maps.py in SPlisHSPlasH (pysplishsplash wheel), for
its three boundary models: prints slope, profile error and wall-column excess as maps.py does.

    python validation/maps_splishsplash.py [--methods 0 1 2] [--until 2.0]

(0: Akinci 2012 particles, 1: density maps, 2: volume maps.) Each run is a subprocess with the
``LD_PRELOAD`` the wheel's import needs on Linux (as benchmarks/vs_splishsplash.py). The column:
UnitBox.obj scaled to 0.6 m wide (mapInvert), r = 1 cm, the fluid block 2r off the walls, 0.5 m
high, DFSPH (max error 0.05 %), fixed dt = 2 ms, standard viscosity 0.01; positions and pressures
averaged over the last 0.5 s; "per step": the same slope fitted to each step's pressures in that
window (how much the pressure field swings at rest). SPlisHSPlasH's DFSPH keeps the field
``p / rho^2`` in its normalised, time-step scaled units; the pressure is
``value * rho^2 / (rho0 dt^2)`` (the slope of the Akinci column comes out 1.04 rho0 g, as
sphkit's).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import maps  # noqa: E402

from sphkit.scene.splishsplash import wheel  # noqa: E402

R, W, H, DT = 0.01, 0.6, 0.5, 0.002


def _child(method: int, until: float, out: str) -> None:
    import pysplishsplash as sph

    folder = Path(out).parent
    scene = {
        "Configuration": {
            "sim2D": True, "particleRadius": R, "simulationMethod": 4,
            "gravitation": [0, -maps.G, 0], "timeStepSize": DT, "cflMethod": 0,
            "stopAt": until, "boundaryHandlingMethod": method, "enableZSort": False,
            "DFSPH": {"minIterations": 2, "maxIterations": 200, "maxError": 0.05,
                      "maxIterationsV": 100, "maxErrorV": 0.1, "enableDivergenceSolver": True}},
        "Materials": [{"id": "Fluid", "density0": maps.RHO0, "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": [{"geometryFile": str(maps.UNIT_BOX), "translation": [0, 0, 0],
                         "rotationAxis": [1, 0, 0], "rotationAngle": 0, "scale": [W, 1.0, 1.0],
                         "isDynamic": False, "isWall": True, "mapInvert": True,
                         "mapThickness": 0.0}],
        "FluidBlocks": [{"denseMode": 0, "start": [-W / 2 + 2 * R, -0.5 + 2 * R, -0.5],
                         "end": [W / 2 - 2 * R, -0.5 + 2 * R + H, 0.5]}],
    }
    path = folder / f"column_{method}.json"
    path.write_text(json.dumps(scene))
    base = sph.Exec.SimulatorBase()
    base.init(["column", "--no-gui", "--output-dir", str(folder), "--no-cache", str(path)],
              "column")
    acc: dict = {"n": 0}

    def on_step() -> None:
        sim = sph.Simulation.getCurrent()
        if sph.TimeManager.getCurrent().getTime() < until - 0.5:
            return
        fm = sim.getFluidModel(0)
        n = fm.numActiveParticles()
        o = np.argsort(np.asarray(fm.getFieldBuffer("id"))[:n])
        x = np.asarray(fm.getFieldBuffer("position"))[:n][o, :2]
        rho = np.asarray(fm.getFieldBuffer("density"))[:n][o]
        k = np.asarray(fm.getFieldBuffer("p / rho^2"))[:n][o]
        p = k * rho ** 2 / (maps.RHO0 * DT * DT)
        acc["x"] = acc.get("x", 0) + x
        acc["p"] = acc.get("p", 0) + p
        acc["n"] += 1
        acc.setdefault("steps", []).append(_slope(x[:, 1], p))

    base.setTimeStepCB(on_step)
    base.run()
    np.savez(out, x=acc["x"] / acc["n"], p=acc["p"] / acc["n"], steps=np.array(acc["steps"]))


def _slope(y: np.ndarray, p: np.ndarray) -> float:
    """Least-squares dp/dy over the middle 80 % of the column height, in units of -rho0 g."""
    lo, hgt = y.min(), y.max() - y.min()
    sel = (y > lo + 0.1 * hgt) & (y < lo + 0.9 * hgt)
    return float(-np.polyfit(y[sel], p[sel], 1)[0] / (maps.RHO0 * maps.G))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", type=int, nargs="+", default=[0, 1, 2], choices=(0, 1, 2))
    ap.add_argument("--until", type=float, default=2.0)
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(int(args.child[0]), args.until, args.child[1])
        return
    env = wheel.subprocess_env(os.environ.get("OMP_NUM_THREADS", "1"))
    names = {0: "Akinci 2012", 1: "density maps", 2: "volume maps"}
    print(f"SPlisHSPlasH 2D column ({args.until} s)")
    print("| boundary | particles | slope / rho0 g | per step: mean +- std [min, max] | "
          "profile error [% rho0 g H] | wall columns [% rho0 g H] | stand-off [r] |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for m in args.methods:
            out = str(Path(tmp) / f"column_{m}.npz")
            subprocess.run([sys.executable, __file__, "--until", str(args.until), "--child",
                            str(m), out], env=env, check=True, capture_output=True)
            d = np.load(out)
            x, p = d["x"], d["p"]
            y = x[:, 1]
            lo, hgt = y.min(), y.max() - y.min()
            sel = (y > lo + 0.1 * hgt) & (y < lo + 0.9 * hgt)
            slope = -np.polyfit(y[sel], p[sel], 1)[0] / (maps.RHO0 * maps.G)
            st = d["steps"]
            print(f"| {names[m]} | {len(y)} | {slope:.3f} | {st.mean():.3f} +- {st.std():.3f} "
                  f"[{st.min():.3f}, {st.max():.3f}] | "
                  f"{100 * maps.profile_error(y, p, R):.2f} | "
                  f"{100 * maps.wall_excess(x, p, R, W):+.1f} | {(lo + 0.5) / R:.2f} |",
                  flush=True)


if __name__ == "__main__":
    main()
