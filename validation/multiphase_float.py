"""A body between two fluid layers (Solenthaler & Pajarola 2008 densities through the rigid
coupling; issue 16).

    python validation/multiphase_float.py [--dim 2|3] [--radius 0.0075] [--until 3]
        [--solvers dfsph iisph ...] [--boundaries akinci2012 ...]

The scene is ``startup.py``'s ``float`` (SPlisHSPlasH format, UnitBox.obj tank 0.8 m wide, a
square / cube of side 0.12 m as a dynamic rigid body; ``--radius`` 7.5 mm makes it 16 particle
radii, where the one-fluid floats of every solver and boundary model are within 45-55 %) with
the pool split into two materials: heavy (1000 kg/m^3) from the floor to 0.15 m, light (250
kg/m^3) from there to 0.40 m (the light block drawn from 2r lower, so that the blocks meet on
one lattice: drawn from 0.15 m its first row would sit a row's gap above the heavy layer and
land on it at the start), and a body of density 600 starting with 10 % of its height below
the interface. At rest the body is fully submerged (the light layer reaches about 0.16 m above
it) and, by Archimedes, the share of its height in the heavy layer is

    f = (rho_b - rho_l) / (rho_h - rho_l) = 350 / 750 = 0.4667.

Printed per solver and boundary model: f measured over the last second of ``--until`` (the
interface height from the 20 highest heavy and the 20 lowest light particles more than one body
width away from the body), its standard deviation, the offset of the body's bottom from the
level f predicts in particle radii, and the largest speed at the end. One fluid's floats sit
about 0.6 r high at this size (validation/README.md, "The 3D floating cube: a fixed offset in
particle radii, so resolution"), which is 5 % of f here.
"""

from __future__ import annotations

import argparse
import json
import logging
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from startup import BOUNDARIES, SOLVERS, splishsplash_scene

from sphkit.scene.files import load_scene
from sphkit.simulation import InstabilityError, Simulation

RHO_H, RHO_L, RHO_B = 1000.0, 250.0, 600.0
HEAVY_TOP, LIGHT_TOP, SIDE = 0.15, 0.40, 0.12  # [m]
EXPECTED = (RHO_B - RHO_L) / (RHO_H - RHO_L)


def scene_file(folder: Path, solver: str, boundary: str, dim: int, r: float,
               until: float) -> Path:
    """``startup.py``'s float scene with the pool in two layers and the body of RHO_B."""
    path = splishsplash_scene(folder, "float", solver, boundary, dim, r, until)
    d = json.loads(path.read_text())
    block = d["FluidBlocks"][0]
    d["FluidBlocks"] = [
        dict(block, end=[block["end"][0], HEAVY_TOP, block["end"][2]], id="heavy"),
        # SPlisHSPlasH puts a block's first particle 2r inside it: the light block starts 2r
        # below the heavy one's end, so that the two meet on one lattice (from HEAVY_TOP its
        # first row would sit a row's gap above the heavy layer and fall onto it)
        dict(block, start=[block["start"][0], HEAVY_TOP - 2 * r, block["start"][2]],
             end=[block["end"][0], LIGHT_TOP, block["end"][2]], id="light")]
    material = d["Materials"][0]
    d["Materials"] = [dict(material, id="heavy", density0=RHO_H),
                      dict(material, id="light", density0=RHO_L)]
    body = d["RigidBodies"][1]
    body["density"] = RHO_B
    body["translation"] = [0.1, HEAVY_TOP + 0.4 * SIDE, 0.0]  # 10 % below the interface
    path.write_text(json.dumps(d, indent=1))
    return path


def measure(path: Path, until: float) -> dict:
    """Run the scene; f over the last second, its spread, the largest speed at the end."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(load_scene(path))
    body = sim.rigid.bodies[0]
    shares = []
    t0 = time.perf_counter()
    try:
        while sim.time < until - 1e-9:
            sim.step()
            if sim.time <= until - 1.0:
                continue
            x = np.asarray(sim.fluid.view("x"))
            heavy = np.asarray(sim.fluid["phase"]) == 0
            far = np.abs(x[:, 0] - float(body.c[0])) > SIDE
            level = 0.5 * (np.sort(x[heavy & far, 1])[-20:].mean()
                           + np.sort(x[~heavy & far, 1])[:20].mean())
            shares.append((level - (float(body.c[1]) - SIDE / 2)) / SIDE)
    except InstabilityError as e:
        return {"status": f"unstable at t = {e.stats.time:.3f} s"}
    v = np.linalg.norm(np.asarray(sim.fluid.view("v")), axis=1)
    return {"status": "ok", "share": float(np.mean(shares)), "std": float(np.std(shares)),
            "vmax": float(v.max()), "n": int(sim.fluid.n), "wall": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2, choices=[2, 3])
    ap.add_argument("--radius", type=float, default=0.0075)
    ap.add_argument("--until", type=float, default=3.0)
    ap.add_argument("--solvers", nargs="+", default=["dfsph", "iisph"], choices=list(SOLVERS))
    ap.add_argument("--boundaries", nargs="+", default=["akinci2012"], choices=list(BOUNDARIES))
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    print(f"body of {RHO_B:g} between {RHO_H:g} and {RHO_L:g} kg/m^3, {args.dim}D, r = "
          f"{args.radius} m (side {SIDE / args.radius:.0f} r), last 1 s of {args.until} s; "
          f"expected share in the heavy layer {EXPECTED:.4f}")
    print("| solver | boundary | particles | share in the heavy layer | std | offset [r] | "
          "max speed [m/s] | wall [s] |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for solver in args.solvers:
            for boundary in args.boundaries:
                path = scene_file(Path(tmp) / f"{solver}_{boundary}", solver, boundary,
                                  args.dim, args.radius, args.until)
                row = measure(path, args.until)
                if row["status"] != "ok":
                    print(f"| {solver} | {boundary} | | {row['status']} | | | | |", flush=True)
                    continue
                offset = (EXPECTED - row["share"]) * SIDE / args.radius
                print(f"| {solver} | {boundary} | {row['n']} | {row['share']:.4f} | "
                      f"{row['std']:.4f} | {offset:+.2f} | {row['vmax']:.3f} | "
                      f"{row['wall']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
