"""SPlisHSPlasH's own Jeske et al. 2023 surface tension on the 3D drop of surface_tension.py.

    python validation/jeske2023_splishsplash.py [--tests mode2 twist] [--gamma 210]
        [--R 0.04] [--r 0.0025] [--seed 0] [--amp-mode2 0.8] [--amp-twist 20]
        [--fixed-dt DT] [--relaxed FILE.npy]

Runs the drop that ``validation/surface_tension.py`` runs for ``jeske2023`` (no gravity, DFSPH,
r = 2.5 mm, h = 4r, cubic kernel, standard viscosity nu = 1e-3 m^2/s, the model's own viscosity
0, gamma = 210 (Becker's kappa 0.3, sigma_KB 8.67 N/m), the CFL step at most 0.7 x the
capillary bound of sigma_KB, or with ``--fixed-dt`` a fixed step; the lattice ball of
radius R jittered by 0.05 particle spacings, seed 0, relaxed at rest for 0.4 s) in SPlisHSPlasH
itself, through the ``pysplishsplash`` wheel in subprocesses (with the ``LD_PRELOAD`` its import
needs on Linux, as benchmarks/vs_splishsplash.py). The jittered start is the very one sphkit's
run uses (the same sampling and random offsets); SPlisHSPlasH relaxes it on its own. Then:

* ``mode2``: the relaxed ball is kicked with ``v = +-A (-x, -y, 2z)`` (``--amp-mode2``) and the
  deformation ``q = <z^2> - (<x^2> + <y^2>)/2`` is sampled over 0.8 s; the part odd in A gives
  the period (like extrema and a damped-cosine fit, the functions of surface_tension.py),
  against Rayleigh's period with sigma_KB of gamma (``Jeske2023.equivalent_sigma``);
* ``twist``: the relaxed ball is twisted, ``v = A (-y z, x z, 0)`` (``--amp-twist``), and the twist
  momentum ``T = sum m z (x v_y - y v_x)`` is sampled over 0.3 s: a liquid has no restoring force
  for this mode (T decays without a sign change), an elastic ball of shear modulus G rings with
  ``omega R / sqrt(G / rho) = 2.50``.

Prints the tables of surface_tension.py's 3D rows for the reference implementation. Results:
validation/README.md, "Jeske et al. 2023 in SPlisHSPlasH itself".
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sphkit.scene.splishsplash import wheel

HERE = Path(__file__).resolve().parent
RHO0 = 1000.0

#: the child: loads the scene, overwrites positions and velocities, runs, samples every step
RUNNER = r"""
import sys, json, tempfile
import numpy as np
import pysplishsplash as sph
cfg = json.load(open(sys.argv[1]))
base = sph.Exec.SimulatorBase()
base.init(["x", "--no-gui", "--output-dir", tempfile.mkdtemp(), "--no-cache", cfg["scene"]],
          "x")
base.initSimulation()
sim = sph.Simulation.getCurrent()
fm = sim.getFluidModel(0)
n = fm.numActiveParticles()
x0 = np.load(cfg["x"])
v0 = np.load(cfg["v"])
if n != len(x0):
    raise SystemExit(f"{n} particles for {len(x0)} positions")
X = np.asarray(fm.getFieldBuffer("position")).reshape(-1, 3)
V = np.asarray(fm.getFieldBuffer("velocity")).reshape(-1, 3)
X[:n] = x0
V[:n] = v0
m = np.array([fm.getMass(i) for i in range(n)])
rcut = cfg["rcut"]
rows = []
st = fm.getSurfaceTensionBase()
def sample():
    x = X[:n].astype(np.float64)
    v = V[:n].astype(np.float64)
    keep = np.linalg.norm(x - np.median(x, axis=0), axis=1) < rcut
    x, v, mk = x[keep], v[keep], m[keep]
    y = x - x.mean(axis=0)
    q = (y[:, 2] ** 2).mean() - 0.5 * ((y[:, 0] ** 2).mean() + (y[:, 1] ** 2).mean())
    tw = (mk * y[:, 2] * (y[:, 0] * v[:, 1] - y[:, 1] * v[:, 0])).sum()
    tm = sph.TimeManager.getCurrent()
    sp = np.linalg.norm(v, axis=1)
    rows.append([tm.getTime(), tm.getTimeStepSize(), q, tw,
                 int(st.getValueUInt(st.ITERATIONS)), sp.max(), np.sqrt((sp**2).mean()),
                 int(keep.sum())])
