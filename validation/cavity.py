"""Lid-driven cavity, 2D, Re 100 and 1000, against Ghia, Ghia & Shin 1982.

Unit square ``[0, L]^2``, ``L = 1 m``, the lid (y = L) moving with ``U = 1 m/s`` along x, the
other walls at rest; ``nu = U L / Re``, ``rho0 = 1000 kg/m^3``, no gravity. The reference is
Ghia et al.'s multigrid solution (129 x 129 grid; J. Comput. Phys. 48, 387-411, Tables I and
II, digitised in ``validation/data/ghia1982_u.csv`` and ``ghia1982_v.csv``): u along the
vertical centreline x = L/2 and v along the horizontal centreline y = L/2 at 17 points each,
of which the 15 inside the cavity are compared (the two end points are the wall velocities).

Setup, after Adami, Hu & Adams 2013 (J. Comput. Phys. 241, Sec. 4.3): WCSPH with the linear
state equation, ``c = 10 U`` (Mach 0.1), no background pressure in the state equation (a tiny
one switches its clamp off: p = c^2 (rho - rho0) can be negative); the transport velocity
``configuration.transport: adami2013`` with ``p_b = rho0 c^2``; square lattice of spacing
``dx = L / n`` (``n`` particles across), fluid block filling the box; ``boxes[0]`` with three
wall layers, their volumes set to the fluid's (Morris et al.'s walls as resting lattice fluid,
tests/test_morris_walls.py), wall pressure mirrored; the standard viscosity with Morris' no-slip
wall velocity (``boundary_velocity: morris1997``, ``morris_beta_max`` 4: the exact
extrapolation, validation/README.md "Poiseuille"), the lid's wall particles (above y = L)
moving with U; sphkit's cubic spline (support 2 dx) with eps 0.0025 h^2 (Morris' 0.01 of the
smoothing length squared); CFL time step (the acoustic and viscous bounds).

Measured at the end (``--t-end``, default 10 s, about 10 lid transits past the steady state of
Re 100 at about 5 s): the SPH (Shepard) interpolation of the fluid velocity at Ghia's points,
averaged over the last two seconds (21 samples; a single sample carries the particles' velocity
noise of a few % of U); errors relative to the lid speed: max and rms over the 15 interior
points of each line. Also printed: the kinetic energy's change over the averaging window (the
distance from steady state).

Run ``python validation/cavity.py`` (``--n 20 40``, ``--re 100 1000``, ``--t-end``,
``--no-tvf`` for the same scene without the transport velocity). It prints the table and saves
``validation/cavity.png`` (``cavity_re1000.png`` for ``--re 1000``) when matplotlib is
installed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.core.kernels import Kernel
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

LENGTH = 1.0  # cavity side L [m]
LID = 1.0  # lid speed U [m/s]
RHO0 = 1000.0  # [kg/m^3]
SOUND = 10.0 * LID  # speed of sound c [m/s] (Mach 0.1)
EOS_BACKGROUND = 1e-6  # state equation's background pressure / (rho0 U^2): unclamps it only
T_END = 10.0  # [s]
AVERAGE = 2.0  # averaging window at the end [s]
SAMPLES = 21  # samples in the window
DATA = Path(__file__).with_name("data")


def ghia(re: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ghia et al.'s centrelines at ``re`` (100 or 1000): (y, u(x = L/2, y), x, v(x, y = L/2))."""
    col = {100: 1, 1000: 2}[int(re)]
    u = np.loadtxt(DATA / "ghia1982_u.csv", delimiter=",", comments="#", skiprows=5)
    v = np.loadtxt(DATA / "ghia1982_v.csv", delimiter=",", comments="#", skiprows=5)
    return u[:, 0], u[:, col], v[:, 0], v[:, col]


