"""Rayleigh-Taylor instability: linear growth rate of two fluids (sphkit.multiphase).

    python validation/rayleigh_taylor.py [--radii 0.0025 0.00125] [--atwood 0.3333]
        [--viscosity 0.001] [--amplitude 0.005] [--methods dfsph] [--until 0.4]
        [--dt-max 0.00025] [--plot validation/rayleigh_taylor.png]

    python validation/rayleigh_taylor.py --study rest [--ratio 10]
        [--methods iisph dfsph pcisph pbf] [--radius 0.01] [--viscosity 0.01] [--until 5]

``growth`` (the default): a 2D box periodic along x (``configuration.periodic_x``) one
wavelength ``LAMBDA`` = 0.2 m wide, walls (Akinci boundary particles) at y = 0 and y = 2H,
H = LAMBDA / 2 = 0.1 m; heavy fluid (rho_h) over light fluid (rho_l = 1000 kg/m^3) with the
interface at y = H; Atwood number A = (rho_h - rho_l) / (rho_h + rho_l) (``--atwood``, 1/3:
2000 over 1000). The box is full, so each layer is bounded by a rigid wall at distance H.

The perturbation is the linear eigenmode's *displacement* of one wavelength, ``k = 2 pi /
LAMBDA``, amplitude ``a0`` (``--amplitude``, in units of LAMBDA) at the interface, applied to the
particles after sphkit's start-up; it is divergence-free and vanishes at the walls:

    light (y < H): xi_y = a0 cos(kx) sinh(ky) / sinh(kH),
                   xi_x = -a0 sin(kx) cosh(ky) / sinh(kH)
    heavy (y > H): xi_y = a0 cos(kx) sinh(k(2H-y)) / sinh(kH),
                   xi_x = a0 sin(kx) cosh(k(2H-y)) / sinh(kH)

The particles start at rest: nothing of the theory's rate enters the start state; linear theory
then gives eta(t) = a0 cosh(n t), the sum of the growing and the decaying mode.

Linear theory (inviscid, rigid walls at distance H on both sides; Chandrasekhar 1961 ch. X):
``n0^2 = A g k tanh(kH)`` (tanh(pi) = 0.996). **Viscous correction: none, and why.** sphkit's
``standard`` viscosity (Morris 1997, kinematic nu) is the Laplacian ``nu lap(v)`` acting within
each phase only (SPlisHSPlasH's convention): no viscous stress crosses the interface, which thus
slips freely. The inviscid eigenmode is a potential flow in each layer, ``lap(v) = 0``, with
continuous normal velocity and pressure at the interface: it solves these equations exactly, so
the model's growth rate is n0 whatever nu. Chandrasekhar's viscous correction comes from the
continuity of tangential velocity and stress at the interface (its vorticity layer), which this
model does not impose. For reference the table also gives the common approximation of that
correction for equal kinematic viscosities, ``n = sqrt(n0^2 + nu^2 k^4) - nu k^2`` (the rate of
a model whose viscosity crossed the interface). By the same argument the phase-local
viscosity damps no RT wave of any length in the continuum (each grows at ``sqrt(A g k)``,
faster the shorter); it damps the particle noise that is not a potential flow.

Measured: the Lagrangian projection of every particle's displacement from its start-up position
onto the eigenfunction, ``eta(t) = sum_i (y_i - y_i0) phi_i / sum_i phi_i^2`` with
``phi = cos(k x0) s(y0)`` (s: the sinh profile above, 1 at the interface), the interface
amplitude of the mode (uniform shifts of the column, such as its compression, do not project
onto cos kx over one period). Two rates over the first e-folding: ``n t_e`` from the time t_e
at which eta first reaches ``e a0`` (``a0 cosh(n t_e) = e a0``: ``n = acosh(e) / t_e``), and
``n fit``, the least-squares fit of ``eta(t) = C+ exp(n t) + C- exp(-n t)`` (three parameters:
the displacement start mixes both modes) from t = 0 to t_e; ``n 2nd`` is the same fit over the
second e-folding (``e a0`` to ``e^2 a0``), as a check that the rate has settled.

``rest``: light (1000 / ``--ratio``) over heavy (1000 kg/m^3) at rest, 0.3 m each, in a closed
box 0.4 m wide (``validation/multiphase.py``'s column), run for ``--until`` s: counts the
particles that end more than one and more than two layers (2r, 4r) on the wrong side of the
height that would split the column into its two phases, the largest such depth and the largest
speed. The column is stable: any particle across the interface is spurious mixing.
"""

