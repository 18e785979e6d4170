"""Turek & Hron 2006 CSM3: an elastic beam released under gravity, tip displacement over time.

The structural test CSM3 of Turek & Hron, "Proposal for numerical benchmarking of
fluid-structure interaction between an elastic object and laminar incompressible flow" (2006):
the beam of the FSI benchmark (length L = 0.35 m, height H = 0.02 m), without the fluid,
St. Venant-Kirchhoff material, rho_s = 1000 kg/m^3, nu_s = 0.4, mu_s = 0.5 MPa (E = 1.4 MPa),
gravity 2 m/s^2 downwards, starting at rest undeformed. The beam is attached to a rigid
cylinder in the benchmark; here (as in the SPH validations of the case) it is a 2D plane-strain
beam clamped at its left end (a fixed box over three particle layers behind x = 0, the pinned
particles' rest positions in the box), free length 0.35 m (the cylinder's surface lies at
x = 0.25 on the beam's axis, 0.2490 at its faces: the benchmark's free length is 0.350 to
0.351 m).

Measured: the displacement of point A (the tip's midpoint, x = L, y = 0), linearly
extrapolated from the mean displacements of the last two particle layers (centres at L - r and
L - 3r) to x = L; the oscillation's periods between successive downward crossings of u_y (u_x)
through the middle of its range; the mean ``(max + min) / 2`` and the amplitude
``(max - min) / 2`` of the last complete period (the benchmark's measure; the table's last
lines give them per period); the frequency 1 / (mean period). The reference
(``validation/data/turek_hron_csm3.csv``): u_x = -14.305 +- 14.305, u_y = -63.607 +- 65.160
[1e-3 m], 1.0995 Hz for both.

Models (``--methods``): ``becker2009`` (explicit corotated SPH at its bound 0.4 * 2r / c, c the
P-wave speed), ``peer2018`` (implicit corotated, the same discretisation and energy),
``kugelstadt2021`` (backward Euler with the corotated energy split into a pre-factorised
stretch solve and a volume solve; its splitting error grows with the step, so it runs at the
explicit bound by default; not among the default ``--methods``) and
``kee2023`` (backward Euler as one minimisation of the hyperelastic energy, Newton;
``--material-model``: ``stable_neo_hookean`` by default, the nearest to St. Venant-Kirchhoff
that sphkit has: both are large-strain energies with the same small-strain moduli; corotated
linear elasticity also shares them). Backward Euler damps the first mode by
``(omega dt)^2 / 2`` a step, so the implicit models run at a few times the explicit bound
(``--dt-factor``). Every model: quadratic gradient weights, rest lists of 1.5 h, particle rest
volumes (sphkit's defaults), ``--clamp`` and ``--alpha`` (zero-energy-mode control).

Run::

    PYTHONPATH=src python validation/turek_hron.py [--methods becker2009 peer2018
        kugelstadt2021 kee2023] [--layers 4 6 8] [--until 5] [--clamp face|particles]
        [--alpha 1] [--dt-factor becker2009=1 peer2018=4 kugelstadt2021=1 kee2023=10]
        [--plot validation/turek_hron.png]

``--quick``: becker2009 at 4 layers for 2.2 s (two periods; about 4 min on one loaded core).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

L, H = 0.35, 0.02
RHO, NU, MU, G = 1000.0, 0.4, 0.5e6, 2.0
E = 2 * MU * (1 + NU)  # 1.4 MPa
DATA = Path(__file__).with_name("data") / "turek_hron_csm3.csv"
DT_FACTOR = {"becker2009": 1.0, "peer2018": 4.0, "kugelstadt2021": 1.0, "kee2023": 10.0}


def reference() -> dict:
    """The benchmark's values from ``validation/data/turek_hron_csm3.csv``: {quantity: (mean,
    amplitude, frequency)} in m and Hz."""
    out = {}
    with DATA.open() as fh:
        for row in csv.DictReader(line for line in fh if not line.startswith("#")):
            out[row["quantity"]] = (float(row["mean_mm"]) * 1e-3,
                                    float(row["amplitude_mm"]) * 1e-3, float(row["frequency_hz"]))
    return out


def _explicit_dt(r: float) -> float:
    lam = 2 * MU * NU / (1 - 2 * NU)
    return 0.4 * 2 * r / math.sqrt((lam + 2 * MU) / RHO)


def scene(method: str, layers: int, dt_factor: float, clamp: str, alpha: float,
          material_model: str, max_change: float = 1e-7) -> Scene:
    """The clamped 2D beam (module docstring) with ``layers`` particles across H."""
    r = H / (2 * layers)
    elasticity = {"method": method, "youngs_modulus": E, "poisson_ratio": NU, "alpha": alpha,
                  "gradient_correction": "quadratic", "rest_support": 1.5, "clamp": clamp,
                  "fixed_boxes": [{"min": [-1.0, -1.0], "max": [0.0, 1.0]}]}
    if method == "kee2023":
        elasticity.update(solver="newton", material_model=material_model,
                          max_position_change=max_change)
    return Scene.model_validate({
        "name": "turek_hron_csm3",
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": "wcsph", "stiffness": 0.0},
                          "time": {"cfl": False, "dt": dt_factor * _explicit_dt(r),
                                   "dt_min": 1e-7}, "zsort_every": 0},
        "materials": [{"id": "beam", "density0": RHO, "elasticity": elasticity}],
        "fluid_blocks": [{"start": [-6 * r, -H / 2], "end": [L, H / 2], "material": "beam"}],
    })


def run(method: str, layers: int, until: float, dt_factor: float, clamp: str, alpha: float,
        material_model: str = "stable_neo_hookean", max_change: float = 1e-7) -> dict:
    """Simulate CSM3 to ``until`` s; the time series of point A's displacement."""
    sim = Simulation(scene(method, layers, dt_factor, clamp, alpha, material_model,
                           max_change))
    f = sim.fluid
    r = sim.scene.configuration.particle_radius
    x0 = f["solid_x0"].copy()
    last = np.flatnonzero(x0[0] > L - 2 * r)
    prev = np.flatnonzero((x0[0] > L - 4 * r) & (x0[0] < L - 2 * r))
    dt = sim.scene.configuration.time.dt
    steps = int(round(until / dt))
    ts, ua = np.zeros(steps + 1), np.zeros((steps + 1, 2))
    t0 = time.perf_counter()
    for k in range(1, steps + 1):
        sim.step()
        x = f["x"]
        # the particles are reordered only by zsort (off): fixed slots; look up by id anyway
        u_last = x[:2, last].mean(axis=1) - x0[:2, last].mean(axis=1)
        u_prev = x[:2, prev].mean(axis=1) - x0[:2, prev].mean(axis=1)
        ts[k], ua[k] = sim.time, 1.5 * u_last - 0.5 * u_prev
        if not np.all(np.isfinite(ua[k])):
            ts, ua = ts[:k + 1], ua[:k + 1]
            break
    wall = time.perf_counter() - t0
    return {"method": method, "layers": layers, "r": r, "n": f.n, "dt": dt, "steps": len(ts) - 1,
            "t": ts, "u": ua, "wall": wall}


