"""Checkpoints and resumed runs of ``sphkit run`` (``--checkpoint-every``, ``--resume``).

``sphkit run SCENE --checkpoint-every T`` writes a checkpoint (:mod:`sphkit.io.checkpoint`) into
``<out>/checkpoints/`` every T simulated seconds (after the step that reaches the time, once its
frames are written) and at the end; the newest ``--keep-checkpoints`` (2) are kept. A run stopped
by SIGINT or SIGTERM writes one after its current step whatever the flags. The manifest records
the newest as ``checkpoint``.

``sphkit run --resume DIR [--until T]`` continues the run in output folder DIR from its newest
checkpoint that can be read and restored (a warning names each newer one that cannot; none:
exit 2 naming the files): the scene, frame rate, formats, attributes and checkpoint interval
are the stored ones (only the end time and the interval may change), frames after the
checkpoint's last frame are dropped and written again, new frames and manifest records are
appended, ``sphkit.log`` is appended to, and the manifest lists the resume under ``resumed``.
On the CPU the continued run equals the uninterrupted one bit for bit when sphkit, its
libraries and the thread count (``NUMBA_NUM_THREADS``) are the same; the command warns when
they differ.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sphkit.cli.common import EXIT_USAGE, error, watch_compiles
from sphkit.io.checkpoint import (
    CHECKPOINT_DIR,
    Checkpoint,
    CheckpointError,
    checkpoint_path,
    list_checkpoints,
    read_checkpoint,
    version_differences,
)
from sphkit.io.log import get_logger
from sphkit.io.manifest import Manifest, RunStats, read_manifest


@dataclass
class Resume:
    """A run to continue: its simulation restored from ``checkpoint`` and its output settings."""

    scene: Any
    sim: Any
    out_dir: Path
    checkpoint: Checkpoint
    fps: float
    formats: list[str]
    attributes: list[str] | None
    run_stats: RunStats
    messages: list[str] = field(default_factory=list)

    def manifest(self, command: Sequence[str]) -> Manifest:
        """The folder's manifest, continued after the checkpoint's frame; frame files of later
        frames (a run killed after its checkpoint) are removed, they are written again."""
        ck = self.checkpoint
        old = read_manifest(self.out_dir)
        for rec in old.get("frames", []):
            if rec["frame"] > ck.frame:
                for name in rec.get("files", []):
                    p = Path(name)
                    if not p.is_absolute() and len(p.parts) == 1:
                        (self.out_dir / p).unlink(missing_ok=True)
        note = {"checkpoint": _relative(ck.path, self.out_dir), "time": ck.time,
                "step": ck.step_count, "frame": ck.frame}
        return Manifest.resume(self.out_dir, ck.frame, command, self.run_stats, note)


def _relative(path: Path, folder: Path) -> str:
    try:
        return path.resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:
        return str(path)


def prepare_resume(args: argparse.Namespace, argv: Sequence[str]) -> Resume | int:
    """Restore the run in ``args.resume`` from its newest checkpoint that reads and restores (a
    warning names each newer one that does not), or print why not and return the exit code
    (2)."""
    from sphkit.scene.schema import SceneError
    from sphkit.simulation import Simulation

    watch_compiles(args)  # restoring the world compiles on a first run too

    out_dir = Path(args.resume)
    given = [name for name, value in (("SCENE", args.scene), ("--fps", args.fps),
                                      ("--format", args.formats),
                                      ("--max-particles", args.max_particles),
                                      ("--precision", args.precision))
             if value is not None]
    if given:
        error(f"--resume {str(out_dir)!r}: got {', '.join(given)} too; expected only --until "
               "(the run continues with the scene, frame rate and formats stored in its folder)")
        return EXIT_USAGE
    if args.out is not None and Path(args.out).resolve() != out_dir.resolve():
        error(f"--out {str(args.out)!r} with --resume {str(out_dir)!r}: a resumed run writes "
               "into its own folder; expected no --out (or the same folder)")
        return EXIT_USAGE
    if not out_dir.is_dir():
        error(f"--resume {str(out_dir)!r}: not a folder; expected the output folder of a run")
        return EXIT_USAGE
    try:
        old = read_manifest(out_dir)
    except (OSError, ValueError) as e:
        error(f"--resume {str(out_dir)!r}: no readable manifest.json ({e}); expected the output "
               "folder of a sphkit run")
        return EXIT_USAGE
    found = list_checkpoints(out_dir)
    if not found:
        error(f"--resume {str(out_dir)!r}: no checkpoint found (expected files "
              f"{CHECKPOINT_DIR}/checkpoint_<step>.npz); runs write checkpoints with "
              "--checkpoint-every and when Ctrl-C or SIGTERM stops them")
        return EXIT_USAGE
    ck = sim = None
    skipped = []
    for path in reversed(found):  # the newest that reads and restores
        try:
            ck = read_checkpoint(path)
            sim = Simulation.from_checkpoint(ck)
            break
        except CheckpointError as e:
            skipped.append(str(e))
            get_logger("cli").warning("--resume: checkpoint skipped: %s", e)
        except (SceneError, OSError) as e:
            error(f"--resume {str(out_dir)!r}: the scene of checkpoint {str(path)!r} cannot be "
                  f"rebuilt:\n{e}")
            return EXIT_USAGE
    if sim is None or ck is None:
        error(f"--resume {str(out_dir)!r}: none of its {len(found)} checkpoint(s) can be "
              f"restored: {'; '.join(skipped[:3])}{'; ...' if len(skipped) > 3 else ''}")
        return EXIT_USAGE
    scene = sim.scene
    if args.checkpoint_every is None:  # keep the interval of the run being continued
        args.checkpoint_every = ck.extra.get("checkpoint_every")
    if args.until is not None:
        scene.configuration.time.until = args.until
    output = old.get("output") or {}
    messages = [f"resuming {str(out_dir)!r} from {_relative(ck.path, out_dir)}: t = "
                f"{ck.time:.6g} s, step {ck.step_count}, frame {ck.frame}"
                + (f" (the {len(skipped)} newer checkpoint(s) could not be restored)"
                   if skipped else "")]
    diffs = version_differences(ck.meta)
    if diffs:
        text = (f"the checkpoint was written with other versions or thread counts "
                f"({'; '.join(diffs)}): the continued run may differ from an uninterrupted one "
                "in the last bits")
        get_logger("cli").warning(text)
    if scene.configuration.time.until <= ck.time:
        messages.append(f"the run already reached t = {ck.time:.6g} s >= until = "
                        f"{scene.configuration.time.until:g} s; nothing to do (extend it with "
                        "--until)")
    return Resume(
        scene=scene, sim=sim, out_dir=out_dir, checkpoint=ck,
        fps=float(output.get("fps") or scene.output.fps),
        formats=list(output.get("formats") or scene.output.formats),
        attributes=output.get("attributes", scene.output.attributes),
        run_stats=RunStats.from_state(ck.extra.get("run_stats")), messages=messages,
    )


class CheckpointSchedule:
    """Writes checkpoints of ``sim`` into ``out_dir/checkpoints`` every ``every`` simulated
    seconds (None: only when :meth:`write` is called) and records them in the manifest."""

    def __init__(self, out_dir: Path, sim: Any, manifest: Manifest, every: float | None,
                 keep: int = 2) -> None:
        self.out_dir = Path(out_dir)
        self.manifest = manifest
        self.every = every
        self.keep = keep
        self.next = math.inf if every is None else self._after(sim.time)

    def _after(self, t: float) -> float:
        return (math.floor(t / self.every + 1e-9) + 1) * self.every

    def after_step(self, sim: Any) -> None:
        """Write a checkpoint when the run passed the next checkpoint time."""
        if sim.time >= self.next - 1e-12:
            self.write(sim)
            self.next = self._after(sim.time)

    def relative(self, path: Path) -> str:
        """``path`` relative to the output folder."""
        return _relative(path, self.out_dir)

    def write(self, sim: Any) -> Path:
        """Write a checkpoint now (atomically) and record it in the manifest; return its path."""
        path = checkpoint_path(self.out_dir, sim.step_count)
        sim.save_checkpoint(path, extra={"run_stats": self.manifest.run_stats.state(),
                                         "checkpoint_every": self.every}, keep=self.keep)
        self.manifest.data["checkpoint"] = {"file": self.relative(path), "time": sim.time,
                                            "step": sim.step_count, "frame": sim._frame}
        self.manifest.write()
        get_logger("cli").info("checkpoint %s at t=%.6g s, step %d", self.relative(path),
                               sim.time, sim.step_count, extra={"console": False})
        return path
