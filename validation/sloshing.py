"""2D sloshing in a swaying rectangular tank against linear potential flow (Faltinsen 1978;
Faltinsen & Timokha 2009, "Sloshing", Ch. 5: the modal solution of forced sway).

A tank of inner length L = 1 m, filled to depth h = 0.5 m with water at rest (rho0 = 1000
kg/m^3, nu = 1e-6 m^2/s, g = 9.81 m/s^2), moves horizontally from rest with the displacement

    eta(t) = A (1 - cos(omega t)),  eta' = A omega sin(omega t),  eta'' = A omega^2 cos(omega t)

(it starts at rest with a finite acceleration: no impulsive start). The measure is the
free-surface elevation at the left wall.

Linear theory (incompressible, inviscid, irrotational, small amplitude; tank frame, s = x - the
left wall in [0, L], k_n = n pi / L). The surface ``zeta(s, t) = sum_n beta_n(t) cos(k_n s)``;
the frame's acceleration enters the dynamic free-surface condition as ``s eta''(t)``, whose
cosine series on [0, L] has the coefficients ``-4 / (L k_n^2)`` (odd n; 0 for even n), so each
odd mode is a forced oscillator

    beta_n'' + omega_n^2 beta_n = (omega_n^2 / g) (4 / (L k_n^2)) eta''(t),
    omega_n^2 = g k_n tanh(k_n h),

and from rest, with eta'' = A omega^2 cos(omega t),

    beta_n(t) = F_n / (omega_n^2 - omega^2) (cos(omega t) - cos(omega_n t)),
    F_n = (omega_n^2 / g) (4 / (L k_n^2)) A omega^2:

a forced part at the tank's frequency and a free part at each natural frequency, as large as
the forced one in mode 1 (no damping in the theory). Quasi-static check: sum_n 4 / (L k_n^2)
over odd n is L / 2, the wall rises by eta'' L / (2 g), the tilted plane's. The measured
elevation is a weighted mean over a strip at the wall (below), so the theory is averaged with
the same weight (each mode by its weighted mean of cos(k_n s), :func:`strip_factor`); 200 odd
modes.

SPH measure: the strip s < W2 at the wall weighted by phi(s) (1 to W1 = 0.05 m, a cos^2 ramp
to 0 at W2 = 0.15 m, in the tank's frame), ``Z(t) = sum_i V0_i phi(s_i) / int phi ds``: the
weighted mean height of the fluid over the strip from the particles in it (their rest volumes;
no surface detection; the ramp keeps a column of particles crossing the strip's edge from
jumping the sum). The elevation is its change since t = 0, antisymmetric part:
``zeta_w = ((Z_left(t) - Z_left(0)) - (Z_right(t) - Z_right(0))) / 2`` (the right wall's strip
mirrored). Sway excites only the odd modes, antisymmetric about the centre, so the theory's
zeta_w is the left wall's; the symmetric part that this removes is what the particles'
packing presumably does at both walls alike (the left strip alone drifts below the theory,
validation/README.md) and the even modes of second order. Column ``top``: the
highest particle's top within 2 spacings of the left wall against the theory at s = 0 (a
wave-probe measure; run-up along the wall and splashes spike it).
Peak: the largest |zeta_w| of the run against the theory's.

Amplitude and phase: a least-squares fit of zeta_w(t) over the run to ``c0 + a cos(omega t) + b
sin(omega t) + e^(-gamma t) (p cos(W t) + q sin(W t))`` (W and gamma by a grid search, W in
steps of 0.2 % of omega_1, gamma of 0.025 1/s; the rest linear): the forced response's amplitude
sqrt(a^2 + b^2) against the theory's ``sum_n F_n s_n / (omega_n^2 - omega^2)`` (s_n the strip
factor), its phase atan2(b, a) (theory 0: in phase with the acceleration below resonance), the
first mode's frequency W against omega_1, its amplitude sqrt(p^2 + q^2) against the theory's
free part (mostly mode 1) and its decay rate gamma (theory 0; with free-slip walls the fluid's
viscosity damps mode 1 at 2 nu k_1^2 = 2e-5 1/s, so what the fit finds is numerical dissipation;
the fit's grid is 0.025 1/s). Also the RMS of zeta_sim - zeta_theory over the run, over the
theory's largest |zeta|.

Setup: a box of boundary particles (``boxes``, 2 layers, open top, walls to h + 0.3 m),
Akinci walls, free-slip (the standard viscosity without its wall term), cubic spline, h = 4r.
The tank moves through the API, as the upper plate of ``validation/couette.py``: after every
step the wall particles are placed at x0 + eta(t) with velocity eta'(t) (``state.boundary``,
``x`` and ``v``; the solvers' divergence and density terms read the wall velocity) and the
boundary grid is rebuilt. sphkit has no scene-level way to prescribe a time-varying wall
motion: a kinematic rigid body moves with a constant velocity and angular velocity, animation
fields set fluid particles only. ``--frame tank``: the same problem in the tank's frame (walls
at rest, gravity (-eta''(t), -g)), exactly equivalent for a rigid translation; a cross-check of
the moving walls.

Solvers: DFSPH and IISPH (SPlisHSPlasH's tolerances, CFL step clamped to dt_max = 2 ms), WCSPH
(Tait, c = 10 sqrt(g h), 1 % compression at the floor; ``boundary.symmetric``: the wall term
V_b k_i, which does no work; with the default mirrored wall term it was unstable in this tank,
also at rest, see validation/README.md). Start: sphkit's default (hydrostatic,
relaxed; WCSPH settles before t = 0).

Cases (``--cases``): ``off`` omega = 0.7 omega_1, A = 0.02 m (forced response 2.4 cm in the
strip, crests to 4.7 cm with the free part, k_1 zeta 0.07-0.15: linear to 0.5-2 % in the
first harmonic); ``near`` omega = 0.9
omega_1, A = 0.005 m (forced 2.5 cm, the free and forced parts beat with period
2 pi / (omega_1 - omega) = 10 T_1: linear theory's limit is amplitude growth at resonance,
which damping and nonlinearity cap in a real tank).

Run ``python validation/sloshing.py`` (``--per-l 30 60 120`` particles along L, ``--solvers
dfsph iisph wcsph``, ``--periods`` of the forcing (4), ``--quick``: DFSPH at 30 and 60,
``--save DIR`` / ``--load FILES`` the runs' time series). It prints the table and saves
``validation/sloshing.png`` when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81  # [m/s^2]
RHO0 = 1000.0  # [kg/m^3]
NU = 1e-6  # kinematic viscosity of water [m^2/s]
LENGTH = 1.0  # tank's inner length L [m]
DEPTH = 0.5  # still-water depth h [m]
W1, W2 = 0.05, 0.15  # the strip at the wall: weight 1 to W1, ramp to 0 at W2 [m]
AREA = 0.5 * (W1 + W2)  # int phi ds [m]
MODES = 200  # odd modes of the theory
SOLVERS = ("dfsph", "iisph", "wcsph")
#: case: (omega / omega_1, amplitude A [m])
CASES = {"off": (0.7, 0.02), "near": (0.9, 0.005)}


def natural(n: np.ndarray | int) -> np.ndarray:
    """omega_n [rad/s] of the tank: omega_n^2 = g k_n tanh(k_n h), k_n = n pi / L."""
    k = np.asarray(n, float) * math.pi / LENGTH
    return np.sqrt(G * k * np.tanh(k * DEPTH))


OMEGA1 = float(natural(1))


def motion(t: float, omega: float, amp: float) -> tuple[float, float, float]:
    """The tank's displacement, velocity and acceleration at t (module docstring)."""
    return (amp * (1.0 - math.cos(omega * t)), amp * omega * math.sin(omega * t),
            amp * omega**2 * math.cos(omega * t))


