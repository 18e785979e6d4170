"""sphkit vs SPlisHSPlasH on one and the same scene file, side by side, in one run.

    python benchmarks/vs_splishsplash.py [SCENE.json ...] [--threads 2]

For each scene (default: benchmarks/scenes/dambreak_wcsph.json, a 3D dam break with WCSPH,
Akinci boundaries and a fixed time step of 1 ms, to t = 0.5 s) the script runs

* SPlisHSPlasH through its ``pysplishsplash`` wheel (``pip install pysplishsplash``), in a
  subprocess with ``OMP_NUM_THREADS`` set and, on Linux, the ``LD_PRELOAD`` the wheel's
  import needs;
* sphkit on the same file (after a short warm-up run so that Numba's compile time is not counted),
  with ``NUMBA_NUM_THREADS`` set to the same thread count,

and prints particles, steps, wall seconds, seconds per step for each and the ratio
sphkit / SPlisHSPlasH of the time per step (below 1 means sphkit is faster).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_SCENES = [HERE / "scenes" / "dambreak_wcsph.json"]
GL_PRELOAD = "/lib/x86_64-linux-gnu/libGLdispatch.so.0"


def run_splishsplash(scene: Path, threads: int) -> dict | None:
    """Time the scene in SPlisHSPlasH (None when the wheel is missing or fails)."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    if sys.platform.startswith("linux") and Path(GL_PRELOAD).exists():
        env["LD_PRELOAD"] = GL_PRELOAD
    res = subprocess.run([sys.executable, str(HERE / "_splishsplash_runner.py"), str(scene)],
                         env=env, capture_output=True, text=True)
    counts = {}
    for key, pat in (("n_fluid", r"Number of fluid particles: (\d+)"),
                     ("n_boundary", r"Number of boundary particles: (\d+)")):
        m = re.search(pat, res.stdout)
        counts[key] = int(m.group(1)) if m else 0
    for line in res.stdout.splitlines():
        if line.startswith("SPHKIT-BENCH "):
            return {**json.loads(line[len("SPHKIT-BENCH "):]), **counts}
    print(f"SPlisHSPlasH run failed (exit {res.returncode}):\n{res.stderr[-2000:]}",
          file=sys.stderr)
    return None


def run_sphkit(scene: Path, threads: int) -> dict:
    """Time the scene in sphkit (in a subprocess so the thread count applies)."""
    code = f"""
import json, time
from sphkit.scene.loader import load_scene
from sphkit.simulation import Simulation
sc = load_scene({str(scene)!r})
warm = Simulation(sc)
for _ in range(3):
    warm.step()
sim = Simulation(sc)
until = sc.configuration.time.until
t0 = time.perf_counter()
while sim.time < until - 1e-12:
    sim.step()
wall = time.perf_counter() - t0
print("SPHKIT-BENCH " + json.dumps({{"steps": sim.step_count, "wall": wall,
      "n_fluid": sim.fluid.n, "n_boundary": sim.boundary.n}}))
"""
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads))
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    for line in res.stdout.splitlines():
        if line.startswith("SPHKIT-BENCH "):
            return json.loads(line[len("SPHKIT-BENCH "):])
    raise RuntimeError(f"sphkit run failed (exit {res.returncode}):\n{res.stderr[-3000:]}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", type=Path, default=DEFAULT_SCENES)
    ap.add_argument("--threads", type=int, default=2, help="threads for both codes (default 2)")
    args = ap.parse_args()
    cpu = platform.processor() or platform.machine()
    print(f"# {time.strftime('%Y-%m-%d')} {platform.node()} {cpu}"
          f", {os.cpu_count()} cores, {args.threads} threads each")
    head = (f"{'scene':28s} {'code':13s} {'fluid':>7s} {'bound.':>7s} {'steps':>6s} "
            f"{'wall s':>8s} {'ms/step':>8s}")
    print(head)
    for scene in args.scenes:
        sk = run_sphkit(scene, args.threads)
        sp = run_splishsplash(scene, args.threads)
        for name, r in (("sphkit", sk), ("SPlisHSPlasH", sp)):
            if r is None:
                print(f"{scene.name:28s} {name:13s} (not available)")
                continue
            print(f"{scene.name:28s} {name:13s} {r['n_fluid']:7d} {r['n_boundary'] or 0:7d} "
                  f"{r['steps']:6d} {r['wall']:8.2f} {1000 * r['wall'] / r['steps']:8.2f}")
        if sp:
            ratio = (sk["wall"] / sk["steps"]) / (sp["wall"] / sp["steps"])
            print(f"{scene.name:28s} ratio sphkit/SPlisHSPlasH time per step: {ratio:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
