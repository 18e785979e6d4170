"""The run manifest: ``manifest.json`` beside the frames.

It records what was run (the full scene as validated, the command line), with what (sphkit and
library versions, platform), when, how it ended, and statistics per frame. It is rewritten
atomically after every frame and at the end, so that a crashed or still running simulation leaves
a valid manifest describing the frames on disk. Layout (``format_version`` 1)::

    {
      "format": "sphkit-manifest", "format_version": 1,
      "status": "running" | "finished" | "unstable" | "interrupted" | "failed",
      "message": null | "why it stopped (the instability diagnosis, the error)",
      "sphkit_version": "0.1.0",
      "versions": {"python": ..., "numpy": ..., "numba": ..., "scipy": ..., "meshio": ...,
                   "pydantic": ...},
      "platform": {"system": ..., "release": ..., "machine": ..., "python_implementation": ...,
                   "cpu_count": ...},
      "command": ["sphkit", "run", ...], "cwd": "/path",
      "started": "2025-01-01T12:00:00+00:00", "ended": null | "...", "wall_time_s": 12.3,
      "output": {"directory": ..., "formats": ["vtk"], "fps": 25.0, "dim": 3},
      "scene": {... Scene.model_dump(mode="json") ...},
      "frames": [{"frame": 0, "time": 0.0, "step": 0, "files": ["frame_00000.vtu"],
                  "n_fluid": 1000, "max_velocity": 0.0, "dt": 0.001, "cfl": null,
                  "density_error_avg": null, "density_error_max": null,
                  "iterations": null, "divergence_iterations": null, "divergence_error": null,
                  "max_displacement": null}, ...],
      "last_step": null | {"step": ..., "time": ..., "dt": ..., "n_fluid": ..., "max_velocity": ...,
                           "cfl": ..., "density_error_avg": ..., "density_error_max": ...,
                           "iterations": ..., "rejected": ..., "divergence_iterations": ...,
                           "divergence_error": ...},
      "run_stats": {"steps": 120, "mean_iterations": 3.4, "max_iterations": 7,
                    "mean_divergence_iterations": 1.1, "mean_density_error": 0.0004,
                    "max_density_error": 0.02, "mean_divergence_error": 0.0009,
                    "rejected": 0},
      "checkpoint": null | {"file": "checkpoints/checkpoint_000000120.npz", "time": ...,
                            "step": ..., "frame": ...},
      "resumed": [{"checkpoint": ..., "time": ..., "step": ..., "frame": ..., "command": [...],
                   "started": ..., "sphkit_version": ...}]   (only in resumed runs)
    }

Units: times and ``dt`` [s], ``max_velocity`` [m/s], ``max_displacement`` [m] (largest distance a
particle moved since the previous frame), density errors are fractions of the rest density (mean and
max over the fluid particles of the pressure solver's compression error, as in ``StepStats``). A
frame records the statistics of the last step before it: ``iterations`` the pressure solver's
iterations in that step (1 for WCSPH), ``divergence_iterations`` and ``divergence_error`` DFSPH's
divergence solve (0 for the other solvers); a fluid of several materials adds ``phases``: per
material its id, ``particles`` and the compression of its densities (``density_error_avg``,
``_max``, fractions of its own rest density). ``run_stats`` sums up all steps so far (see
:meth:`Manifest.add_step`): ``mean_iterations`` and ``max_iterations`` per step,
``mean_divergence_iterations`` per step, ``mean_density_error`` (the mean over steps of
``density_error_avg``), ``max_density_error`` (the largest ``density_error_max``) and
``mean_divergence_error``, and ``rejected``, the times a step was computed again with half
the step after a failed pressure solve (``configuration.time.retries``; each step's own count is
its ``rejected``). Statistics that are not known yet (before the first step) or not finite
(an exploded run) are ``null``; file names are relative to the manifest. ``checkpoint`` is the
newest checkpoint written (``sphkit run --checkpoint-every``, or at a stop by a signal); a resumed
run (``sphkit run --resume``) keeps the frames up to its checkpoint's and appends.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import json
import math
import os
import platform
import sys
import time
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.io.atomic import atomic_write_text

MANIFEST_NAME = "manifest.json"
STATUSES = ("running", "finished", "unstable", "interrupted", "failed")
_LIBRARIES = ("numpy", "numba", "scipy", "meshio", "pydantic")


def sphkit_version() -> str:
    """``sphkit.__version__`` if the package defines it, else the installed distribution's."""
    try:
        from sphkit import __version__  # type: ignore[attr-defined]

        return str(__version__)
    except ImportError:
        pass
    try:
        return importlib.metadata.version("sphkit")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def library_versions() -> dict[str, str | None]:
    """Versions of Python and the libraries a run depends on (None: not installed)."""
    out: dict[str, str | None] = {"python": platform.python_version()}
    for name in _LIBRARIES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def platform_info() -> dict[str, Any]:
    """Operating system, machine and CPU count."""
    return {
        "system": platform.system(),
        "release": platform.release(),
        "machine": platform.machine(),
        "python_implementation": platform.python_implementation(),
        "cpu_count": os.cpu_count(),
    }


