"""ICSPH and projective fluids on a small 3D dam break: the density error they reach against the
one they are set to, and their iterations.

    python validation/compressible.py [--radius 0.01] [--until 0.6] [--rows icsph pf ...]

The dam break: a block 0.3 x 0.4 x 0.2 m of water (r = 1 cm: 2,700 particles, r off the walls)
in the corner of a
0.8 x 0.6 x 0.2 m tank (sphkit's ``boxes`` walls, two layers of boundary particles, MLS
boundary pressure: sphkit's defaults), standard viscosity 0.01 m^2/s, run to ``--until`` (0.6 s:
the front hits the far wall at about 0.25 s and runs up it). Each row is one solver setting:

* ``icsph``: ICSPH (Gissler et al. 2020) with SPlisHSPlasH's defaults, lambda = 2e5 Pa and
  maxError 0.01 %; ``icsph-scene``: the settings of SPlisHSPlasH's ``CompressibleSPH_ICSPH.json``
  (lambda = 1e5 Pa, no pressure clamping, maxError 0.05 %); ``icsph-stiff``: lambda = 1e12 Pa
  (the incompressible limit), maxError 0.01 %;
* ``pf``: projective fluids (Weiler et al. 2016) with the stiffness 25,000 N/m of
  SPlisHSPlasH's ``CompressibleSPH_PF.json`` and its minIterations 2; ``pf-stiff``: stiffness
  250,000; ``pf-10``: stiffness 25,000 with minIterations 10;
* ``iisph``: IISPH at maxError 0.01 %, the incompressible reference.

Columns, averaged over the steps after 0.05 s (percent of rho0):

* ``solver avg/max``: the error the solver reports (StepStats), averaged over the steps, and its
  largest value; ``target``: the error it is set to (ICSPH, IISPH: maxError; PF has none: its
  density error follows its stiffness and iteration count);
* ``conv``: the fraction of steps whose solve reached its target within maxIterations;
* ``comp avg/max``: the compression ``mean(max(rho / rho0 - 1, 0))`` of the densities each step
  produced (measured at the start of the next step), averaged over the steps and its largest
  value, and the largest single-particle compression over the run (``peak``);
* ``state eq.``: ICSPH only, the departure from its state equation: the compressive part of
  ``rho_{n+1} / (rho0 (1 + p_n / lambda)) - 1`` (the density the step produced against the one
  its pressure asks for), averaged over particles and steps;
* ``it/step``: iterations per step (mean, max); ``steps``, wall seconds.
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

RHO0 = 1000.0

ROWS: dict[str, dict] = {
    "icsph": {"method": "icsph", "icsph_lambda": 2e5, "max_error": 0.01},
    "icsph-scene": {"method": "icsph", "icsph_lambda": 1e5, "icsph_clamping": False,
                    "max_error": 0.05},
    "icsph-stiff": {"method": "icsph", "icsph_lambda": 1e12, "max_error": 0.01},
    "pf": {"method": "pf", "pf_stiffness": 25000.0},
    "pf-stiff": {"method": "pf", "pf_stiffness": 250000.0},
    "pf-10": {"method": "pf", "pf_stiffness": 25000.0, "min_iterations": 10},
    "iisph": {"method": "iisph", "max_error": 0.01},
}


def dambreak(pressure: dict, r: float) -> Scene:
    """The 3D dam break of the module docstring with the given ``configuration.pressure``."""
    m = r
    return Scene.model_validate({
        "name": "dambreak-3d",
        "configuration": {"dim": 3, "particle_radius": r, "pressure": pressure},
        "materials": [{"id": "fluid", "density0": RHO0,
                       "viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [m, m, m], "end": [0.3 + m, 0.4 + m, 0.2 - m]}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.8, 0.6, 0.2], "layers": 2}],
    })


def run(name: str, r: float, until: float) -> dict:
    """One row: run the dam break, collect the per-step measures."""
    pressure = ROWS[name]
    sim = Simulation(dambreak(pressure, r))
    lam = pressure.get("icsph_lambda")
    rec: dict = {"solver": [], "solver_max": [], "conv": [], "comp": [], "peak": 0.0,
                 "state": [], "its": [], "prev_p": None}

    def on_step(s: Simulation, st) -> None:
        o = s.fluid.order_by_id()
        rho = s.densities[o] / RHO0  # the density the previous step produced
        if rec["prev_p"] is not None and s.time > 0.05 and lam is not None \
                and rec["prev_p"].shape == rho.shape:
            rec["state"].append(float(np.maximum(rho / (1.0 + rec["prev_p"] / lam) - 1.0,
                                                 0.0).mean()))
        rec["prev_p"] = s.pressures[o].copy()
        if s.time > 0.05:
            rec["solver"].append(st.density_error_avg)
            rec["solver_max"].append(st.density_error_max)
            rec["conv"].append(bool(s.last_solver.converged))
            rec["comp"].append(float(np.maximum(rho - 1.0, 0.0).mean()))
            rec["peak"] = max(rec["peak"], float(rho.max() - 1.0))
            rec["its"].append(st.iterations)

    t0 = time.perf_counter()
    sim.run(until=until, on_step=on_step)
    wall = time.perf_counter() - t0
    target = pressure.get("max_error") if pressure["method"] != "pf" else None
    return {
        "row": name, "n": sim.fluid.n, "target": target,
        "solver_avg": 100 * np.mean(rec["solver"]), "solver_max": 100 * np.max(rec["solver"]),
        "conv": np.mean(rec["conv"]),
        "comp_avg": 100 * np.mean(rec["comp"]), "comp_max": 100 * np.max(rec["comp"]),
        "peak": 100 * rec["peak"],
        "state": 100 * np.mean(rec["state"]) if rec["state"] else None,
        "its_mean": float(np.mean(rec["its"])), "its_max": int(np.max(rec["its"])),
        "steps": len(rec["its"]), "wall": wall,
        "front": float(sim.positions[:, 0].max()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--radius", type=float, default=0.01, help="particle radius [m]")
    ap.add_argument("--until", type=float, default=0.6, help="simulated time [s]")
    ap.add_argument("--rows", nargs="+", default=list(ROWS), choices=list(ROWS))
    args = ap.parse_args()
    logging.getLogger("sphkit").setLevel(logging.ERROR)  # PF/ICSPH limits are counted instead

    def f(v: float | None, fmt: str = "{:.4f}") -> str:
        return "-" if v is None else fmt.format(v)

    print("| row | N | target % | solver avg / max % | conv | comp avg / max % | peak % "
          "| state eq. % | it/step (max) | steps | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.rows:
        res = run(name, args.radius, args.until)
        print(f"| {name} | {res['n']} | {f(res['target'], '{:g}')} | "
              f"{f(res['solver_avg'])} / {f(res['solver_max'])} | {res['conv']:.2f} | "
              f"{f(res['comp_avg'])} / {f(res['comp_max'])} | {res['peak']:.2f} | "
              f"{f(res['state'])} | {res['its_mean']:.1f} ({res['its_max']}) | "
              f"{res['steps']} | {res['wall']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
