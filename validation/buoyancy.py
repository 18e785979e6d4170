"""Where a floating body's draft goes wrong: the free surface against the pressure field, and the
body's coupling against the pressure field (the float of ``startup.py``).

    python validation/buoyancy.py [--dim 3] [--radius 0.015] [--side 0.12] [--until 3]
                                  [--solvers dfsph] [--boundaries akinci2012 ...]

The scene is ``startup.py``'s ``float`` (SPlisHSPlasH format, a cube / square of density 500 in
a pool 0.24 m deep, the fluid block 0.2 r off the walls), optionally with another cube side
(``--side``; the pool deepens to keep 2 sides of water). Over the last second of the run each
frame gives

* ``level``: the free surface as ``startup.py`` counts it (mean height of the top layer of the
  fluid away from the body, plus r);
* ``y0``: where the hydrostatic pressure of the fluid away from the body and the walls extrapolates
  to zero (least-squares line of the particle pressures over height, middle 80 % of the depth);
* the body's bottom ``yb`` (centre minus half the side; the body barely tilts in these runs).

Archimedes puts the bottom at ``d* = M / (rho0 A)`` below the pressure's zero. Two offsets, in
particle radii, split the error of the submerged fraction ``(level - yb) / L = 0.5 + (e_s -
e_c) / L``:

* ``e_s = level - y0``: the counted surface above the pressure's zero;
* ``e_c = d* - (y0 - yb)``: how much higher the body rides than Archimedes puts it in the
  fluid's own pressure field -- the coupling's share.

Also printed: the pool's pressure slope (rho0 g), the fluid's vertical force on the body over
M g, and for the fluid within 3 r below the body's bottom (2 r in from its edges) its mean depth
below the bottom and its mean pressure above the pool's line, both in r and rho0 g r. The two
shares trade against each other between boundary pressures (validation/README.md, "Floats and
columns against issue 15's targets"); their sum is the robust quantity.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import startup

from sphkit.scene.files import load_scene
from sphkit.simulation import InstabilityError, Simulation


def measure(folder: Path, solver: str, boundary: str, dim: int, r: float, side: float,
            until: float, edit=None) -> dict:
    startup.SIDE = side
    startup.POOL = max(0.24, 2 * side)
    path = startup.splishsplash_scene(folder / f"{solver}-{boundary}-{dim}-{r}-{side}", "float",
                                      solver, boundary, dim, r, until)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(path)
        if edit is not None:
            edit(scene)
        sim = Simulation(scene)
    body = sim.rigid.bodies[0]
    area = side ** (dim - 1)
    dstar = body.mass / (1000.0 * area)
    w = startup.TANK[0]
    layers = startup.POOL / (2 * r)
    rows = []
    t0 = time.time()
    status = "stable"
    try:
        while sim.time < until - 1e-9:
            sim.step()
            if sim.time <= until - 1.0:
                continue
            x = sim.fluid["x"]
            p = sim.pressures
            far = startup.far_from_body(x, body.c, side, dim)
            level = startup.water_level(x, far, r, layers)
            inner = far & (np.abs(x[0]) < w / 2 - 6 * r)
            if dim == 3:
                inner &= np.abs(x[2]) < startup.TANK[2] / 2 - 6 * r
            y = x[1, inner]
            m = (y > 0.1 * level) & (y < 0.9 * level)
            a, b = np.polyfit(y[m], p[inner][m], 1)
            y0 = -b / a
            yb = body.c[1] - side / 2
            under = (np.abs(x[0] - body.c[0]) < side / 2 - 2 * r) & (x[1] < yb) \
                & (x[1] > yb - 3 * r)
            if dim == 3:
                under &= np.abs(x[2] - body.c[2]) < side / 2 - 2 * r
            rows.append((level, y0, yb, -a / (1000 * 9.81), body.force[1] / (body.mass * 9.81),
                         x[1, under].mean() if under.any() else np.nan,
                         p[under].mean() if under.any() else np.nan))
    except InstabilityError as e:
        status = f"unstable at {e.stats.time:.3g} s"
    if not rows:
        return {"status": status}
    a = np.array(rows).mean(axis=0)
    level, y0, yb, slope, fratio, y1, p1 = a
    return {"status": status, "n": sim.fluid.n, "frac": (level - yb) / side,
            "e_s": (level - y0) / r, "e_c": (dstar - (y0 - yb)) / r, "slope": slope,
            "force": fratio, "gap1": (yb - y1) / r,
            "p1": (p1 / (1000 * 9.81) - (y0 - y1)) / r, "wall": time.time() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=3, choices=[2, 3])
    ap.add_argument("--radius", type=float, nargs="+", default=None)
    ap.add_argument("--side", type=float, nargs="+", default=[0.12])
    ap.add_argument("--until", type=float, default=3.0)
    ap.add_argument("--solvers", nargs="+", default=["dfsph"], choices=list(startup.SOLVERS))
    ap.add_argument("--boundaries", nargs="+", default=list(startup.BOUNDARIES),
                    choices=list(startup.BOUNDARIES))
    ap.add_argument("--body-map", type=int, default=startup.BODY_MAP,
                    help="the body's map cells per axis (density and volume maps; default "
                    f"{startup.BODY_MAP}, SPlisHSPlasH's own default is 20)")
    args = ap.parse_args()
    startup.BODY_MAP = args.body_map
    radii = args.radius or [0.015 if args.dim == 3 else 0.01]
    folder = Path(tempfile.mkdtemp(prefix="sphkit-buoyancy-"))
    print(f"{args.dim}D float, density 500, last 1 s of {args.until} s; e_s, e_c, gap, p1 in r")
    print("| solver | boundary | r [m] | side [r] | particles | submerged | e_s = level - y0 | "
          "e_c = d* - (y0 - yb) | slope / rho0 g | F_y / Mg | fluid within 3 r under the "
          "bottom: mean depth | its pressure above the pool's line [rho0 g r] | run | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in radii:
        for side in args.side:
            for solver in args.solvers:
                for boundary in args.boundaries:
                    d = measure(folder, solver, boundary, args.dim, r, side, args.until)
                    if "frac" not in d:
                        print(f"| {solver} | {boundary} | {r} | {side / r:.0f} | | | | | | | | "
                              f"| {d['status']} | |", flush=True)
                        continue
                    print(f"| {solver} | {boundary} | {r} | {side / r:.0f} | {d['n']} | "
                          f"{100 * d['frac']:.1f} % | {d['e_s']:+.2f} | {d['e_c']:+.2f} | "
                          f"{d['slope']:.3f} | {d['force']:.3f} | {d['gap1']:.2f} | "
                          f"{d['p1']:+.2f} | {d['status']} | {d['wall']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
