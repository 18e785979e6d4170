"""Where sphkit's memory goes in a step: a byte table per fluid particle (measured, not timed).

    python benchmarks/memory.py [--radius 0.0125] [--start 0] [--steps 3] [--solver dfsph]
                                [--scene SCENE.json] [--precision float64|float32]

Builds the benchmark dam break (``scenes/dambreak_<solver>.json``, SPlisHSPlasH's DamBreakModel
setup, Akinci walls) at the given particle radius (0.0125 m: 59,319 fluid particles; 0.00625 m:
493,039), steps to t = ``--start`` and ``--steps`` steps more (the fluid reaches the walls at
about 0.1 s: before that it has no boundary neighbours) and measures one more step:

* **live arrays**: every NumPy array reachable from the simulation object (particle fields with
  their spare capacity, neighbour lists, cached pair gradients, boundary grid, MLS coefficients,
  solver fields) at the entry of the pressure solve (the step's fullest moment: the pair
  gradients are alive), by owner, in bytes per fluid particle;
* **peak resident memory per phase** of the measured step (the kernel's high-water mark, reset
  before every phase through ``/proc/self/clear_refs``, Linux only): the neighbour search, the
  densities with the pair gradients, the divergence solve, the non-pressure forces, the density
  solve, so that temporaries inside compiled passes (which the walk cannot see) show as the
  phase's excess over the live arrays;
* the process's resident memory before the world was built (Python, NumPy, Numba and the
  compiled passes: the baseline) and its peak (``ru_maxrss``);
* where the resident memory lies at the entry of the pressure solve (``/proc/self/smaps``): the
  main heap (``[heap]``: small and mid-sized allocations, and what the allocator keeps of them
  after they are freed), anonymous mappings (large arrays, other threads' arenas) and
  file-backed pages (shared libraries, the compiled passes' code), and how much of it the C
  allocator gives back when asked after the step (``malloc_trim(0)``, glibc only): memory that
  was freed but stayed resident.

The table is the one in ``benchmarks/README.md`` ("Memory").
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    return 0


def rss() -> int:
    """Resident bytes now."""
    return 1024 * _kib("VmRSS")


def hwm() -> int:
    """Peak resident bytes since the last :func:`reset_peak`."""
    return 1024 * _kib("VmHWM")


def reset_peak() -> None:
    """Reset the kernel's peak-RSS mark to the current RSS (``echo 5 > clear_refs``)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        pass


def resident_regions() -> dict[str, int]:
    """Resident bytes by kind of mapping (``/proc/self/smaps``): the main ``heap``, ``anonymous``
    mappings and ``file``-backed ones (Linux; empty elsewhere)."""
    out = {"heap": 0, "anonymous": 0, "file": 0}
    kind = None
    try:
        lines = Path("/proc/self/smaps").read_text().splitlines()
    except OSError:
        return {}
    for line in lines:
        head = line.split()
        if head and "-" in head[0] and len(head) >= 5 and ":" in head[3]:  # a mapping's line
            name = head[5] if len(head) > 5 else ""
            kind = "heap" if name == "[heap]" else "anonymous" if not name else (
                None if name.startswith("[") else "file")
        elif line.startswith("Rss:") and kind is not None:
            out[kind] += 1024 * int(head[1])
    return out


def malloc_trim() -> int | None:
    """Ask glibc to return the free memory of its heaps (``malloc_trim(0)``); the resident bytes
    released, or None where there is no glibc."""
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return None
    before = rss()
    libc.malloc_trim(0)
    return before - rss()


def _owner(a: np.ndarray) -> np.ndarray:
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def live_arrays(root: object, name: str = "sim") -> dict[str, int]:
    """Bytes of every array reachable from ``root`` (objects' ``__dict__``, dataclasses, lists,
    tuples, dicts), by the path of the first reference found to the owning buffer."""
    seen_obj: set[int] = set()
    seen_buf: dict[int, str] = {}
    out: dict[str, int] = {}
    stack = [(name, root)]
    while stack:
        path, obj = stack.pop()
        if isinstance(obj, np.ndarray):
            own = _owner(obj)
            if id(own) not in seen_buf:
                seen_buf[id(own)] = path
                out[path] = own.nbytes
            continue
        if id(obj) in seen_obj or obj is None or isinstance(obj, (str, bytes, int, float, bool,
                                                                    type)):
            continue
        seen_obj.add(id(obj))
        if isinstance(obj, dict):
            items = [(f"{path}[{k!r}]", v) for k, v in obj.items()]
        elif isinstance(obj, (list, tuple)):
            items = [(f"{path}[{i}]", v) for i, v in enumerate(obj)]
        else:
            d = getattr(obj, "__dict__", None)
            if d is None or type(obj).__module__.split(".")[0] not in ("sphkit", "__main__"):
                continue
            items = [(f"{path}.{k}", v) for k, v in d.items()]
        stack.extend(reversed(items))
    return out


