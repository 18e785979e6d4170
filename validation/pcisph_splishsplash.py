"""SPlisHSPlasH's own PCISPH on issue 15's 2D column: does the reference diverge as sphkit did?

    python validation/pcisph_splishsplash.py [--boundaries akinci2012 koschier2017 bender2019]
                                             [--until 0.15]

Writes the column of ``validation/hydrostatic.py`` (``splishsplash_column``: 0.6 m wide, 0.5 m
high, r = 1 cm, SPlisHSPlasH's default settings, UnitBox.obj walls, the block r above the floor)
with ``simulationMethod`` 1 (PCISPH), runs it headless through the ``pysplishsplash`` wheel in a
subprocess (with the ``LD_PRELOAD`` its import needs on Linux, as benchmarks/vs_splishsplash.py)
and prints per boundary model the first step whose largest particle speed exceeds 5 m/s (the
column lands at 0.44 m/s), with its time, the iterations of the steps before it and the largest
speed reached. Results: validation/README.md, "PCISPH: the column that diverged (2026-12-02)".
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from sphkit.scene.splishsplash import wheel

HERE = Path(__file__).resolve().parent

RUNNER = r"""
import sys, json, tempfile
import numpy as np
import pysplishsplash as sph
base = sph.Exec.SimulatorBase()
base.init(["x", "--no-gui", "--output-dir", tempfile.mkdtemp(), "--no-cache", sys.argv[1]], "x")
rows = []
def cb():
    sim = sph.Simulation.getCurrent()
    fm = sim.getFluidModel(0)
    n = fm.numActiveParticles()
    v = np.asarray(fm.getFieldBuffer("velocity")).reshape(-1, 3)[:n]
    tm = sph.TimeManager.getCurrent()
    rows.append([tm.getTime(), tm.getTimeStepSize(), int(sim.getTimeStep().getNumIterations()),
                 float(np.linalg.norm(v, axis=1).max())])
base.setTimeStepCB(cb)
base.run()
print("SPHKIT-ROWS " + json.dumps(rows), flush=True)
"""


def run(boundary: str, until: float) -> list:
    """Per step (time, dt, iterations, max speed) of SPlisHSPlasH's PCISPH on the column."""
    sys.path.insert(0, str(HERE))
    from hydrostatic import splishsplash_column

    scene = splishsplash_column("pcisph", boundary, 2, 0.6)
    scene["Configuration"].update(stopAt=until, enableVTKExport=False,
                                  enablePartioExport=False)
    folder = Path(tempfile.mkdtemp(prefix="sphkit-pcisph-sps-"))
    (folder / "scene.json").write_text(json.dumps(scene))
    (folder / "run.py").write_text(RUNNER)
    env = wheel.subprocess_env("1")
    res = subprocess.run([sys.executable, str(folder / "run.py"), str(folder / "scene.json")],
                         env=env, capture_output=True, text=True, timeout=600)
    line = next((s for s in res.stdout.splitlines() if s.startswith("SPHKIT-ROWS ")), None)
    if line is None:
        raise SystemExit(f"pysplishsplash failed: {res.stderr.strip()[-300:]}")
    return json.loads(line.split(" ", 1)[1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--boundaries", nargs="+",
                    default=["akinci2012", "koschier2017", "bender2019"])
    ap.add_argument("--until", type=float, default=0.15)
    args = ap.parse_args()
    print("| boundary | first step above 5 m/s | time [s] | iterations of the steps before | "
          "largest speed [m/s] |")
    print("|---|---|---|---|---|")
    for b in args.boundaries:
        rows = run(b, args.until)
        k = next((i for i, r in enumerate(rows) if r[3] > 5.0), None)
        its = ", ".join(str(r[2]) for r in rows[max((k or len(rows)) - 5, 0):k])
        vmax = max(r[3] for r in rows)
        step = "-" if k is None else str(k + 1)
        t = "-" if k is None else f"{rows[k][0]:.4f}"
        print(f"| {b} | {step} | {t} | {its} | {vmax:.4g} |", flush=True)


if __name__ == "__main__":
    main()
