"""Evaluation of a learned simulator on a dataset split (``sphkit learn eval``).

Each trajectory of the split is rolled out from its first ``input_seq_length`` (6) frames to its
end, by the model and by the constant-velocity baseline ``x[t+1] = 2 x[t] - x[t-1]``, and
compared with the solver's frames:

* **Position MSE** of the fluid particles (mean over particles and coordinates, m^2) at every
  rollout step; ``MSE_k`` is its mean over the first k steps, as LagrangeBench's ``mse5`` /
  ``mse20`` / full-rollout MSE, for k = 1, 5, 20 and the full horizon (averaged over
  trajectories).
* **Kinetic energy** per unit mass, ``0.5 mean |v|^2`` [J/kg] with ``v = (x[t] - x[t-1]) / dt``,
  over time (model, baseline, solver); summarised by the mean absolute difference to the solver's
  relative to the solver's mean.
* **Density error** over time: the mean over the fluid of ``|rho / rho0 - 1|`` with the SPH
  density of :func:`~sphkit.learn.rollout.sph_density` (sphkit's cubic kernel, h = 2 dx, every
  particle with the lattice volume), evaluated the same way on the model's, the baseline's and
  the solver's positions. The solver's value is the floor (its own compression with the same
  estimator, about 1 % for WCSPH); a rollout that bunches or tears the fluid shows up above it.
  Relative to rho0 rather than to the solver's density, because particle i of a rollout drifts
  away from particle i of the solver and a per-particle comparison would measure that drift
  twice.
* **Inside the tank**: the largest number of fluid particles outside ``bounds`` at any step.
* **Wall collisions** (``collisions``, on by default as in ``sphkit learn rollout``): the
  model's and the baseline's fluid particles collide with the wall particles after every step
  (:mod:`sphkit.learn.walls`); ``collisions=False`` (``--no-collisions``) measures the network
  and the baseline alone.
* **Later starts** (``starts``, default 8): rollouts from the start of a trajectory begin with
  its most violent transient (in the dam break: the column's free fall and impact on the
  floor), so ``MSE_20`` is also measured on 20-step rollouts started at ``starts`` evenly
  spaced frames of each trajectory (the first one at its beginning), model and baseline alike,
  and reported beside the LagrangeBench-style numbers, never instead of them.

Writes ``eval.json`` (the numbers and the per-step curves) and, with matplotlib, ``mse.png``,
``energy.png`` and ``density.png``; the table is printed either way.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.io.atomic import atomic_write_text
from sphkit.learn.data import INPUT_SEQ_LENGTH, load_split, read_metadata
from sphkit.learn.rollout import constant_velocity, outside, rollout, sph_density
from sphkit.learn.walls import WallCollision

HORIZONS = (1, 5, 20)


def kinetic_energy(x: np.ndarray, dt: float) -> np.ndarray:
    """``0.5 mean |v|^2`` [J/kg] per frame of positions (T, N, dim), v by backward difference
    (T - 1 values)."""
    v = (x[1:] - x[:-1]) / dt
    return 0.5 * (v ** 2).sum(axis=2).mean(axis=1)


def density_error(x: np.ndarray, walls: np.ndarray, dx: float) -> np.ndarray:
    """Mean ``|rho / rho0 - 1|`` of the fluid positions per frame (T, N, dim)."""
    return np.array([float(np.abs(sph_density(f, walls, dx) - 1.0).mean()) for f in x])


def cumulative(mse: np.ndarray, k: int) -> float:
    """Mean of the per-step MSE over the first k steps (all of them when fewer)."""
    return float(mse[:k].mean())


def evaluate(model: str | os.PathLike[str], dataset: str | os.PathLike[str],
             split: str = "test", out: str | os.PathLike[str] | None = None,
             limit: int | None = None, device: str = "cpu", starts: int = 8,
             say: Callable[[str], None] | None = None,
             check_interrupt: Callable[[], None] | None = None,
             collisions: bool = True) -> dict[str, Any]:
    """Evaluate the checkpoint ``model`` on ``dataset/<split>.h5``; return the results (also
    written to ``out/eval.json`` with the plots when ``out`` is given). ``collisions``: the
    model's and the baseline's fluid collide with the wall particles
    (:mod:`sphkit.learn.walls`); off, both move freely (the network alone)."""
    from sphkit.learn.train import load_simulator

    say = say or print
    simulator, ckpt = load_simulator(model, device)
    meta = read_metadata(dataset)
    if int(meta["dim"]) != int(ckpt["metadata"]["dim"]):
        raise ValueError(f"the dataset is {meta['dim']}D, the model was trained on "
                         f"{ckpt['metadata']['dim']}D data")
    dt = float(meta["dt"])
    dx = float(meta.get("dx") or ckpt["metadata"].get("dx"))
    trajs = load_split(dataset, split, limit=limit)
    per: list[dict[str, Any]] = []
    for tr in trajs:
        pos = tr.position.astype(np.float64)
        T = pos.shape[0]
        steps = T - INPUT_SEQ_LENGTH
        if steps < 1:
            continue
        fluid = tr.fluid
        walls = pos[0, ~fluid]
        hist = pos[:INPUT_SEQ_LENGTH]
        collide = WallCollision(walls, dx) if collisions else None

        def tick(k: int, x: np.ndarray) -> bool:
            if check_interrupt is not None:
                check_interrupt()
            return not np.all(np.isfinite(x))

        pred = rollout(simulator, hist, tr.particle_type, steps, tick, collide)
        if len(pred) < steps:  # the model blew up: count the rest as lost at the last state
            pred = np.concatenate([pred, np.repeat(pred[-1:], steps - len(pred), axis=0)])
        cv = constant_velocity(hist, tr.particle_type, steps, collide)
        gt = pos[INPUT_SEQ_LENGTH:]
        err = {name: ((p[:, fluid] - gt[:, fluid]) ** 2).mean(axis=(1, 2))
               for name, p in (("model", pred), ("cv", cv))}
        full = {name: np.concatenate([pos[INPUT_SEQ_LENGTH - 1:INPUT_SEQ_LENGTH], p])[:, fluid]
                for name, p in (("model", pred), ("cv", cv), ("solver", gt))}
        ek = {name: kinetic_energy(p, dt) for name, p in full.items()}
        rho = {name: density_error(p[1:], walls, dx) for name, p in full.items()}
        n_out = [outside(p, meta["bounds"]) for p in pred[:, fluid]]
        later = {"model": [], "cv": []}
        horizon = min(20, steps)
        for t0 in np.linspace(0, T - INPUT_SEQ_LENGTH - horizon, max(starts, 1)).astype(int):
            h0 = pos[t0:t0 + INPUT_SEQ_LENGTH]
            ref = pos[t0 + INPUT_SEQ_LENGTH:t0 + INPUT_SEQ_LENGTH + horizon, fluid]
            for name, p in (("model", rollout(simulator, h0, tr.particle_type, horizon, tick,
                                              collide)),
                            ("cv", constant_velocity(h0, tr.particle_type, horizon, collide))):
                p = p if len(p) == horizon else np.concatenate(
                    [p, np.repeat(p[-1:], horizon - len(p), axis=0)])
                later[name].append(float(((p[:, fluid] - ref) ** 2).mean()))
        ek_ref = max(float(np.mean(ek["solver"])), 1e-30)
        per.append({
            "trajectory": tr.name, "particles": int(fluid.sum()), "steps": steps,
            "mse": {name: {**{f"{k}": cumulative(e, k) for k in HORIZONS},
                           "full": float(e.mean())} for name, e in err.items()},
            "mse_per_step": {name: e.tolist() for name, e in err.items()},
            "kinetic_energy": {name: e.tolist() for name, e in ek.items()},
            "kinetic_energy_error": {name: float(np.mean(np.abs(ek[name] - ek["solver"])) / ek_ref)
                                     for name in ("model", "cv")},
            "density_error": {name: r.tolist() for name, r in rho.items()},
            "mean_density_error": {name: float(np.mean(r)) for name, r in rho.items()},
            "max_outside": int(max(n_out)), "finite": bool(np.all(np.isfinite(pred))),
            "mse_20_later_starts": {name: float(np.mean(v)) for name, v in later.items()},
        })
        say(f"{split} {tr.name}: {int(fluid.sum())} fluid particles, {steps} steps; MSE_20 "
            f"model {per[-1]['mse']['model']['20']:.3g} vs constant velocity "
            f"{per[-1]['mse']['cv']['20']:.3g} m^2; outside the bounds: {max(n_out)}")
    if not per:
        raise ValueError(f"{split}: no trajectory longer than {INPUT_SEQ_LENGTH} frames")
    keys = [str(k) for k in HORIZONS] + ["full"]
    summary = {
        "model": str(model), "dataset": str(dataset), "split": split,
        "trajectories": len(per), "trained_steps": int(ckpt["step"]), "frame_dt": dt,
        "wall_collisions": collisions,
        "mse": {name: {k: float(np.mean([p["mse"][name][k] for p in per])) for k in keys}
                for name in ("model", "cv")},
        "kinetic_energy_error": {name: float(np.mean([p["kinetic_energy_error"][name]
                                                      for p in per])) for name in ("model", "cv")},
        "mean_density_error": {name: float(np.mean([p["mean_density_error"][name] for p in per]))
                               for name in ("model", "cv", "solver")},
        "max_outside": int(max(p["max_outside"] for p in per)),
        "starts": starts,
        "mse_20_later_starts": {name: float(np.mean([p["mse_20_later_starts"][name]
                                                     for p in per])) for name in ("model", "cv")},
        "per_trajectory": per,
    }
    summary["mse_ratio_cv_over_model"] = {
        k: summary["mse"]["cv"][k] / max(summary["mse"]["model"][k], 1e-300) for k in keys}
    for line in table(summary):
        say(line)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "eval.json", json.dumps(summary, indent=1) + "\n")
        plotted = plots(summary, out)
        say(f"wrote {out / 'eval.json'}" + (f" and {', '.join(plotted)}" if plotted else
                                              " (no plots: matplotlib is not installed)"))
    return summary


def table(s: dict[str, Any]) -> list[str]:
    """The printed summary: MSE at 1, 5, 20 steps and the full horizon, model vs baseline."""
    keys = [str(k) for k in HORIZONS] + ["full"]
    head = f"{'position MSE [m^2]':<24}" + "".join(f"{'MSE_' + k:>12}" for k in keys)
    rows = [head]
    for name, label in (("model", "GNS"), ("cv", "constant velocity")):
        rows.append(f"{label:<24}" + "".join(f"{s['mse'][name][k]:>12.3e}" for k in keys))
    rows.append(f"{'baseline / GNS':<24}" + "".join(
        f"{s['mse_ratio_cv_over_model'][k]:>12.2f}" for k in keys))
    ls = s["mse_20_later_starts"]
    rows.append(f"MSE_20 of 20-step rollouts from {s['starts']} start frames per trajectory: GNS "
                f"{ls['model']:.3e}, constant velocity {ls['cv']:.3e} (baseline / GNS "
                f"{ls['cv'] / max(ls['model'], 1e-300):.2f})")
    ke, de = s["kinetic_energy_error"], s["mean_density_error"]
    rows.append(f"kinetic energy error (mean |E - E_solver| / mean E_solver): GNS "
                f"{ke['model']:.3g}, constant velocity {ke['cv']:.3g}")
    rows.append(f"density error (mean |rho/rho0 - 1|): GNS {de['model']:.3g}, constant velocity "
                f"{de['cv']:.3g}, solver {de['solver']:.3g}")
    rows.append(f"fluid particles outside the bounds (most at any step): {s['max_outside']}; "
                f"wall collisions {'on' if s.get('wall_collisions', False) else 'off'}")
    return rows


def plots(s: dict[str, Any], out: Path) -> list[str]:
    """MSE, kinetic energy and density error over time (the first trajectory for the last two)
    as PNGs; [] without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return []
    written = []
    dt = s["frame_dt"]
    p0 = s["per_trajectory"][0]
    labels = {"model": "GNS", "cv": "constant velocity", "solver": "solver"}
    fig, ax = plt.subplots(figsize=(6, 4))
    for name in ("model", "cv"):
        curve = np.mean([p["mse_per_step"][name] for p in s["per_trajectory"]
                         if p["steps"] == p0["steps"]], axis=0)
        ax.semilogy(np.arange(1, len(curve) + 1), curve, label=labels[name])
    ax.set(xlabel="rollout step", ylabel="position MSE [m^2]", title="rollout error")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "mse.png", dpi=100)
    plt.close(fig)
    written.append("mse.png")
    for key, ylabel, fname in (("kinetic_energy", "kinetic energy [J/kg]", "energy.png"),
                               ("density_error", "mean |rho/rho0 - 1|", "density.png")):
        fig, ax = plt.subplots(figsize=(6, 4))
        for name in ("solver", "model", "cv"):
            y = np.asarray(p0[key][name])
            ax.plot(dt * np.arange(1, len(y) + 1), y, label=labels[name])
        ax.set(xlabel="time after the input frames [s]", ylabel=ylabel,
               title=f"{key.replace('_', ' ')} ({s['split']} {p0['trajectory']})")
        if key == "density_error":
            ax.set_ylim(0, max(0.2, 2 * max(p0[key]["solver"])))
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / fname, dpi=100)
        plt.close(fig)
        written.append(fname)
    return written