def measure(scene: Path, start: float, steps: int, precision: str | None) -> dict:
    from sphkit.scene.files import load_scene
    from sphkit.simulation import Simulation

    base = rss()
    sc = load_scene(scene)
    if precision:
        sc.configuration.precision = precision
    sim = Simulation(sc)
    while sim.time < start:
        sim.step()
    for _ in range(steps):
        sim.step()
    phases: dict[str, int] = {}
    snap: dict[str, int] = {}
    regions: dict[str, int] = {}

    def wrap(obj: object, attr: str, label: str, snapshot: bool = False) -> None:
        fn = getattr(obj, attr)

        def inner(*a, **k):
            if snapshot:
                snap.update(live_arrays(sim))
                regions.update(resident_regions())
            reset_peak()
            try:
                return fn(*a, **k)
            finally:
                phases[label] = max(phases.get(label, 0), hwm())
        setattr(obj, attr, inner)

    wrap(sim, "_neighbors", "neighbour search (z-order, fluid-fluid, fluid-boundary)")
    wrap(sim, "compute_density", "densities and pair gradients")
    wrap(sim.pressure, "pre_forces", "DFSPH factors and divergence solve")
    for k, force in enumerate(sim.forces):
        wrap(force, "apply", f"non-pressure force {k} ({type(force).__name__})")
    wrap(sim.pressure, "solve", "pressure solve", snapshot=True)
    z = sim.scene.configuration.zsort_every
    if z:  # make the measured step one that reorders the fluid
        sim.step_count = (sim.step_count // z + 1) * z
    sim.step()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    trimmed = malloc_trim()
    return {"n_fluid": sim.fluid.n, "time": sim.time, "n_boundary": sim.boundary.n,
            "fluid_pairs": int(sim.state.nl_ff.indices.shape[0]),
            "boundary_pairs": int(sim.state.nl_fb.indices.shape[0]),
            "baseline": base, "live": snap, "phases": phases, "regions": regions,
            "trimmed": trimmed, "peak": peak}


def report(r: dict) -> None:
    n = r["n_fluid"]
    print(f"{n} fluid, {r['n_boundary']} boundary particles at t = {r['time']:.3f} s; "
          f"{r['fluid_pairs'] / n:.1f} fluid and {r['boundary_pairs'] / n:.2f} boundary "
          "neighbours per fluid particle")
    print(f"{'array (live at the entry of the pressure solve)':62s} {'MB':>8s} {'B/fluid':>8s}")
    tot = 0
    for path, b in sorted(r["live"].items(), key=lambda kv: -kv[1]):
        tot += b
        if b >= 0.002 * n * 8:
            print(f"{path:62s} {b / 1e6:8.2f} {b / n:8.1f}")
    print(f"{'all live arrays':62s} {tot / 1e6:8.2f} {tot / n:8.1f}")
    print(f"{'process before the world (Python, NumPy, Numba, compiled code)':62s} "
          f"{r['baseline'] / 1e6:8.2f} {r['baseline'] / n:8.1f}")
    for kind, b in r.get("regions", {}).items():
        print(f"{'resident at the solve: ' + kind:62s} {b / 1e6:8.2f} {b / n:8.1f}")
    if r.get("trimmed") is not None:
        print(f"{'freed but resident after the step (malloc_trim gives back)':62s} "
              f"{r['trimmed'] / 1e6:8.2f} {r['trimmed'] / n:8.1f}")
    print(f"{'peak resident memory of the phase':62s}")
    for label, b in r["phases"].items():
        print(f"  {label:60s} {b / 1e6:8.2f} {b / n:8.1f}")
    print(f"{'peak resident memory of the process (ru_maxrss)':62s} {r['peak'] / 1e6:8.2f} "
          f"{r['peak'] / n:8.1f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solver", default="dfsph",
                    choices=("wcsph", "pcisph", "pbf", "iisph", "dfsph"))
    ap.add_argument("--scene", type=Path, help="a SPlisHSPlasH scene (default: the dam break "
                    "of --solver)")
    ap.add_argument("--radius", type=float, default=0.0125, help="particle radius [m]")
    ap.add_argument("--start", type=float, default=0.0, help="simulated time [s] before the "
                    "measured steps")
    ap.add_argument("--steps", type=int, default=3, help="steps before the measured one")
    ap.add_argument("--precision", choices=("float64", "float32"))
    ap.add_argument("--json", type=Path, metavar="FILE", help="also write the numbers as JSON")
    args = ap.parse_args()
    if not args.radius > 0 or args.steps < 0:
        ap.error(f"--radius {args.radius}, --steps {args.steps}: expected a positive radius "
                 "and steps >= 0")
    scene = args.scene or HERE / "scenes" / f"dambreak_{args.solver}.json"
    data = json.loads(scene.read_text())
    data["Configuration"]["particleRadius"] = args.radius
    for body in data.get("RigidBodies", []):
        if body.get("geometryFile") and not Path(body["geometryFile"]).is_absolute():
            body["geometryFile"] = str((scene.parent / body["geometryFile"]).resolve())
    with tempfile.TemporaryDirectory(prefix="sphkit-memory-") as tmp:
        path = Path(tmp) / scene.name
        path.write_text(json.dumps(data))
        r = measure(path, args.start, args.steps, args.precision)
    report(r)
    if args.json:
        args.json.write_text(json.dumps(r, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
