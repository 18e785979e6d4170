"""Couette flow start-up (Morris, Fox & Zhu 1997, J. Comput. Phys. 136, Sec. 4.1).

Fluid between two parallel plates ``L = 1 mm`` apart, periodic along x
(``configuration.periodic_x``), at rest at t = 0; at t = 0 the upper plate (y = L) starts to
move along x at ``U = 2.5e-5 m/s``, the lower plate (y = 0) stays at rest; no body force.
``nu = 1e-6 m^2/s``, ``rho0 = 1000 kg/m^3`` (Re = U L / nu = 0.025), Morris et al.'s setup.

Analytic solution (diffusion equation u_t = nu u_yy with u(0) = 0, u(L) = U, u(y, 0) = 0; the
steady part U y / L plus the sine series of its negative, each mode decaying at its own rate):

    u(y, t) = U y / L + sum_{n>=1} 2 U (-1)^n / (n pi) sin(n pi y / L) exp(-nu n^2 pi^2 t / L^2)

(at t = 0 the series is the sine series of -U y / L, so u = 0 inside). The profiles are compared
at Morris et al.'s times t = 0.0225, 0.045, 0.1125, 0.225 s and at 1 s (steady: the slowest
mode is down to exp(-pi^2) = 5e-5). Errors of a profile over all fluid particles:
``max = max_i |u_i - u(y_i, t)| / U`` and ``L2 = sqrt(mean_i (u_i - u(y_i, t))^2) / U``.

Setup: the channel of ``validation/poiseuille.py`` (:func:`poiseuille.hex_channel`, body force
0): rows along x on a hexagonal lattice, ``n`` rows across, 12 particles per row and period;
walls of resting lattice fluid (Morris' wall particles: the fluid's lattice volume), as many
rows as the kernel support needs; Morris et al.'s quintic spline with support 3 spacings and
their regularisation 0.01/9 h^2; WCSPH (linear state equation, Mach 4e-4) at the explicit
viscous step ``0.125 spacing^2 / nu``; the standard (explicit Morris/Monaghan) viscosity with
the walls' viscosity nu_b = nu. The moving plate is the upper wall's boundary particles with
``state.boundary["v"] = (U, 0)`` set through the API after the build: their positions do not
move (an infinite plate translating along a periodic x is the same plate at every step), and
nothing in the step writes the velocity of static wall particles (only rigid bodies move
theirs); the standard viscosity's wall term uses the boundary particle's own velocity in
``v_i - v_b``. Wall velocity cases (viscosity option ``boundary_velocity``):

* ``zero``: the wall particles' own velocity (0 below, U above; SPlisHSPlasH's convention); the
  fluid slips by about a constant number of spacings at each wall.
* ``morris1997``: Morris et al.'s antisymmetric extrapolation across the wall plane,
  ``v_i - v_b -> beta (v_i - v_b)`` with ``beta = min(beta_max, 1 + d_b / d_i)``, i.e. about
  the wall's own velocity U on the moving plate; ``beta_max = 4`` (the exact extrapolation on
  this lattice, see poiseuille.py).
* ``morris1997+mv``: as ``morris1997``, and the upper plate's particles also move with it
  (``x += U dt`` after each step, wrapped into the period, boundary grid rebuilt): with static
  plate particles the fluid rows next to the plate (moving at about U) slide over them, and
  the hexagonal registration between the last fluid row and the first wall row is lost
  (0.43 spacing at 1 s for 20 rows); moving them keeps it.

Run ``python validation/couette.py`` (``--n 10 20 40`` rows across; ``--quick``: 10 and 20).
It prints the errors per time and resolution and saves ``validation/couette.png`` when
matplotlib is installed.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.simulation import Simulation


def _load_poiseuille():
    path = Path(__file__).resolve().parent / "poiseuille.py"
    spec = importlib.util.spec_from_file_location("poiseuille_validation", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


P = _load_poiseuille()
WIDTH = P.WIDTH  # plate distance L [m]
NU = P.NU  # kinematic viscosity [m^2/s]
SPEED = 2.5e-5  # upper plate speed U [m/s]
TIMES = (0.0225, 0.045, 0.1125, 0.225, 1.0)  # Morris et al.'s times, and steady [s]
#: (label, boundary_velocity, plate particles moving)
CASES = (("morris1997", "morris1997", False), ("zero", "zero", False),
         ("morris1997+mv", "morris1997", True))


def analytic(y: np.ndarray, t: float, terms: int = 400) -> np.ndarray:
    """u(y, t) of the Couette start-up (module docstring)."""
    u = SPEED * y / WIDTH
    for n in range(1, terms + 1):
        u = u + (2.0 * SPEED * (-1) ** n / (n * math.pi) * np.sin(n * math.pi * y / WIDTH)
                 * math.exp(-NU * (n * math.pi) ** 2 * t / WIDTH**2))
    return u


def channel(n: int, wall_velocity: str = "morris1997", method: str = "standard",
            columns: int = 12) -> Simulation:
    """The Couette channel of the module docstring: n rows across, the upper wall moving."""
    kw = dict(walls="lattice", force=0.0, **P.MORRIS)
    if wall_velocity != "zero":
        kw.update(wall_velocity=wall_velocity, beta_max=P.BETA_MAX)
    sim = P.hex_channel(method, n, columns, **kw)
    b = sim.state.boundary
    upper = b["x"][1] > WIDTH
    b["v"][0, upper] = SPEED
    return sim


def run(sim: Simulation, times: tuple[float, ...] = TIMES, moving: bool = False
        ) -> dict[float, tuple[float, float, np.ndarray, np.ndarray]]:
    """Run to each time; returns {t: (max error, L2 error, y, u)} (relative to U).
    ``moving``: the upper plate's particles also move, ``x += U dt`` after every step (wrapped
    into the period, the boundary grid rebuilt), so they keep their registration with the fluid
    rows next to them (module docstring)."""
    out = {}
    st = sim.state
    b = st.boundary
    upper = b["x"][1] > WIDTH
    for t in times:
        while sim.time < t - 1e-12:
            s = sim.step(land_at=t)
            if moving:
                b["x"][0, upper] = st.period_lo + np.mod(
                    b["x"][0, upper] + SPEED * s.dt - st.period_lo, st.period)
                sim.boundary_model.rebuild(st)
        # the plate's velocity is only set once: nothing in the step may change it
        assert np.all(b["v"][0, upper] == SPEED) and np.all(b["v"][0, ~upper] == 0.0)
        y = sim.fluid["x"][1].copy()
        u = sim.fluid["v"][0].copy()
        d = u - analytic(y, sim.time)
        out[t] = (float(np.abs(d).max() / SPEED), float(np.sqrt((d * d).mean()) / SPEED), y, u)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[10, 20, 40],
                    help="particles across the channel (default 10 20 40)")
    ap.add_argument("--quick", action="store_true", help="10 and 20 particles across")
    ap.add_argument("--method", default="standard", help="viscosity method (default standard)")
    args = ap.parse_args(argv)
    ns = [10, 20] if args.quick else args.n
    print(f"Couette start-up, L = {WIDTH} m, U = {SPEED} m/s, nu = {NU} m^2/s, "
          f"viscosity {args.method}, WCSPH at 0.125 spacing^2/nu; hexagonal lattice, lattice "
          "walls, quintic spline (support 3 spacings); error max / L2 of (u - u_exact) / U")
    print(f"{'wall velocity':<14}{'n':>4}" + "".join(f"{f't={t:g}':>16}" for t in TIMES)
          + f"{'time [s]':>9}")
    results = {}
    for case, wall_velocity, moving in CASES:
        for n in ns:
            t0 = time.perf_counter()
            res = run(channel(n, wall_velocity, args.method), moving=moving)
            wall = time.perf_counter() - t0
            results[(case, n)] = res
            print(f"{case:<14}{n:>4}"
                  + "".join(f"{100 * res[t][0]:7.2f}/{100 * res[t][1]:5.2f}% " for t in TIMES)
                  + f"{wall:9.1f}", flush=True)
    for case, _w, _m in CASES:  # observed order of the L2 error between successive resolutions
        for a, b in zip(ns, ns[1:], strict=False):
            orders = [math.log(results[(case, a)][t][1] / results[(case, b)][t][1])
                      / math.log(b / a) for t in TIMES]
            print(f"order {case} n {a}->{b}: " + " ".join(f"{o:5.2f}" for o in orders))
    plt = pyplot()
    if plt is None:
        return 0
    fig, ax = plt.subplots(figsize=(6, 4))
    yy = np.linspace(0.0, WIDTH, 200)
    n = max(ns)
    for t in TIMES:
        ax.plot(analytic(yy, t) * 1e6, yy * 1e3, "k-", lw=0.8)
        for (case, _w, _m), mk in zip(CASES, ("o", "+", "x"), strict=True):
            _e, _l, y, u = results[(case, n)][t]
            ax.plot(u * 1e6, y * 1e3, mk, ms=3,
                    label=f"{case}, n = {n}" if t == TIMES[-1] else None)
    ax.set_xlabel("u [um/s]")
    ax.set_ylabel("y [mm]")
    ax.set_title("Couette start-up (lines: series solution; t = " + ", ".join(
        f"{t:g}" for t in TIMES) + " s)", fontsize=8)
    ax.legend(fontsize=7)
    path = Path(__file__).with_suffix(".png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
