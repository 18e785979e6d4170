"""Run one SPlisHSPlasH scene headless through the pysplishsplash wheel and print timing as JSON.

Invoked by vs_splishsplash.py in a subprocess (the wheel's import needs LD_PRELOAD on Linux).
Usage: python _splishsplash_runner.py SCENE.json
"""

import json
import sys
import tempfile
import time

import pysplishsplash as sph


def main() -> None:
    scene = sys.argv[1]
    base = sph.Exec.SimulatorBase()
    out = tempfile.mkdtemp(prefix="sphkit-bench-sps-")
    base.init(["bench", "--no-gui", "--output-dir", out, "--no-cache", scene], "bench")
    steps = [0]

    def count() -> None:
        steps[0] += 1

    base.setTimeStepCB(count)
    t0 = time.perf_counter()
    base.run()
    wall = time.perf_counter() - t0
    # particle counts are parsed from the wheel's own log by the caller: touching the
    # simulation object after run() crashes the wheel
    print("SPHKIT-BENCH " + json.dumps({"steps": steps[0], "wall": wall}), flush=True)


if __name__ == "__main__":
    # the wheel prints its own timing tables to stdout; we mark our line
    main()
