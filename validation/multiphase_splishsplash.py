"""A two-layer column at rest in SPlisHSPlasH and in sphkit, from the same scene file.

    python validation/multiphase_splishsplash.py [--ratio 10] [--until 3] [--radius 0.01]
        [--layer 0.6] [--width 0.4] [--codes splishsplash sphkit] [--every 0.1]

Writes the hydrostatic two-layer column of ``validation/multiphase.py`` (light over heavy, rest
densities 1000 and ``1000 / --ratio``, layers ``--layer`` m deep, a square tank ``--width`` m
across, 3D) as a SPlisHSPlasH scene: UnitBox.obj walls with Akinci particles, one fluid model
per layer (standard viscosity 0.01 m^2/s, SPlisHSPlasH's multiphase scenes' value), two
FluidBlocks, DFSPH with the multiphase scenes' maxError 0.05 %, ``cflMaxTimeStepSize`` 2 ms.
It runs the file through the ``pysplishsplash`` wheel (a subprocess, with the ``LD_PRELOAD``
its import needs on Linux) and through sphkit (``from_splishsplash``, the scene's defaults:
the solved walls at a ratio above 4), and prints every ``--every`` s, per code: the time, the
steps and mean / largest iterations since the last line, and per layer the rms and largest
speed and the mean vertical velocity [m/s]. A run whose fastest particle exceeds 100 m/s is
reported as blown up and stopped. SPlisHSPlasH places the first particle 2r inside a block, so
its fluid stands 2r off the walls (19 particles across at the defaults, 29 rows a layer).
Results: validation/README.md, "The step bound's slack".
"""

from __future__ import annotations

import argparse
import json
import logging
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from sphkit.scene.splishsplash import from_splishsplash, wheel

HERE = Path(__file__).resolve().parent
UNIT_BOX = HERE.parent / "benchmarks" / "scenes" / "UnitBox.obj"
#: a run whose fastest particle exceeds this [m/s] has blown up
BLOWN = 100.0

RUNNER = r"""
import sys, json, tempfile
import numpy as np
import pysplishsplash as sph
every, blown = float(sys.argv[2]), float(sys.argv[3])
base = sph.Exec.SimulatorBase()
base.init(["x", "--no-gui", "--output-dir", tempfile.mkdtemp(), "--no-cache", sys.argv[1]], "x")
acc = {"its": [], "t0": 0.0}
def cb():
    sim = sph.Simulation.getCurrent()
    tm = sph.TimeManager.getCurrent()
    t = tm.getTime()
    acc["its"].append(int(sim.getTimeStep().getNumIterations()))
    layers, vmax = [], 0.0
    for k in range(sim.numberOfFluidModels()):
        fm = sim.getFluidModel(k)
        v = np.asarray(fm.getFieldBuffer("velocity")).reshape(-1, 3)[:fm.numActiveParticles()]
        s = np.linalg.norm(v, axis=1)
        vmax = max(vmax, float(s.max()))
        layers.append([float(np.sqrt((s ** 2).mean())), float(s.max()), float(v[:, 1].mean())])
    if t - acc["t0"] >= every - 1e-9 or vmax > blown:
        acc["t0"] = t
        print("SPHKIT-ROW " + json.dumps([t, acc["its"], layers]), flush=True)
        acc["its"] = []
    if vmax > blown:
        print("SPHKIT-BLOWN", flush=True)
        sys.stdout.flush()
        import os
        os._exit(0)
base.setTimeStepCB(cb)
base.run()
"""


def scene(ratio: float, until: float, r: float, layer: float, width: float) -> dict:
    """The column as a SPlisHSPlasH scene (dict); the tank's floor at y = 0, its lid 0.2 m
    above the fluid."""
    high = 2 * layer + 0.2
    visc = {"viscosity": 0.01}
    return {
        "Configuration": {"particleRadius": r, "simulationMethod": 4, "boundaryHandlingMethod": 0,
                          "gravitation": [0, -9.81, 0], "cflMethod": 1, "cflFactor": 1,
                          "cflMaxTimeStepSize": 0.002, "stopAt": until,
                          "enableVTKExport": False, "enablePartioExport": False,
                          "DFSPH": {"minIterations": 2, "maxIterations": 100, "maxError": 0.05,
                                    "maxIterationsV": 100, "maxErrorV": 0.1,
                                    "enableDivergenceSolver": True}},
        "Materials": [{"id": "heavy", "density0": 1000.0, "viscosityMethod": 1,
                       "Standard viscosity": visc},
                      {"id": "light", "density0": 1000.0 / ratio, "viscosityMethod": 1,
                       "Standard viscosity": visc}],
        "RigidBodies": [{"geometryFile": str(UNIT_BOX), "translation": [0, high / 2, 0],
                         "rotationAxis": [1, 0, 0], "rotationAngle": 0,
                         "scale": [width, high, width], "isDynamic": False, "isWall": True,
                         "mapInvert": True, "mapThickness": 0.0}],
        "FluidBlocks": [
            {"id": "heavy", "denseMode": 0, "start": [-width / 2, 0, -width / 2],
             "end": [width / 2, layer, width / 2]},
            {"id": "light", "denseMode": 0, "start": [-width / 2, layer, -width / 2],
             "end": [width / 2, 2 * layer, width / 2]}],
    }