from __future__ import annotations

import argparse
import logging
import math
import time
import warnings

import numpy as np
from scipy.optimize import least_squares

from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81
LAMBDA = 0.2
H = LAMBDA / 2
RHO_L = 1000.0
K = 2.0 * math.pi / LAMBDA


def theory(atwood: float, nu: float) -> tuple[float, float]:
    """(inviscid n0, viscous n) [1/s] of the module docstring."""
    n0 = math.sqrt(atwood * G * K * math.tanh(K * H))
    return n0, math.sqrt(n0 ** 2 + nu ** 2 * K ** 4) - nu * K ** 2


def growth_scene(method: str, r: float, atwood: float, nu: float,
                 dt_max: float = 2.5e-4) -> Scene:
    """The periodic two-layer box of the module docstring."""
    rho_h = RHO_L * (1 + atwood) / (1 - atwood)
    visc = {"method": "standard", "coefficient": nu} if nu > 0 else {"method": "none"}
    pressure: dict = {"method": method, "max_error": 0.05}
    if method == "wcsph":
        pressure = {"method": "wcsph", "stiffness": 1e5, "exponent": 7.0}
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": pressure, "periodic_x": [0.0, LAMBDA],
                          "time": {"dt_max": dt_max}},
        "materials": [{"id": "heavy", "density0": rho_h, "viscosity": visc},
                      {"id": "light", "density0": RHO_L, "viscosity": visc}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [LAMBDA, H], "material": "light"},
                         {"start": [0.0, H], "end": [LAMBDA, 2 * H], "material": "heavy"}],
        "boxes": [{"min": [0.0, 0.0], "max": [LAMBDA, 2 * H]}],
    })


def profile(y: np.ndarray) -> np.ndarray:
    """The eigenmode's vertical profile s(y), 1 at the interface, 0 at the walls."""
    return np.where(y < H, np.sinh(K * np.clip(y, 0, H)),
                    np.sinh(K * np.clip(2 * H - y, 0, H))) / math.sinh(K * H)


def fit_rate(t: np.ndarray, f: np.ndarray, guess: tuple[float, float, float]) -> float:
    """n of the least-squares fit f = C+ exp(n t) + C- exp(-n t), from ``guess`` (n, C+, C-)."""
    scale = float(np.abs(f).max())

    def res(p: np.ndarray) -> np.ndarray:
        return (p[1] * np.exp(p[0] * t) + p[2] * np.exp(-p[0] * t) - f) / scale
    return float(least_squares(res, list(guess)).x[0])