def _clean(value: Any) -> Any:
    """Make ``value`` strict JSON: numpy scalars to Python, non-finite floats to None."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    return value


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


_STAT_FIELDS = ("step", "time", "dt", "n_fluid", "max_velocity", "cfl",
                "density_error_avg", "density_error_max", "iterations",
                "divergence_iterations", "divergence_error")


def stats_dict(stats: Any) -> dict[str, Any] | None:
    """A StepStats (dataclass or any object with its attributes) as a JSON-ready dict."""
    if stats is None:
        return None
    if dataclasses.is_dataclass(stats) and not isinstance(stats, type):
        d = dataclasses.asdict(stats)
    else:
        d = {k: getattr(stats, k) for k in _STAT_FIELDS if hasattr(stats, k)}
    return _clean(d)


def _number(value: Any) -> float | None:
    """``value`` as a finite float, else None (absent, None or not finite)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


class RunStats:
    """Running totals of the per-step statistics (a StepStats, or any object with its fields).

    A field a step does not report (None, absent, not finite) is left out of that field's mean;
    ``divergence_iterations`` and ``divergence_error`` count as 0 when absent (solvers without a
    divergence solve).
    """

    def __init__(self) -> None:
        self.steps = 0
        self._sums: dict[str, float] = {}
        self._counts: dict[str, int] = {}
        self.max_iterations: int | None = None
        self.max_density_error: float | None = None

    def _add(self, key: str, value: float | None) -> None:
        if value is not None:
            self._sums[key] = self._sums.get(key, 0.0) + value
            self._counts[key] = self._counts.get(key, 0) + 1

    def add(self, stats: Any) -> None:
        """Count one step."""
        self.steps += 1
        iterations = _number(getattr(stats, "iterations", None))
        self._add("iterations", iterations)
        if iterations is not None:
            self.max_iterations = max(self.max_iterations or 0, int(iterations))
        self._add("divergence_iterations",
                  _number(getattr(stats, "divergence_iterations", 0)))
        self._add("density_error", _number(getattr(stats, "density_error_avg", None)))
        self._add("divergence_error", _number(getattr(stats, "divergence_error", 0.0)))
        emax = _number(getattr(stats, "density_error_max", None))
        if emax is not None:
            self.max_density_error = max(self.max_density_error or 0.0, emax)
        self._add("rejected", _number(getattr(stats, "rejected", 0)))

    def mean(self, key: str) -> float | None:
        """Mean over the steps that reported ``key`` (iterations, divergence_iterations,
        density_error, divergence_error); None before any."""
        n = self._counts.get(key, 0)
        return self._sums[key] / n if n else None

    def state(self) -> dict[str, Any]:
        """The running totals (for a checkpoint; :meth:`from_state` continues them)."""
        return {"steps": self.steps, "sums": dict(self._sums), "counts": dict(self._counts),
                "max_iterations": self.max_iterations,
                "max_density_error": self.max_density_error}

    @classmethod
    def from_state(cls, state: dict[str, Any] | None) -> RunStats:
        """Totals saved by :meth:`state` (empty totals for None)."""
        rs = cls()
        if state:
            rs.steps = int(state["steps"])
            rs._sums = {str(k): float(v) for k, v in state["sums"].items()}
            rs._counts = {str(k): int(v) for k, v in state["counts"].items()}
            rs.max_iterations = state.get("max_iterations")
            rs.max_density_error = state.get("max_density_error")
        return rs

    def as_dict(self) -> dict[str, Any]:
        """The manifest's ``run_stats``."""
        return {
            "steps": self.steps,
            "mean_iterations": self.mean("iterations"),
            "max_iterations": self.max_iterations,
            "mean_divergence_iterations": self.mean("divergence_iterations"),
            "mean_density_error": self.mean("density_error"),
            "max_density_error": self.max_density_error,
            "mean_divergence_error": self.mean("divergence_error"),
            "rejected": int(self._sums.get("rejected", 0.0)),
        }


