"""Run SPlisHSPlasH's scenes unchanged (the two dam breaks, or ``--all``); report how they end.

    python validation/splishsplash_scenes.py [--until 1.0] [--scenes DamBreakModel_2D.json ...]
    python validation/splishsplash_scenes.py --all [--until 1.0] [--budget 300]
                                             [--max-particles 100000] [--json FILE]
    python validation/splishsplash_scenes.py --scenes DoubleDamBreak.json --methods 0 1 2 3 4
                                             --boundaries 0 1 2

``--methods`` and ``--boundaries`` run each scene once per ``Configuration.simulationMethod``
(0 WCSPH, 1 PCISPH, 2 PBF, 3 IISPH, 4 DFSPH) and ``boundaryHandlingMethod`` (0 Akinci
particles, 1 density maps, 2 volume maps) given, as a user who changes only that line of the
file would (a copy in a temporary folder beside a link to the wheel's models); the row's name
says the variant, e.g. ``DoubleDamBreak.json m1 b2``.

The scene files are those of the installed pysplishsplash wheel (``data/Scenes``), read with
sphkit's SPlisHSPlasH front end without any edit (not even the particle radius). For each scene
the table gives the particles, the steps, the simulated and the wall time, the mean pressure
iterations and density error, and how the run ended; a scene that needs a feature sphkit does not
have is listed with the feature the loader names. Not run in CI (minutes per scene).

Each scene runs to ``min(--until, its own stopAt when > 0)``; ``--budget S`` stops a scene after
S wall seconds of stepping ("budget at t = ...": how far it got, not a failure), and
``--max-particles N`` skips scenes with more fluid particles at the start. Beyond the columns
above the table gives the fluid particles at the end (emitters add), the largest density error
and speed of the run, the fluid particles outside the scene's domain (the bounding box of all
its boundaries -- boxes, every mesh at its start pose, emitter housings -- widened by
``--margin`` kernel supports h, open above against gravity; at the end and the most at any step:
fluid that leaked through a wall or fell beside it), and for scenes with rigid bodies how many
bodies' centres are outside that box (closed above: a body thrown away) at the end; "open":
the scene has no container (no box, no static mesh with the fluid inside), only obstacles the
fluid may fall off by design. The step's own stability guard (:mod:`sphkit.simulation`) stops
a leaking run itself ("unstable: ... left the domain") in scenes with a container, unless an
emitter reuses particles.
``--json FILE`` appends one line per scene.
"""

from __future__ import annotations

import argparse
import itertools
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

DEFAULT = ["DamBreakModel_2D.json", "DamBreakModel.json"]


def stop_at(path: Path) -> float | None:
    """The scene file's own ``Configuration.stopAt`` when it is > 0, else None."""
    try:
        v = float(json.loads(path.read_text()).get("Configuration", {}).get("stopAt", -1))
    except (ValueError, TypeError, AttributeError):
        return None
    return v if v > 0 else None


def scene_box(sim) -> tuple[np.ndarray, np.ndarray] | None:
    """The bounding box (lo, hi) of all of the scene's boundaries: boxes, every mesh at its
    start pose (static walls and bodies), emitter housings; None when it has none."""
    from sphkit.world.meshes import SceneMeshes

    scene, dim = sim.scene, sim.dim
    lo, hi = [], []
    for box in scene.boxes:
        lo.append(np.asarray(box.min, float)[:dim])
        hi.append(np.asarray(box.max, float)[:dim])
    meshes = SceneMeshes(scene)
    for k in range(len(scene.meshes)):
        b = meshes.mesh(k).bounds
        lo.append(b[0, :dim])
        hi.append(b[1, :dim])
    for em, cfg in zip(sim.emitters, scene.emitters, strict=True):
        if cfg.housing:
            b = em.housing_mesh().bounds
            lo.append(b[0, :dim])
            hi.append(b[1, :dim])
    if not lo:
        return None
    return np.min(lo, axis=0), np.max(hi, axis=0)


def has_container(scene) -> bool:
    """Whether the scene holds fluid in a container (a box, or a static mesh with ``invert``);
    without one, fluid falling off its obstacles (or out of emitters) is no leak."""
    from sphkit.world.walls import moving_meshes

    bodies = moving_meshes(scene)
    return bool(scene.boxes) or any(m.invert for k, m in enumerate(scene.meshes)
                                    if k not in bodies)


def outside(x: np.ndarray, box) -> int:
    """Points of ``x`` ((dim, N)) outside ``box`` (lo, hi); 0 without a box."""
    if box is None or x.shape[1] == 0:
        return 0
    lo, hi = box
    return int(np.count_nonzero(np.any((x < lo[:, None]) | (x > hi[:, None]), axis=0)))