def window(s: np.ndarray) -> np.ndarray:
    """The strip's weight phi(s): 1 for s <= W1, a cos^2 ramp to 0 at s = W2, 0 beyond."""
    u = np.clip((np.asarray(s, float) - W1) / (W2 - W1), 0.0, 1.0)
    return np.cos(0.5 * math.pi * u) ** 2


def strip_factor(k: np.ndarray) -> np.ndarray:
    """The weighted mean of cos(k s) over the strip, int phi cos(k s) ds / int phi ds (trapezoid
    rule on 4001 points)."""
    s = np.linspace(0.0, W2, 4001)
    phi = window(s)
    return np.trapezoid(phi[None, :] * np.cos(np.outer(k, s)), s, axis=1) / np.trapezoid(phi, s)


def theory(t: np.ndarray, omega: float, amp: float, at_wall: bool = False
           ) -> tuple[np.ndarray, float, float]:
    """Linear theory's elevation at the left wall, zeta_w(t) [m] (the strip's weighted mean;
    ``at_wall``: at s = 0), its forced amplitude (coefficient of cos(omega t)) and its mode-1
    free amplitude (coefficient of -cos(omega_1 t)) (module docstring)."""
    n = np.arange(1, 2 * MODES, 2)
    k = n * math.pi / LENGTH
    wn = natural(n)
    s = np.ones_like(k) if at_wall else strip_factor(k)
    c = (wn**2 / G) * 4.0 / (LENGTH * k**2) * amp * omega**2 / (wn**2 - omega**2) * s
    t = np.asarray(t, float)
    z = (c[:, None] * (np.cos(omega * t)[None, :] - np.cos(np.outer(wn, t)))).sum(axis=0)
    return z, float(c.sum()), float(c[0])