def cavity(n: int, re: float, tvf: bool = True) -> Simulation:
    """The cavity with ``n`` particles across (module docstring)."""
    dx = LENGTH / n
    r = dx / 2.0
    nu = LID * LENGTH / re
    vis = {"method": "standard", "coefficient": nu, "boundary_coefficient": nu,
           "boundary_velocity": "morris1997", "morris_beta_max": 4.0, "laplacian_eps": 0.0025}
    cfg = {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0], "kernel": "cubic",
           "precision": "float64", "zsort_every": 50,
           "start": {"relax": False, "hydrostatic": False},
           "boundary": {"method": "akinci2012", "pressure": "mirror"},
           "pressure": {"method": "wcsph", "equation": "linear", "stiffness": SOUND**2,
                        "background_pressure": EOS_BACKGROUND * RHO0 * LID**2},
           "time": {"cfl": True, "dt": 0.4 * dx / SOUND, "dt_max": 0.005}}
    if tvf:
        cfg["transport"] = {"method": "adami2013"}  # p_b = rho0 c^2
    sim = Simulation(Scene.model_validate({
        "name": f"cavity-re{re:g}-n{n}", "configuration": cfg,
        "materials": [{"density0": RHO0, "viscosity": vis}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [LENGTH, LENGTH]}],
        "boxes": [{"min": [0.0, 0.0], "max": [LENGTH, LENGTH], "layers": 3}],
    }))
    st = sim.state
    b = st.boundary
    b["V"][:] = st.fluid["V0"][0]  # the walls are resting lattice fluid (Morris et al.)
    b["v"][:] = 0.0
    b["v"][0, b["x"][1] > LENGTH] = LID  # the lid's layers, corners included
    return sim


def probe(sim: Simulation, pts: np.ndarray) -> np.ndarray:
    """Shepard interpolation ``sum_j V_j v_j W / sum_j V_j W`` of the fluid velocity (2, M)
    at the points ``pts`` (2, M)."""
    f = sim.fluid
    st = sim.state
    k = Kernel(sim.scene.configuration.kernel, st.h, 2)
    vol = f["m"] / f["rho"]
    out = np.zeros((2, pts.shape[1]))
    for m in range(pts.shape[1]):  # a few dozen points, once per sample: not the step
        w = vol * k.w(np.linalg.norm(f["x"] - pts[:, m:m + 1], axis=0))
        out[:, m] = (f["v"] * w).sum(axis=1) / w.sum()
    return out