def run(path: Path, until: float, budget: float = float("inf"),
        max_particles: int | None = None, margin: float = 3.0) -> dict:
    """Load, build and step one scene; the report's fields (see the module docstring)."""
    from sphkit.scene.files import load_scene
    from sphkit.simulation import InstabilityError, Simulation

    own = stop_at(path)
    end = min(until, own) if own is not None else until
    t_build = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scene = load_scene(path)
            sim = Simulation(scene)
        except Exception as e:
            msg = " ".join(str(e).split()).split("': ", 1)[-1]  # without the file's path
            return {"status": f"does not load: {msg[:160]}"}
    build = time.perf_counter() - t_build
    notes = [str(w.message)[-120:] for w in caught]
    n0 = sim.fluid.n
    if max_particles is not None and n0 > max_particles:
        return {"status": f"skipped: {n0} fluid particles > --max-particles {max_particles}"}
    box = scene_box(sim)
    fluid_box = None
    if box is not None:
        pad = margin * sim.state.h
        box = (box[0] - pad, box[1] + pad)
        fluid_box = (box[0].copy(), box[1].copy())  # open above, as the step's guard
        g = np.asarray(sim.state.gravity, float)
        if np.any(g):
            up = int(np.argmax(np.abs(g)))
            if g[up] < 0:
                fluid_box[1][up] = np.inf
            else:
                fluid_box[0][up] = -np.inf
    iters, errs, errs_max = [], [], []
    vmax, left_max = 0.0, 0
    t0 = time.perf_counter()
    status = "finished"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            while sim.time < end - 1e-12:
                if time.perf_counter() - t0 > budget:
                    status = f"budget at t = {sim.time:.3f} s"
                    break
                s = sim.step()
                iters.append(s.iterations)
                errs.append(s.density_error_avg)
                errs_max.append(s.density_error_max)
                vmax = max(vmax, s.max_velocity)
                left_max = max(left_max, outside(sim.state.fluid["x"], fluid_box))
        except InstabilityError as e:
            status = f"unstable: {' '.join(str(e).split())[:400]}"
        except Exception as e:  # reported, not raised: the sweep goes on
            status = f"exception: {type(e).__name__}: {' '.join(str(e).split())[:300]}"
    notes += [f"(run) {str(w.message)[-160:]}" for w in caught]
    wall = time.perf_counter() - t0
    f = sim.fluid
    x = f["x"]
    bodies, bodies_out = 0, 0
    for b in sim.rigid.bodies:
        c = np.asarray(b.stats()["position"], float)[: sim.dim]
        bodies += 1
        if box is not None and (np.any(c < box[0]) or np.any(c > box[1])):
            bodies_out += 1
    finite = np.all(np.isfinite(x), axis=0) if f.n else np.zeros(0, bool)
    ext = ([x[:, finite].min(axis=1).tolist(), x[:, finite].max(axis=1).tolist()]
           if finite.any() else None)
    return {"status": status, "fluid0": n0, "fluid": f.n, "boundary": sim.boundary.n,
            "dim": sim.dim, "steps": sim.step_count, "time": sim.time, "end": end,
            "wall": wall, "build": build,
            "iters": float(np.mean(iters)) if iters else float("nan"),
            "err": float(np.mean(errs)) if errs else float("nan"),
            "err_max": float(np.max(errs_max)) if errs_max else float("nan"),
            "vmax": vmax, "left": outside(x, fluid_box), "left_max": left_max,
            "box": None if box is None else [box[0].tolist(), box[1].tolist()],
            "container": has_container(sim.scene),
            "fluid_extent": ext, "bodies": bodies, "bodies_out": bodies_out, "notes": notes}


HEADER = ("| scene | particles (fluid + boundary) | steps | simulated s | wall s | wall s per "
          "simulated s | mean iterations | mean density error | result | fluid at end | "
          "max density error | largest speed m/s | fluid outside the domain (end / most) | "
          "bodies outside |")


def row(name: str, r: dict) -> str:
    """The scene's table row."""
    if "steps" not in r:
        return f"| {name} | | | | | | | | {r['status']} | | | | | |"
    bodies = f"{r['bodies_out']} of {r['bodies']}" if r["bodies"] else ""
    left = "no walls" if r["box"] is None else f"{r['left']} / {r['left_max']}"
    if r["box"] is not None and not r.get("container", True):
        left = f"open (no container): {left}"
    return (f"| {name} | {r['fluid0']} + {r['boundary']} ({r['dim']}D) | {r['steps']} | "
            f"{r['time']:.3f} | {r['wall']:.1f} | {r['wall'] / max(r['time'], 1e-12):.1f} | "
            f"{r['iters']:.2f} | {100 * r['err']:.3f} % | {r['status']} | {r['fluid']} | "
            f"{100 * r['err_max']:.2f} % | {r['vmax']:.3g} | {left} | {bodies} |")


