"""Per-step series of a dam break in sphkit and SPlisHSPlasH: step size, iterations, largest speed.

    python benchmarks/step_series.py [--solver dfsph] [--radius 0.009] [--until 0.3]
                                     [--fixed-dt DT] [--no-viscous-bound]
                                     [--wall-spacing 2.0] [--boundary-pressure mirror]
                                     [--codes sphkit,splishsplash]
                                     [--json FILE]
    python benchmarks/step_series.py --scene Emitter --until 0.2 --first 20

Issue 22's trace of DFSPH's iterations per step (benchmarks/README.md, "passes.py"): the
benchmark dam break (``scenes/dambreak_<solver>.json``, particle radius and ``stopAt``
replaced, as :func:`scaling.scene_at`) runs in both codes, each in its own subprocess with one
thread (counts, not timings), and every step records the time after it, the density and
divergence iterations, the largest fluid speed |v| after the step, the mean compression
max(rho / rho0 - 1, 0) of the step's densities and the number of fluid particles (emitters).
Printed: steps, iterations per step and per simulated second (the count that sets the cost), and
the same in windows of 0.05 s.

Options that take sphkit or both codes off the CFL step, to separate the solver from the step
sequence:

* ``--fixed-dt DT``: both codes at the fixed step DT (the scene's ``cflMethod`` 0,
  ``timeStepSize`` DT): equal steps, so equal iterations mean equal solvers;
* ``--no-viscous-bound``: sphkit without the explicit viscosity's step bound (0.125 (2r)^2 / nu,
  which SPlisHSPlasH does not have; validation/README.md);
* ``--wall-spacing S``: sphkit samples the walls' boundary particles S r apart instead of its
  2r (SPlisHSPlasH's regular triangle sampling: 1.5r); a probe, through the sampler's radius;
* ``--boundary-pressure P``: sphkit's ``configuration.boundary.pressure`` (a translated
  SPlisHSPlasH scene takes sphkit's default, ``mls`` at Akinci walls; ``mirror`` is
  SPlisHSPlasH's term).

SPlisHSPlasH's step: the wheel's ``TimeManager`` time after each step (its integration uses
the step size of the previous step's CFL update; its pressure solve already the new one).
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

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from scaling import scene_at  # noqa: E402 - the scene copies live beside this script

from sphkit.scene.splishsplash import wheel  # noqa: E402

SPHKIT_CHILD = """
import json, sys
import numpy as np
from sphkit.simulation import Simulation
import sphkit.world.walls as walls
from sphkit.scene.files import load_scene
scene, out, novisc, spacing = sys.argv[1], sys.argv[2], sys.argv[3] == "1", float(sys.argv[4])
if spacing != 2.0:  # the sampler puts particles 2r apart: give it the radius of S r apart
    sample = walls.sample_mesh_surface
    walls.sample_mesh_surface = lambda mesh, r, dim=3: sample(mesh, 0.5 * spacing * r, dim)
sc = load_scene(scene)
if sys.argv[5]:  # validated as the scene's own field
    bc = sc.configuration.boundary
    given = {**bc.model_dump(), "pressure": sys.argv[5]}
    sc.configuration.boundary = type(bc).model_validate(given)
sim = Simulation(sc)
if novisc:
    for force in sim.forces:
        force.max_time_step = lambda state: float("inf")
until = sim.scene.configuration.time.until
rows = []
while sim.time < until - 1e-12:
    s = sim.step()
    rho = sim.densities / sim.fluid["rho0"] if sim.fluid.n else np.ones(1)
    rows.append([s.time, s.iterations, s.divergence_iterations, s.max_velocity,
                 float(np.mean(np.maximum(rho - 1.0, 0.0))), sim.fluid.n])
json.dump({"fluid": sim.fluid.n, "boundary": sim.boundary.n, "rows": rows}, open(out, "w"))
"""

SPLISHSPLASH_CHILD = """
import json, sys, tempfile
import numpy as np
import pysplishsplash as sph
scene, out = sys.argv[1], sys.argv[2]
base = sph.Exec.SimulatorBase()
base.init(["series", "--no-gui", "--output-dir", tempfile.mkdtemp(), "--no-cache", scene],
          "series")
