"""A lone fluid particle thrown at a wall: does it come back faster than it came?

    python validation/wall_bounce.py [--boundaries bender2019 koschier2017] [--speeds 1 3 6 ...]
                                     [--stiffness-cfl 0.8] [--dt-max 0.005]

The tank of validation/startup.py in 3D (UnitBox.obj as a 0.8 x 0.6 x 0.4 m container,
``mapInvert``, map resolution 20 x 15 x 10), SPlisHSPlasH format, WCSPH (stiffness 50,000,
exponent 7), r = 1.5 cm, standard viscosity 0.01, no gravity, one particle at the centre thrown
at the back wall (z = -0.2 m) with the given speed; it runs until the particle is back at its
start. The table gives the speed it comes back with (and the ratio), its closest distance to the
wall [r], the steps and the particles pushed out of the map's solid. ``--stiffness-cfl`` sets
``sphkit.pressure.wcsph.STIFFNESS_CFL`` (a large value, e.g. 1e9, switches the local stiffness
bound off, the behaviour before it); ``--dt-max`` SPlisHSPlasH's cflMaxTimeStepSize.

Results in validation/README.md ("WCSPH and PCISPH with volume maps").
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
from startup import splishsplash_scene

import sphkit.pressure.wcsph as wcsph
from sphkit.scene.files import load_scene
from sphkit.simulation import InstabilityError, Simulation

R = 0.015


def bounce(folder: Path, v0: float, boundary: str, dt_max: float) -> dict:
    """One throw; returns the row."""
    path = splishsplash_scene(folder / boundary, "dambreak", "wcsph", boundary, 3, R, 1.0)
    sc = json.loads(path.read_text())
    sc["Configuration"]["gravitation"] = [0, 0, 0]
    sc["Configuration"]["cflMaxTimeStepSize"] = dt_max
    sc["FluidBlocks"] = [{"denseMode": 0, "start": [-0.03, 0.27, -0.03],
                          "end": [0.03, 0.33, 0.03]}]
    path.write_text(json.dumps(sc))
    sim = Simulation(load_scene(path))
    assert sim.fluid.n == 1, sim.fluid.n
    sim.fluid["v"][:, 0] = [0.0, 0.0, -v0]
    z0 = float(sim.fluid["x"][2, 0])
    closest, steps = np.inf, 0
    try:
        while steps < 20000:
            sim.step()
            steps += 1
            x, v = sim.fluid["x"][:, 0], sim.fluid["v"][:, 0]
            closest = min(closest, (x[2] + 0.2) / R)
            if v[2] > 0.0 and x[2] >= z0:
                break
    except InstabilityError as e:
        return {"status": f"unstable at step {e.stats.step} ({e.stats.max_velocity:.3g} m/s)"}
    pushed = getattr(sim.boundary_model, "pushed", 0)
    return {"status": "back", "v": float(np.linalg.norm(sim.fluid["v"][:, 0])),
            "closest": closest, "steps": steps, "pushed": pushed}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--boundaries", nargs="+", default=["bender2019"],
                    choices=["akinci2012", "koschier2017", "bender2019"])
    ap.add_argument("--speeds", nargs="+", type=float, default=[1, 3, 6, 12, 24, 48])
    ap.add_argument("--stiffness-cfl", type=float, default=wcsph.STIFFNESS_CFL)
    ap.add_argument("--dt-max", type=float, default=0.005)
    args = ap.parse_args()
    wcsph.STIFFNESS_CFL = args.stiffness_cfl
    folder = Path(tempfile.mkdtemp(prefix="sphkit-bounce-"))
    print(f"STIFFNESS_CFL {args.stiffness_cfl:g}, dt_max {args.dt_max:g} s")
    print("| boundary | speed in [m/s] | speed out [m/s] | out / in | closest [r] | steps | "
          "pushed |")
    print("|---|---|---|---|---|---|---|")
    for boundary in args.boundaries:
        for v0 in args.speeds:
            row = bounce(folder, v0, boundary, args.dt_max)
            if row["status"] != "back":
                print(f"| {boundary} | {v0:g} | {row['status']} | | | | |", flush=True)
                continue
            print(f"| {boundary} | {v0:g} | {row['v']:.3g} | {row['v'] / v0:.2f} | "
                  f"{row['closest']:.2f} | {row['steps']} | {row['pushed']} |", flush=True)


if __name__ == "__main__":
    main()
