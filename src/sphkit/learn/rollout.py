"""Autoregressive rollouts of a learned simulator, from stored frames or from a scene.

:func:`rollout` advances a history of ``input_seq_length`` (6) positions step by step with a
:class:`~sphkit.learn.sanchez_gonzalez2020.LearnedSimulator` (non-fluid particles stay where
they are); :func:`constant_velocity` is the baseline ``x[t+1] = 2 x[t] - x[t-1]``.

:func:`rollout_scene` starts from a scene instead: the world is built as ``sphkit run`` builds
it (:class:`sphkit.simulation.Simulation`: fluid blocks, walls, initial velocities), the history
is seeded with the positions the initial velocities imply, ``x[-k] = x[0] - k v0 dt`` for
k = 5..0 (``dt`` the dataset's frame interval), and the rollout is written frame by frame like a
simulation (:class:`sphkit.io.frames.FrameWriter` and :class:`sphkit.io.manifest.Manifest`), so
``sphkit render OUT`` and ``sphkit surface OUT`` work on it. The frames carry the velocity
``(x[t] - x[t-1]) / dt`` and the SPH density of the predicted particles (:func:`sph_density`);
the pressure is zero (the network predicts none).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.core.kernels import Kernel, lattice_volume
from sphkit.core.neighbors import Grid
from sphkit.io.datasets import fluid_particle_types
from sphkit.learn.data import INPUT_SEQ_LENGTH, WALL, is_fluid
from sphkit.learn.walls import WallCollision


class RolloutError(RuntimeError):
    """A rollout that cannot start (a scene the model was not trained for)."""


def rollout(simulator: Any, history: np.ndarray, particle_type: np.ndarray, steps: int,
            on_step: Callable[[int, np.ndarray], bool] | None = None,
            collide: WallCollision | None = None) -> np.ndarray:
    """Positions (steps, N, dim) after ``history`` (W, N, dim), W >= 6 frames; ``on_step(k,
    x)`` after each step may return True to stop (the result is then shorter); ``collide``
    moves the fluid's predicted positions out of the walls (:mod:`sphkit.learn.walls`)."""
    hist = np.asarray(history, dtype=np.float64)[-INPUT_SEQ_LENGTH:].transpose(1, 0, 2).copy()
    fluid = is_fluid(particle_type)
    out = []
    for k in range(steps):
        nxt = simulator.step(hist, particle_type)
        if collide is not None:
            nxt[fluid] = collide(hist[fluid, -1], nxt[fluid])
        out.append(nxt)
        hist = np.concatenate([hist[:, 1:], nxt[:, None]], axis=1)
        if on_step is not None and on_step(k + 1, nxt):
            break
    dim = hist.shape[2]
    return np.stack(out) if out else np.zeros((0, hist.shape[0], dim))


def constant_velocity(history: np.ndarray, particle_type: np.ndarray, steps: int,
                      collide: WallCollision | None = None) -> np.ndarray:
    """The baseline ``x[t+1] = 2 x[t] - x[t-1]`` (non-fluid particles fixed): (steps, N, dim);
    with ``collide``, step by step with the same wall collisions as a model's rollout."""
    x1, x0 = np.asarray(history[-1], np.float64), np.asarray(history[-2], np.float64)
    fluid = is_fluid(particle_type)
    v = np.where(fluid[:, None], x1 - x0, 0.0)
    if collide is None:
        k = np.arange(1, steps + 1, dtype=np.float64)[:, None, None]
        return x1[None] + k * v[None]
    out = np.empty((steps,) + x1.shape)
    for k in range(steps):
        nxt = x1 + v
        nxt[fluid] = collide(x1[fluid], nxt[fluid])
        x1, v = nxt, nxt - x1
        out[k] = nxt
    return out


