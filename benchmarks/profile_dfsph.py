"""Where the time of a DFSPH step goes, at a chosen resolution (the profile note of
``benchmarks/README.md``).

    python benchmarks/profile_dfsph.py [--radius 0.0105] [--start 0.06] [--steps 20]
                                       [--threads 2] [--scene SCENE.json]

Runs the DFSPH benchmark scene (``scenes/dambreak_dfsph.json``: SPlisHSPlasH's DamBreakModel set-up,
Akinci boundaries) with the particle radius replaced (0.0105 m gives about 104,000 fluid and
102,000 boundary particles), steps to t = ``--start`` without timing (compilation, the first
splash), then profiles ``--steps`` steps with cProfile and prints the milliseconds per step of
each part: the neighbour search, the densities with the pair gradients, the solver iterations,
the viscosity and the rest. Set the thread count before numba starts (the script re-runs itself
with ``NUMBA_NUM_THREADS``). Needs an idle machine, like every timing.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: part of the step -> the compiled functions (by name) whose own time counts for it; a pass
#: run through sphkit.backend.launch spends its time in the driver ``<body>__launch_<kind>``
PARTS = {
    "solver iterations": ("kappa_accel_cached", "kappa_accel_body__launch_each", "jacobi_sweep",
                          "jacobi_body__launch_sum_max"),
    "neighbour search": ("_dense_query", "_dense_cell_query", "_query", "_compact",
                         "_counting_sort", "_dense_cells", "_cells", "zorder_permutation",
                         "_merge_rows"),
    "densities and pair gradients V_j grad W_ij": ("density_pair_gradients",
                                                   "density_pair_gradients_body__launch_each",
                                                   "pair_gradients"),
    "velocity divergences (sources)": ("pair_divergence_cached", "divergence_body__launch_each"),
    "standard viscosity": ("_standard", "standard_body__launch_each"),
    "diagonal (factor alpha) and divergence source": ("diagonal_cached",
                                                      "diagonal_body__launch_each"),
    "MLS boundary pressure (coefficients, extrapolation)": (
        "coefficients_body__launch_each", "extrapolate_body__launch_each",
        "extrapolate_phases_body__launch_each", "phase_kb_body__launch_each",
        "values_body__launch_each", "_transpose"),
}


def _profile(scene: Path, start: float, steps: int) -> None:
    from sphkit.simulation import Simulation

    sim = Simulation.from_scene(scene)
    while sim.time < start:
        sim.step()
    prof = cProfile.Profile()
    its = div = 0
    t0 = time.perf_counter()
    prof.enable()
    for _ in range(steps):
        s = sim.step()
        its += s.iterations
        div += s.divergence_iterations
    prof.disable()
    wall = (time.perf_counter() - t0) / steps * 1e3
    stats = pstats.Stats(prof).stats
    own: dict[str, float] = {}
    for (_file, _line, name), (_cc, _nc, tt, _ct, _callers) in stats.items():
        # a driver compiled with constants is named <body>__launch_<kind>__<name><value>
        base = name.split("__launch_")[0] + "__launch_" + name.split("__launch_")[1].split(
            "__")[0] if "__launch_" in name else name
        own[base] = own.get(base, 0.0) + tt
    print(f"{sim.fluid.n} fluid and {sim.boundary.n} boundary particles, steps {steps} from "
          f"t = {start} s, {os.environ.get('NUMBA_NUM_THREADS', '?')} threads")
    print(f"{wall:.1f} ms per step; {its / steps:.1f} density and {div / steps:.1f} divergence "
          "iterations per step")
    print(f"{'part':45s} {'ms/step':>8s} {'share':>6s}  functions (ms/step)")
    counted = 0.0
    for part, names in PARTS.items():
        ms = {n: own.get(n, 0.0) / steps * 1e3 for n in names if own.get(n, 0.0) > 0.0}
        tot = sum(ms.values())
        counted += tot
        detail = ", ".join(f"{n} {v:.1f}" for n, v in ms.items())
        print(f"{part:45s} {tot:8.1f} {100 * tot / wall:5.0f}%  {detail}")
    rest = wall - counted
    print(f"{'the rest (sources, integration, statistics)':45s} {rest:8.1f} "
          f"{100 * rest / wall:5.0f}%")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, default=HERE / "scenes" / "dambreak_dfsph.json")
    ap.add_argument("--radius", type=float, default=0.0105, help="particle radius [m]")
    ap.add_argument("--start", type=float, default=0.06, help="untimed simulated time [s]")
    ap.add_argument("--steps", type=int, default=20, help="profiled steps")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.radius <= 0 or args.steps < 1 or args.threads < 1:
        ap.error(f"--radius {args.radius}, --steps {args.steps}, --threads {args.threads}: "
                 "expected a positive radius and at least one step and thread")
    if args.child:
        _profile(args.scene, args.start, args.steps)
        return 0
    data = json.loads(args.scene.read_text())
    data["Configuration"]["particleRadius"] = args.radius
    for body in data.get("RigidBodies", []):  # absolute mesh paths for the copy
        if body.get("geometryFile") and not Path(body["geometryFile"]).is_absolute():
            body["geometryFile"] = str((args.scene.parent / body["geometryFile"]).resolve())
    with tempfile.TemporaryDirectory(prefix="sphkit-profile-") as tmp:
        path = Path(tmp) / args.scene.name
        path.write_text(json.dumps(data))
        env = dict(os.environ, NUMBA_NUM_THREADS=str(args.threads))
        cmd = [sys.executable, __file__, "--child", "--scene", str(path), "--start",
               str(args.start), "--steps", str(args.steps)]
        return subprocess.run(cmd, env=env, check=False).returncode


if __name__ == "__main__":
    sys.exit(main())
