"""Single-fluid results before and after a change, to the last bit.

    python validation/single_fluid_identity.py --before /path/to/old/checkout/src [--steps 25]
        [--cases dfsph wcsph ...]

Runs each small scene below (every pressure solver; Akinci, density-map and volume-map walls;
MLS and hydrostatic boundary pressure; implicit viscosity, surface tension, vorticity and drag;
2D and 3D) for ``--steps`` steps with the sphkit of ``--before`` and with this checkout's, each
case in a fresh process (PCISPH's round-off depends on what ran before it in the same process),
and prints whether positions, velocities, densities and pressures (sorted by particle id) are
identical, else the largest difference. Used for the per-particle rest densities
(``sphkit.multiphase``): a scene of one fluid must give the same numbers as before.

Run it with ``NUMBA_NUM_THREADS=1``, and twice after making a fresh worktree for ``--before``:
a case whose passes compile in its own process (a cold cache) can differ in the last bits from
the same code loaded from the cache (2026-12-07: eight scenes, WCSPH's and PBF's among them,
differed by 1e-30 to 1e-6 on the first run against a new worktree and were identical on the
second).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"


def scene(method: str, bnd: str = "akinci2012", bp: str = "mirror", visc: str = "standard",
          st: str = "none", vort: str = "none", drag: str = "none", dim: int = 2,
          st_extra: dict | None = None):  # noqa: ANN201
    """A small dam break in a box: 99 particles in 2D (r = 2 cm), 40 in 3D (r = 4 cm)."""
    from sphkit.scene.schema import Scene

    r = 0.02 if dim == 2 else 0.04
    mat = {"viscosity": {"method": visc, "coefficient": 0.01}}
    if st != "none":
        mat["surface_tension"] = {"method": st, "coefficient": 0.05, **(st_extra or {})}
    if vort != "none":
        mat["vorticity"] = {"method": vort, "coefficient": 0.01}
    if drag != "none":
        mat["drag"] = {"method": drag, "coefficient": 0.01}
    d = {
        "configuration": {"dim": dim, "particle_radius": r, "gravity": [0.0, -9.81, 0.0][:dim],
                          "pressure": {"method": method},
                          "time": {"dt_max": 0.004},
                          "boundary": {"method": bnd, "pressure": bp}},
        "materials": [mat],
        "fluid_blocks": [{"start": [2*r, 2*r, 2*r][:dim], "end": [0.4, 0.5, 0.3][:dim]}],
        "boxes": [{"min": [0.0]*dim, "max": [1.0, 0.8, 0.34][:dim]}],
    }
    if method == "wcsph":
        d["configuration"]["pressure"].update({"stiffness": 20000.0, "exponent": 7.0})
    return Scene.model_validate(d)


CASES = {
    "wcsph": dict(method="wcsph"),
    "pcisph": dict(method="pcisph"),
    "pbf": dict(method="pbf"),
    "iisph": dict(method="iisph"),
    "dfsph": dict(method="dfsph"),
    "dfsph_mls": dict(method="dfsph", bp="mls"),
    "iisph_mls": dict(method="iisph", bp="mls"),
    "dfsph_vmap": dict(method="dfsph", bnd="bender2019"),
    "wcsph_vmap": dict(method="wcsph", bnd="bender2019"),
    "dfsph_dmap": dict(method="dfsph", bnd="koschier2017"),
    "pcisph_dmap": dict(method="pcisph", bnd="koschier2017"),
    "dfsph_hydro": dict(method="dfsph", bnd="bender2019", bp="hydrostatic"),
    "dfsph_hydro3": dict(method="dfsph", bnd="bender2019", bp="hydrostatic", dim=3),
    "dfsph_dmap_hydro3": dict(method="dfsph", bnd="koschier2017", bp="hydrostatic", dim=3),
    "dfsph_weiler_st": dict(method="dfsph", visc="weiler2018", st="akinci2013",
                            vort="micropolar", drag="macklin2014"),
    "wcsph_st": dict(method="wcsph", st="becker2007", vort="confinement", drag="gissler2017"),
    "dfsph_he": dict(method="dfsph", st="he2014", visc="bender2017"),
    "dfsph_jeske": dict(method="dfsph", st="jeske2023", visc="weiler2018",
                        st_extra={"jeske2023": {"viscosity": 0.01, "boundary_viscosity": 0.01,
                                                "xsph": 0.1}}),
    "dfsph_jeske3": dict(method="dfsph", st="jeske2023", dim=3,
                         st_extra={"jeske2023": {"viscosity": 0.01, "boundary_viscosity": 0.01,
                                                 "xsph": 0.1}}),
    "dfsph3": dict(method="dfsph", dim=3),
    "pbf3": dict(method="pbf", dim=3),
}


def run_case(name: str, steps: int, out: str) -> None:
    """Run one case with the sphkit on sys.path and save its arrays to ``out`` (npz)."""
    from sphkit.simulation import Simulation

    warnings.simplefilter("ignore")
    sim = Simulation(scene(**CASES[name]))
    for _ in range(steps):
        sim.step()
    o = sim.fluid.order_by_id()
    np.savez(out, **{k: sim.fluid[k][..., o] for k in ("x", "v", "rho", "p")})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", required=True, help="the src folder of the old checkout")
    ap.add_argument("--steps", type=int, default=25)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--case", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.case:  # the child process
        run_case(args.case, args.steps, args.out)
        return
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.cases:
            res = {}
            for label, src in (("before", args.before), ("after", str(SRC))):
                out = os.path.join(tmp, f"{name}_{label}.npz")
                env = dict(os.environ, PYTHONPATH=src)
                p = subprocess.run([sys.executable, __file__, "--before", args.before,
                                    "--case", name, "--steps", str(args.steps), "--out", out],
                                   env=env, capture_output=True, text=True)
                if p.returncode:
                    res = None
                    print(f"{name:18s} failed ({label}): {p.stderr.strip().splitlines()[-1:]}")
                    break
                res[label] = np.load(out)
            if res is None:
                continue
            diffs = [f"{k} {np.abs(res['before'][k] - res['after'][k]).max():.3g}"
                     for k in ("x", "v", "rho", "p")
                     if not np.array_equal(res["before"][k], res["after"][k])]
            print(f"{name:18s} " + ("identical" if not diffs else "DIFFERENT: " + ", ".join(diffs)),
                  flush=True)


if __name__ == "__main__":
    main()
