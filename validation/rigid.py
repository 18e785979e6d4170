"""Dynamic rigid bodies in water (Akinci et al. 2012 coupling, sphkit.boundary.rigid).

    python validation/rigid.py [--r 0.0125] [--until 3] [--dt-max 0.002] [--solver dfsph]
        [--cases float sink] [--dim 3]

A 0.2 m cube starts 37.5 % submerged in a 0.5 m wide tank of water 0.3 m deep (3D, the
fluid one particle diameter off the side walls, so that it starts without the corner compression
of the lattice walls):

* ``float`` (density 500): Archimedes wants half of its volume submerged; the table gives the
  submerged fraction averaged over the last second (the cube oscillates with little damping),
  counted on a 40^3 grid of points in the rotated cube below the free surface (top layer of the
  fluid away from the cube, plus r);
* ``sink`` (density 2000): it sinks and must rest on the floor; the table gives the lowest
  corner's height over the floor at any time (negative: penetration) and the final speed.

``--dim 2``: the same in the plane, a 0.2 m square (the section z = 0 of the cube, moving in the
xy-plane; mass and moment per metre of depth) in a 0.5 m wide tank (suggested ``--r 0.005``).

Measured (validation/README.md): the sinking cube lands and rests with DFSPH (the default) and
with WCSPH.

Prints a table; with matplotlib, ``validation/rigid.png`` shows the cube's height over time.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

SIDE, L, H = 0.2, 0.5, 0.3


def scene(r: float, density: float, mesh_file: str, until: float, dt_max: float,
          solver: str, dim: int = 3) -> Scene:
    lo, hi = (L - SIDE) / 2, (L + SIDE) / 2
    yb = H - 0.375 * SIDE
    gap = 2 * r
    if dim == 2:  # the fluid 2r off the walls and the square (2D Akinci walls, see
        # tests/test_rigid_2d.py)
        blocks = [([gap, gap], [L - gap, yb - gap]), ([gap, yb - gap], [lo - gap, H]),
                  ([hi + gap, yb - gap], [L - gap, H])]
        box = {"min": [0, 0], "max": [L, 0.8], "open_top": True}
        mesh = {"geometry_file": mesh_file, "translation": [L / 2, yb + SIDE / 2, 0],
                "dynamic": True, "density": density}
    else:
        blocks = [([0, 0, 0], [L, yb, L]), ([0, yb, 0], [lo, H, L]), ([hi, yb, 0], [L, H, L]),
                  ([lo, yb, 0], [hi, H, lo]), ([lo, yb, hi], [hi, H, L])]
        box = {"min": [-gap, 0, -gap], "max": [L + gap, 0.8, L + gap], "open_top": True,
               "layers": 2}
        mesh = {"geometry_file": mesh_file, "translation": [L / 2, yb + SIDE / 2, L / 2],
                "dynamic": True, "density": density}
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r,
                          "gravity": [0, -9.81, 0][:dim],
                          "time": {"until": until, "cfl": True, "cfl_factor": 0.2,
                                   "dt_max": dt_max},
                          "pressure": {"method": solver}},
        "materials": [{"id": "water", "density0": 1000.0,
                       "viscosity": {"method": "xsph", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": a, "end": b, "material": "water"} for a, b in blocks],
        "boxes": [box],
        "meshes": [mesh],
    })


def run(case: str, r: float, until: float, mesh_file: str, dt_max: float, solver: str,
        dim: int = 3) -> dict:
    density = 500.0 if case == "float" else 2000.0
    sim = Simulation(scene(r, density, mesh_file, until, dt_max, solver, dim))
    body = sim.rigid.bodies[0]
    layers = (H - (2 * r if dim == 2 else 0.0)) / (2 * r)
    g = (np.arange(40) + 0.5) / 40 * SIDE - SIDE / 2
    gz = g if dim == 3 else [0.0]
    grid = np.stack(np.meshgrid(g, g, gz, indexing="ij")).reshape(3, -1)
    s = np.array([-1.0, 1.0]) * SIDE / 2
    sz = s if dim == 3 else [0.0]
    corners = np.stack(np.meshgrid(s, s, sz, indexing="ij")).reshape(3, -1)
    t, y, frac = [], [], []
    lowest = np.inf
    status = "ok"
    t0 = time.time()
    try:
        while sim.time < until:
            sim.step()
            t.append(sim.time)
            y.append(body.c[1])
            lowest = min(lowest, float((body.c[:, None] + body.R @ corners)[1].min()))
            if case == "float" and sim.time > until - 1.0:
                x = sim.fluid["x"]  # (reordered every few steps)
                far = np.abs(x[0] - L / 2) > SIDE / 2 + 0.05
                if dim == 3:
                    far |= np.abs(x[2] - L / 2) > SIDE / 2 + 0.05
                yy = np.sort(x[1, far])
                level = yy[-int(len(yy) / layers):].mean() + r
                frac.append(np.mean((body.c[:, None] + body.R @ grid)[1] < level))
    except InstabilityError as e:
        status = f"unstable at t = {e.stats.time:.3f} s"
    return {"case": case, "density": density, "fraction": float(np.mean(frac)) if frac else None,
            "lowest": lowest, "speed": float(np.linalg.norm(body.v)), "status": status,
            "centre": float(body.c[1] - SIDE / 2),
            "wall": time.time() - t0, "t": t, "y": y, "steps": sim.step_count}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--r", type=float, default=0.0125, help="particle radius [m]")
    ap.add_argument("--until", type=float, default=3.0, help="simulated time [s]")
    ap.add_argument("--dt-max", type=float, default=0.002, help="largest time step [s]")
    ap.add_argument("--solver", default="dfsph", help="pressure solver")
    ap.add_argument("--cases", nargs="+", default=["float", "sink"], choices=["float", "sink"])
    ap.add_argument("--dim", type=int, default=3, choices=[2, 3], help="2: a square in the plane")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        mesh_file = str(Path(tmp) / "cube.obj")
        trimesh.creation.box(extents=[SIDE] * 3).export(mesh_file)
        rows = [run(c, a.r, a.until, mesh_file, a.dt_max, a.solver, a.dim) for c in a.cases]
    body = "cube" if a.dim == 3 else "square"
    print(f"\n{a.dim}D, r = {a.r} m, {a.until} s, dt_max {a.dt_max} s, {a.solver}, {body} {SIDE} m")
    print("| case | density | submerged (last 1 s) | lowest corner [mm] | centre - side/2 [mm] | "
          "final speed [m/s] | status | steps | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for w in rows:
        fr = "-" if w["fraction"] is None else f"{w['fraction']:.3f}"
        print(f"| {w['case']} | {w['density']:.0f} | {fr} | {1000 * w['lowest']:+.2f} | "
              f"{1000 * w['centre']:.2f} | {w['speed']:.3f} | {w['status']} | {w['steps']} | "
              f"{w['wall']:.0f} |")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for w in rows:
        ax.plot(w["t"], w["y"], label=f"{w['case']} (density {w['density']:.0f})")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("centre of mass height [m]")
    ax.legend()
    fig.tight_layout()
    suffix = "" if a.dim == 3 else "_2d"
    fig.savefig(Path(__file__).with_name(f"rigid_{a.solver}{suffix}.png"), dpi=120)


if __name__ == "__main__":
    main()