def variant(folder: Path, name: str, method: int | None, boundary: int | None,
            tmp: Path, kernel: int | None = None, radius: float | None = None,
            settings: list[tuple[str, object]] | None = None) -> Path:
    """The scene ``name`` with its ``simulationMethod`` / ``boundaryHandlingMethod`` /
    ``kernel`` and ``gradKernel`` replaced, its ``particleRadius`` scaled by ``radius`` (None:
    the file's own) and each ``(path, value)`` of ``settings`` set (``Configuration.DFSPH.
    maxError``; every material's with ``Materials[*].``), written to ``tmp/Scenes`` beside a
    link to the wheel's models."""
    if method is None and boundary is None and kernel is None and radius is None and not settings:
        return folder / name
    data = json.loads((folder / name).read_text())
    for path, value in settings or []:
        keys = path.split(".")
        targets = [data]
        for key in keys[:-1]:
            if key.endswith("[*]"):
                targets = [t for o in targets for t in o.get(key[:-3], [])]
            else:
                targets = [o.setdefault(key, {}) for o in targets]
        for t in targets:
            t[keys[-1]] = value
    cfg = data.setdefault("Configuration", {})
    if method is not None:
        cfg["simulationMethod"] = method
    if boundary is not None:
        cfg["boundaryHandlingMethod"] = boundary
    if kernel is not None:
        cfg["kernel"] = cfg["gradKernel"] = kernel
    if radius is not None:
        cfg["particleRadius"] = radius * cfg.get("particleRadius", 0.025)
    scenes = tmp / "Scenes"
    scenes.mkdir(exist_ok=True)
    models = tmp / "models"
    if not models.exists():
        models.symlink_to(folder.parent / "models", target_is_directory=True)
    tag = abs(hash(json.dumps(settings))) % 10**8 if settings else 0
    out = scenes / f"m{method}_b{boundary}_k{kernel}_r{radius}_s{tag}_{name}"
    out.write_text(json.dumps(data, indent=1))
    return out


def main() -> None:
    from sphkit.cli.compat import wheel_scene_folder

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--until", type=float, default=1.0,
                    help="simulated end time [s] (a scene's own stopAt when earlier)")
    ap.add_argument("--scenes", nargs="+", default=DEFAULT, help="scene file names")
    ap.add_argument("--all", action="store_true", help="every scene of the wheel")
    ap.add_argument("--budget", type=float, default=float("inf"),
                    help="wall seconds of stepping per scene")
    ap.add_argument("--max-particles", type=int, default=None,
                    help="skip scenes with more fluid particles at the start")
    ap.add_argument("--margin", type=float, default=3.0,
                    help="the domain's margin around the boundaries' bounding box [h]")
    ap.add_argument("--json", type=Path, default=None, help="append one JSON line per scene")
    ap.add_argument("--methods", type=int, nargs="+", default=[None], choices=range(7),
                    help="run each scene with these simulationMethod values")
    ap.add_argument("--boundaries", type=int, nargs="+", default=[None], choices=range(3),
                    help="run each scene with these boundaryHandlingMethod values")
    ap.add_argument("--kernels", type=int, nargs="+", default=[None], choices=range(5),
                    help="run each scene with these kernel (and gradKernel) values")
    ap.add_argument("--radius-scales", type=float, nargs="+", default=[None],
                    help="run each scene with its particleRadius times these factors")
    ap.add_argument("--set", nargs="+", default=[], metavar="PATH=JSON",
                    help="set these fields in each scene (Configuration.cflMethod=0, "
                         "Materials[*].viscosityMethod=6; the value is JSON)")
    args = ap.parse_args()
    settings = []
    for item in args.set:
        path, sep, value = item.partition("=")
        try:
            settings.append((path, json.loads(value)))
        except json.JSONDecodeError:
            ap.error(f"--set {item!r}: expected PATH=JSON (a number, true, \"text\", ...)")
        if not sep or not path:
            ap.error(f"--set {item!r}: expected PATH=JSON")
    if not (args.until > 0 and args.budget > 0 and args.margin >= 0
            and all(rs is None or rs > 0 for rs in args.radius_scales)):
        ap.error("--until, --budget and --radius-scales must be positive, --margin not "
                 "negative")
    folder = wheel_scene_folder()
    if folder is None:
        print("pysplishsplash is not installed: its scenes are not available")
        return
    import numba

    names = sorted(p.name for p in folder.glob("*.json")) if args.all else args.scenes
    print(f"scenes of {folder}, until t = {args.until:g} s, {numba.get_num_threads()} threads")
    print(HEADER)
    print("|---" * HEADER.count(" | ") + "|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            for m, b, k, rs in itertools.product(args.methods, args.boundaries, args.kernels,
                                                 args.radius_scales):
                path = variant(folder, name, m, b, Path(tmp), k, rs, settings)
                label = name + "".join(f" {key}{v:g}" for key, v in
                                       (("m", m), ("b", b), ("k", k), ("r x", rs))
                                       if v is not None) + "".join(f" {x}" for x in args.set)
                r = run(path, args.until, args.budget, args.max_particles, args.margin)
                print(row(label, r), flush=True)
                for note in r.get("notes", []):
                    print(f"  warning: {note}")
                if args.json is not None:
                    with args.json.open("a") as fh:
                        fh.write(json.dumps({"scene": label, **r}) + "\n")


if __name__ == "__main__":
    main()