class Manifest:
    """``<out_dir>/manifest.json`` of one run; every change is written to disk atomically.

    ``scene`` is a :class:`sphkit.scene.schema.Scene` (anything with ``model_dump``, or a dict);
    ``command`` the command line (default ``sys.argv``); ``output`` describes the frame output
    (directory, formats, fps, dim). The file is first written by the constructor (status
    "running").
    """

    def __init__(self, out_dir: str | os.PathLike[str], scene: Any,
                 command: Sequence[str] | None = None,
                 output: dict[str, Any] | None = None) -> None:
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.path = self.out_dir / MANIFEST_NAME
        self._t0 = time.perf_counter()
        scene_data = scene.model_dump(mode="json") if hasattr(scene, "model_dump") else scene
        self.data: dict[str, Any] = {
            "format": "sphkit-manifest",
            "format_version": 1,
            "status": "running",
            "message": None,
            "sphkit_version": sphkit_version(),
            "versions": library_versions(),
            "platform": platform_info(),
            "command": list(sys.argv if command is None else command),
            "cwd": os.getcwd(),
            "started": _now(),
            "ended": None,
            "wall_time_s": 0.0,
            "output": dict(output or {}),
            "scene": scene_data,
            "frames": [],
            "last_step": None,
            "run_stats": None,
        }
        self.run_stats = RunStats()
        self.write()

    @classmethod
    def resume(cls, out_dir: str | os.PathLike[str], frame: int,
               command: Sequence[str] | None = None, run_stats: RunStats | None = None,
               note: dict[str, Any] | None = None) -> Manifest:
        """Continue the manifest of ``out_dir`` after its frame ``frame`` (a resumed run): later
        frame records are dropped (they are written again), the status is "running" again, and
        ``resumed`` lists each resume (``note``, the command and when). ``wall_time_s`` keeps
        counting from the earlier runs' total."""
        self = cls.__new__(cls)
        self.out_dir = Path(out_dir)
        self.path = self.out_dir / MANIFEST_NAME
        self.data = read_manifest(self.path)
        wall = float(self.data.get("wall_time_s") or 0.0)
        self._t0 = time.perf_counter() - wall
        self.data["frames"] = [r for r in self.data.get("frames", []) if r["frame"] <= frame]
        self.data.update(status="running", message=None, ended=None)
        self.data.setdefault("resumed", []).append({
            **(note or {}), "command": list(sys.argv if command is None else command),
            "started": _now(), "sphkit_version": sphkit_version()})
        self.run_stats = run_stats or RunStats()
        self.write()
        return self

    @property
    def status(self) -> str:
        """The current status (one of :data:`STATUSES`)."""
        return str(self.data["status"])

    @property
    def frames(self) -> list[dict[str, Any]]:
        """The per-frame records so far."""
        return self.data["frames"]

    def add_step(self, stats: Any) -> None:
        """Count a time step's statistics (a StepStats) into ``run_stats``; the file is not
        rewritten here but with the next frame or at the end."""
        self.run_stats.add(stats)

    def write(self) -> Path:
        """Write the manifest now (atomically); return its path."""
        self.data["wall_time_s"] = round(time.perf_counter() - self._t0, 3)
        if self.run_stats.steps:
            self.data["run_stats"] = self.run_stats.as_dict()
        text = json.dumps(_clean(self.data), indent=1, allow_nan=False)
        return atomic_write_text(self.path, text + "\n")

    def add_frame(self, sim: Any, frame: int, files: Sequence[str | os.PathLike[str]],
                  max_displacement: float | None = None,
                  body_files: Sequence[str | os.PathLike[str]] = ()) -> dict[str, Any]:
        """Record a written frame of ``sim`` and rewrite the manifest; return the record.
        ``body_files``: the frame's rigid-body meshes (:mod:`sphkit.io.bodies`).

        Statistics come from ``sim.last`` (the StepStats of the last step) where a step was
        taken, else from the particles (``max_velocity``) or are null (density errors).
        """
        last = getattr(sim, "last", None)
        fluid = sim.fluid
        if last is not None:
            vmax = last.max_velocity
        elif fluid.n and "v" in fluid:
            vmax = float(np.sqrt((np.asarray(fluid["v"], dtype=float) ** 2).sum(axis=0)).max())
        else:
            vmax = 0.0
        record = {
            "frame": int(frame),
            "time": float(sim.time),
            "step": int(sim.step_count),
            "files": [self._relative(f) for f in files],
            "n_fluid": int(fluid.n),
            "max_velocity": vmax,
            "dt": getattr(sim, "dt", None),
            "cfl": getattr(last, "cfl", None),
            "density_error_avg": getattr(last, "density_error_avg", None),
            "density_error_max": getattr(last, "density_error_max", None),
            "iterations": getattr(last, "iterations", None),
            "divergence_iterations": (None if last is None
                                      else getattr(last, "divergence_iterations", 0)),
            "divergence_error": None if last is None else getattr(last, "divergence_error", 0.0),
            "max_displacement": max_displacement,
        }
        if getattr(last, "rigid_bodies", None):  # moving bodies: fluid force, torque, pose
            record["rigid_bodies"] = last.rigid_bodies
        if body_files:
            record["body_files"] = [self._relative(f) for f in body_files]
        if getattr(last, "phases", None):  # several fluids: particles, density error each
            record["phases"] = last.phases
        self.data["frames"].append(_clean(record))
        self.data["last_step"] = stats_dict(last)
        self.write()
        return self.data["frames"][-1]

    def finish(self, status: str, message: str | None = None, stats: Any = None) -> Path:
        """Set the final ``status`` (with ``message``, e.g. the diagnosis) and write the manifest.

        ``stats`` (a StepStats, e.g. the last step's or an InstabilityError's) is recorded as
        ``last_step`` if given.
        """
        if status not in STATUSES:
            raise ValueError(f"manifest status {status!r}; expected one of {', '.join(STATUSES)}")
        self.data["status"] = status
        self.data["message"] = message
        self.data["ended"] = _now()
        if stats is not None:
            self.data["last_step"] = stats_dict(stats)
        return self.write()

    def _relative(self, f: str | os.PathLike[str]) -> str:
        p = Path(f)
        try:
            return p.relative_to(self.out_dir).as_posix()
        except ValueError:
            return str(p)


def read_manifest(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a manifest (``path`` is the file or its folder)."""
    p = Path(path)
    if p.is_dir():
        p = p / MANIFEST_NAME
    with open(p, encoding="utf-8") as f:
        return json.load(f)