def run(n: int, re: float, t_end: float = T_END, tvf: bool = True) -> dict[str, object]:
    """Run the cavity; returns the centreline errors of the module docstring."""
    yg, ug, xg, vg = ghia(re)
    inner_u = (yg > 0.0) & (yg < LENGTH)
    inner_v = (xg > 0.0) & (xg < LENGTH)
    pu = np.stack([np.full(inner_u.sum(), 0.5 * LENGTH), yg[inner_u]])
    pv = np.stack([xg[inner_v], np.full(inner_v.sum(), 0.5 * LENGTH)])
    sim = cavity(n, re, tvf)
    samples = np.linspace(t_end - AVERAGE, t_end, SAMPLES)
    line = np.linspace(0.0, LENGTH, 81)  # the centreline profiles for the plot
    lu = np.stack([np.full_like(line, 0.5 * LENGTH), line])
    lv = np.stack([line, np.full_like(line, 0.5 * LENGTH)])
    su, sv, ke, ts, pu_, pv_ = [], [], [], [], [], []
    t_probe = np.concatenate([np.arange(0.5, t_end - AVERAGE, 0.5), samples])
    for t in t_probe:
        while sim.time < t - 1e-12:
            sim.step(land_at=float(t))
        f = sim.fluid
        ke.append(float(0.5 * (f["m"] * (f["v"] ** 2).sum(axis=0)).sum()))
        ts.append(float(t))
        if t >= samples[0] - 1e-9:
            su.append(probe(sim, pu)[0])
            sv.append(probe(sim, pv)[1])
            pu_.append(probe(sim, lu)[0])
            pv_.append(probe(sim, lv)[1])
    u, v = np.mean(su, axis=0), np.mean(sv, axis=0)
    eu, ev = (u - ug[inner_u]) / LID, (v - vg[inner_v]) / LID
    ke = np.array(ke)
    k0 = int(np.searchsorted(ts, t_end - AVERAGE - 1e-9))
    prof_u, prof_v = np.mean(pu_, axis=0), np.mean(pv_, axis=0)
    return {"u_max": float(np.abs(eu).max()), "u_rms": float(np.sqrt((eu ** 2).mean())),
            "u_at": float(yg[inner_u][np.argmax(np.abs(eu))]),
            "v_at": float(xg[inner_v][np.argmax(np.abs(ev))]),
            "v_max": float(np.abs(ev).max()), "v_rms": float(np.sqrt((ev ** 2).mean())),
            "ke_change": float(ke[-1] / ke[k0] - 1.0), "steps": sim.step_count,
            "y": yg[inner_u], "u": u, "x": xg[inner_v], "v": v, "line": line,
            "prof_u": prof_u, "prof_v": prof_v, "t": np.array(ts), "ke": ke}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[20, 40],
                    help="particles across the cavity (default 20 40)")
    ap.add_argument("--re", type=float, nargs="+", default=[100.0], choices=[100.0, 1000.0])
    ap.add_argument("--t-end", type=float, default=T_END, help="end time [s] (default 10)")
    ap.add_argument("--no-tvf", action="store_true", help="without the transport velocity")
    args = ap.parse_args(argv)
    tvf = not args.no_tvf
    print(f"lid-driven cavity, L = {LENGTH} m, U = {LID} m/s, c = {SOUND} m/s, WCSPH"
          f"{' + transport velocity (Adami 2013, p_b = rho0 c^2)' if tvf else ''}, Morris "
          f"no-slip walls; centrelines against Ghia et al. 1982 averaged over the last "
          f"{AVERAGE} s of {args.t_end} s; errors / U")
    print(f"{'Re':>6}{'n':>5}{'u max':>8}{'at y':>7}{'u rms':>8}{'v max':>8}{'at x':>7}"
          f"{'v rms':>8}{'dKE/KE':>9}{'steps':>7}{'wall [s]':>9}")
    results = {}
    for re in args.re:
        for n in args.n:
            t0 = time.perf_counter()
            res = run(n, re, args.t_end, tvf)
            results[(re, n)] = res
            print(f"{re:6g}{n:5d}{100 * res['u_max']:7.2f}%{res['u_at']:7.3f}"
                  f"{100 * res['u_rms']:7.2f}%{100 * res['v_max']:7.2f}%{res['v_at']:7.3f}"
                  f"{100 * res['v_rms']:7.2f}%"
                  f"{100 * res['ke_change']:8.2f}%{res['steps']:>7}"
                  f"{time.perf_counter() - t0:9.1f}", flush=True)
    plt = pyplot()
    if plt is None:
        return 0
    fig, axs = plt.subplots(1, 2 * len(args.re), figsize=(9 * len(args.re), 4), squeeze=False)
    for k, re in enumerate(args.re):
        yg, ug, xg, vg = ghia(re)
        a, b = axs[0, 2 * k], axs[0, 2 * k + 1]
        a.plot(ug, yg, "ks", ms=4, label="Ghia et al. 1982")
        b.plot(xg, vg, "ks", ms=4, label="Ghia et al. 1982")
        for n, ls in zip(args.n, ("-", "--", ":", "-."), strict=False):
            res = results[(re, n)]
            a.plot(res["prof_u"], res["line"], ls, lw=1.0, label=f"n = {n}")
            b.plot(res["line"], res["prof_v"], ls, lw=1.0, label=f"n = {n}")
        a.set_xlabel("u / U at x = L/2")
        a.set_ylabel("y / L")
        b.set_xlabel("x / L")
        b.set_ylabel("v / U at y = L/2")
        a.set_title(f"Re {re:g}", fontsize=9)
        a.legend(fontsize=6)
    path = Path(__file__).with_suffix(".png")
    if args.re != [100.0]:
        path = path.with_name("cavity_re" + "_".join(f"{re:g}" for re in args.re) + ".png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