def oscillation(t: np.ndarray, u: np.ndarray) -> dict:
    """The periods of u between successive downward crossings of the middle of its range
    (crossings closer than 0.4 s, about 0.4 of the first mode's period, are the superposed
    higher modes' and are skipped); per complete period the mean ``(max + min) / 2`` and the
    amplitude ``(max - min) / 2``. Returns the last complete period's mean and amplitude (the
    benchmark's measure), the frequency 1 / (mean period), the number of periods and the
    per-period means and amplitudes."""
    mid = 0.5 * (u.max() + u.min())
    down = np.flatnonzero((u[:-1] > mid) & (u[1:] <= mid))
    tc = t[down] + (u[down] - mid) * (t[down + 1] - t[down]) / (u[down] - u[down + 1])
    keep: list[int] = []
    for i, c in enumerate(tc):
        if not keep or c - tc[keep[-1]] > 0.4:
            keep.append(i)
    tc, idx = tc[keep], down[keep]
    nan = float("nan")
    if len(tc) < 2:
        return {"mean": nan, "amplitude": nan, "frequency": nan, "periods": 0, "means": [],
                "amplitudes": []}
    means, amps = [], []
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        seg = u[a:b + 2]
        means.append(0.5 * (seg.max() + seg.min()))
        amps.append(0.5 * (seg.max() - seg.min()))
    return {"mean": means[-1], "amplitude": amps[-1],
            "frequency": 1.0 / float(np.mean(np.diff(tc))), "periods": len(tc) - 1,
            "means": means, "amplitudes": amps}