sample()
base.setTimeStepCB(sample)
base.runSimulation()
np.save(cfg["out"], X[:n].astype(np.float64))
json.dump(rows, open(cfg["rows"], "w"))
base.cleanup()
"""


def splishsplash_scene(gamma: float, r: float, nu: float, dt_max: float, until: float,
                       particle_file: str, fixed_dt: float = 0.0) -> dict:
    """The drop's scene in SPlisHSPlasH's format (DFSPH with its defaults, CFL step at most
    ``dt_max`` [s], or the fixed step ``fixed_dt`` > 0 [s], standard viscosity nu [m^2/s],
    surfaceTensionMethod 4 with ``gamma``)."""
    return {
        "Configuration": {
            "particleRadius": r, "gravitation": [0.0, 0.0, 0.0], "simulationMethod": 4,
            "stopAt": until, "enableVTKExport": False, "enablePartioExport": False,
            "cflMethod": 0 if fixed_dt > 0 else 1, "cflMaxTimeStepSize": dt_max,
            "timeStepSize": fixed_dt if fixed_dt > 0 else dt_max,
            "kernel": 0, "gradKernel": 0, "boundaryHandlingMethod": 0,
        },
        "FluidModels": [{"id": "Fluid", "particleFile": particle_file}],
        "Materials": [{
            "id": "Fluid", "density0": RHO0, "viscosityMethod": 1, "viscosity": nu,
            "surfaceTensionMethod": 4,
            "Jeske et al. 2023": {"surfaceTension": gamma, "surfaceTensionBoundary": 0.0,
                                  "surfaceTensionViscosity": 0.0,
                                  "surfaceTensionViscosityBoundary": 0.0},
        }],
    }


def run(gamma: float, r: float, nu: float, dt_max: float, until: float, x: np.ndarray,
        v: np.ndarray, rcut: float = np.inf,
        fixed_dt: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """One SPlisHSPlasH run from positions x and velocities v (N, 3): the final positions and
    the per-step rows (time, dt, q, twist momentum, surface tension CG iterations, largest and
    rms speed, particles counted); q, the speeds and the
    twist are taken over the particles within ``rcut`` [m] of the median position (particles
    thrown off the drop left out)."""
    from sphkit.io.bgeo import write_bgeo

    folder = Path(tempfile.mkdtemp(prefix="sphkit-jeske-sps-"))
    write_bgeo(folder / "drop.bgeo", {"position": x})
    scene = splishsplash_scene(gamma, r, nu, dt_max, until, str(folder / "drop.bgeo"), fixed_dt)
    (folder / "scene.json").write_text(json.dumps(scene))
    np.save(folder / "x.npy", x)
    np.save(folder / "v.npy", v)
    cfg = {"scene": str(folder / "scene.json"), "x": str(folder / "x.npy"),
           "v": str(folder / "v.npy"), "rcut": float(rcut), "out": str(folder / "out.npy"),
           "rows": str(folder / "rows.json")}
    (folder / "cfg.json").write_text(json.dumps(cfg))
    (folder / "run.py").write_text(RUNNER)
    env = wheel.subprocess_env("1")
    res = subprocess.run([sys.executable, str(folder / "run.py"), str(folder / "cfg.json")],
                         env=env, capture_output=True, text=True, timeout=1800)
    if res.returncode != 0 or not (folder / "rows.json").exists():
        raise SystemExit(f"pysplishsplash failed: {res.stderr.strip()[-500:]}")
    out = np.load(folder / "out.npy")
    rows = np.array(json.loads((folder / "rows.json").read_text()))
    shutil.rmtree(folder, ignore_errors=True)
    return out, rows


def jittered_ball(gamma: float, R: float, r: float, nu: float, dt_max: float, jitter: float,
                  seed: int) -> np.ndarray:
    """The start of surface_tension.py's drop: sphkit's sampling of ``ball_blocks`` and the
    same random offsets (``relaxed_ball`` with relax 0)."""
    sys.path.insert(0, str(HERE))
    from surface_tension import relaxed_ball

    x0, _ = relaxed_ball(gamma, R, r, 0.0, nu, name="jeske2023", solver="dfsph",
                         dt_max=dt_max, jitter=jitter, seed=seed)
    return x0


def samples(rows: np.ndarray, until: float, nsamp: int, col: int) -> tuple:
    """Column ``col`` of the per-step rows at ``nsamp + 1`` equally spaced times (the step
    nearest each), as surface_tension.py samples its runs."""
    t = rows[:, 0]
    want = np.linspace(0.0, until, nsamp + 1)
    k = np.clip(np.searchsorted(t, want), 0, len(t) - 1)
    return t[k] - t[0], rows[k, col]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tests", nargs="+", default=["mode2", "twist"],
                    choices=("mode2", "twist"))
    ap.add_argument("--gamma", type=float, default=210.0)
    ap.add_argument("--R", type=float, default=0.04)
    ap.add_argument("--r", type=float, default=0.0025)
    ap.add_argument("--nu", type=float, default=1e-3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--relax", type=float, default=0.4)
    ap.add_argument("--amp-mode2", type=float, default=0.8, help="A of the mode-2 kick [1/s]")
    ap.add_argument("--amp-twist", type=float, default=20.0, help="A of the twist [1/(m s)]")
    ap.add_argument("--fixed-dt", type=float, default=0.0,
                    help="a fixed time step [s] instead of the CFL step (cflMethod 0)")
    ap.add_argument("--relaxed", default=None,
                    help="a .npy file: the relaxed ball is read from it if it exists, else "
                         "written to it")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(HERE))
    from surface_tension import capillary_dt, damped_fit, kb_sigma, period_from_extrema

    r, gamma, nu = args.r, args.gamma, args.nu
    m = RHO0 * (2 * r) ** 3
    sigma, pint = kb_sigma("jeske2023", gamma, m, r, 3)
    dt_max = 0.7 * capillary_dt(sigma, r)
    t0 = time.perf_counter()
    cache = Path(args.relaxed) if args.relaxed else None
    if cache is not None and cache.exists():
        xr = np.load(cache)
        n = len(xr)
        print(f"  relaxed ball read from {cache}", file=sys.stderr)
    else:
        x = jittered_ball(gamma, args.R, r, nu, dt_max, 0.05, args.seed)
        n = len(x)
        xr, rows = run(gamma, r, nu, dt_max, args.relax, x, np.zeros_like(x), np.inf,
                       args.fixed_dt)
        print(f"  relax: {time.perf_counter() - t0:.0f} s, {len(rows)} steps, CG iterations "
              f"{rows[1:, 4].mean():.1f}/step", file=sys.stderr)
        if cache is not None:
            np.save(cache, xr)
    Rv = float((n * m / RHO0 * 3 / (4 * np.pi)) ** (1 / 3))
    rcut = 1.5 * Rv  # particles thrown off the drop while it relaxes are left out
    dist = np.linalg.norm(xr - np.median(xr, axis=0), axis=1)
    keep = dist < rcut
    if keep.sum() < n // 2:
        print(f"SPlisHSPlasH jeske2023: N = {n}, gamma = {gamma:g}: the drop broke up while it "
              f"relaxed ({int(keep.sum())} particles within 1.5 R of the median)")
        return 1
    y = xr - xr[keep].mean(axis=0)
    y[~keep] = 0.0  # no kick for particles off the drop
    print(f"SPlisHSPlasH jeske2023: N = {n}, R = {Rv:.4f} m, gamma = {gamma:g}, sigma_KB = "
          f"{sigma:.4g} N/m (p_int_KB {pint:.4g} Pa), dt <= {dt_max:.3g} s; relaxed "
          f"{args.relax} s: {int((~keep).sum())} particles beyond 1.5 R (left out), max |x - c|"
          f" / R of the others {dist[keep].max() / Rv:.3f}")
    if "mode2" in args.tests:
        until, nsamp, amp = 0.8, 160, args.amp_mode2
        qs = []
        for a in (amp, -amp):
            v = a * np.stack([-y[:, 0], -y[:, 1], 2 * y[:, 2]], axis=1)
            t1 = time.perf_counter()
            _, rw = run(gamma, r, nu, dt_max, until, xr, v, rcut, args.fixed_dt)
            print(f"  mode2 {a:+g}: {time.perf_counter() - t1:.0f} s, {len(rw)} steps, CG "
                  f"iterations {rw[1:, 4].mean():.1f}/step; speeds in the drop: largest "
                  f"{rw[1:, 5].max():.3g} m/s (median over steps {np.median(rw[1:, 5]):.3g}), "
                  f"rms {np.median(rw[1:, 6]):.3g} m/s (median over steps), particles counted "
                  f"{int(rw[:, 7].min())}-{int(rw[:, 7].max())}", file=sys.stderr)
            t, q = samples(rw, until, nsamp, 2)
            qs.append(q - q[0])
        q0 = 0.5 * (qs[0] - qs[1])
        omega = np.sqrt(8 * sigma / (RHO0 * Rv**3))
        fit = damped_fit(t, q0, omega)
        te = period_from_extrema(t, q0)
        tr = 2 * np.pi / omega
        print("| code | N | R/h | period Rayleigh (sigma_KB) [s] | period, extrema [s] | "
              "period, fit [s] | omega / omega_R (extrema / fit) | damping, Lamb [1/s] | "
              "fit resid |")
        print("|---|---|---|---|---|---|---|---|---|")
        print(f"| SPlisHSPlasH | {n} | {Rv / (4 * r):.2f} | {tr:.4g} | {te:.4g} | "
              f"{fit['T_fit']:.4g} | {tr / te:.2f} / {tr / fit['T_fit']:.2f} | "
              f"{fit['gamma']:.2f}, {5 * nu / Rv**2:.2f} | {fit['fit_resid']:.3f} |")
        k = np.linspace(0, len(t) - 1, 17).astype(int)
        print("q(t) / max|q|: " + ", ".join(f"{t[i]:.2f}: {q0[i] / np.abs(q0).max():+.2f}"
                                             for i in k))
    if "twist" in args.tests:
        until, nsamp, amp = 0.3, 120, args.amp_twist
        v = amp * np.stack([-y[:, 1] * y[:, 2], y[:, 0] * y[:, 2], np.zeros(n)], axis=1)
        t1 = time.perf_counter()
        _, rw = run(gamma, r, nu, dt_max, until, xr, v, rcut, args.fixed_dt)
        print(f"  twist: {time.perf_counter() - t1:.0f} s, {len(rw)} steps; speeds in the drop: "
              f"largest {rw[1:, 5].max():.3g} m/s (median over steps {np.median(rw[1:, 5]):.3g}),"
              f" rms {np.median(rw[1:, 6]):.3g} m/s", file=sys.stderr)
        t, q = samples(rw, until, nsamp, 3)
        period = period_from_extrema(t, q)
        G = RHO0 * (2 * np.pi / period * Rv / 2.50) ** 2 if np.isfinite(period) else np.nan
        cs = np.sqrt(G / RHO0)
        t_s = 2 * np.pi * Rv / (np.sqrt(38.0 / 5.0) * cs) if cs > 0 else float("nan")
        print("| code | sign changes of the twist momentum | min T / T(0) | period, extrema [s] "
              "| G [Pa] | elastic ball's spheroidal l = 2 period [s] |")
        print("|---|---|---|---|---|---|")
        print(f"| SPlisHSPlasH | {int((np.diff(np.sign(q)) != 0).sum())} | "
              f"{q.min() / q[0]:.3f} | {period:.4g} | {G:.4g} | {t_s:.4g} |")
        k = np.linspace(0, len(t) - 1, 11).astype(int)
        print("T / T(0) at t = " + ", ".join(f"{t[i]:.3f} s: {q[i] / q[0]:+.2f}" for i in k))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