def grow(method: str, r: float, atwood: float, nu: float, a0: float,
         until: float, dt_max: float = 2.5e-4) -> dict:
    """One run: the history of eta, the measured rates (module docstring)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(growth_scene(method, r, atwood, nu, dt_max))
    f = sim.fluid
    order = f.order_by_id()
    x0 = f.view("x")[order].copy()  # start-up positions, by id
    phi = np.cos(K * x0[:, 0]) * profile(x0[:, 1])
    norm = float((phi ** 2).sum())
    # the eigenmode's displacement (module docstring), applied once
    a = a0 * LAMBDA
    light = x0[:, 1] < H
    yl = np.where(light, x0[:, 1], 2 * H - x0[:, 1])  # distance from the wall
    sx = np.cosh(K * yl) / math.sinh(K * H)
    xi_x = np.where(light, -1.0, 1.0) * a * np.sin(K * x0[:, 0]) * sx
    xi_y = a * np.cos(K * x0[:, 0]) * profile(x0[:, 1])
    xv = f.view("x")
    xv[order, 0] = np.mod(x0[:, 0] + xi_x, LAMBDA)
    xv[order, 1] = x0[:, 1] + xi_y
    ts, eta = [], []

    def record() -> None:
        o = f.order_by_id()
        ts.append(sim.time)
        eta.append(float(((f.view("x")[o, 1] - x0[:, 1]) * phi).sum() / norm))

    record()
    note, steps = "", 0
    t0 = time.perf_counter()
    try:
        while sim.time < until - 1e-9 and eta[-1] < math.e ** 2.5 * eta[0]:
            sim.step()
            steps += 1
            record()
    except InstabilityError as e:
        note = f"unstable at t = {e.stats.time:.3f} s"
    wall = time.perf_counter() - t0
    t, eta_a = np.array(ts), np.array(eta)
    out = {"n_fluid": f.n, "steps": steps, "wall": wall, "note": note, "t": t, "eta": eta_a,
           "eta0": eta_a[0]}
    n0, _ = theory(atwood, nu)
    for name, lo, hi in (("first", 1.0, math.e), ("second", math.e, math.e ** 2)):
        reached = np.nonzero(eta_a >= hi * eta_a[0])[0]
        if not len(reached):
            out[name] = float("nan")
            continue
        end = reached[0]
        start = 0 if lo == 1.0 else np.nonzero(eta_a >= lo * eta_a[0])[0][0]
        sel = slice(start, end + 1)
        e0 = eta_a[0]  # the guess: the inviscid solution a0 cosh(n0 t)
        out[name] = fit_rate(t[sel], eta_a[sel], (n0, 0.5 * e0, 0.5 * e0))
        if name == "first":  # the time eta takes to reach e a0: a0 cosh(n t_e) = e a0
            te = float(np.interp(math.e, eta_a[: end + 1] / e0, t[: end + 1]))
            out["first_te"] = math.acosh(math.e) / te
        out[name + "_t"] = (float(t[start]), float(t[end]))
    return out


def growth(methods: list[str], radii: list[float], atwood: float, nu: float, a0: float,
           until: float, plot: str | None, dt_max: float = 2.5e-4) -> None:
    n0, n = theory(atwood, nu)
    print(f"\nRayleigh-Taylor, 2D periodic, lambda = {LAMBDA} m, H = {H} m each side, "
          f"A = {atwood:.4f}, nu = {nu} m^2/s, a0 = {a0} lambda, dt_max = {dt_max} s")
    print(f"linear theory: inviscid n0 = {n0:.3f} 1/s, viscous n = {n:.3f} 1/s")
    print(f"{'solver':7s} {'r':>7s} {'lam/2r':>6s} {'N':>6s} {'steps':>6s} {'window1 [s]':>13s} "
          f"{'n fit':>7s} {'/n0-1':>7s} {'/n-1':>7s} {'n t_e':>7s} {'/n0-1':>7s} "
          f"{'n 2nd':>7s} {'/n0-1':>7s} {'wall':>6s}  note")
    runs = []
    for method in methods:
        for r in radii:
            o = grow(method, r, atwood, nu, a0, until, dt_max)
            runs.append((method, r, o))
            w1 = o.get("first_t", (float("nan"), float("nan")))
            te = o.get("first_te", math.nan)
            print(f"{method:7s} {r:7.5f} {LAMBDA / (2 * r):6.0f} {o['n_fluid']:6d} "
                  f"{o['steps']:6d} {w1[0]:5.3f}-{w1[1]:5.3f}   {o['first']:7.3f} "
                  f"{o['first'] / n0 - 1:+7.1%} {o['first'] / n - 1:+7.1%} "
                  f"{te:7.3f} {te / n0 - 1:+7.1%} "
                  f"{o['second']:7.3f} {o['second'] / n0 - 1:+7.1%} {o['wall']:6.0f}  {o['note']}",
                  flush=True)
    if plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        tt = np.linspace(0, max(o["t"][-1] for _, _, o in runs), 200)
        for method, r, o in runs:
            ax.semilogy(o["t"], o["eta"] / o["eta0"], label=f"{method}, lambda/2r = "
                        f"{LAMBDA / (2 * r):.0f}")
        ax.semilogy(tt, np.cosh(n * tt), "k--", label=f"cosh(n t), n = {n:.2f} 1/s")
        ax.semilogy(tt, np.cosh(n0 * tt), "k:", label=f"inviscid, n0 = {n0:.2f} 1/s")
        ax.axhline(math.e, color="grey", lw=0.5)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("eta / a0")
        ax.set_title(f"Rayleigh-Taylor, A = {atwood:.3f}, nu = {nu} m^2/s")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(plot, dpi=100)
        print(f"plot: {plot}")


def rest_scene(method: str, r: float, ratio: float, nu: float) -> Scene:
    """Light over heavy at rest, validation/multiphase.py's column (module docstring)."""
    visc = {"method": "standard", "coefficient": nu}
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": method, "max_error": 0.05},
                          "time": {"dt_max": 0.002}},
        "materials": [{"id": "heavy", "density0": 1000.0, "viscosity": visc},
                      {"id": "light", "density0": 1000.0 / ratio, "viscosity": visc}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.4, 0.3], "material": "heavy"},
                         {"start": [0.0, 0.3], "end": [0.4, 0.6], "material": "light"}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.4, 0.8]}],
    })


