"""Pools written in sphkit's own format against mesh walls, for every pressure solver and boundary
model: does the fluid start inside, stay inside and rest?

    python validation/pools.py [--dim 2 3] [--cases container obstacle gap] [--radius R]
                               [--until 0.5]

Own-format fluid blocks put their first particles r from the block's faces, so a block written
flush against a mesh starts r from the mesh surface (SPlisHSPlasH's blocks start 2r inside;
``startup.py`` covers those). Two scenes, standard viscosity 0.01, gravity, SPlisHSPlasH's
default tolerances:

* ``container``: a box mesh 0.2 x 0.3 (x 0.2) m with ``invert`` (the fluid inside), a block
  filling it from wall to wall and from the floor to 0.12 m;
* ``obstacle``: an open box of lattice walls 0.2 m wide (and deep) with a solid box mesh 0.06 m
  wide standing on its floor (from below the floor to 0.06 m), a block from wall to wall over
  it, 0.12 m deep;
* ``gap``: the same with the solid box held 2 cm above the floor (from 0.02 to 0.06 m, a
  static obstacle the fluid fills the gap under: 4 r high in 2D, 2 r in 3D).

Each runs to ``--until`` (default 0.5 s) with every solver (WCSPH with stiffness 50,000) and
boundary model (``akinci2012``, ``koschier2017``, ``bender2019``). The table gives the fluid
particles, those the start-up removed (inside a wall / claimed by the boundary, ``start``'s
``removed_inside`` and ``removed_close``) and put back where they were sampled
(``held_back``), the first step's iterations and average density error, the largest speed over
the second half of the run (a pool at rest: the start's settling only), the particles outside
the container (or the box's interior, up to its top: fluid thrown over an open box counts) at
the end, and how the run ended. Results in
validation/README.md ("Own-format pools against mesh walls").
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

SOLVERS = ("wcsph", "pcisph", "pbf", "iisph", "dfsph")
BOUNDARIES = ("akinci2012", "koschier2017", "bender2019")
WIDTH, HEIGHT, DEPTH = 0.2, 0.3, 0.12  # the tank and the water's depth [m]


def meshes(folder: Path) -> None:
    """The container (a box mesh) and the obstacles (2D: a prism through z = 0)."""
    import trimesh

    trimesh.creation.box(bounds=[[0, 0, 0], [WIDTH, HEIGHT, WIDTH]]).export(folder / "tank3.obj")
    trimesh.creation.box(bounds=[[0, 0, -0.5], [WIDTH, HEIGHT, 0.5]]).export(folder / "tank2.obj")
    trimesh.creation.box(bounds=[[0.08, -0.05, 0.08], [0.14, 0.06, 0.14]]).export(
        folder / "cube3.obj")
    trimesh.creation.box(bounds=[[0.08, -0.05, -0.5], [0.14, 0.06, 0.5]]).export(
        folder / "cube2.obj")
    trimesh.creation.box(bounds=[[0.08, 0.02, 0.08], [0.14, 0.06, 0.14]]).export(
        folder / "gap3.obj")
    trimesh.creation.box(bounds=[[0.08, 0.02, -0.5], [0.14, 0.06, 0.5]]).export(
        folder / "gap2.obj")


def scene(case: str, dim: int, r: float, solver: str, boundary: str, folder: Path) -> Scene:
    """The scene of the module docstring."""
    z = [0.0] * (dim - 2)
    pressure: dict = {"method": solver}
    if solver == "wcsph":
        pressure["stiffness"] = 50000.0
    data: dict = {
        "configuration": {"dim": dim, "particle_radius": r, "gravity": [0.0, -9.81] + z,
                          "pressure": pressure, "boundary": {"method": boundary}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0.0, 0.0] + z, "end": [WIDTH, DEPTH] + [WIDTH] * (dim - 2)}],
    }
    if case == "container":
        data["meshes"] = [{"geometry_file": str(folder / f"tank{dim}.obj"), "invert": True}]
    else:
        data["boxes"] = [{"min": [0.0, 0.0] + z, "max": [WIDTH, HEIGHT] + [WIDTH] * (dim - 2),
                          "open_top": True}]
        solid = "cube" if case == "obstacle" else "gap"
        data["meshes"] = [{"geometry_file": str(folder / f"{solid}{dim}.obj")}]
    return Scene.model_validate(data)


def run(case: str, dim: int, r: float, solver: str, boundary: str, until: float,
        folder: Path) -> dict:
    """One row of the table."""
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(case, dim, r, solver, boundary, folder))
        st = sim.world.start
        first = sim.step()
        late, end = 0.0, "ran"
        try:
            while sim.time < until - 1e-9:
                s = sim.step()
                if sim.time > 0.5 * until:
                    late = max(late, s.max_velocity)
        except InstabilityError as e:
            end = f"unstable at {e.stats.time:.3f} s"
    x = sim.positions
    hi = np.array([WIDTH, HEIGHT, WIDTH][:dim])  # thrown over the open box's top: out too
    outside = int(((x < -0.1 * r) | (x > hi + 0.1 * r)).any(axis=1).sum())
    return {"n": sim.fluid.n, "removed": sum(st.removed_inside.values()),
            "close": sum(st.removed_close.values()), "held": st.held_back,
            "iterations": first.iterations, "error": first.density_error_avg,
            "late": late if end == "ran" else float("nan"), "outside": outside, "end": end,
            "wall": time.perf_counter() - t0}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, nargs="+", default=[2, 3], choices=[2, 3])
    ap.add_argument("--cases", nargs="+", default=["container", "obstacle", "gap"],
                    choices=["container", "obstacle", "gap"])
    ap.add_argument("--radius", type=float, default=None,
                    help="particle radius [m] (default 5 mm in 2D, 1 cm in 3D)")
    ap.add_argument("--until", type=float, default=0.5)
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=list(SOLVERS))
    ap.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES),
                    choices=list(BOUNDARIES))
    args = ap.parse_args(argv)
    print("| dim | case | boundary | solver | particles | removed (inside + close) | held back "
          "| first step: iterations, error | largest speed, 2nd half [m/s] | outside | end "
          "| wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        meshes(folder)
        for dim in args.dim:
            r = args.radius or (0.005 if dim == 2 else 0.01)
            for case in args.cases:
                for boundary in args.boundaries:
                    for solver in args.solvers:
                        o = run(case, dim, r, solver, boundary, args.until, folder)
                        print(f"| {dim} | {case} | {boundary} | {solver} | {o['n']} | "
                              f"{o['removed']} + {o['close']} | {o['held']} | "
                              f"{o['iterations']}, {100 * o['error']:.4f} % | {o['late']:.3f} | "
                              f"{o['outside']} | {o['end']} | {o['wall']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
