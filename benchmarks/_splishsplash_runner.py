"""Run one SPlisHSPlasH scene headless through the pysplishsplash wheel; print statistics as JSON.

Invoked by vs_splishsplash.py in a subprocess (the wheel's import needs LD_PRELOAD on Linux).
Usage: python _splishsplash_runner.py SCENE.json

Everything is read inside the time-step callback (``SimulatorBase.setTimeStepCB``, called after
every step): touching the simulation object after ``run()`` returns crashes the wheel. Per step:

* ``iterations``: the pressure solver's iterations, ``TimeStep.getNumIterations()`` (the
  read-only parameter ``iterations`` of SPlisHSPlasH's ``TimeStep``; 0 for WCSPH, which does not
  iterate);
* ``divergence_iterations``: DFSPH's divergence-solver iterations, the read-only parameter
  ``iterationsV`` (``TimeStepDFSPH.SOLVER_ITERATIONS_V``); 0 for the other methods;
* the density error: the wheel does not expose its solvers' own error, so it is measured from the
  particles' ``density`` field (``FluidModel.getFieldBuffer("density")``) as the average over the
  particles of every fluid model of max(rho / rho0 - 1, 0), each with its model's rho0: the
  compression of the density the step computed
  (at the start of the step for WCSPH, PCISPH, IISPH and DFSPH; after the position correction for
  PBF).

The line ``SPHKIT-BENCH {json}`` carries steps, wall seconds of ``run()``, the simulated time,
and the sums of the per-step values above (the caller divides by the steps); ``maxrss`` is the
process's peak resident memory (``ru_maxrss``) and ``rss_base`` its resident memory before the
scene was loaded, in bytes.
"""

import json
import resource
import sys
import tempfile
import time

import numpy as np
import pysplishsplash as sph


def _rss() -> int:
    """Resident bytes now (Linux; 0 elsewhere)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return 1024 * int(line.split()[1])
    except OSError:
        pass
    return 0


def main() -> None:
    scene = sys.argv[1]
    rss_base = _rss()  # the process before the scene: Python, NumPy, the wheel
    base = sph.Exec.SimulatorBase()
    out = tempfile.mkdtemp(prefix="sphkit-bench-sps-")
    base.init(["bench", "--no-gui", "--output-dir", out, "--no-cache", scene], "bench")
    rec = {"steps": 0, "iterations": 0, "divergence_iterations": 0, "density_error": 0.0,
           "sim_time": 0.0, "method": None, "parameters": None}

    def on_step() -> None:
        sim = sph.Simulation.getCurrent()
        ts = sim.getTimeStep()
        if rec["method"] is None:
            rec["method"] = ts.getMethodName()
            rec["parameters"] = _parameters(ts)
        rec["steps"] += 1
        rec["iterations"] += int(ts.getNumIterations())
        if hasattr(ts, "SOLVER_ITERATIONS_V"):
            rec["divergence_iterations"] += int(ts.getValueUInt(ts.SOLVER_ITERATIONS_V))
        err, n_all = 0.0, 0
        for k in range(sim.numberOfFluidModels()):  # several fluids, elastic solids
            fm = sim.getFluidModel(k)
            n = fm.numActiveParticles()
            if n:
                rho = np.asarray(fm.getFieldBuffer("density"))[:n]
                err += float(np.sum(np.maximum(rho / fm.getDensity0() - 1.0, 0.0)))
                n_all += n
        if n_all:
            rec["density_error"] += err / n_all
        rec["sim_time"] = float(sph.TimeManager.getCurrent().getTime())

    base.setTimeStepCB(on_step)
    t0 = time.perf_counter()
    base.run()
    rec["wall"] = time.perf_counter() - t0
    rec["maxrss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
    rec["rss_base"] = rss_base
    # particle counts are parsed from the wheel's own log by the caller
    print("SPHKIT-BENCH " + json.dumps(rec), flush=True)


def _parameters(ts) -> dict:
    """The time step's parameters as SPlisHSPlasH read them from the scene (a check that the
    solver block was applied)."""
    out = {}
    for i in range(ts.numParameters()):
        kind, name = ts.getType(i), ts.getName(i)
        if kind in (ts.FLOAT, ts.DOUBLE):
            out[name] = round(float(ts.getValueFloat(i)), 9)
        elif kind == ts.UINT32:
            out[name] = int(ts.getValueUInt(i))
        elif kind == ts.BOOL:
            out[name] = bool(ts.getValueBool(i))
        elif kind in (ts.ENUM, ts.INT32):
            out[name] = int(ts.getValueInt(i))
    return out


if __name__ == "__main__":
    # the wheel prints its own timing tables to stdout; we mark our line
    main()