rows = []
def on_step():
    sim = sph.Simulation.getCurrent()
    ts = sim.getTimeStep()
    fm = sim.getFluidModel(0)
    n = fm.numActiveParticles()
    v = np.asarray(fm.getFieldBuffer("velocity"))[:n] if n else np.zeros((1, 3))
    rho = (np.asarray(fm.getFieldBuffer("density"))[:n] / fm.getDensity0() if n
           else np.ones(1))
    its = ts.getValueUInt(ts.SOLVER_ITERATIONS_V) if hasattr(ts, "SOLVER_ITERATIONS_V") else 0
    rows.append([float(sph.TimeManager.getCurrent().getTime()), int(ts.getNumIterations()),
                 int(its), float(np.sqrt((v * v).sum(1)).max()),
                 float(np.mean(np.maximum(rho - 1.0, 0.0))), int(n)])
base.setTimeStepCB(on_step)
base.run()
json.dump({"fluid": None, "boundary": None, "rows": rows}, open(out, "w"))
"""


def run(code: str, scene: Path, folder: Path, novisc: bool, spacing: float,
        boundary_pressure: str) -> dict:
    """One code's series in a subprocess with one thread; ``{"error": ...}`` when it fails."""
    out = folder / f"{code}.json"
    if code == "sphkit":
        env = dict(os.environ, NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1")
        cmd = [sys.executable, "-c", SPHKIT_CHILD, str(scene), str(out), str(int(novisc)),
               str(spacing), boundary_pressure]
    else:
        env = wheel.subprocess_env("1")
        cmd = [sys.executable, "-c", SPLISHSPLASH_CHILD, str(scene), str(out)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if res.returncode or not out.exists():
        tail = (res.stderr.strip() or res.stdout.strip()).splitlines()[-3:]
        return {"error": f"exit {res.returncode}: {' / '.join(tail)}"}
    return json.loads(out.read_text())


def wheel_scene_at(name: str, until: float, folder: Path) -> Path:
    """A copy of a SPlisHSPlasH scene (a file, or a name in the pysplishsplash wheel's scene
    folder) in ``folder`` with ``stopAt`` = ``until`` and its relative file names made
    absolute, so that both codes read it from there."""
    src = Path(name)
    if not src.is_file():
        found = wheel.scene_file(name)
        if found is None:
            raise SystemExit(f"--scene {name!r}: not a file nor a scene of the "
                             "pysplishsplash wheel (pip install pysplishsplash)")
        src = found
    data = json.loads(src.read_text())
    data.setdefault("Configuration", {})["stopAt"] = until
    for block, keys in (("RigidBodies", ("geometryFile", "particleFile", "mapFile")),
                        ("FluidModels", ("particleFile", "visMeshFile"))):
        for entry in data.get(block, []):
            for key in keys:
                if isinstance(entry.get(key), str) and not Path(entry[key]).is_absolute():
                    entry[key] = str((src.parent / entry[key]).resolve())
    out = folder / src.name
    out.write_text(json.dumps(data, indent=1))
    return out


def first_steps(results: dict, k: int) -> None:
    """The first ``k`` steps of each code side by side: step size [ms] and iterations."""
    series = {c: np.array(r["rows"]) for c, r in results.items() if "error" not in r}
    if not series or k <= 0:
        return
    print("step | " + " | ".join(f"{c} dt [ms], iterations" for c in series))
    for i in range(k):
        cells = []
        for a in series.values():
            if i < len(a):
                dt = a[i, 0] - (a[i - 1, 0] if i else 0.0)
                cells.append(f"{1e3 * dt:.4f}, {int(a[i, 1])}")
            else:
                cells.append("-")
        print(f"{i + 1:4d} | " + " | ".join(cells))


def summary(name: str, r: dict, window: float = 0.05) -> None:
    """Steps, iterations per step and per simulated second, overall and in windows."""
    if "error" in r:
        print(f"{name}: {r['error']}")
        return
    a = np.array(r["rows"])
    t, it, itv, vmax, err, count = a.T
    T = t[-1]
    print(f"{name}: {len(t)} steps to {T:.4f} s; iterations per step {it.mean():.2f} density + "
          f"{itv.mean():.2f} divergence = {(it + itv).mean():.2f}; per simulated second "
          f"{it.sum() / T:.0f} + {itv.sum() / T:.0f} = {(it + itv).sum() / T:.0f}; mean "
          f"compression {100 * err.mean():.4f} %"
          + (f"; {r['fluid']} fluid, {r['boundary']} boundary particles" if r["fluid"] else ""))
    edges = np.arange(0.0, T + window, window)
    for lo, hi in zip(edges[:-1], edges[1:], strict=False):
        m = (t > lo + 1e-9) & (t <= hi + 1e-9)
        if m.any():
            print(f"  ({lo:.2f}, {hi:.2f}] s: {m.sum():3d} steps, {it[m].mean():5.2f} + "
                  f"{itv[m].mean():4.2f} iterations per step, {(it[m] + itv[m]).sum():4.0f} in "
                  f"all, largest speed {vmax[m].max():5.2f} m/s (mean over the steps "
                  f"{vmax[m].mean():5.2f}), {int(count[m][-1])} fluid particles at its end")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solver", default="dfsph", choices=("pcisph", "pbf", "iisph", "dfsph"))
    ap.add_argument("--radius", type=float, default=0.009, help="particle radius [m]")
    ap.add_argument("--until", type=float, default=0.3, help="simulated time [s]")
    ap.add_argument("--fixed-dt", type=float, metavar="DT", help="both codes at this step [s]")
    ap.add_argument("--no-viscous-bound", action="store_true",
                    help="sphkit without the explicit viscosity's step bound")
    ap.add_argument("--wall-spacing", type=float, default=2.0, metavar="S",
                    help="sphkit's wall particles S r apart (default 2)")
    ap.add_argument("--boundary-pressure", default="", metavar="P",
                    help="sphkit's configuration.boundary.pressure (default: the scene's)")
    ap.add_argument("--scene", metavar="NAME",
                    help="a SPlisHSPlasH scene (file, or name in the wheel's scenes) instead "
                         "of the benchmark dam break (--solver, --radius, --fixed-dt unused)")
    ap.add_argument("--first", type=int, default=0, metavar="K",
                    help="print the first K steps of both codes side by side")
    ap.add_argument("--codes", default="sphkit,splishsplash")
    ap.add_argument("--json", type=Path, metavar="FILE", help="both series as JSON")
    args = ap.parse_args()
    codes = [c for c in args.codes.split(",") if c]
    if not (args.radius > 0 and args.until > 0 and args.wall_spacing > 0) \
            or (args.fixed_dt is not None and not args.fixed_dt > 0) \
            or not codes or not set(codes) <= {"sphkit", "splishsplash"}:
        ap.error(f"--radius {args.radius}, --until {args.until}, --fixed-dt {args.fixed_dt}, "
                 f"--wall-spacing {args.wall_spacing}, --codes {args.codes}: expected positive "
                 "numbers and codes among sphkit, splishsplash")
    results = {}
    with tempfile.TemporaryDirectory(prefix="sphkit-series-") as tmp:
        folder = Path(tmp)
        if args.scene:
            scene = wheel_scene_at(args.scene, args.until, folder)
        else:
            scene = scene_at(args.solver, args.radius, args.until, folder)
        if args.fixed_dt is not None:
            data = json.loads(scene.read_text())
            data["Configuration"].update(cflMethod=0, timeStepSize=args.fixed_dt)
            scene.write_text(json.dumps(data, indent=1))
        for code in codes:
            results[code] = run(code, scene, folder, args.no_viscous_bound, args.wall_spacing,
                                args.boundary_pressure)
            summary(code, results[code])
        first_steps(results, args.first)
    if args.json:
        args.json.write_text(json.dumps(results) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