def rest(methods: list[str], r: float, ratio: float, nu: float, until: float) -> None:
    print(f"\nlight over heavy at rest, 2D, r = {r} m, rho0 {1000 / ratio:g} over 1000, "
          f"nu = {nu} m^2/s, until {until} s")
    print(f"{'solver':7s} {'N':>5s} {'>2r':>5s} {'>4r':>5s} {'deepest [2r]':>12s} "
          f"{'vmax':>7s} {'steps':>6s} {'wall':>6s}  note")
    for method in methods:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(rest_scene(method, r, ratio, nu))
        note, steps = "", 0
        t0 = time.perf_counter()
        try:
            while sim.time < until - 1e-9:
                sim.step()
                steps += 1
        except InstabilityError as e:
            note = f"unstable at t = {e.stats.time:.3f} s"
        wall = time.perf_counter() - t0
        f = sim.fluid
        y = f.view("x")[:, 1]
        heavy = f["phase"] == 0
        nh = int(heavy.sum())
        ys = np.sort(y)
        split = 0.5 * (ys[nh - 1] + ys[nh])
        depth = np.concatenate([y[heavy] - split, split - y[~heavy]])
        deep = float(depth.max(initial=0.0)) / (2 * r)
        vmax = float(np.sqrt((f["v"] ** 2).sum(axis=0)).max())
        print(f"{method:7s} {f.n:5d} {int((depth > 2 * r).sum()):5d} "
              f"{int((depth > 4 * r).sum()):5d} {deep:12.2f} {vmax:7.4f} {steps:6d} "
              f"{wall:6.0f}  {note}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", choices=["growth", "rest"], default="growth")
    ap.add_argument("--methods", nargs="+", default=None)
    ap.add_argument("--radii", nargs="+", type=float, default=[0.0025, 0.00125])
    ap.add_argument("--atwood", type=float, default=1.0 / 3.0)
    ap.add_argument("--viscosity", type=float, default=None,
                    help="kinematic nu [m^2/s] (growth: 1e-3, rest: 0.01)")
    ap.add_argument("--amplitude", type=float, default=0.005, help="a0 in units of lambda")
    ap.add_argument("--until", type=float, default=None, help="growth: 0.4 s, rest: 5 s")
    ap.add_argument("--ratio", type=float, default=10.0)
    ap.add_argument("--radius", type=float, default=0.01)
    ap.add_argument("--plot", default=None, help="growth: write eta(t) to this PNG")
    ap.add_argument("--dt-max", type=float, default=2.5e-4, help="growth: largest step [s]")
    args = ap.parse_args()
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    if args.study == "growth":
        growth(args.methods or ["dfsph"], args.radii, args.atwood,
               1e-3 if args.viscosity is None else args.viscosity, args.amplitude,
               args.until or 0.4, args.plot, args.dt_max)
    else:
        rest(args.methods or ["iisph", "dfsph", "pcisph", "pbf"], args.radius, args.ratio,
             0.01 if args.viscosity is None else args.viscosity, args.until or 5.0)


if __name__ == "__main__":
    main()
