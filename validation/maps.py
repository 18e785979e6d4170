"""Boundary models on mesh geometry: hydrostatic columns in a mesh tank and a dam break against a
sphere obstacle, for Akinci particles, density maps and volume maps (DFSPH).

    python validation/maps.py [--dim 2|3] [--until 2.0] [--realizations K] [--skip-dambreak]
                              [--lattice square|hexagonal] [--radius R]
                              [--pressures mirror mls hydrostatic]

1. Hydrostatic column: benchmarks/scenes/UnitBox.obj scaled to a tank of width W (mapInvert),
   water of height H starting 2r off the walls (``--lattice hexagonal``: the 2D block sampled
   on the hexagonal lattice of touching discs, ``fluid_blocks[].lattice``, in the same box),
   DFSPH (max error 0.05 %); pressures and heights averaged per particle over the last 0.5 s.
   Boundaries: Akinci particles (mirrored / one-sided pressure, and the MLS pressure of Band
   et al. 2018), density and volume maps with
   SPlisHSPlasH's boundary term and with the hydrostatic boundary pressure
   (``configuration.boundary.pressure: "hydrostatic"``, :mod:`sphkit.boundary.maps_hydrostatic`).
   Prints the pressure slope over the middle 80 % of the column as a multiple of rho0 g and its
   deviation from 1 in %; the profile error (:func:`profile_error`: the largest deviation of a
   layer-averaged pressure from rho0 g depth over the middle 80 %, layers 2r thick, the free
   surface r above the highest particle centre, in % of rho0 g H) of the layer means averaged
   over K realizations (realization k > 0 settles from the lattice jittered by up to 0.1 r;
   default K = 4 in 2D, where a layer holds ~28 particles whose static packing scatter is ~5 %
   of rho0 g H each, 3 in 3D, where single runs differ by ~1 %), with the standard error of
   the worst layer's mean ("noise") and which layer it is; realization 0 alone (the single-run
   number of earlier tables); the profile error with the free surface r above the *mean*
   height of the top particle centres (:func:`mean_surface`; the highest single particle sits
   0.3-0.8 r above them, 1-1.6 % of H in 2D and up to 4 % in 3D); the profile error of the
   pressure read as an SPH field (:func:`interpolated_pressure`, "SPH field": the particle
   pressures carry a floor-excited row-alternating mode that the pressure force does not
   feel, see validation/README.md); the mean deviation of the particles within 3r of a side
   wall ("wall columns"); the stand-off of the fluid from the floor (lowest particle height
   over the tank bottom, in r); and how many particles left the tank. Then the layer means of
   each model.
2. 3D dam break against a sphere (icosphere mesh, R = 0.1 m) in a 1 x 0.6 x 0.4 m UnitBox tank,
   maps also with the hydrostatic boundary pressure, r = 0.02 m, 1.5 s at 50 frames/s: the
   smallest distance of a fluid particle centre from the sphere centre at any frame, in R
   (below 1 means a particle inside the obstacle).

Writes ``validation/maps.png`` (pressure profiles) when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from sphkit.core.kernels import Kernel
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

UNIT_BOX = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
METHODS = ("akinci2012", "koschier2017", "bender2019")
G, RHO0 = 9.81, 1000.0


def mean_surface(x: np.ndarray, r: float) -> float:
    """The free surface r above the mean height of the top particle centres: the highest
    particle of every column 2r wide (2D) or 2r x 2r (3D), averaged over the columns that hold
    at least half the median number of particles (a bin that catches only a few particles of a
    wall row would report a low "top"). x: averaged positions (N, dim)."""
    key = np.floor(x[:, [0, 2][: x.shape[1] - 1]] / (2 * r)).astype(np.int64)
    _, col = np.unique(key, axis=0, return_inverse=True)
    col = col.ravel()
    tops = np.full(col.max() + 1, -np.inf)
    np.maximum.at(tops, col, x[:, 1])
    count = np.bincount(col)
    return float(tops[count >= 0.5 * np.median(count)].mean() + r)


def layer_errors(y: np.ndarray, p: np.ndarray, r: float,
                 surface: float | None = None) -> np.ndarray:
    """Per layer of the middle 80 % of the column (layers 2r thick, from the bottom): the mean
    deviation of the pressure from rho0 g (depth) and its standard error, as fractions of
    rho0 g H, shape (layers, 2). Depth below the free surface, by default r above the highest
    particle centre (the issue's first definition), or ``surface`` (:func:`mean_surface`)."""
    lo, top = y.min(), y.max()
    hgt = top + r - (lo - r)
    surface = top + r if surface is None else surface
    out = []
    for a in np.arange(lo + 0.1 * hgt, lo + 0.9 * hgt - 2 * r, 2 * r):
        m = (y >= a) & (y < a + 2 * r)
        if m.sum() > 2:
            e = (p[m] - RHO0 * G * (surface - y[m])) / (RHO0 * G * hgt)
            out.append((e.mean(), e.std() / np.sqrt(m.sum())))
    return np.array(out).reshape(-1, 2)


def profile_error(y: np.ndarray, p: np.ndarray, r: float, surface: float | None = None) -> float:
    """Largest deviation of the layer-averaged pressure from rho0 g (depth) over the middle 80 %
    of the column, as a fraction of rho0 g H (the issue's "pressure profile within 2 % of
    rho0 g H"); see :func:`layer_errors`."""
    return float(np.abs(layer_errors(y, p, r, surface)[:, 0]).max())


def interpolated_pressure(x: np.ndarray, p: np.ndarray, r: float) -> np.ndarray:
    """The SPH pressure field at each particle, read the way a pressure probe reads it: the
    moving-least-squares fit of a linear field ``a + b . (x_j - x_i)`` to the particle
    pressures of the fluid neighbours j (self included) with the kernel weights ``W_ij``
    (cubic spline, support 4r, equal particle volumes), evaluated at x_i (``a``). Exact for a
    linear (hydrostatic) field also where the neighbourhood is one-sided (the lowest layers of
    the 3D window lie within 4r of the floor); the zeroth-order Shepard sum
    ``sum_j p_j W_ij / sum_j W_ij`` that e.g. DualSPHysics' gauges use is biased there. The fit
    averages over about two particle rows on either side, which removes most of the
    row-alternating part of the particle pressures -- a mode the symmetric pressure force of a
    layered packing does not feel (see validation/README.md, "the odd-even row mode").
    x: averaged positions (N, dim); p: (N,)."""
    n, dim = x.shape
    kern = Kernel("cubic", 4 * r, dim)
    i, j = cKDTree(x).query_pairs(4 * r, output_type="ndarray").T
    i, j = np.concatenate([i, j, np.arange(n)]), np.concatenate([j, i, np.arange(n)])
    d = x[j] - x[i]
    w = kern.w(np.linalg.norm(d, axis=1))
    basis = np.concatenate([np.ones((len(i), 1)), d / r], axis=1)  # (pairs, dim + 1)
    m = np.zeros((n, dim + 1, dim + 1))
    np.add.at(m, i, w[:, None, None] * basis[:, :, None] * basis[:, None, :])
    rhs = np.zeros((n, dim + 1))
    np.add.at(rhs, i, (w * p[j])[:, None] * basis)
    return np.linalg.solve(m, rhs[:, :, None])[:, 0, 0]


def wall_excess(x: np.ndarray, p: np.ndarray, r: float, W: float) -> float:
    """Mean deviation of the pressure from rho0 g (depth) of the particles less than 3r from a
    side wall (tank half-width W / 2) in the middle 80 % of the column, as a fraction of
    rho0 g H. x: averaged positions (N, dim)."""
    y = x[:, 1]
    lo, top = y.min(), y.max()
    surface, hgt = top + r, top + r - (lo - r)
    side = np.abs(x[:, [0, 2][: x.shape[1] - 1]])
    m = (np.min(W / 2 - side, axis=1) < 3 * r) & (y > lo + 0.1 * hgt) & (y < lo + 0.9 * hgt)
    return float(np.mean(p[m] - RHO0 * G * (surface - y[m])) / (RHO0 * G * hgt))


def column(method: str, dim: int, until: float, cache: str, bp: str = "mirror",
           realization: int = 0, lattice: str = "square", size: tuple[float, float] | None = None,
           average: float = 0.5, radius: float | None = None) -> dict:
    """One settled column. ``realization`` k > 0 starts from the lattice jittered by up to
    0.1 r (uniform, seed k): the same column settling into another packing. ``lattice``: the
    fluid block's sampling (``fluid_blocks[].lattice``; "hexagonal" is 2D only), in the same
    block 2r off the walls. ``size``: tank width W and water height H [m] (default 0.6 x 0.5 in
    2D, 0.6 x 0.4 in 3D); pressures and positions are averaged over the last ``average`` s.
    ``radius``: particle radius r [m] (default 0.01 in 2D, 0.02 in 3D); the tank and the water
    block keep their size, so a smaller r puts more rows under the free surface."""
    r = radius or (0.01 if dim == 2 else 0.02)
    W, H = size or ((0.6, 0.5) if dim == 2 else (0.6, 0.4))
    start = [-W / 2 + 2 * r, -0.5 + 2 * r, -W / 2 + 2 * r][:dim]
    end = [W / 2 - 2 * r, -0.5 + 2 * r + H, W / 2 - 2 * r][:dim]
    scene = Scene.model_validate({
        "configuration": {
            "dim": dim, "particle_radius": r, "gravity": [0.0, -G, 0.0][:dim],
            "pressure": {"method": "dfsph", "max_error": 0.05, "max_iterations": 200},
            "time": {"dt_max": 0.002},
            "boundary": {"method": method, "map_cache_dir": cache, "pressure": bp},
        },
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": start, "end": end, "lattice": lattice}],
        "meshes": [{"geometry_file": str(UNIT_BOX), "scale": [W, 1.0, W], "invert": True}],
    })
    t0 = time.perf_counter()
    sim = Simulation(scene)
    if realization:
        x0 = sim.fluid["x"]
        x0 += np.random.default_rng(realization).uniform(-0.1 * r, 0.1 * r, x0.shape)
    sim.run(until=until - average)
    n = sim.fluid.n
    p_sum, x_sum, its = np.zeros(n), np.zeros((n, dim)), []

    def acc(s: Simulation, st) -> None:
        o = s.fluid.order_by_id()
        p_sum[:] += s.pressures[o]
        x_sum[:] += s.positions[o]
        its.append(st.iterations)

    sim.run(until=until, on_step=acc)
    p, xm = p_sum / len(its), x_sum / len(its)
    y = xm[:, 1]
    x = sim.positions
    lo, hgt = y.min(), y.max() - y.min()
    sel = (y > lo + 0.1 * hgt) & (y < lo + 0.9 * hgt)
    slope = -np.polyfit(y[sel], p[sel], 1)[0] / (RHO0 * G)
    outside = int(np.sum(np.any(np.abs(x[:, [0, 2][: dim - 1]]) >= W / 2, axis=1))
                  + np.sum(x[:, 1] <= -0.5))
    return {"n": n, "slope": slope, "dev": 100 * abs(slope - 1), "standoff": (lo + 0.5) / r,
            "profile": 100 * profile_error(y, p, r), "layers": layer_errors(y, p, r),
            "layers_ms": layer_errors(y, p, r, mean_surface(xm, r)),
            "layers_sph": (lsph := layer_errors(y, interpolated_pressure(xm, p, r), r)),
            "profile_sph": 100 * float(np.abs(lsph[:, 0]).max()),
            "wall": 100 * wall_excess(xm, p, r, W),
            "outside": outside, "its": float(np.mean(its)), "y": y, "p": p, "x": xm,
            "time": time.perf_counter() - t0}


def column_ensemble(method: str, dim: int, until: float, cache: str, bp: str,
                    realizations: int, lattice: str = "square",
                    radius: float | None = None) -> dict:
    """:func:`column` for realizations 0 .. K-1. The layer errors are averaged over the
    realizations layer by layer (layer j of each run: the same height over its floor); the
    ensemble profile error is the largest |mean|, with the standard error of that layer's mean
    (``noise``: the packing scatter, sqrt(sum of the runs' squared standard errors) / K).
    Slopes, wall excess, stand-off, iterations: means; outside: the sum; realization 0 alone is
    the single-run number of earlier tables (``profile0``)."""
    runs = [column(method, dim, until, cache, bp, k, lattice, radius=radius)
            for k in range(realizations)]
    nl = min(len(c["layers"]) for c in runs)
    lay = np.stack([c["layers"][:nl] for c in runs])  # (K, layers, 2)
    mean = lay[:, :, 0].mean(axis=0)
    se = np.sqrt((lay[:, :, 1] ** 2).sum(axis=0)) / realizations
    j = int(np.argmax(np.abs(mean)))
    lay_ms = np.stack([c["layers_ms"][:nl] for c in runs])
    mean_ms = lay_ms[:, :, 0].mean(axis=0)
    mean_sph = np.stack([c["layers_sph"][:nl] for c in runs])[:, :, 0].mean(axis=0)
    out = dict(runs[0])
    out.update({
        "profile0": runs[0]["profile"], "profile": 100 * abs(mean[j]), "noise": 100 * se[j],
        "worst": j, "layer_means": 100 * mean,
        "profile_ms": 100 * float(np.abs(mean_ms).max()), "layer_means_ms": 100 * mean_ms,
        "profile_sph": 100 * float(np.abs(mean_sph).max()), "layer_means_sph": 100 * mean_sph,
        "slope": float(np.mean([c["slope"] for c in runs])),
        "wall": float(np.mean([c["wall"] for c in runs])),
        "standoff": float(np.mean([c["standoff"] for c in runs])),
        "its": float(np.mean([c["its"] for c in runs])),
        "outside": int(sum(c["outside"] for c in runs)),
        "time": float(sum(c["time"] for c in runs)),
    })
    out["dev"] = 100 * abs(out["slope"] - 1)
    return out


def dambreak(method: str, until: float, folder: Path, bp: str = "mirror") -> dict:
    R, c, r = 0.1, np.array([0.15, -0.2, 0.0]), 0.02
    trimesh.creation.icosphere(subdivisions=4, radius=R).export(folder / "sphere.obj")
    scene = Scene.model_validate({
        "configuration": {
            "dim": 3, "particle_radius": r, "pressure": {"method": "dfsph", "max_error": 0.05},
            "boundary": {"method": method, "map_cache_dir": str(folder), "pressure": bp},
        },
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [-0.5 + 2 * r, -0.3 + 2 * r, -0.2 + 2 * r],
                          "end": [-0.1, 0.2, 0.2 - 2 * r]}],
        "meshes": [
            {"geometry_file": str(UNIT_BOX), "scale": [1.0, 0.6, 0.4], "invert": True},
            {"geometry_file": str(folder / "sphere.obj"), "translation": c.tolist()},
        ],
    })
    t0 = time.perf_counter()
    sim = Simulation(scene)
    closest: list[float] = []
    sim.run(until=until, fps=50,
            on_frame=lambda s, k: closest.append(np.linalg.norm(s.positions - c, axis=1).min()))
    return {"n": sim.fluid.n, "closest": min(closest) / R, "frames": len(closest),
            "pushed": getattr(sim.boundary_model, "pushed", 0), "time": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--until", type=float, default=2.0, help="column: simulated time [s]")
    ap.add_argument("--dambreak-until", type=float, default=1.5)
    ap.add_argument("--skip-dambreak", action="store_true")
    ap.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    ap.add_argument("--realizations", type=int, default=None,
                    help="columns per model, from jittered lattices (default 4 in 2D, 3 in 3D)")
    ap.add_argument("--pressures", nargs="+", default=["mirror", "mls", "hydrostatic"],
                    choices=("mirror", "mls", "hydrostatic"),
                    help="column: boundary pressures to run (configuration.boundary.pressure; "
                    "'mls' with akinci2012, 'hydrostatic' with the maps)")
    ap.add_argument("--radius", type=float, default=None,
                    help="column: particle radius [m] (default 0.01 in 2D, 0.02 in 3D; the tank "
                    "and the water keep their size)")
    ap.add_argument("--lattice", default="square", choices=("square", "hexagonal"),
                    help="column: fluid block sampling (fluid_blocks[].lattice; hexagonal: 2D)")
    args = ap.parse_args()
    if args.lattice == "hexagonal" and args.dim != 2:
        ap.error(f"--lattice hexagonal needs --dim 2 (got --dim {args.dim}): the hexagonal "
                 "lattice is 2D")
    with tempfile.TemporaryDirectory() as tmp:
        k = args.realizations or (4 if args.dim == 2 else 3)
        r = args.radius or (0.01 if args.dim == 2 else 0.02)
        print(f"Hydrostatic column in a UnitBox.obj tank ({args.dim}D, r = {r} m, DFSPH, "
              f"{args.until} s, {k} realization(s), {args.lattice} lattice)")
        print("| boundary | particles | slope / rho0 g | |slope - 1| [%] | profile error "
              "[% rho0 g H] (noise) | worst layer | realization 0 | mean-surface profile error | "
              "SPH-interpolated profile error | wall columns [% rho0 g H] | "
              "stand-off [r] | outside | iterations | time [s] |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        res = {}
        runs = [(m, "mirror") for m in METHODS if m in args.methods]
        if "akinci2012" in args.methods:
            runs.insert(1, ("akinci2012", "mls"))
        runs += [(m, "hydrostatic") for m in METHODS[1:] if m in args.methods]
        runs = [(m, bp) for m, bp in runs if bp in args.pressures]
        layers = {}
        for m, bp in runs:
            c = column_ensemble(m, args.dim, args.until, tmp, bp, k, args.lattice, args.radius)
            name = m + {"mls": " + MLS pressure (Band 2018)", "mirror": "",
                        "hydrostatic": " + hydrostatic wall pressure"}[bp]
            res[name] = c
            layers[name] = (c["layer_means"], c["layer_means_ms"], c["layer_means_sph"])
            print(f"| {name} | {c['n']} | {c['slope']:.3f} | {c['dev']:.1f} | "
                  f"{c['profile']:.2f} ({c['noise']:.2f}) | {c['worst'] + 1} of "
                  f"{len(c['layer_means'])} | {c['profile0']:.2f} | {c['profile_ms']:.2f} | "
                  f"{c['profile_sph']:.2f} | "
                  f"{c['wall']:+.1f} | {c['standoff']:.2f} | {c['outside']} | "
                  f"{c['its']:.1f} | {c['time']:.0f} |", flush=True)
        print("\nLayer means [% rho0 g H], bottom to top of the middle 80 %:")
        for name, (lm, lms, lsph) in layers.items():
            print(f"  {name}: " + " ".join(f"{v:+.1f}" for v in lm))
            print("    mean surface: " + " ".join(f"{v:+.1f}" for v in lms))
            print("    SPH-interpolated: " + " ".join(f"{v:+.1f}" for v in lsph))
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            fig, ax = plt.subplots(figsize=(5, 4))
            for m, c in res.items():
                ax.plot(c["p"] / 1000.0, c["y"], ".", ms=2, label=m)
            ax.set_xlabel("pressure [kPa]")
            ax.set_ylabel("height [m]")
            ax.legend()
            fig.savefig(Path(__file__).with_name("maps.png"), dpi=120)
        except ImportError:
            pass
        if args.skip_dambreak:
            return
        print(f"\n3D dam break against a sphere mesh (R = 0.1 m), {args.dambreak_until} s")
        print("| boundary | particles | frames | min distance / R | pushed out | time [s] |")
        print("|---|---|---|---|---|---|")
        druns = [(m, "mirror") for m in args.methods]
        druns += [(m, "hydrostatic") for m in METHODS[1:] if m in args.methods]
        for m, bp in druns:
            folder = Path(tmp) / f"{m}-{bp}"
            folder.mkdir()
            d = dambreak(m, args.dambreak_until, folder, bp)
            name = m + (" + hydrostatic wall pressure" if bp == "hydrostatic" else "")
            print(f"| {name} | {d['n']} | {d['frames']} | {d['closest']:.3f} | {d['pushed']} | "
                  f"{d['time']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
