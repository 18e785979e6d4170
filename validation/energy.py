"""The energy of a small dam break in a closed box, for every pressure solver and boundary model:
does a wall term pump energy into the flow?

    python validation/energy.py [--dim 2 3] [--radius R] [--until T]
                                [--viscosity none 1e-6] [--solvers ...] [--boundaries ...]

A block 0.2 m square (2D; a cube in 3D) collapses in a closed box 0.6 x 0.5 (x 0.4) m, written
in sphkit's own format with the defaults (the boundary pressure of each model, WCSPH's stiffness
50,000 Pa, SPlisHSPlasH's tolerances), without viscosity or with the standard viscosity
``--viscosity`` [m^2/s] (``none``: no viscosity; default: none and water's 1e-6). Nothing drives
the flow, so its mechanical energy ``E = sum m (|v|^2 / 2 + g y)`` can only fall (viscosity, the
incompressible solvers' projections) or stay (an inviscid state equation, whose elastic energy
takes a few per cent): the table gives E at the end and its largest value over the run, each over
E at t = 0, and how the run ended. Results in validation/README.md ("WCSPH's walls by default:
the energy they pump").
"""

from __future__ import annotations

import argparse
import time
import warnings

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

SOLVERS = ("wcsph", "pcisph", "pbf", "iisph", "dfsph")
BOUNDARIES = ("akinci2012", "koschier2017", "bender2019")
G = 9.81


def scene(dim: int, r: float, solver: str, boundary: str, nu: float | None) -> Scene:
    """The module docstring's dam break."""
    z = [0.0] * (dim - 2)
    material = {} if nu is None else {"viscosity": {"method": "standard", "coefficient": nu}}
    return Scene.model_validate({
        "configuration": {"dim": dim, "particle_radius": r, "gravity": [0.0, -G] + z,
                          "pressure": {"method": solver}, "boundary": {"method": boundary}},
        "materials": [material],
        "fluid_blocks": [{"start": [0.1, 0.1] + [0.1] * (dim - 2),
                          "end": [0.3, 0.3] + [0.3] * (dim - 2)}],
        "boxes": [{"min": [0.0] * dim, "max": [0.6, 0.5] + [0.4] * (dim - 2)}],
    })


def energy(sim: Simulation) -> float:
    """The fluid's kinetic and gravitational energy [J, or J/m in 2D]."""
    m, v, x = sim.fluid["m"], sim.fluid["v"], sim.fluid["x"]
    return float((m * (0.5 * (v * v).sum(axis=0) + G * x[1])).sum())


def run(dim: int, r: float, solver: str, boundary: str, nu: float | None,
        until: float) -> dict:
    """One row of the table."""
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(dim, r, solver, boundary, nu))
        e0 = energy(sim)
        top, end = e0, "ran"
        try:
            while sim.time < until - 1e-9:
                sim.step()
                top = max(top, energy(sim))
        except InstabilityError as e:
            end = f"unstable at {e.stats.time:.2f} s"
    return {"n": sim.fluid.n, "symmetric": sim.scene.configuration.boundary.symmetric,
            "end_ratio": energy(sim) / e0, "max_ratio": top / e0, "end": end,
            "wall": time.perf_counter() - t0}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, nargs="+", default=[2, 3], choices=[2, 3])
    ap.add_argument("--radius", type=float, default=None,
                    help="particle radius [m] (default 1 cm in 2D, 2 cm in 3D)")
    ap.add_argument("--until", type=float, default=4.0)
    ap.add_argument("--viscosity", nargs="+", default=["none", "1e-6"],
                    help="standard viscosities [m^2/s] to run, 'none' for none")
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=list(SOLVERS))
    ap.add_argument("--boundaries", nargs="+", default=list(BOUNDARIES),
                    choices=list(BOUNDARIES))
    args = ap.parse_args(argv)
    try:
        nus = [None if v == "none" else float(v) for v in args.viscosity]
    except ValueError:
        ap.error(f"--viscosity {args.viscosity}: expected numbers [m^2/s] or 'none'")
    if not (args.until > 0 and all(nu is None or nu >= 0 for nu in nus)):
        ap.error("--until must be positive and the viscosities not negative")
    print("| dim | viscosity | boundary | solver | particles | symmetric walls | E end / E0 "
          "| E max / E0 | end | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for dim in args.dim:
        r = args.radius or (0.01 if dim == 2 else 0.02)
        for nu in nus:
            for boundary in args.boundaries:
                for solver in args.solvers:
                    o = run(dim, r, solver, boundary, nu, args.until)
                    print(f"| {dim} | {'none' if nu is None else f'{nu:g}'} | {boundary} "
                          f"| {solver} | {o['n']} | {o['symmetric']} | {o['end_ratio']:.3f} "
                          f"| {o['max_ratio']:.3f} | {o['end']} | {o['wall']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