def sph_density(fluid: np.ndarray, walls: np.ndarray, dx: float,
                kernel: str = "cubic") -> np.ndarray:
    """Density of the fluid particles as a fraction of the rest density, ``V sum_j W(x_i - x_j,
    h)`` over fluid and wall particles (self included), with sphkit's defaults: support radius
    ``h = 2 dx`` (= 4 r) and the lattice volume ``V`` that gives exactly 1 on a regular lattice of
    spacing ``dx`` (:func:`sphkit.core.kernels.lattice_volume`). Wall particles count as
    lattice particles of the same volume (sphkit's walls have lattice spacing too)."""
    fluid = np.asarray(fluid, dtype=np.float64)
    if len(fluid) == 0:
        return np.zeros(0)
    dim = fluid.shape[1]
    h = 2.0 * dx
    pts = np.concatenate([fluid, np.asarray(walls, dtype=np.float64).reshape(-1, dim)])
    nl = Grid(np.ascontiguousarray(pts.T), h).query(np.ascontiguousarray(fluid.T))
    rows = np.repeat(np.arange(len(fluid)), np.diff(nl.offsets))
    r = np.linalg.norm(fluid[rows] - pts[nl.indices], axis=1)
    w = Kernel(kernel, h, dim).w(r)
    return lattice_volume(dx, kernel, h, dim) * np.bincount(rows, weights=w, minlength=len(fluid))


def outside(x: np.ndarray, bounds: Sequence[Sequence[float]]) -> int:
    """How many points of ``x`` (N, dim) lie outside the box ``bounds`` or are not finite."""
    b = np.asarray(bounds, dtype=np.float64)
    ok = np.all((x >= b[:, 0]) & (x <= b[:, 1]), axis=1) & np.all(np.isfinite(x), axis=1)
    return int((~ok).sum())


class _FrameSource:
    """What FrameWriter and Manifest read from a simulation: the fluid ParticleSet of the
    scene's world, with the predicted positions, velocities and densities written into it."""

    def __init__(self, sim: Any) -> None:
        self.fluid = sim.fluid
        self.time = 0.0
        self.step_count = 0
        self.dt: float | None = None
        self.last = None
        self.order = np.argsort(np.asarray(self.fluid["id"]), kind="stable")

    def set(self, x: np.ndarray, v: np.ndarray, rho: np.ndarray | None) -> None:
        """Positions and velocities (N, dim) in id order; densities as fractions of rho0."""
        f = self.fluid
        f["x"][:, self.order] = x.T
        f["v"][:, self.order] = v.T
        if rho is not None and "rho" in f:
            f["rho"][self.order] = rho * np.asarray(f["rho0"])[self.order] \
                if "rho0" in f else rho


