"""Kinetic energy of a decaying 2D vortex with and without vorticity models.

A square of fluid (side 1 m, no gravity, no walls, DFSPH, standard viscosity nu = 1e-3 m^2/s)
starts with the Gaussian vortex ``v = 2 exp(-|x|^2 / 0.04) (-y, x)`` about its centre. Viscosity
and numerical dissipation let the kinetic energy decay; vorticity confinement (Macklin & Mueller
2013) and the micropolar model (Bender et al. 2017) are meant to keep more of it. Prints the
kinetic energy relative to its start at a few times and saves ``validation/vorticity.png``
(matplotlib). (A dam break was tried first; on this 2-core machine it was too slow for a
validation run, and boxed vortices start with a wall pressure jolt larger than the vortex.)

    python validation/vorticity.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation


def vortex(vort: dict, n: int = 30, until: float = 1.5, samples: int = 30) -> tuple:
    """(times, kinetic energy / initial) of one run with ``n`` particles per side."""
    L = 1.0
    r = L / (2 * n)
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0],
                          "pressure": {"method": "dfsph"}, "time": {"dt_max": 0.004}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 1e-3},
                       "vorticity": vort}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [L, L]}],
    })
    sim = Simulation(sc)
    x = sim.positions - 0.5 * L
    vt = 2.0 * np.exp(-(x**2).sum(axis=1) / 0.04)
    sim.velocities[:, 0] = -vt * x[:, 1]
    sim.velocities[:, 1] = vt * x[:, 0]
    m = sim.fluid["m"]

    def ke() -> float:
        return float(0.5 * (m * (sim.velocities**2).sum(axis=1)).sum())

    e0 = ke()
    ts, es = [0.0], [1.0]
    for k in range(1, samples + 1):
        sim.run(until=until * k / samples, fps=1e9)
        ts.append(sim.time)
        es.append(ke() / e0)
    return np.array(ts), np.array(es)


MODELS = {
    "none": {"method": "none"},
    "confinement (eps 0.1 m/s)": {"method": "confinement", "coefficient": 0.1},
    "micropolar (nu_t 0.01 m^2/s)": {"method": "micropolar", "coefficient": 0.01},
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarse and short (a smoke test)")
    args = ap.parse_args(argv)
    n, until = (16, 0.3) if args.quick else (30, 1.5)
    results = {}
    for name, vort in MODELS.items():
        t0 = time.perf_counter()
        results[name] = vortex(vort, n=n, until=until)
        print(f"  {name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    ts = results["none"][0]
    picks = [len(ts) // 3, len(ts) // 2, 2 * len(ts) // 3, len(ts) - 1]
    late = ts >= ts[-1] / 3
    print(f"2D Gaussian vortex in a free square, {n}x{n} particles, DFSPH, nu = 1e-3 m^2/s; "
          "kinetic energy / initial")
    print("| model | " + " | ".join(f"t = {ts[i]:.2f} s" for i in picks)
          + f" | mean over t >= {ts[-1] / 3:.2f} s |")
    print("|---|" + "---|" * (len(picks) + 1))
    for name, (_t, e) in results.items():
        print(f"| {name} | " + " | ".join(f"{e[i]:.4f}" for i in picks)
              + f" | {e[late].mean():.4f} |")
    plt = pyplot()
    if plt is None:
        return 0
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, (t, e) in results.items():
        ax.plot(t, e, label=name)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("kinetic energy / initial")
    ax.set_title("2D Gaussian vortex (DFSPH)")
    ax.legend()
    out = Path(__file__).with_name("vorticity.png")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"plot: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
