"""sphkit vs SPlisHSPlasH on one and the same scene file, side by side, in one run.

    python benchmarks/vs_splishsplash.py [SCENE.json ...] [--threads 2] [--until T]
                                         [--codes sphkit,splishsplash] [--repeat 3]
                                         [--json FILE]

Without scene arguments it runs the five 3D dam breaks of ``benchmarks/scenes`` (SPlisHSPlasH's
DamBreakModel setup: 19^3 fluid particles of radius 0.025 m, Akinci boundary particles, standard
viscosity 0.01): ``dambreak_wcsph.json`` (WCSPH, fixed 1 ms step, to t = 0.5 s) and
``dambreak_{pcisph,pbf,iisph,dfsph}.json`` (simulationMethod 1..4 with equal settings: maxError
0.05 %, DFSPH maxErrorV 0.1 %, SPlisHSPlasH's default minIterations per solver, maxIterations 100,
the CFL step with cflFactor 1 and at most 5 ms, to t = 1 s). For each scene it runs

* SPlisHSPlasH through its ``pysplishsplash`` wheel (``pip install pysplishsplash``), in a
  subprocess with ``OMP_NUM_THREADS`` set and, on Linux, the ``LD_PRELOAD`` the wheel's import
  needs (``_splishsplash_runner.py``, which reads the statistics in the time-step callback);
* sphkit on the same file (after a short warm-up run so that Numba's compile time is not counted),
  in a subprocess with ``NUMBA_NUM_THREADS`` set to the same thread count,

``--repeat N`` times, alternating the two codes (so that a disturbance of the shared machine hits
both alike), and prints for each code its fastest run (the least disturbed measurement, as
``timeit`` reports): fluid and boundary particles, simulated seconds, wall seconds, steps,
mean pressure-solver iterations per step (``it/step``; ``-`` for WCSPH, which does not iterate),
mean DFSPH divergence iterations per step (``div/step``), the mean density error (``rho err``:
the average over steps of the fluid average of max(rho / rho0 - 1, 0), in % of rho0, measured the
same way in both codes from the density field each holds after the step), sphkit's own solver
error (``solver err``: the mean of ``StepStats.density_error_avg``; the wheel does not expose
SPlisHSPlasH's), milliseconds per step, and the ratio sphkit / SPlisHSPlasH of the wall time per
simulated second of the fastest runs (below 1 means sphkit is faster), followed by the ratio of
each pair of runs. A scene sphkit cannot run yet (a solver that is
not implemented) is reported as ``sphkit: not available: <reason>`` and the script goes on.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sphkit.scene.splishsplash import wheel

HERE = Path(__file__).resolve().parent
SCENES = HERE / "scenes"
DEFAULT_SCENES = [SCENES / f"dambreak_{m}.json" for m in ("wcsph", "pcisph", "pbf", "iisph",
                                                          "dfsph", "dfsph_volumemaps")]
TIMEOUT_S = 1800  # per code and scene


def _marked(stdout: str, mark: str) -> str | None:
    for line in stdout.splitlines():
        if line.startswith(mark + " "):
            return line[len(mark) + 1:]
    return None


def _summary(raw: dict) -> dict:
    """Per-step means from a runner's sums."""
    steps = max(raw["steps"], 1)
    out = dict(raw)
    out["iterations"] = raw["iterations"] / steps
    out["divergence_iterations"] = raw["divergence_iterations"] / steps
    out["density_error"] = raw["density_error"] / steps
    if raw.get("solver_error") is not None:
        out["solver_error"] = raw["solver_error"] / steps
    return out


