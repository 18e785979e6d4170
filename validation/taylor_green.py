"""Taylor-Green vortex, 2D, periodic in x and y, Re = 100 (Taylor & Green 1937).

Domain ``[0, L)^2``, periodic along x and y (``configuration.periodic_x`` and ``periodic_y``),
``L = 1 m``, velocity scale ``U = 1 m/s``, ``nu = U L / Re = 0.01 m^2/s``, ``rho0 = 1000
kg/m^3``, no body force. With ``k = 2 pi / L`` (two by two vortices in the period),

    u = U exp(-2 nu k^2 t) sin(k x) cos(k y),   v = -U exp(-2 nu k^2 t) cos(k x) sin(k y),
    p = rho U^2 / 4 exp(-4 nu k^2 t) (cos(2 k x) + cos(2 k y))

is an exact solution of the incompressible Navier-Stokes equations, so the kinetic energy
``E = sum_i m_i |v_i|^2 / 2`` decays as ``exp(-4 nu k^2 t)``: the analytic rate is
``lambda = 4 nu k^2 = 1.5791 1/s``. The measured rate is the least-squares slope of ``ln E``
over ``T0 <= t <= T`` (``T0 = 0.1 s`` leaves out the start, where WCSPH's pressure field, zero
at t = 0, rings up; ``T = 1 s``, about one vortex turnover, E down to 0.21); its error is
``lambda_SPH / lambda - 1``. Also reported: ``E(T) / E_exact(T) - 1`` and the L2 velocity error
at T, ``sqrt(mean_i |v_i - v(x_i, T)|^2) / (U exp(-2 nu k^2 T))``.

Setup: a hexagonal lattice (scenes sample square lattices, on which sphkit's Monaghan-form
Laplacian is anisotropic: validation/poiseuille.py), ``nx`` particles per row, ``ny`` rows
(``ny`` even, ``ny sqrt(3)/2 ~ nx``, so the lattice is hexagonal to within 0.07 % in its
aspect: :data:`LATTICES`); Morris et al.'s quintic spline with support 3 spacings (spacing =
sqrt of the area per particle) and their regularisation ``0.01/9 h^2``, as in
validation/poiseuille.py; rest volume = the inverse kernel sum over the lattice (density rho0
at t = 0); velocities set to the field above at t = 0. Cases:

* ``wcsph/standard``: WCSPH, linear state equation with ``c = 10 m/s`` (Mach 0.1) and the
  background pressure ``p_b = rho0 U^2`` (twice the largest pressure deficit of the vortex
  cores; without it WCSPH's clamped state equation cannot hold a pressure below the mean),
  the explicit standard viscosity (Morris/Monaghan), fixed step ``0.4 spacing / c``.
* ``wcsph/weiler2018``: the same with Weiler et al.'s implicit viscosity (CG to 1e-7).
* ``dfsph/standard``: DFSPH (sphkit's defaults: 0.01 % density, 0.1 % divergence error) with the
  standard viscosity, CFL step (``0.4 * 2r / max|v|``, at most 5 ms, and the explicit
  viscosity's bound); the doubly periodic, filled domain makes it solve as a closed domain
  (``pressure.free_surface`` left null: sources relative to the mean, signed pressures;
  :mod:`sphkit.pressure.dfsph`, "Closed domains").
* ``iisph/standard``: IISPH (0.01 %) as ``dfsph/standard``, its closed domain chosen the same way
  (:mod:`sphkit.pressure.iisph`).
* ``wcsph/tvf``: ``wcsph/standard`` with the transport velocity of Adami, Hu & Adams 2013
  (``configuration.transport: adami2013``, :mod:`sphkit.transport.adami2013`) and their
  choices: background pressure ``p_b = rho0 c^2`` in the transport velocity, none in the state
  equation (a tiny one, ``1e-6 rho0 U^2``, only switches the clamp off: ``p = c^2 (rho - rho0)``
  goes negative in the vortex cores).

Run ``python validation/taylor_green.py`` (``--n 12 26 45``: particles per row, from
:data:`LATTICES`; ``--quick``: 12 and 26; ``--cases``; ``--re 1 --t-end 0.5``: the Stokes
limit of validation/README.md; ``--sound``: c [m/s]). It prints the errors per case and
resolution and the observed order of the rate error between successive resolutions, and saves
``validation/taylor_green.png`` when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

LENGTH = 1.0  # period L [m]
SPEED = 1.0  # velocity scale U [m/s]
RE = 100.0
NU = SPEED * LENGTH / RE  # kinematic viscosity [m^2/s]
RHO0 = 1000.0  # [kg/m^3]
K = 2.0 * math.pi / LENGTH  # wave number [1/m]
RATE = 4.0 * NU * K * K  # analytic decay rate of the kinetic energy [1/s]
T0, T_END = 0.1, 1.0  # fit window of ln E [s]
SOUND = 10.0  # WCSPH: speed of sound c [m/s] (Mach 0.1 at Re 100)
BACKGROUND = 1.0  # WCSPH: background pressure / (rho0 U^2)
PRESSURE_START = True  # WCSPH: start in the vortex's pressure field (masses)
CG_TOL = 1e-7  # weiler2018: relative residual
#: (particles per row nx, rows ny): ny even and ny sqrt(3)/2 within 0.07 % of nx
LATTICES = {12: (12, 14), 26: (26, 30), 45: (45, 52), 71: (71, 82), 97: (97, 112),
            123: (123, 142)}
#: TVF: the transport velocity's background pressure / (rho0 c^2) (Adami et al. 2013: 1) and
#: the state equation's background pressure / (rho0 U^2) (only to unclamp it: p ~ c^2 (rho - rho0))
TVF_BACKGROUND = 1.0
TVF_EOS_BACKGROUND = 1e-6
#: (label, pressure solver, viscosity, transport velocity)
CASES = (("wcsph/standard", "wcsph", "standard", "none"),
         ("wcsph/weiler2018", "wcsph", "weiler2018", "none"),
         ("dfsph/standard", "dfsph", "standard", "none"),
         ("iisph/standard", "iisph", "standard", "none"),
         ("wcsph/tvf", "wcsph", "standard", "adami2013"))
#: the cases run by default (the others on request, ``--cases``; validation/README.md)
DEFAULT_CASES = ("wcsph/standard", "wcsph/tvf")


def set_reynolds(re: float) -> None:
    """Set ``RE`` and, with it, the velocity scale ``U = Re nu / L`` (nu, the sound speed and
    so the steps stay; the analytic rate 4 nu k^2 too)."""
    global RE, SPEED
    RE, SPEED = re, re * NU / LENGTH


def velocity(x: np.ndarray, t: float) -> np.ndarray:
    """The exact velocity (2, N) [m/s] at the points x (2, N) at time t (module docstring)."""
    a = SPEED * math.exp(-2.0 * NU * K * K * t)
    return np.array([a * np.sin(K * x[0]) * np.cos(K * x[1]),
                     -a * np.cos(K * x[0]) * np.sin(K * x[1])])


def pressure_field(x: np.ndarray, t: float) -> np.ndarray:
    """The exact pressure (N,) [Pa] about its mean at the points x (2, N) at time t."""
    return (RHO0 * SPEED**2 / 4.0 * math.exp(-4.0 * NU * K * K * t)
            * (np.cos(2.0 * K * x[0]) + np.cos(2.0 * K * x[1])))


def vortex(nx: int, pressure: str = "wcsph", viscosity: str = "standard",
           t_end: float = T_END, transport: str = "none") -> Simulation:
    """The Taylor-Green vortex on the ``nx`` lattice of :data:`LATTICES` (module docstring)."""
    from sphkit.core.kernels import Kernel

    nx, ny = LATTICES[nx]
    a, dy = LENGTH / nx, LENGTH / ny
    spacing = math.sqrt(a * dy)  # sqrt of the area per particle
    r = 3.0 * spacing / 4.0  # support h = 4r = 3 spacings
    c = SOUND
    vis = {"method": viscosity, "coefficient": NU, "laplacian_eps": 0.01 / 9.0,
           "max_error": CG_TOL}
    cfg = {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0], "kernel": "quintic",
           "precision": "float64", "periodic_x": [0.0, LENGTH], "periodic_y": [0.0, LENGTH],
           "start": {"relax": False, "hydrostatic": False}}
    if transport != "none":  # Adami et al. 2013: p_b = rho0 c^2
        cfg["transport"] = {"method": transport,
                            "background_pressure": TVF_BACKGROUND * RHO0 * c * c}
    if pressure == "wcsph":
        eos_pb = (TVF_EOS_BACKGROUND if transport != "none" else BACKGROUND) * RHO0 * SPEED**2
        cfg["pressure"] = {"method": "wcsph", "equation": "linear", "stiffness": c * c,
                           "background_pressure": eos_pb}
        cfg["time"] = {"dt": 0.4 * spacing / c, "cfl": False}
    else:
        cfg["pressure"] = {"method": pressure}
    sim = Simulation(Scene.model_validate({
        "name": f"taylor-green-{pressure}-{viscosity}", "configuration": cfg,
        "materials": [{"density0": RHO0, "viscosity": vis}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [4 * r, 4 * r]}],  # replaced below
    }))
    st = sim.state
    i, k = np.meshgrid(np.arange(nx), np.arange(ny))
    x = np.stack([((i + 0.5 * (k % 2) + 0.25) * a).ravel(), ((k + 0.5) * dy).ravel()], axis=1)
    # rest volume: the inverse of the kernel sum over the (periodic) lattice
    s = np.arange(-8, 9)
    ii, jj = np.meshgrid(s, s)
    lat = np.stack([(a * (ii + 0.5 * (jj % 2))).ravel(), (dy * jj).ravel()], axis=1)
    vol = 1.0 / Kernel("quintic", st.h, 2).w(np.linalg.norm(lat, axis=1)).sum()
    fluid = st.fluid.empty_like()
    # WCSPH starts in its pressure field: masses scaled so that the summed density carries
    # the vortex's pressure through the state equation (rho0 + p / c^2)
    m = RHO0 * vol * np.ones(len(x))
    if pressure == "wcsph" and PRESSURE_START:
        m *= 1.0 + pressure_field(x.T, 0.0) / (RHO0 * c * c)
    fluid.add(x, name="vortex", m=m, V0=vol, rho=RHO0, rho0=RHO0)
    fluid["v"][:] = velocity(fluid["x"], 0.0)
    st.fluid = fluid
    for force in sim.forces:
        force.init(st)
    sim.pressure.init(st)
    return sim


def energy(sim: Simulation) -> float:
    """Kinetic energy ``sum_i m_i |v_i|^2 / 2`` [J per m of depth]."""
    f = sim.fluid
    return float(0.5 * (f["m"] * (f["v"] ** 2).sum(axis=0)).sum())


def run(sim: Simulation, t_end: float = T_END, t0: float = T0, samples: int = 40
        ) -> dict[str, object]:
    """Run to ``t_end``; returns the energy history and the errors of the module docstring."""
    ts = np.linspace(0.0, t_end, samples + 1)
    es = []
    for t in ts:
        while sim.time < t - 1e-12:
            sim.step(land_at=float(t))
        es.append(energy(sim))
    es = np.array(es)
    fit = ts >= t0 - 1e-12
    rate = -float(np.polyfit(ts[fit], np.log(es[fit]), 1)[0])
    f = sim.fluid
    ref = velocity(f["x"], sim.time)
    l2 = float(np.sqrt(((f["v"] - ref) ** 2).sum(axis=0).mean())
               / (SPEED * math.exp(-2.0 * NU * K * K * sim.time)))
    return {"t": ts, "E": es, "rate": rate, "rate_err": rate / RATE - 1.0,
            "end_err": float(es[-1] / (es[0] * math.exp(-RATE * ts[-1])) - 1.0), "l2": l2,
            "steps": sim.step_count}


def main(argv: list[str] | None = None) -> int:
    global SOUND
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[12, 26, 45],
                    choices=sorted(LATTICES), help="particles per row (default 12 26 45)")
    ap.add_argument("--quick", action="store_true", help="12 and 26 particles per row")
    ap.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES),
                    choices=[c[0] for c in CASES])
    ap.add_argument("--t-end", type=float, default=T_END, help="end of the fit window [s]")
    ap.add_argument("--sound", type=float, default=SOUND,
                    help="WCSPH: speed of sound c [m/s] (default 10, Mach 0.1; with the transport "
                    "velocity p_b = rho0 c^2 follows it)")
    ap.add_argument("--re", type=float, default=RE,
                    help="Reynolds number U L / nu (default 100; 1: the Stokes limit, where "
                    "the decay only tests the viscous operator)")
    args = ap.parse_args(argv)
    SOUND = args.sound
    set_reynolds(args.re)
    ns = [12, 26] if args.quick else args.n
    cases = [c for c in CASES if c[0] in args.cases]
    print(f"Taylor-Green vortex, L = {LENGTH} m, U = {SPEED} m/s, k = 2 pi / L, nu = {NU} "
          f"m^2/s (Re {RE:g}); analytic energy decay rate 4 nu k^2 = {RATE:.5f} 1/s; fit of "
          f"ln E over {T0} <= t <= {args.t_end} s; hexagonal lattice, quintic spline (support "
          "3 spacings)")
    print(f"{'case':<18}{'nx x ny':>9}{'N':>7}{'rate [1/s]':>12}{'rate err':>10}"
          f"{'E(T) err':>10}{'L2(T)':>9}{'steps':>7}{'time [s]':>9}")
    results = {}
    for label, pressure, viscosity, transport in cases:
        for n in ns:
            t0 = time.perf_counter()
            res = run(vortex(n, pressure, viscosity, transport=transport), args.t_end)
            wall = time.perf_counter() - t0
            results[(label, n)] = res
            nx, ny = LATTICES[n]
            print(f"{label:<18}{f'{nx}x{ny}':>9}{nx * ny:>7}{res['rate']:12.5f}"
                  f"{100 * res['rate_err']:9.2f}%{100 * res['end_err']:9.2f}%"
                  f"{100 * res['l2']:8.2f}%{res['steps']:>7}{wall:9.1f}", flush=True)
    for label, _p, _v, _t in cases:  # observed order of the rate error between resolutions
        for a, b in zip(ns, ns[1:], strict=False):
            ea, eb = abs(results[(label, a)]["rate_err"]), abs(results[(label, b)]["rate_err"])
            # spacing ratio from the particle counts (the rows are not exactly nx)
            ha = 1.0 / math.sqrt(np.prod(LATTICES[a]))
            hb = 1.0 / math.sqrt(np.prod(LATTICES[b]))
            order = math.log(ea / eb) / math.log(ha / hb) if ea > 0 and eb > 0 else float("nan")
            print(f"order {label} nx {a}->{b}: rate error {order:5.2f}")
    plt = pyplot()
    if plt is None:
        return 0
    fig, ax = plt.subplots(figsize=(6, 4))
    tt = np.linspace(0.0, args.t_end, 200)
    ax.semilogy(tt, np.exp(-RATE * tt), "k-", lw=1.0, label="exp(-4 nu k^2 t)")
    for (label, _p, _v, _t), ls in zip(cases, ("-", "--", ":", "-."), strict=False):
        for n, mk in zip(ns, ("o", "s", "^", "v", "d"), strict=False):
            res = results[(label, n)]
            ax.semilogy(res["t"], res["E"] / res["E"][0], ls, marker=mk, ms=3, lw=0.8,
                        label=f"{label}, nx = {n}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("E / E(0)")
    ax.set_title(f"Taylor-Green vortex, Re {RE:g}: kinetic energy", fontsize=9)
    ax.legend(fontsize=6)
    path = Path(__file__).with_suffix(".png")
    if args.re != 100.0:
        path = path.with_name(f"taylor_green_re{args.re:g}.png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
