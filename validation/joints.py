"""Hinge joints with target-velocity motors: SPlisHSPlasH's MotorScene and MotorScene2 unchanged.

    python validation/joints.py [--until 1.0] [--scenes MotorScene MotorScene2] [--splishsplash]

Both scenes (pysplishsplash wheel's ``data/Scenes``; DFSPH, volume maps) hinge a dynamic
paddle (RigidBodies[1], 1 x 0.1 x 0.2 m, density 10000) to the static box (RigidBodies[0], a
wall) at the origin about y, with a velocity motor: MotorScene ``target -6``, MotorScene2
the repeating sequence ``[0, -5, 1, 5, 2, -5]``. PositionBasedDynamics drives ``w_1 - w_2 =
-target a``, so the paddle turns at ``+6`` rad/s about y (sphkit's ``target_velocity`` 6).

Per scene the table gives, over the steps after ``--spin-up`` seconds: the largest deviation of
the joint's relative angular velocity about its axis (step statistics) from the target of the
step; the angle the paddle turned (from its rotation matrices, unwrapped) against the exact
integral of the sequence (the constant target, or the sequence's piecewise-linear integral), as
mean angular velocities; the largest drift of the
hinge point (paddle's anchor from the box's) and of the axis (tilt); the fluid's mean torque on
the motor about the axis; the wall time of the steps. ``--splishsplash`` also runs the scene in
SPlisHSPlasH (pysplishsplash wheel, a child process) and gives the largest difference of the
paddle's angular velocity about y between the two (sphkit's interpolated to SPlisHSPlasH's
step times), over the steps after the spin-up.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from sphkit.scene.files import load_scene
from sphkit.scene.splishsplash import wheel
from sphkit.simulation import Simulation


def scene_path(name: str) -> Path:
    path = wheel.scene_file(name)
    if path is None:
        raise SystemExit(f"the pysplishsplash wheel ships no data/Scenes/{name}.json")
    return path


def _child(name: str, until: float, out: str) -> None:
    """SPlisHSPlasH on the scene (model paths made absolute, ``stopAt`` = until): the step
    times and the paddle's (RigidBodies[1]) angular velocity into ``out`` (npz)."""
    import pysplishsplash as sph

    src = scene_path(name)
    d = json.loads(src.read_text())
    for rb in d["RigidBodies"]:
        rb["geometryFile"] = str((src.parent / rb["geometryFile"]).resolve())
    d["Configuration"]["stopAt"] = until
    folder = Path(out).parent
    path = folder / f"{name}.json"
    path.write_text(json.dumps(d))
    base = sph.Exec.SimulatorBase()
    base.init([name, "--no-gui", "--output-dir", str(folder), str(path)], name)
    rows: list = []

    def on_step() -> None:
        body = sph.Simulation.getCurrent().getBoundaryModel(1).getRigidBodyObject()
        rows.append([sph.TimeManager.getCurrent().getTime(),
                     *np.asarray(body.getAngularVelocity(), dtype=np.float64)])

    base.setTimeStepCB(on_step)
    base.run()
    np.save(out, np.array(rows))


def splishsplash(name: str, until: float) -> np.ndarray:
    """(steps, 4): SPlisHSPlasH's time and the paddle's angular velocity (:func:`_child`)."""
    env = wheel.subprocess_env(os.environ.get("OMP_NUM_THREADS", "2"))
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "w.npy")
        subprocess.run([sys.executable, __file__, "--child", name, str(until), out], env=env,
                       check=True, capture_output=True)
        return np.load(out)


def quad(jt, t0: float, t1: float, n: int = 200000) -> float:
    """The integral of the joint's target over [t0, t1] (midpoint rule, n intervals: exact to
    round-off on the linear pieces, the kinks within (t1 - t0) / n)."""
    h = (t1 - t0) / n
    return sum(jt.target(t0 + (k + 0.5) * h) for k in range(n)) * h


def run(name: str, until: float, spin_up: float, compare: bool) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        sim = Simulation(load_scene(scene_path(name)))
        build = time.perf_counter() - t0
    rb = sim.rigid
    jt = rb.joints[0]
    body = rb.bodies[jt.a]
    dev, drift, tilt, torque = 0.0, 0.0, 0.0, []
    angle, prev = 0.0, body.R.copy()
    ts, ws = [], []
    t0 = time.perf_counter()
    while sim.time < until - 1e-12:
        s = sim.step()
        j = s.rigid_bodies[jt.a]["joints"][0]
        a = body.R @ jt.axis_a
        d = body.R @ prev.T  # this step's rotation
        turn = math.atan2(0.5 * (a @ [d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]]),
                          0.5 * (np.trace(d) - 1.0))
        prev = body.R.copy()
        ts.append(s.time)
        ws.append(float(body.omega @ jt.axis_b))
        xa = body.c + body.R @ jt.anchor_a
        drift = max(drift, float(np.linalg.norm(xa - jt.anchor_b)))
        tilt = max(tilt, math.degrees(math.acos(min(1.0, abs(float(a @ jt.axis_b))))))
        if s.time - s.dt >= spin_up - 1e-12:
            tgt = j["target_velocity"]
            dev = max(dev, abs(j["relative_angular_velocity"] - tgt) / max(abs(tgt), 1e-12))
            angle += turn
            torque.append(j["motor_torque"])
    wall = time.perf_counter() - t0
    span = sim.time - spin_up
    integral = quad(jt, spin_up, sim.time)
    diff = float("nan")
    if compare:
        ref = splishsplash(name, until)
        sel = ref[:, 0] >= spin_up
        mine = np.interp(ref[sel, 0], ts, ws)
        amp = max(abs(jt.target(t)) for t in ref[sel, 0])
        diff = float(np.max(np.abs(mine - ref[sel, 1:4] @ jt.axis_b))) / amp
    return {"scene": name, "diff": diff, "steps": sim.step_count, "n": sim.fluid.n, "build": build,
            "wall": wall, "dev": dev, "w_pose": angle / span, "w_target": integral / span,
            "drift": drift, "tilt": tilt, "torque": float(np.mean(torque))}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--until", type=float, default=1.0, help="simulated time [s]")
    p.add_argument("--spin-up", type=float, default=0.1, help="left out at the start [s]")
    p.add_argument("--scenes", nargs="+", default=["MotorScene", "MotorScene2"])
    p.add_argument("--splishsplash", action="store_true",
                   help="compare with SPlisHSPlasH's angular velocity (pysplishsplash wheel)")
    p.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        _child(args.child[0], float(args.child[1]), args.child[2])
        return 0
    rows = [run(n, args.until, args.spin_up, args.splishsplash) for n in args.scenes]
    print("| scene | particles | steps | max rel. dev. of w_rel from target | mean w from poses "
          "/ mean target [rad/s] | hinge drift [m] | axis tilt [deg] | mean motor torque "
          "[N m] | build / steps wall [s] | max diff. from SPlisHSPlasH [of max target] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scene']} | {r['n']} | {r['steps']} | {r['dev']:.2e} | "
              f"{r['w_pose']:.6f} / {r['w_target']:.6f} | {r['drift']:.2e} | "
              f"{r['tilt']:.2e} | {r['torque']:.1f} | {r['build']:.1f} / {r['wall']:.1f} | "
              f"{100 * r['diff']:.2f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