def rollout_scene(model: str | os.PathLike[str], scene: Any, out: str | os.PathLike[str],
                  steps: int | None = None, until: float | None = None,
                  formats: Sequence[str] | None = None, command: Sequence[str] | None = None,
                  device: str = "cpu", say: Callable[[str], None] | None = None,
                  check_interrupt: Callable[[], None] | None = None,
                  collisions: bool = True) -> dict[str, Any]:
    """Roll the model out from the initial state of ``scene`` (a Scene) and write its frames
    and ``manifest.json`` into ``out``; ``collisions``: the fluid collides with the wall particles
    (:mod:`sphkit.learn.walls`). Returns a summary (frames, particles outside the bounds,
    status)."""
    from sphkit.io.frames import FrameWriter
    from sphkit.io.manifest import Manifest
    from sphkit.learn.train import load_simulator
    from sphkit.simulation import Simulation

    say = say or (lambda text: None)
    simulator, ckpt = load_simulator(model, device)
    meta = ckpt["metadata"]
    sim = Simulation.from_scene(scene)
    dim = sim.dim
    if dim != int(meta["dim"]):
        raise RolloutError(f"the scene is {dim}D, the model was trained on {meta['dim']}D data")
    spacing = 2.0 * float(scene.configuration.particle_radius)
    dx = float(meta.get("dx") or spacing)
    if not math.isclose(spacing, dx, rel_tol=1e-3):
        raise RolloutError(
            f"configuration.particle_radius: the scene's particle spacing is {spacing:g} m, the "
            f"model was trained on dx = {dx:g} m; a learned simulator works at its training "
            f"resolution only (set particle_radius to {dx / 2:g})")
    if sim.rigid.bodies:
        raise RolloutError("the scene has rigid bodies; the learned simulator moves fluid only "
                           "(walls are static)")
    dt = float(meta["dt"])
    if steps is None:
        t_end = float(until if until is not None else scene.configuration.time.until)
        steps = max(1, int(round(t_end / dt)))
    src = _FrameSource(sim)
    order = src.order
    fx = np.asarray(sim.fluid.view("x"), dtype=np.float64)[order]
    fv = np.asarray(sim.fluid.view("v"), dtype=np.float64)[order]
    walls = np.asarray(sim.boundary.view("x"), dtype=np.float64).reshape(-1, dim)
    nf = len(fx)
    x0 = np.concatenate([fx, walls])
    v0 = np.concatenate([fv, np.zeros_like(walls)])
    ptype = np.concatenate([fluid_particle_types(sim.fluid, order),
                            np.full(len(walls), WALL)]).astype(np.int64)
    history = np.stack([x0 - k * dt * v0 for k in range(INPUT_SEQ_LENGTH - 1, -1, -1)])
    formats = list(formats or scene.output.formats)
    out = Path(out)
    writer = FrameWriter(out, formats, dim)
    fps = 1.0 / dt
    manifest = Manifest(out, scene, command=command,
                        output={"directory": str(out), "formats": formats, "fps": fps,
                                "dim": dim, "attributes": None,
                                "series": writer.series_path.name if "vtk" in formats else None})
    manifest.data["learned"] = {"model": str(Path(model).resolve()), "step": ckpt["step"],
                                "dataset": ckpt.get("dataset"), "steps": steps,
                                "frame_dt": dt, "method": "sanchez_gonzalez2020",
                                "wall_collisions": collisions}
    bounds = meta["bounds"]
    worst = {"outside": 0}

    def write(k: int, x: np.ndarray, prev: np.ndarray) -> None:
        rho = sph_density(x[:nf], walls, dx, scene.configuration.kernel) if nf else None
        src.set(x[:nf], (x[:nf] - prev[:nf]) / dt, rho)
        src.time, src.step_count, src.dt = k * dt, k, dt
        files = writer.write(src, k)
        rec = manifest.add_frame(src, k, files, max_displacement=writer.max_displacement)
        n_out = outside(x[:nf], bounds)
        rec["n_outside"] = n_out
        worst["outside"] = max(worst["outside"], n_out)

    write(0, x0, history[-2])
    say(f"scene {scene.name!r}: {nf} fluid and {len(walls)} wall particles, {dim}D; "
        f"{steps} learned steps of {dt:g} s into {out}")
    status, message = "finished", None
    prev = {"x": x0}

    def on_step(k: int, x: np.ndarray) -> bool:
        nonlocal status, message
        if check_interrupt is not None:
            check_interrupt()
        if not np.all(np.isfinite(x)):
            status, message = "unstable", f"non-finite positions at step {k}"
            return True
        write(k, x, prev["x"])
        prev["x"] = x
        if k % max(1, steps // 10) == 0:
            say(f"step {k}/{steps}  t = {k * dt:.4g} s  outside the bounds: "
                f"{manifest.frames[-1]['n_outside']}")
        return False

    try:
        rollout(simulator, history, ptype, steps, on_step,
                WallCollision(walls, dx) if collisions else None)
    except KeyboardInterrupt:
        manifest.finish("interrupted", "interrupted (Ctrl-C)")
        raise
    manifest.data["learned"]["max_outside"] = worst["outside"]
    manifest.finish(status, message)
    return {"frames": len(manifest.frames), "status": status, "message": message,
            "max_outside": worst["outside"], "out": str(out)}