def scene(solver: str, per_l: int, dt_max: float = 2e-3, nu: float = NU) -> Scene:
    """The tank of the module docstring: ``per_l`` particles along L; ``nu`` the kinematic
    viscosity [m^2/s]."""
    r = LENGTH / (2 * per_l)
    pressure: dict = {"method": solver}
    if solver == "wcsph":
        c = 10.0 * math.sqrt(G * DEPTH)
        pressure.update(equation="tait", exponent=7.0, stiffness=RHO0 * c * c / 7.0)
    data: dict = {
        "name": f"sloshing-{solver}",
        "configuration": {
            "dim": 2, "particle_radius": r, "gravity": [0.0, -G],
            "pressure": pressure,
            "time": {"dt": 1e-4, "dt_min": 1e-7, "dt_max": dt_max},
            # WCSPH: the energy-consistent wall term (the mirrored one pumped energy into the
            # tank at rest until it blew up, validation/README.md)
            "boundary": {"symmetric": solver == "wcsph"},
        },
        "materials": [{"density0": RHO0, "viscosity": {"method": "standard",
                                                       "coefficient": nu}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [LENGTH, DEPTH]}],
        "boxes": [{"min": [0.0, 0.0], "max": [LENGTH, DEPTH + 0.3], "layers": 2,
                   "open_top": True}],
    }
    return Scene.model_validate(data)


def run(sim: Simulation, omega: float, amp: float, t_end: float, frame: str = "moving"
        ) -> dict:
    """Step to t_end moving the tank (``frame`` 'moving': the wall particles through the API;
    'tank': walls at rest, gravity (-eta'', -g)); per step t, zeta_w (antisymmetric strip
    measure), the left strip's change alone, the highest particle's top next to the left wall
    and the tank's displacement."""
    st = sim.state
    f = sim.fluid
    b = st.boundary
    bx0 = b["x"][0].copy()

    def strips(shift: float) -> tuple[float, float, float]:
        """Weighted rest volume in the strips at the left and right walls, and the top of
        the two columns of particles next to the left wall."""
        s = f["x"][0] - shift
        top = s < 4.0 * st.r
        return (float(np.dot(f["V0"], window(s))), float(np.dot(f["V0"], window(LENGTH - s))),
                float(f["x"][1][top].max() + st.r) if top.any() else 0.0)

    left0, right0, top0 = strips(0.0)
    ts, zs, zl, tops, etas = [0.0], [0.0], [0.0], [0.0], [0.0]
    if frame == "tank":
        st.gravity[0] = -motion(0.0, omega, amp)[2]
    while sim.time < t_end - 1e-12:
        sim.step()
        t = sim.time
        x, v, a = motion(t, omega, amp)
        shift = 0.0
        if frame == "moving":
            b["x"][0] = bx0 + x
            b["v"][0] = v
            sim.boundary_model.rebuild(st)
            shift = x
        else:
            st.gravity[0] = -a
        left, right, top = strips(shift)
        ts.append(t)
        zs.append(0.5 * ((left - left0) - (right - right0)) / AREA)
        zl.append((left - left0) / AREA)
        tops.append(top - top0)
        etas.append(x)
    return {"t": np.array(ts), "zeta": np.array(zs), "left": np.array(zl),
            "top": np.array(tops),
            "eta": np.array(etas), "steps": sim.step_count, "n": f.n}


def fit(t: np.ndarray, z: np.ndarray, omega: float) -> dict:
    """Least-squares fit of zeta(t) (module docstring): forced amplitude and phase [rad],
    free frequency W [rad/s], its amplitude and decay rate gamma [1/s]."""
    tu = np.linspace(t[0], t[-1], 1200)  # uniform in time: adaptive steps weigh alike
    z = np.interp(tu, t, z)
    t = tu
    best = None
    for gamma in np.linspace(0.0, 1.0, 41):
        for w in np.linspace(0.85 * OMEGA1, 1.1 * OMEGA1, 126):
            e = np.exp(-gamma * t)
            M = np.stack([np.ones_like(t), np.cos(omega * t), np.sin(omega * t),
                          e * np.cos(w * t), e * np.sin(w * t)], axis=1)
            coef, *_ = np.linalg.lstsq(M, z, rcond=None)
            res = float(np.sum((M @ coef - z) ** 2))
            if best is None or res < best[0]:
                best = (res, gamma, w, coef)
    _, gamma, w, c = best
    return {"forced": math.hypot(c[1], c[2]), "phase": math.atan2(c[2], c[1]),
            "W": float(w), "free": math.hypot(c[3], c[4]), "gamma": float(gamma),
            "mean": float(c[0])}