def run_splishsplash(scene: Path, threads: int) -> dict:
    """Run the scene in SPlisHSPlasH; ``{"error": ...}`` when the wheel is missing or fails."""
    env = wheel.subprocess_env(str(threads))
    try:
        res = subprocess.run([sys.executable, str(HERE / "_splishsplash_runner.py"), str(scene)],
                             env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return {"error": f"no result within {TIMEOUT_S} s"}
    line = _marked(res.stdout, "SPHKIT-BENCH")
    if line is None:
        why = (res.stderr.strip() or res.stdout.strip()).splitlines()[-3:]
        return {"error": f"exit {res.returncode}: {' / '.join(why) or 'no output'}"}
    counts = {}  # summed over the fluid models (several fluids, elastic solids)
    for key, pat in (("n_fluid", r"Number of fluid particles: (\d+)"),
                     ("n_boundary", r"Number of boundary particles: (\d+)")):
        counts[key] = sum(int(m) for m in re.findall(pat, res.stdout))
    out = _summary({**json.loads(line), **counts})
    # the wheel's own timers at exit ("Time sum: <part>: <ms> ms"), in seconds over the run
    out["parts"] = {name: float(ms) / 1e3 for name, ms in
                    re.findall(r"^Time sum: ([^:]+): ([0-9.eE+-]+) ms", res.stdout, re.M)}
    if out.get("method") == "WCSPH":
        out["iterations"] = None  # WCSPH does not iterate (SPlisHSPlasH reports 0)
    return out


SPHKIT_CODE = """
import gc, json, os, resource, sys, time
import numpy as np
from sphkit.scene.files import load_scene
from sphkit.scene.schema import SceneError
from sphkit.simulation import InstabilityError, Simulation

def say(mark, obj):
    print(mark + " " + json.dumps(obj), flush=True)

def rss():  # resident bytes now (Linux; 0 elsewhere)
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return 1024 * int(line.split()[1])
    except OSError:
        pass
    return 0

def configured(scene):  # sphkit-only settings of the run (SPHKIT_BENCH_CONFIG, JSON)
    for key, value in json.loads(os.environ.get("SPHKIT_BENCH_CONFIG") or "{}").items():
        *path, last = key.split(".")  # dotted: a nested field, e.g. boundary.pressure
        obj = scene.configuration
        for part in path:
            obj = getattr(obj, part)
        setattr(obj, last, value)
    return scene

try:
    sc = configured(load_scene(sys.argv[1]))
    # warm-up (compilation) on the scene itself or, for large runs, on a smaller copy of it
    warm = Simulation(configured(load_scene(sys.argv[2])) if len(sys.argv) > 2 else sc)
    for _ in range(3):
        warm.step()
    del warm
    gc.collect()
    rss_base = rss()  # the process before the measured world: Python, Numba, compiled code
    sim = Simulation(sc)
except SceneError as e:
    say("SPHKIT-UNAVAILABLE", " / ".join(str(e).splitlines()))
    sys.exit(0)
until = sc.configuration.time.until
rec = {"steps": 0, "iterations": 0, "divergence_iterations": 0, "density_error": 0.0,
       "solver_error": 0.0, "method": sc.configuration.pressure.method,
       "n_fluid": sim.fluid.n, "n_boundary": sim.boundary.n}
t0 = time.perf_counter()
try:
    while sim.time < until - 1e-12:
        s = sim.step()
        rec["steps"] += 1
        rec["iterations"] += getattr(s, "iterations", 1)
        rec["divergence_iterations"] += getattr(s, "divergence_iterations", 0)
        rec["solver_error"] += s.density_error_avg
        if sim.fluid.n:
            rho0 = sim.fluid["rho0"]  # per particle (several fluids, solids), after the step
            rec["density_error"] += float(np.mean(np.maximum(sim.densities / rho0 - 1.0, 0.0)))
except InstabilityError as e:
    say("SPHKIT-FAILED", f"unstable: {e}")
    sys.exit(0)
rec["wall"] = time.perf_counter() - t0
rec["sim_time"] = sim.time
rec["maxrss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
rec["rss_base"] = rss_base
say("SPHKIT-BENCH", rec)
"""


def run_sphkit(scene: Path, threads: int, warm: Path | None = None,
               config: dict | None = None) -> dict:
    """Run the scene in sphkit (in a subprocess so the thread count applies); ``{"unavailable":
    ...}`` when sphkit rejects the scene, ``{"error": ...}`` when the run fails. ``warm``: the
    scene of the untimed warm-up run (default: the scene itself; a small copy of a large scene
    keeps the warm-up short and out of the peak memory). The result carries the child's peak
    resident memory ``maxrss`` and its resident memory before the measured world was built
    ``rss_base`` (bytes). ``config``: sphkit-only settings of ``configuration`` for the run
    (e.g. ``{"precision": "float32", "neighbor_skin": 0.5}``)."""
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
               SPHKIT_BENCH_CONFIG=json.dumps(config or {}))
    cmd = [sys.executable, "-c", SPHKIT_CODE, str(scene)] + ([str(warm)] if warm else [])
    try:
        res = subprocess.run(cmd, env=env,
                             capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return {"error": f"no result within {TIMEOUT_S} s"}
    line = _marked(res.stdout, "SPHKIT-BENCH")
    if line is not None:
        out = _summary(json.loads(line))
        if out["method"] == "wcsph":
            out["iterations"] = None
        return out
    for mark, key in (("SPHKIT-UNAVAILABLE", "unavailable"), ("SPHKIT-FAILED", "error")):
        text = _marked(res.stdout, mark)
        if text is not None:
            return {key: json.loads(text)}
    why = res.stderr.strip().splitlines()[-3:]
    return {"error": f"exit {res.returncode}: {' / '.join(why) or 'no output'}"}


#: the fields of a SPlisHSPlasH scene that name a file relative to the scene's folder
FILE_FIELDS = ("geometryFile", "particleFile", "mapFile")


def _with_end_time(scene: Path, until: float, folder: Path) -> Path:
    """A copy of the SPlisHSPlasH scene with ``stopAt`` = until and absolute file paths (meshes
    of rigid bodies, particle files of fluid models, in every block)."""
    data = json.loads(scene.read_text())
    data.setdefault("Configuration", {})["stopAt"] = until
    for block in data.values():
        for entry in block if isinstance(block, list) else []:
            for key in FILE_FIELDS:
                name = entry.get(key) if isinstance(entry, dict) else None
                if isinstance(name, str) and name and not Path(name).is_absolute():
                    entry[key] = str((scene.parent / name).resolve())
    path = folder / scene.name
    path.write_text(json.dumps(data, indent=1))
    return path


def resolve_scene(name: Path) -> Path:
    """A scene path as given, or else a scene of the pysplishsplash wheel by its name
    (``DoubleDamBreakMultiPhase`` or ``Beam.json``)."""
    if name.exists():
        return name.resolve()  # the wheel crashes on a relative scene path
    from sphkit.cli.compat import wheel_scene_folder

    folder = wheel_scene_folder()
    if folder is not None:
        for candidate in (folder / name.name, folder / f"{name.name}.json"):
            if candidate.exists():
                return candidate
    raise SystemExit(f"vs_splishsplash.py: scene {str(name)!r}: no such file, nor a scene of the "
                     "pysplishsplash wheel by that name")


def _per_sim_s(r: dict) -> float:
    return r["wall"] / r["sim_time"] if r["sim_time"] > 0 else float("inf")


def _fastest(runs: list[dict]) -> dict:
    """The run with the least wall time per simulated second, or the first failure."""
    ok = [r for r in runs if "wall" in r]
    return min(ok, key=_per_sim_s) if ok else runs[0]


def _num(value: float | None, spec: str, scale: float = 1.0) -> str:
    return "-" if value is None else f"{value * scale:{spec}}"


COLUMNS = (f"{'scene':30s} {'code':13s} {'fluid':>6s} {'bound.':>6s} {'sim s':>6s} "
           f"{'wall s':>7s} {'steps':>5s} {'it/step':>7s} {'div/step':>8s} {'rho err%':>8s} "
           f"{'solver err%':>11s} {'ms/step':>7s}")


def _row(scene: str, code: str, r: dict) -> str:
    if "unavailable" in r:
        return f"{scene:30s} {code}: not available: {r['unavailable']}"
    if "error" in r:
        return f"{scene:30s} {code}: failed: {r['error']}"
    div = r["divergence_iterations"] if r.get("method") in ("dfsph", "DFSPH") else None
    return (f"{scene:30s} {code:13s} {r['n_fluid']:6d} {r['n_boundary'] or 0:6d} "
            f"{r['sim_time']:6.3f} {r['wall']:7.2f} {r['steps']:5d} "
            f"{_num(r['iterations'], '7.2f')} {_num(div, '8.2f')} "
            f"{_num(r['density_error'], '8.4f', 100)} {_num(r.get('solver_error'), '11.4f', 100)} "
            f"{1000 * r['wall'] / max(r['steps'], 1):7.2f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", type=Path, default=DEFAULT_SCENES,
                    help="SPlisHSPlasH scene files, or names of the pysplishsplash wheel's "
                         "scenes (default: the six dam breaks)")
    ap.add_argument("--threads", type=int, default=2, help="threads for both codes (default 2)")
    ap.add_argument("--until", type=float, metavar="T",
                    help="simulated end time [s] for every scene (default: each scene's stopAt)")
    ap.add_argument("--codes", default="sphkit,splishsplash", metavar="LIST",
                    help="which codes to run: sphkit, splishsplash or both (default)")
    ap.add_argument("--repeat", type=int, default=3, metavar="N",
                    help="paired runs per scene, alternating the codes; each code's fastest run "
                         "is reported (default 3)")
    ap.add_argument("--json", type=Path, metavar="FILE", help="also write the results as JSON")
    ap.add_argument("--sphkit-config", default="{}", metavar="JSON",
                    help="sphkit-only fields of configuration for its runs, dotted keys for "
                         "nested ones, e.g. '{\"boundary.pressure\": \"mirror\"}' "
                         "(SPlisHSPlasH's wall pressure term)")
    args = ap.parse_args()
    try:
        sk_config = json.loads(args.sphkit_config)
        if not isinstance(sk_config, dict):
            raise ValueError("not an object")
    except ValueError as e:
        ap.error(f"--sphkit-config: {args.sphkit_config!r}; expected a JSON object ({e})")
    codes = {c.strip().lower() for c in args.codes.split(",") if c.strip()}
    if args.repeat < 1:
        ap.error(f"--repeat: got {args.repeat}; expected a positive number of runs")
    if not codes or not codes <= {"sphkit", "splishsplash"}:
        ap.error(f"--codes: got {args.codes!r}; expected sphkit, splishsplash or both, "
                 "comma-separated")
    cpu = platform.processor() or platform.machine()
    versions = []
    for dist in ("pysplishsplash", "numba"):
        try:
            versions.append(f"{dist} {importlib.metadata.version(dist)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{dist} (not installed)")
    print(f"# {time.strftime('%Y-%m-%d')} {platform.node()} {cpu}, {os.cpu_count()} cores, "
          f"{args.threads} threads each; {', '.join(versions)}"
          + (f"; sphkit configuration {sk_config}" if sk_config else ""))
    print(COLUMNS, flush=True)
    results = []
    with tempfile.TemporaryDirectory(prefix="sphkit-bench-") as tmp:
        for scene in args.scenes:
            scene = resolve_scene(scene)
            path = scene if args.until is None else _with_end_time(scene, args.until, Path(tmp))
            sk = sp = {"unavailable": "not run (--codes)"}
            runs_sk: list[dict] = []
            runs_sp: list[dict] = []
            for _ in range(args.repeat):  # alternate: a disturbance hits both codes alike
                if "sphkit" in codes:
                    runs_sk.append(run_sphkit(path, args.threads, config=sk_config))
                if "splishsplash" in codes:
                    runs_sp.append(run_splishsplash(path, args.threads))
                if any("wall" not in r for r in runs_sk + runs_sp):
                    break  # a code failed or is unavailable: no point in repeating
            if runs_sk:
                sk = _fastest(runs_sk)
                print(_row(scene.name, "sphkit", sk), flush=True)
            if runs_sp:
                sp = _fastest(runs_sp)
                print(_row(scene.name, "SPlisHSPlasH", sp), flush=True)
            entry = {"scene": scene.name, "sphkit": sk, "splishsplash": sp, "ratio": None,
                     "runs": {"sphkit": runs_sk, "splishsplash": runs_sp}}
            if "wall" in sk and "wall" in sp and sk["sim_time"] > 0 and sp["sim_time"] > 0:
                entry["ratio"] = _per_sim_s(sk) / _per_sim_s(sp)
                pairs = [_per_sim_s(a) / _per_sim_s(b)
                         for a, b in zip(runs_sk, runs_sp, strict=False)
                         if "wall" in a and "wall" in b]
                each = ", ".join(f"{r:.2f}" for r in pairs)
                print(f"{scene.name:30s} ratio sphkit/SPlisHSPlasH wall time per simulated "
                      f"second: {entry['ratio']:.2f} (fastest runs; the {len(pairs)} paired runs: "
                      f"{each})", flush=True)
            results.append(entry)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
