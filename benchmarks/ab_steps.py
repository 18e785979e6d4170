"""Two versions of sphkit's step on the same state, alternated batch by batch (before/after of a
change to the step, on a machine whose speed drifts).

    python benchmarks/ab_steps.py BASE_SRC [--scene SCENE.json] [--start 0.5] [--rounds 60]
                                  [--steps 10] [--threads 2]

``BASE_SRC`` is the ``src`` folder of the other checkout (e.g. a ``git worktree`` of the
commit before the change); the version under test is the installed ``sphkit``. Each version
runs in a process of its own; both restore the same checkpoint (written once by the base, at
t = ``--start``), warm up, and then take turns: one runs ``--steps`` steps, then the other, for
``--rounds`` rounds (the order swapped every round; each process restores the checkpoint
every 300 steps, so both step through the same states). Prints each version's step times
(min, 10th percentile, median) and the median over rounds of the ratio of the two versions'
median step in that round: the ratio to read, as a drift of the machine's speed between
rounds touches both versions of a round alike (this VM's step time moves by 20-50 % within
seconds, so separate runs of each version do not show a 5 % change; benchmarks/README.md,
"The step's glue at 7k"). Compile both versions first (a step of each; a cold cache is not
timed but delays the start). Needs an idle machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESTART_EVERY = 300  # steps before a process restores the checkpoint again

_CHILD = r"""
import sys, time
from sphkit.io.checkpoint import read_checkpoint
from sphkit.simulation import Simulation
scene, ck_path, start, k, write = sys.argv[1:6]
start, k, write = float(start), int(k), write == "1"
sim = Simulation.from_scene(scene)
if write:
    while sim.time < start:
        sim.step()
    sim.save_checkpoint(ck_path)
    print("written", flush=True)
    sys.exit(0)
ck = read_checkpoint(ck_path)
sim.restore_checkpoint(ck)
for _ in range(20):
    sim.step()
sim.restore_checkpoint(ck)
done = 0
print("ready", flush=True)
for line in sys.stdin:
    if line.strip() != "go":
        break
    if done >= RESTART_EVERY:
        sim.restore_checkpoint(ck)
        done = 0
    times = []
    for _ in range(k):
        t = time.perf_counter()
        sim.step()
        times.append(time.perf_counter() - t)
    done += k
    print(" ".join(f"{t:.7f}" for t in times), flush=True)
""".replace("RESTART_EVERY", str(RESTART_EVERY))


def main() -> int:
    """Alternate the two versions and print their step times and the ratio."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("base", type=Path, help="the src folder of the version to compare with")
    ap.add_argument("--scene", type=Path, default=HERE / "scenes" / "dambreak_dfsph.json")
    ap.add_argument("--start", type=float, default=0.5, help="checkpoint time [s]")
    ap.add_argument("--rounds", type=int, default=60)
    ap.add_argument("--steps", type=int, default=10, help="steps per version and round")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    if not (args.base / "sphkit" / "__init__.py").is_file():
        ap.error(f"base: {args.base} holds no sphkit package; expected a checkout's src folder")
    env = dict(os.environ, NUMBA_NUM_THREADS=str(args.threads))
    env.pop("PYTHONPATH", None)
    envs = {"base": dict(env, PYTHONPATH=str(args.base.resolve())), "new": env}
    with tempfile.TemporaryDirectory() as tmp:
        ck = str(Path(tmp) / "start.npz")
        subprocess.run([sys.executable, "-c", _CHILD, str(args.scene), ck, str(args.start),
                        str(args.steps), "1"], env=envs["base"], check=True,
                       stdout=subprocess.DEVNULL)
        procs = {name: subprocess.Popen(
            [sys.executable, "-c", _CHILD, str(args.scene), ck, str(args.start),
             str(args.steps), "0"], env=e, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, text=True) for name, e in envs.items()}
        for name, p in procs.items():
            if p.stdout.readline().strip() != "ready":
                raise SystemExit(f"the {name} version did not start")
        times: dict[str, list[float]] = {name: [] for name in procs}
        ratios = []
        for r in range(args.rounds):
            got = {}
            for name in (("base", "new") if r % 2 == 0 else ("new", "base")):
                procs[name].stdin.write("go\n")
                procs[name].stdin.flush()
                got[name] = [float(t) for t in procs[name].stdout.readline().split()]
                times[name].extend(got[name])
            ratios.append(statistics.median(got["new"]) / statistics.median(got["base"]))
        for p in procs.values():
            p.stdin.write("stop\n")
            p.stdin.flush()
            p.wait()
    for name, t in times.items():
        ms = np.array(t) * 1e3
        print(f"{name:4s} {len(ms)} steps: min {ms.min():.3f}, p10 {np.percentile(ms, 10):.3f}, "
              f"median {np.median(ms):.3f} ms")
    print(f"new / base: {statistics.median(ratios):.4f} (median over {args.rounds} rounds of "
          f"the ratio of the round's median steps)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