def simulate(solver: str, per_l: int, case: str, periods: float, frame: str = "moving",
             nu: float = NU) -> dict | str:
    """One run; an error message if it blew up."""
    ratio, amp = CASES[case]
    omega = ratio * OMEGA1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene(solver, per_l, nu=nu))
    t0 = time.perf_counter()
    try:
        out = run(sim, omega, amp, periods * 2.0 * math.pi / omega, frame)
    except InstabilityError as e:
        return f"unstable at t = {sim.time:.3f} s: {str(e).splitlines()[0]}"
    out["wall"] = time.perf_counter() - t0
    return out


def measures(o: dict, case: str) -> dict:
    """Errors of one run against the theory."""
    ratio, amp = CASES[case]
    omega = ratio * OMEGA1
    zt, forced, free = theory(o["t"], omega, amp)
    fs = fit(o["t"], o["zeta"], omega)
    return {"amp": fs["forced"] / forced - 1.0, "phase": math.degrees(fs["phase"]),
            "W": fs["W"] / OMEGA1 - 1.0, "free": fs["free"] / abs(free) - 1.0,
            "gamma": fs["gamma"],
            "rms": float(np.sqrt(np.mean((o["zeta"] - zt) ** 2)) / np.abs(zt).max()),
            "top": fit(o["t"], o["top"], omega)["forced"] / theory(o["t"][:1], omega, amp,
                                                                   at_wall=True)[1] - 1.0,
            "peak": float(np.abs(o["zeta"]).max() / np.abs(zt).max()) - 1.0,
            "forced_theory": forced, "forced_sim": fs["forced"]}