def run_splishsplash(path: Path, every: float) -> tuple[list, bool]:
    """Rows (time, iterations since the last row, per layer [rms, max, mean v_y]) of the wheel's
    run, and whether it blew up."""
    runner = path.parent / "run.py"
    runner.write_text(RUNNER)
    res = subprocess.run([sys.executable, str(runner), str(path), str(every), str(BLOWN)],
                         env=wheel.subprocess_env("2"), capture_output=True, text=True,
                         timeout=7200)
    rows = [json.loads(s.split(" ", 1)[1]) for s in res.stdout.splitlines()
            if s.startswith("SPHKIT-ROW ")]
    if not rows and res.returncode != 0:
        raise SystemExit(f"pysplishsplash failed: {res.stderr.strip()[-300:]}")
    return rows, "SPHKIT-BLOWN" in res.stdout


def run_sphkit(data: dict, until: float, every: float) -> tuple[list, bool]:
    """The same rows from sphkit's run of the scene."""
    from sphkit.simulation import InstabilityError, Simulation

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(from_splishsplash(data))
    logging.disable(logging.WARNING)
    f = sim.fluid
    rows, its, t0 = [], [], 0.0
    try:
        while sim.time < until - 1e-9:
            its.append(sim.step().iterations)
            v = f.view("v")
            speed = np.linalg.norm(v, axis=1)
            last = sim.time >= until - 1e-9
            if sim.time - t0 >= every - 1e-9 or speed.max() > BLOWN or last:
                t0 = sim.time
                ph = f["phase"]
                rows.append([sim.time, its, [[float(np.sqrt((speed[ph == k] ** 2).mean())),
                                              float(speed[ph == k].max()),
                                              float(v[ph == k, 1].mean())] for k in (0, 1)]])
                its = []
                if speed.max() > BLOWN:
                    return rows, True
    except InstabilityError:
        return rows, True
    finally:
        logging.disable(logging.NOTSET)
    return rows, False


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ratio", type=float, default=10.0)
    ap.add_argument("--until", type=float, default=3.0)
    ap.add_argument("--radius", type=float, default=0.01)
    ap.add_argument("--layer", type=float, default=0.6)
    ap.add_argument("--width", type=float, default=0.4)
    ap.add_argument("--every", type=float, default=0.1)
    ap.add_argument("--codes", nargs="+", default=["splishsplash", "sphkit"],
                    choices=["splishsplash", "sphkit"])
    args = ap.parse_args()
    data = scene(args.ratio, args.until, args.radius, args.layer, args.width)
    folder = Path(tempfile.mkdtemp(prefix="sphkit-mp-sps-"))
    path = folder / "scene.json"
    path.write_text(json.dumps(data))
    print(f"two-layer column, 3D, rho0 1000 / {1000 / args.ratio:g}, layers {args.layer} m, "
          f"r = {args.radius} m, tank {args.width} m across; per layer: rms / max speed, mean "
          f"v_y [m/s]")
    for code in args.codes:
        t = time.perf_counter()
        rows, blown = (run_splishsplash(path, args.every) if code == "splishsplash"
                       else run_sphkit(data, args.until, args.every))
        print(f"\n{code} ({time.perf_counter() - t:.0f} s wall)")
        print(f"{'t [s]':>7s} {'steps':>5s} {'its':>5s} {'max':>4s}  "
              f"{'heavy rms':>9s} {'max':>7s} {'v_y':>8s}  {'light rms':>9s} {'max':>7s} "
              f"{'v_y':>8s}")
        for tt, its, layers in rows:
            (hr, hm, hv), (lr, lm, lv) = layers
            print(f"{tt:7.3f} {len(its):5d} {np.mean(its):5.1f} {max(its):4d}  {hr:9.4f} "
                  f"{hm:7.3g} {hv:+8.4f}  {lr:9.4f} {lm:7.3g} {lv:+8.4f}", flush=True)
        if blown:
            print(f"blown up: a particle above {BLOWN:g} m/s at t = {rows[-1][0]:.4f} s"
                  if rows else "blown up")


if __name__ == "__main__":
    main()
