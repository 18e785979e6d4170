"""A heavy body landing through the fluid: the squeezed film under it, per solver and boundary
model (tests/test_rigid.py's and tests/test_rigid_2d.py's heavy box, with maps as well).

    python validation/landing.py [--dim 2] [--solvers wcsph] [--boundaries akinci2012 ...]
                                 [--until 1.2] [--start 0.075 ...] [--density 2000]

A cube (3D, r = 12.5 mm) or square (2D, r = 5 mm) of side 0.1 m and density 2000 starts with
its bottom 7.5 cm above the floor of a tank 0.3 m wide with water 0.2 m deep (the fluid 2 r off
the walls and the body, as tests/test_rigid_maps.py places it for maps), sinks, lands and
should rest on the floor (``--start``: other heights of its bottom, neighbouring set-ups of a
landing that is chaotic; ``--density``: another body density). Printed (tests/_landing.py):
when the lowest corner first came within 0.1 r of the floor, the lowest corner ever, the fastest
fluid particle after the landing (the squeezed film's ejection) and in the whole run, the lowest
corner at the end, the body's median speed and drift over the last 0.2 s, |omega| at the end,
whether the fluid stayed finite and in the tank, and the particles the maps pushed out of a
solid.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from _landing import track_landing  # noqa: E402

from sphkit.scene.schema import Scene  # noqa: E402
from sphkit.simulation import InstabilityError, Simulation  # noqa: E402

SIDE, L, H = 0.1, 0.3, 0.2


def scene(dim: int, solver: str, boundary: str, until: float, folder: Path, yb: float = 0.075,
          density: float = 2000.0) -> tuple[Scene, float, np.ndarray]:
    """The scene with the body's bottom at ``yb`` [m] (``density`` [kg/m^3]), its particle
    radius and the body's corners (3, K) in its frame."""
    s = np.array([-1.0, 1.0]) * SIDE / 2
    if dim == 2:
        r, g = 0.005, 0.01
        f = folder / "square.obj"
        trimesh.creation.box(extents=[SIDE, SIDE, 0.5]).export(f)
        lo, hi = (L - SIDE) / 2, (L + SIDE) / 2
        blocks = [([g, g], [L - g, yb - g]), ([g, yb - g], [lo - g, H]),
                  ([hi + g, yb - g], [L - g, H]), ([lo - g, yb + SIDE + g], [hi + g, H])]
        c = [L / 2, yb + SIDE / 2, 0.0]
        box = {"min": [0, 0], "max": [L, 0.6], "open_top": True}
        gravity, dt_max = [0.0, -9.81], 0.001
        corners = np.stack(np.meshgrid(s, s, [0.0], indexing="ij")).reshape(3, -1)
    else:
        r = 0.0125
        g = 2 * r
        f = folder / "cube.obj"
        trimesh.creation.box(extents=[SIDE] * 3).export(f)
        x0, y0, x1 = (L - SIDE) / 2 - g, yb - g, (L + SIDE) / 2 + g
        w, e = g, L - g
        blocks = [([w, w, w], [e, y0, e]), ([w, y0, w], [x0, H, e]), ([x1, y0, w], [e, H, e]),
                  ([x0, y0, w], [x1, H, x0]), ([x0, y0, x1], [x1, H, e])]
        c = [L / 2, yb + SIDE / 2, L / 2]
        box = {"min": [0, 0, 0], "max": [L, 0.6, L], "open_top": True, "layers": 2}
        gravity, dt_max = [0.0, -9.81, 0.0], 0.005
        corners = np.stack(np.meshgrid(s, s, s, indexing="ij")).reshape(3, -1)
    sc = Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r, "gravity": gravity,
                          "time": {"until": until, "cfl": True, "dt_max": dt_max},
                          "pressure": {"method": solver},
                          "boundary": {"method": boundary, "map_cache_dir": str(folder)}},
        "materials": [{"id": "water", "density0": 1000.0,
                       "viscosity": {"method": "xsph", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": a, "end": b, "material": "water"} for a, b in blocks],
        "boxes": [box],
        "meshes": [{"geometry_file": str(f), "translation": c, "dynamic": True,
                    "density": density}]})
    return sc, r, corners


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=3, choices=[2, 3])
    ap.add_argument("--solvers", nargs="+", default=["wcsph"])
    ap.add_argument("--boundaries", nargs="+",
                    default=["akinci2012", "koschier2017", "bender2019"])
    ap.add_argument("--until", type=float, default=1.2)
    ap.add_argument("--start", type=float, nargs="+", default=[0.075],
                    help="heights of the body's bottom above the floor at t = 0 [m]")
    ap.add_argument("--density", type=float, default=2000.0, help="the body's [kg/m^3]")
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="sphkit-landing-"))
    print("| dim | solver | boundary | start [m] | landed [s] | lowest [mm] | fluid after landing "
          "[m/s] | fluid, whole run [m/s] | final lowest [r] | median speed, last 0.2 s [m/s] | "
          "drift [mm] | omega [rad/s] | finite, in the tank | pushed | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for solver, boundary, yb in itertools.product(args.solvers, args.boundaries, args.start):
        sc, r, corners = scene(args.dim, solver, boundary, args.until, folder, yb,
                               args.density)
        sim = Simulation(sc)
        body = sim.rigid.bodies[0]
        t0 = time.time()
        row = f"| {args.dim}D | {solver} | {boundary} | {yb} |"
        try:
            tr = track_landing(sim, body, corners, args.until, r, window=0.2)
        except InstabilityError as e:
            print(f"{row} unstable at {e.stats.time:.3g} s | | | | | | | | | | "
                  f"{time.time() - t0:.0f} |", flush=True)
            continue
        x = sim.fluid["x"]
        ok = bool(np.all(np.isfinite(x)) and np.all((x[0] > 0) & (x[0] < L) & (x[1] > 0)))
        landed = "never" if tr.landed is None else f"{tr.landed:.3f}"
        print(f"{row} {landed} | {tr.lowest * 1000:+.3f} | {tr.vmax:.2f} | {tr.vmax_all:.2f} | "
              f"{tr.final / r:+.2f} | {tr.rest_speed:.1e} | {tr.drift * 1000:.2f} | "
              f"{np.linalg.norm(body.omega):.1e} | {'yes' if ok else 'NO'} | "
              f"{getattr(sim.boundary_model, 'pushed', '-')} | {time.time() - t0:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