def row(key: tuple, o: dict | str) -> str:
    """One line of the table."""
    case, solver, per_l = key
    head = f"{case:5s}{solver:>7s}{per_l:5d}"
    if isinstance(o, str):
        return f"{head}  {o}"
    m = measures(o, case)
    return (f"{head}{o['n']:7d}{o['steps']:7d}{1000 * m['forced_sim']:7.2f}mm"
            f"{m['amp']:+9.1%}{m['phase']:+7.1f}d{m['W']:+8.1%}{m['free']:+9.1%}"
            f"{m['gamma']:7.2f}{m['rms']:8.1%}{m['peak']:+8.1%}{m['top']:+9.1%}{o['wall']:7.1f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--per-l", type=int, nargs="+", default=[30, 60, 120],
                    help="particles along the tank length L (default 30 60 120)")
    ap.add_argument("--solvers", nargs="+", default=list(SOLVERS))
    ap.add_argument("--cases", nargs="+", default=["off"], choices=list(CASES))
    ap.add_argument("--periods", type=float, default=4.0, help="forcing periods to run (default 4)")
    ap.add_argument("--frame", choices=("moving", "tank"), default="moving",
                    help="moving walls (default) or walls at rest under gravity (-eta'', -g)")
    ap.add_argument("--nu", type=float, default=NU,
                    help=f"kinematic viscosity [m^2/s] (default {NU:g}, water)")
    ap.add_argument("--quick", action="store_true", help="DFSPH at 30 and 60 along L")
    ap.add_argument("--save", type=Path, help="folder to write each run's time series to (.npz)")
    ap.add_argument("--load", type=Path, nargs="*", default=[],
                    help="print and plot runs saved with --save (runs nothing)")
    args = ap.parse_args(argv)
    if args.quick:
        args.solvers, args.per_l = ["dfsph"], [30, 60]
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    print(f"2D sloshing, tank L = {LENGTH} m, depth h = {DEPTH} m, omega_1 = {OMEGA1:.4f} "
          f"rad/s (T_1 = {2 * math.pi / OMEGA1:.4f} s); sway eta = A (1 - cos omega t), "
          f"{args.frame} walls (--load: the label says); elevation: weighted mean height over "
          f"the strip s < {W2} m (weight 1 to {W1} m), left minus right wall over 2; errors "
          "against linear theory: forced amplitude and phase, first mode's frequency W, "
          "free amplitude and decay gamma [1/s] (fit), rms/max, peak |zeta|, top particle's "
          "forced amplitude")
    print(f"{'case':5s}{'solver':>7s}{'L/2r':>5s}{'N':>7s}{'steps':>7s}{'forced':>9s}"
          f"{'amp err':>9s}{'phase':>8s}{'W/w1-1':>8s}{'free err':>9s}{'gamma':>7s}"
          f"{'rms/max':>8s}{'peak':>8s}{'top err':>9s}{'wall':>7s}")
    results: dict = {}
    for path in args.load:
        with np.load(path) as d:
            o = {k: d[k] for k in d.files}
        key = (str(o.pop("case")), str(o.pop("solver")), int(o.pop("per_l")))
        o.update(steps=int(o["steps"]), n=int(o["n"]), wall=float(o["wall"]))
        results[key] = o
    for key in sorted(results):
        print(row(key, results[key]), flush=True)
    cases = [] if args.load else [(case, solver, per_l) for case in args.cases
                                  for solver in args.solvers for per_l in args.per_l]
    for key in cases:
        case, solver, per_l = key
        o = simulate(solver, per_l, case, args.periods, args.frame, args.nu)
        if args.frame == "tank":  # the label of the runs in the tank's frame
            key = (case, f"{solver}/tank", per_l)
        if args.nu != NU:
            key = (key[0], f"{key[1]}/nu{args.nu:g}", per_l)
        print(row(key, o), flush=True)
        if isinstance(o, str):
            continue
        results[key] = o
        if args.save:
            args.save.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(args.save / f"{case}_{key[1].replace('/', '_')}_{per_l}.npz",
                                case=case, solver=key[1], per_l=per_l, **o)
    for case in sorted({k[0] for k in results} | set(args.cases)):
        ratio, amp = CASES[case]
        _, forced, free = theory(np.zeros(1), ratio * OMEGA1, amp)
        print(f"case {case}: omega = {ratio} omega_1, A = {amp} m; theory: forced amplitude "
              f"{1000 * forced:.2f} mm, mode-1 free {1000 * abs(free):.2f} mm")
        for solver in sorted({k[1] for k in results if k[0] == case}):
            runs = sorted((k[2], results[k]) for k in results if k[:2] == (case, solver))
            if len(runs) > 1:
                for name in ("amp", "rms"):
                    e = [abs(measures(o, case)[name]) for _, o in runs]
                    orders = [math.log(e[i] / e[i + 1]) / math.log(runs[i + 1][0] / runs[i][0])
                              for i in range(len(e) - 1) if e[i + 1] > 0]
                    print(f"  observed order of |{name} err| {solver}: "
                          + ", ".join(f"{p:.2f}" for p in orders))
    _plot(results)
    return 0


def _plot(results: dict) -> None:
    plt = pyplot()
    if plt is None:
        return
    if not results:
        return
    cases = sorted({k[0] for k in results})
    groups = {(k[0], k[1]) for k in results}
    conv = [g for g in sorted(groups) if sum(k[:2] == g for k in results) > 1]
    rows = len(cases) + bool(conv)
    fig, axes = plt.subplots(rows, 1, figsize=(11, 3.6 * rows), squeeze=False)
    for ax, case in zip(axes[:, 0], cases, strict=False):
        ratio, amp = CASES[case]
        keys = sorted(k for k in results if k[0] == case)
        t_end = max(results[k]["t"][-1] for k in keys)
        tt = np.linspace(0.0, t_end, 2000)
        ax.plot(tt, 1000 * theory(tt, ratio * OMEGA1, amp)[0], "k-", lw=1.5,
                label="linear theory (strip mean)")
        for k in keys:
            o = results[k]
            ax.plot(o["t"], 1000 * o["zeta"], lw=0.8, label=f"{k[1]} L/2r = {k[2]}")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("elevation at the left wall [mm]")
        ax.set_title(f"sway omega = {ratio} omega_1, A = {1000 * amp:g} mm", fontsize=9)
        ax.legend(fontsize=6, ncol=3)
    if conv:
        ax = axes[-1, 0]
        for (case, solver), mk in zip(conv, "ovs^dx", strict=False):
            keys = sorted(k for k in results if k[:2] == (case, solver))
            m = [measures(results[k], case) for k in keys]
            n = [k[2] for k in keys]
            ax.plot(n, [100 * abs(e["amp"]) for e in m], marker=mk, label=f"{case} {solver} "
                    "|forced amplitude error|")
            ax.plot(n, [100 * e["rms"] for e in m], marker=mk, ls=":",
                    label=f"{case} {solver} rms / max")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("particles along L")
        ax.set_ylabel("error [%]")
        ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    path = Path(__file__).with_suffix(".png")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
