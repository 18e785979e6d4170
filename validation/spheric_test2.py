"""SPHERIC Test 2: 3D dam break with a box on the floor (Kleefsman et al. 2005), water heights.

MARIN's experiment (Kleefsman, Fekken, Veldman, Iwanowski & Buchner 2005, J. Comput. Phys.
206, 363-393): a tank 3.22 m long, 1 m wide, 1 m high; water 1.228 m long and 0.55 m deep at
its far end (x > 1.992 m) is released at t = 0 and hits a box 0.161 x 0.403 x 0.161 m on the
floor (0.6635 <= x <= 0.8245 m, across the tank's middle). Reference
(``validation/data/kleefsman2005_marin_heights.csv``, which names its source and which rows it
holds): the water heights at four vertical gauges on the tank's centre line, x = 0.496 (in the
box's lee), 0.992, 1.488 and 2.638 m (in the reservoir). The pressures on the box were not found
in a usable form (only digitised curves of unclear scaling), so only the heights are compared.

Scene (sphkit axes: y up, z across, the tank's centre line at z = 0.5 m): rho0 = 1000 kg/m^3,
nu = 1e-6 m^2/s (standard viscosity), g = 9.81, DFSPH, a closed box of Akinci particles (two
layers) and the box as a static mesh (surface-sampled Akinci particles), wall pressures solved
in the PPE (``configuration.boundary.solved``: the default MLS walls pump energy into 3D flows,
validation/README.md "Dam break in 3D"), free-slip, cubic spline h = 4r, CFL step (dt_max 4 ms),
no settling. Height at a gauge: along the vertical line at the gauge, the highest point where
the fluid's kernel sum ``sum_j V_j W`` (a Shepard fluid fraction: 1 inside, about 0.5 at a free
surface) is at least 0.5, sampled every r/2 (the analogue of the VOF fraction 0.5 that Lethe's
post-processing uses); a layer thinner than about h/2 reads 0.

Run ``python validation/spheric_test2.py`` (``--r 0.025``, ``--t-end 2``). Prints the heights
at the tabulated times and the mean |h_sim - h_exp| per gauge over t <= t_end, and saves
``validation/spheric_test2.png`` when matplotlib is installed.
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from _plotting import pyplot

from sphkit.core.kernels import Kernel
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

G = 9.81
RHO0 = 1000.0
NU = 1e-6
TANK = (3.22, 1.0, 1.0)  # length x, height y, width z [m]
WATER = (1.992, 0.55)  # water from x = 1.992 m to the far wall, 0.55 m deep
BOX = ((0.6635, 0.0, 0.2985), (0.8245, 0.161, 0.7015))  # the obstacle, sphkit axes
GAUGES = (0.496, 0.992, 1.488, 2.638)  # x of the height gauges [m], at z = 0.5
DATA = Path(__file__).resolve().parent / "data" / "kleefsman2005_marin_heights.csv"
COLUMNS = {0.496: "h_x0496", 0.992: "h_x0992", 1.488: "h_x1488", 2.638: "h_x2638"}


def experiment() -> tuple[np.ndarray, dict[float, np.ndarray]]:
    """t and the heights per gauge x from ``validation/data``."""
    rows = [s for s in DATA.read_text().splitlines() if s and not s.startswith("#")]
    head = rows[0].split(",")
    d = np.array([[float(v) for v in s.split(",")] for s in rows[1:]])
    return d[:, 0], {x: d[:, head.index(c)] for x, c in COLUMNS.items()}


def _box_obj(folder: Path) -> Path:
    import trimesh

    box = trimesh.creation.box(bounds=[list(BOX[0]), list(BOX[1])])
    path = folder / "obstacle.obj"
    box.export(path)
    return path


def scene(r: float, folder: Path) -> Scene:
    """The tank, water and box of the module docstring with particle radius ``r``."""
    data = {
        "name": "spheric-test2",
        "configuration": {
            "dim": 3, "particle_radius": r, "gravity": [0.0, -G, 0.0],
            "pressure": {"method": "dfsph"},
            "time": {"dt": 1e-4, "dt_min": 1e-7, "dt_max": 4e-3},
            "boundary": {"solved": True},
            "start": {"settle": False},
        },
        "materials": [{"density0": RHO0, "viscosity": {"method": "standard", "coefficient": NU}}],
        "fluid_blocks": [{"start": [WATER[0], 0.0, 0.0], "end": [TANK[0], WATER[1], TANK[2]]}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": list(TANK), "layers": 2}],
        "meshes": [{"geometry_file": str(_box_obj(folder))}],
    }
    return Scene.model_validate(data)


class Gauges:
    """Water height along vertical lines (module docstring)."""

    def __init__(self, sim: Simulation) -> None:
        st = sim.state
        self.kernel = Kernel(st.kid, st.h, 3)
        self.h = st.h
        self.ys = np.arange(0.0, TANK[1], 0.5 * st.r)

    def __call__(self, sim: Simulation) -> np.ndarray:
        f = sim.fluid
        x = np.asarray(f["x"])
        V = np.asarray(f["m"]) / np.asarray(f["rho"])
        out = []
        for xg in GAUGES:
            near = (np.abs(x[0] - xg) < self.h) & (np.abs(x[2] - 0.5 * TANK[2]) < self.h)
            if not near.any():
                out.append(0.0)
                continue
            dx = (x[0, near] - xg) ** 2 + (x[2, near] - 0.5 * TANK[2]) ** 2
            r = np.sqrt(dx[None, :] + (self.ys[:, None] - x[1, near][None, :]) ** 2)
            s = (self.kernel.w(r) * V[near][None, :]).sum(axis=1)
            wet = np.nonzero(s >= 0.5)[0]
            out.append(float(self.ys[wet[-1]]) if len(wet) else 0.0)
        return np.array(out)


def run(sim: Simulation, t_end: float, every: float = 0.01) -> dict:
    """Step to t_end; the gauges every ``every`` seconds (at the first step past each)."""
    g = Gauges(sim)
    ts, hs = [0.0], [g(sim)]
    nxt = every
    while sim.time < t_end:
        sim.step()
        if sim.time >= nxt:
            ts.append(sim.time)
            hs.append(g(sim))
            nxt += every
    return {"t": np.array(ts), "h": np.array(hs).T, "steps": sim.step_count, "n": sim.fluid.n}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--r", type=float, nargs="+", default=[0.025], help="particle radii [m]")
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--save", type=Path, help="write the runs' gauges to this .npz")
    ap.add_argument("--load", type=Path, nargs="*", default=[],
                    help="print and plot runs saved with --save (runs nothing)")
    args = ap.parse_args(argv)
    logging.getLogger("sphkit").setLevel(logging.ERROR)
    te, he = experiment()
    results: dict = {}
    loaded: dict = {}
    for path in args.load:
        with np.load(path) as d:
            for name in d.files:
                r, f = name.split("|")
                loaded.setdefault(float(r), {})[f] = d[name]
    with tempfile.TemporaryDirectory() as tmp:
        for r in sorted(loaded) if args.load else args.r:
            if args.load:
                o = loaded[r]
                o["n"], o["steps"], o["wall"] = (int(o["info"][0]), int(o["info"][1]),
                                                 float(o["info"][2]))
            else:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sim = Simulation(scene(r, Path(tmp)))
                t0 = time.perf_counter()
                o = run(sim, args.t_end)
                o["wall"] = time.perf_counter() - t0
                o["info"] = np.array([o["n"], o["steps"], o["wall"]])
            results[r] = o
            if args.save:
                np.savez_compressed(args.save, **{f"{q}|{f}": v[f] for q, v in results.items()
                                                  for f in ("t", "h", "info")})
            print(f"r = {r} m: {o['n']} fluid particles, {o['steps']} steps, {o['wall']:.0f} s")
            keep = te <= o["t"][-1]
            print(f"{'t':>6s}" + "".join(f"{'x=' + str(x):>16s}" for x in GAUGES)
                  + "   (sim / exp [m])")
            for k in np.nonzero(keep)[0]:
                print(f"{te[k]:6.3f}" + "".join(
                    f"{np.interp(te[k], o['t'], o['h'][i]):8.3f}/{he[x][k]:.3f}"
                    for i, x in enumerate(GAUGES)))
            err = [np.abs(np.interp(te[keep], o["t"], o["h"][i]) - he[x][keep]).mean()
                   for i, x in enumerate(GAUGES)]
            print("mean |h_sim - h_exp| [m]: " + ", ".join(
                f"x = {x}: {e:.3f}" for x, e in zip(GAUGES, err, strict=True)), flush=True)
    _plot(results, te, he)
    return 0


def _plot(results: dict, te: np.ndarray, he: dict) -> None:
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(2, 2, figsize=(12, 7))
    for i, (x, ax) in enumerate(zip(GAUGES, axes.ravel(), strict=True)):
        ax.plot(te, he[x], "ko", ms=3, label="MARIN (Kleefsman 2005)")
        for r, o in results.items():
            ax.plot(o["t"], o["h"][i], lw=1, label=f"DFSPH r = {r} m")
        ax.set_title(f"gauge at x = {x} m", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("h [m]")
        if i == 0:
            ax.legend(fontsize=7)
    path = Path(__file__).with_suffix(".png")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