def _order(errs: list[float], layers: list[int]) -> str:
    """Observed orders log(e_k / e_k+1) / log(n_k+1 / n_k) between successive resolutions."""
    out = []
    for k in range(len(errs) - 1):
        (e1, n1), (e2, n2) = (errs[k], layers[k]), (errs[k + 1], layers[k + 1])
        if n1 != n2 and e1 and e2 and e1 * e2 > 0:
            out.append(f"{math.log(abs(e1 / e2)) / math.log(n2 / n1):.2f}")
        else:
            out.append("n/a")
    return ", ".join(out) if out else "-"


def main() -> None:
    """Run the models and resolutions, print the tables, save the plot."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", nargs="+", default=["becker2009", "peer2018", "kee2023"],
                    choices=tuple(DT_FACTOR))
    ap.add_argument("--layers", type=int, nargs="+", default=[4, 6, 8],
                    help="particles across the thickness H")
    ap.add_argument("--until", type=float, default=5.0, help="simulated time [s]")
    ap.add_argument("--clamp", choices=("particles", "face"), default="face",
                    help="elasticity.clamp")
    ap.add_argument("--alpha", type=float, default=1.0, help="zero-energy-mode control factor")
    ap.add_argument("--dt-factor", nargs="*", default=[], metavar="METHOD=K",
                    help="time step as K times the explicit bound, per method (defaults "
                    + ", ".join(f"{k} {v:g}" for k, v in DT_FACTOR.items()) + ")")
    ap.add_argument("--material-model", choices=("corotated", "stable_neo_hookean"),
                    default="stable_neo_hookean", help="kee2023's energy density")
    ap.add_argument("--max-change", type=float, default=1e-7,
                    help="kee2023: max_position_change [m], its stopping tolerance")
    ap.add_argument("--plot", default="validation/turek_hron.png")
    ap.add_argument("--save", default="", metavar="DIR",
                    help="write each run's time series to DIR/<method>_<layers>.npz")
    ap.add_argument("--load", nargs="*", default=[], metavar="NPZ",
                    help="analyse saved runs instead of running")
    ap.add_argument("--quick", action="store_true", help="becker2009, 4 layers, 2.2 s")
    a = ap.parse_args()
    factors = dict(DT_FACTOR)
    for item in a.dt_factor:
        k, _, v = item.partition("=")
        try:
            factors[k] = float(v)
        except ValueError:
            ap.error(f"--dt-factor {item!r}: expected METHOD=K with a number K (e.g. "
                     "peer2018=4)")
        if k not in DT_FACTOR or not 0.0 < factors[k] < float("inf"):
            ap.error(f"--dt-factor {item!r}: expected one of {sorted(DT_FACTOR)} and a "
                     "positive finite factor")
    if a.quick:
        a.methods, a.layers, a.until = ["becker2009"], [4], 2.2
    ref = reference()
    print(f"Turek & Hron CSM3 (L {L} m, H {H} m, E {E / 1e6:g} MPa, nu {NU}, g {G} m/s^2, plane "
          f"strain), clamp {a.clamp}, alpha {a.alpha:g}, "
          + ("saved runs" if a.load else f"{a.until:g} s") + f"; reference: u_x "
          f"{1e3 * ref['ux'][0]:.3f} +- {1e3 * ref['ux'][1]:.3f} mm, u_y {1e3 * ref['uy'][0]:.3f}"
          f" +- {1e3 * ref['uy'][1]:.3f} mm, {ref['uy'][2]:.4f} Hz")
    print("| model | layers | particles | dt [s] | steps | periods | u_x mean [mm] | u_x ampl. "
          "[mm] | f_x [Hz] | u_y mean [mm] | u_y ampl. [mm] | f_y [Hz] | err u_x mean | "
          "err u_x ampl. | err u_y mean | err u_y ampl. | err f | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    if a.load:
        jobs = [dict(np.load(p, allow_pickle=False)) for p in a.load]
        for res in jobs:
            for k in ("method", "label"):
                res[k] = str(res[k])
            for k in ("layers", "n", "steps"):
                res[k] = int(res[k])
            for k in ("dt", "wall", "r"):
                res[k] = float(res[k])
    else:
        jobs = [(m, n) for m in a.methods for n in a.layers]
    runs: list[dict] = []
    errors: dict = {}
    per_period: list[str] = []
    for job in jobs:
        if isinstance(job, dict):
            res = job
        else:
            m, n = job
            res = run(m, n, a.until, factors[m], a.clamp, a.alpha, a.material_model,
                      a.max_change)
            res["label"] = m + (f" ({a.material_model})" if m == "kee2023" else "") + (
                f", {factors[m]:g} x bound" if factors[m] != 1 else "")
            if a.save:
                Path(a.save).mkdir(parents=True, exist_ok=True)
                np.savez(Path(a.save) / f"{m}_{n}.npz", **res)
        n, label = res["layers"], res["label"]
        runs.append(res)
        ox = oscillation(res["t"], res["u"][:, 0])
        oy = oscillation(res["t"], res["u"][:, 1])
        e = [ox["mean"] / ref["ux"][0] - 1, ox["amplitude"] / ref["ux"][1] - 1,
             oy["mean"] / ref["uy"][0] - 1, oy["amplitude"] / ref["uy"][1] - 1,
             oy["frequency"] / ref["uy"][2] - 1]
        errors.setdefault(label, []).append((n, e))
        print(f"| {label} | {n} | {res['n']} | {res['dt']:.3g} | {res['steps']} | "
              f"{oy['periods']} | {1e3 * ox['mean']:.3f} | {1e3 * ox['amplitude']:.3f} | "
              f"{ox['frequency']:.4f} | {1e3 * oy['mean']:.3f} | {1e3 * oy['amplitude']:.3f} | "
              f"{oy['frequency']:.4f} | "
              + " | ".join(f"{100 * x:+.1f} %" for x in e) + f" | {res['wall']:.0f} |",
              flush=True)
        per_period.append(f"{label}, {n} across: u_y mean per period "
                          + ", ".join(f"{1e3 * x:.3f}" for x in oy["means"]) + " mm; amplitude "
                          + ", ".join(f"{1e3 * x:.3f}" for x in oy["amplitudes"]) + " mm")
    print("\n".join(per_period))
    names = ("u_x mean", "u_x amplitude", "u_y mean", "u_y amplitude", "frequency")
    for m, rows in errors.items():
        if len(rows) < 2:
            continue
        ns = [n for n, _ in rows]
        print(f"{m}: observed order between layers {ns}: "
              + "; ".join(f"{name} {_order([e[i] for _, e in rows], ns)}"
                          for i, name in enumerate(names)))
    _plot(runs, ref, a.plot)


def _plot(runs: list[dict], ref: dict, path: str) -> None:
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for k, (ax, q) in enumerate(zip(axes, ("ux", "uy"), strict=True)):
        mean, amp, _f = ref[q]
        for res in runs:
            ax.plot(res["t"], 1e3 * res["u"][:, k], lw=0.7,
                    label=f"{res['label']}, {res['layers']} across")
        for y in (mean - amp, mean, mean + amp):
            ax.axhline(1e3 * y, color="k", lw=0.6, ls="--")
        ax.set_ylabel(f"{q} of A [mm]")
    axes[0].legend(fontsize=6, ncol=2)
    axes[1].set_xlabel("t [s]")
    axes[0].set_title("Turek & Hron CSM3 (dashed: reference mean and mean +- amplitude)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"plot: {path}")


if __name__ == "__main__":
    main()
