"""Run SPlisHSPlasH's own dam-break scenes unchanged to t = 1 s and report the cost.

    python validation/splishsplash_scenes.py [--until 1.0] [--scenes DamBreakModel_2D.json ...]

The scene files are those of the installed pysplishsplash wheel (``data/Scenes``), read with
sphkit's SPlisHSPlasH front end without any edit (not even the particle radius). For each scene
the table gives the particles, the steps, the simulated and the wall time, the mean pressure
iterations and density error, and how the run ended; a scene that needs a feature sphkit does not
have is listed with the feature the loader names. Not run in CI (minutes per scene).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

DEFAULT = ["DamBreakModel_2D.json", "DamBreakModel.json"]


def run(path, until: float) -> dict:
    from sphkit.scene.files import load_scene
    from sphkit.simulation import InstabilityError, Simulation

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scene = load_scene(path)
            sim = Simulation(scene)
        except Exception as e:
            return {"status": f"does not load: {' '.join(str(e).split())[-160:]}"}
    notes = [str(w.message)[-120:] for w in caught]
    iters, errs = [], []
    t0 = time.perf_counter()
    status = "finished"
    try:
        while sim.time < until - 1e-12:
            s = sim.step()
            iters.append(s.iterations)
            errs.append(s.density_error_avg)
    except InstabilityError as e:
        status = f"unstable: {str(e)[:120]}"
    wall = time.perf_counter() - t0
    return {"status": status, "fluid": sim.fluid.n, "boundary": sim.boundary.n, "dim": sim.dim,
            "steps": sim.step_count, "time": sim.time, "wall": wall,
            "iters": float(np.mean(iters)) if iters else float("nan"),
            "err": float(np.mean(errs)) if errs else float("nan"), "notes": notes}


def main() -> None:
    from sphkit.cli.compat import wheel_scene_folder

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--until", type=float, default=1.0, help="simulated end time [s]")
    ap.add_argument("--scenes", nargs="+", default=DEFAULT, help="scene file names")
    args = ap.parse_args()
    folder = wheel_scene_folder()
    if folder is None:
        print("pysplishsplash is not installed: its scenes are not available")
        return
    import numba

    print(f"scenes of {folder}, until t = {args.until:g} s, {numba.get_num_threads()} threads")
    print("| scene | particles (fluid + boundary) | steps | simulated s | wall s | wall s per "
          "simulated s | mean iterations | mean density error | result |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.scenes:
        r = run(folder / name, args.until)
        if "steps" not in r:
            print(f"| {name} | | | | | | | | {r['status']} |")
            continue
        print(f"| {name} | {r['fluid']} + {r['boundary']} ({r['dim']}D) | {r['steps']} | "
              f"{r['time']:.3f} | {r['wall']:.1f} | {r['wall'] / max(r['time'], 1e-12):.1f} | "
              f"{r['iters']:.2f} | {100 * r['err']:.3f} % | {r['status']} |", flush=True)
        for note in r["notes"]:
            print(f"  warning: {note}")


if __name__ == "__main__":
    main()
