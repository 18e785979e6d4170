"""Training a GNS (:mod:`sphkit.learn.sanchez_gonzalez2020`) on a dataset folder.

One step: ``batch`` windows drawn uniformly from the training split (6 positions and the next
one, :class:`~sphkit.learn.data.WindowDataset`), random-walk noise on the fluid's input
positions, the radius graph on the noisy current positions, the L2 loss between the predicted
and the target normalised accelerations of the fluid particles (walls are inputs, never
predicted), one Adam step.

**Noise** (GNS Sec. 3, "Training noise"; LagrangeBench ``add_gns_noise``): each of the C = 5
input velocities gets independent Gaussian noise of std ``noise_std / sqrt(C)``, accumulated as a
random walk (so the last velocity's noise has std ``noise_std``) and integrated into the
positions; the target position moves with the last input position's noise, so the target
acceleration asks the network to undo the last velocity's noise. ``noise_std`` is in metres per
frame, like the velocities; the normalisation's standard deviations are widened by it.

**Learning rate**: ``lr(k) = lr_final + (lr - lr_final) * 0.1 ** (k / lr_decay_steps)``
(LagrangeBench's exponential decay, 1e-4 -> 1e-6 over 1e5 steps; the CPU default is 2e-3
decaying tenfold every 5,000 steps, for a run of a few thousand steps: README, "Learned
simulators").

**Checkpoints**: ``OUT/model.pt`` (model, optimiser, step, random states, the dataset's metadata,
the configurations and the normalisation) written atomically every ``checkpoint_every`` steps,
every ``checkpoint_seconds`` of wall time, and at the end; ``resume`` continues from it (the step
counter, learning rate, optimiser moments and random streams continue). ``OUT/train_log.jsonl``
gets one line per progress report.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from sphkit.io.atomic import atomic_path
from sphkit.learn.data import (
    INPUT_SEQ_LENGTH,
    Normalizer,
    WindowDataset,
    is_fluid,
    load_split,
    read_metadata,
)
from sphkit.learn.sanchez_gonzalez2020 import GNS, FeatureBuilder, GNSConfig

CHECKPOINT_NAME = "model.pt"
FORMAT = "sphkit-gns"


@dataclass
class TrainConfig:
    """Training settings (the defaults are those of the README's 10-minute CPU run)."""

    steps: int = 100_000  #: train up to this step count (total, across resumes)
    time_limit: float | None = None  #: stop after this many seconds of this invocation
    batch: int = 2  #: windows (graphs) per step
    lr: float = 2e-3  #: initial learning rate
    lr_final: float = 1e-5
    lr_decay_steps: int = 5_000  #: steps per decade of the learning rate's decay
    #: std of the random-walk noise on the last input velocity [m / frame]; None:
    #: :func:`default_noise`
    noise_std: float | None = None
    radius: float | None = None  #: connectivity radius [m]; None: the dataset's default
    seed: int = 0
    checkpoint_every: int = 500
    checkpoint_seconds: float = 60.0
    report_seconds: float = 5.0
    device: str = "cpu"
    gns: GNSConfig = field(default_factory=GNSConfig)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def default_noise(meta: dict[str, Any]) -> float:
    """The default training noise [m / frame]: LagrangeBench's 3e-4 for its 2D datasets
    (dx = 0.02 m, like sphkit's 2D dam break), scaled with the particle spacing. On the dam
    break at 100 frames/s (acceleration std about 1e-3 m per frame^2) ten minutes of training
    with 3e-4 gave a 20-step MSE 4.8 times below the constant-velocity baseline's, with 1e-4
    2.7 times, and left fewer particles outside the tank (README, "Learned simulators")."""
    return 3e-4 * float(meta.get("dx") or 0.02) / 0.02


class TrainingError(RuntimeError):
    """A problem with the dataset, the checkpoint or the device (exit code 2 in the CLI)."""


def random_walk_noise(n: int, velocities: int, dim: int, noise_std: float,
                      rng: np.random.Generator) -> np.ndarray:
    """Position noise (n, velocities + 1, dim): zero for the first position, then the running
    sum of velocity noise whose running sum has std ``noise_std`` at the last velocity."""
    steps = rng.normal(0.0, noise_std / math.sqrt(velocities), size=(n, velocities, dim))
    vel_noise = np.cumsum(steps, axis=1)
    pos_noise = np.cumsum(vel_noise, axis=1)
    return np.concatenate([np.zeros((n, 1, dim)), pos_noise], axis=1)


def noisy_window(window: np.ndarray, particle_type: np.ndarray, noise_std: float,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A window (N, W+1, dim) -> (noisy inputs (N, W, dim), target position (N, dim)) with the
    fluid's noise; the target carries the last input's noise (LagrangeBench's add_gns_noise)."""
    x = window.astype(np.float64)
    inputs, target = x[:, :-1].copy(), x[:, -1].copy()
    if noise_std > 0:
        fluid = is_fluid(particle_type)
        noise = random_walk_noise(int(fluid.sum()), inputs.shape[1] - 1, x.shape[2], noise_std, rng)
        inputs[fluid] += noise
        target[fluid] += noise[:, -1]
    return inputs, target


def target_acceleration(inputs: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``x[t+1] - 2 x[t] + x[t-1]`` (N, dim) from the inputs' last two positions."""
    return target - 2.0 * inputs[:, -1] + inputs[:, -2]


class Trainer:
    """Model, optimiser and data of one training run (see the module notes)."""

    def __init__(self, dataset: str | os.PathLike[str], out: str | os.PathLike[str],
                 config: TrainConfig, resume: bool = False,
                 say: Callable[[str], None] | None = None) -> None:
        self.dataset = Path(dataset)
        self.out = Path(out)
        self.say = say or (lambda text: print(text, file=sys.stderr, flush=True))
        self.meta = read_metadata(self.dataset)
        ckpt = None
        if resume:
            path = self.out / CHECKPOINT_NAME
            if not path.is_file():
                raise TrainingError(f"--resume: no {CHECKPOINT_NAME} in {str(self.out)!r}")
            ckpt = load_checkpoint(path)
            old = TrainConfig(**{**ckpt["train_config"], "gns": GNSConfig(**ckpt["gns_config"])})
            # what may change on resuming: how long, where, and the reporting
            old.steps, old.time_limit, old.device = config.steps, config.time_limit, config.device
            config = old
        self.config = config
        if config.device == "cuda" and not torch.cuda.is_available():
            raise TrainingError("--device cuda: PyTorch sees no CUDA device")
        self.device = torch.device(config.device)
        if config.noise_std is None:
            config.noise_std = default_noise(self.meta)
        if config.radius is None:
            config.radius = float(self.meta["default_connectivity_radius"])
        config.gns.dim = int(self.meta["dim"])
        config.gns.velocities = INPUT_SEQ_LENGTH - 1
        self.normalizer = (Normalizer.from_state(ckpt["normalization"]) if ckpt else
                           Normalizer(self.meta, config.noise_std))
        self.features = FeatureBuilder(self.normalizer, self.meta["bounds"], config.radius,
                                       self.meta.get("periodic_boundary_conditions"),
                                       config.gns.history)
        self.train_set = WindowDataset(load_split(self.dataset, "train"))
        try:
            self.valid = load_split(self.dataset, "valid", limit=2)
        except ValueError:
            self.valid = []
        torch.manual_seed(config.seed)
        self.model = GNS(config.gns).to(self.device)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.lr)
        self.rng = np.random.default_rng(config.seed)
        self.step = 0
        self.wall = 0.0  # training seconds of the earlier invocations
        self._t0: float | None = None  # start of this invocation
        if ckpt:
            self.model.load_state_dict(ckpt["model"])
            self.optimizer.load_state_dict(ckpt["optimizer"])
            self.step = int(ckpt["step"])
            self.wall = float(ckpt.get("wall_seconds", 0.0))
            self.rng.bit_generator.state = ckpt["numpy_rng"]
            torch.set_rng_state(ckpt["torch_rng"])

    def lr(self, step: int) -> float:
        c = self.config
        return c.lr_final + (c.lr - c.lr_final) * 0.1 ** (step / c.lr_decay_steps)

    def parameters(self) -> int:
        return sum(p.numel() for p in self.model.parameters())

    def loss_on(self, windows: list[tuple[np.ndarray, np.ndarray]], noise_std: float,
                rng: np.random.Generator) -> torch.Tensor:
        """Mean squared normalised-acceleration error of the fluid over ``windows``."""
        hists, types, targets = [], [], []
        for w, pt in windows:
            inputs, target = noisy_window(w, pt, noise_std, rng)
            hists.append(inputs)
            types.append(pt)
            targets.append(self.normalizer.norm_acc(target_acceleration(inputs, target)))
        f = self.features(hists, types, self.device)
        pred = self.model(f.node, f.particle_type, f.edge, f.senders, f.receivers)
        tgt = torch.as_tensor(np.concatenate(targets), dtype=torch.float32, device=self.device)
        fluid = is_fluid(f.particle_type)
        return ((pred - tgt)[fluid] ** 2).mean()

    def train_step(self) -> float:
        for g in self.optimizer.param_groups:
            g["lr"] = self.lr(self.step)
        picks = self.rng.integers(0, len(self.train_set), size=self.config.batch)
        windows = []
        for k in picks:
            w, pt = self.train_set[int(k)]
            windows.append((w.numpy(), pt.numpy()))
        self.model.train()
        loss = self.loss_on(windows, float(self.config.noise_std), self.rng)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        self.step += 1
        return float(loss.detach())

    @torch.no_grad()
    def validation_loss(self, windows: int = 8) -> float | None:
        """One-step loss (no noise) on evenly spaced windows of the validation split."""
        if not self.valid:
            return None
        self.model.eval()
        rng = np.random.default_rng(0)
        losses = []
        for tr in self.valid:
            T = tr.position.shape[0]
            for t in np.linspace(0, T - INPUT_SEQ_LENGTH - 1, windows // len(self.valid) + 1,
                                 dtype=int):
                w = tr.position[t:t + INPUT_SEQ_LENGTH + 1].transpose(1, 0, 2)
                losses.append(float(self.loss_on([(w, tr.particle_type)], 0.0, rng)))
        return float(np.mean(losses))

    def save(self) -> Path:
        """Write ``OUT/model.pt`` atomically."""
        self.out.mkdir(parents=True, exist_ok=True)
        state = {
            "format": FORMAT, "format_version": 1, "step": self.step,
            "wall_seconds": self.wall + (time.perf_counter() - self._t0 if self._t0 else 0.0),
            "model": self.model.state_dict(), "optimizer": self.optimizer.state_dict(),
            "gns_config": self.config.gns.to_dict(),
            "train_config": {k: v for k, v in self.config.to_dict().items() if k != "gns"},
            "metadata": self.meta, "normalization": self.normalizer.state(),
            "dataset": str(self.dataset.resolve()),
            "numpy_rng": self.rng.bit_generator.state, "torch_rng": torch.get_rng_state(),
        }
        path = self.out / CHECKPOINT_NAME
        with atomic_path(path) as tmp:
            torch.save(state, tmp)
        return path

    def run(self) -> dict[str, Any]:
        """Train until ``steps`` or ``time_limit``; return a summary."""
        c = self.config
        t0 = self._t0 = time.perf_counter()
        last_report = last_ckpt_time = t0
        start_step = self.step
        losses: list[float] = []
        log_path = self.out / "train_log.jsonl"
        self.out.mkdir(parents=True, exist_ok=True)
        self.say(f"training GNS ({self.parameters():,} parameters, latent {c.gns.latent}, "
                 f"{c.gns.layers} layers) on {self.dataset} ({len(self.train_set)} windows of "
                 f"{len(self.train_set.trajectories)} trajectories), radius {c.radius:.4g} m, "
                 f"noise {c.noise_std:.3g} m/frame, device {c.device}, from step {self.step}")
        stopped = "steps"
        while self.step < c.steps:
            losses.append(self.train_step())
            now = time.perf_counter()
            elapsed = now - t0
            if now - last_report >= c.report_seconds or self.step == c.steps:
                rate = (self.step - start_step) / max(elapsed, 1e-9)
                rec = {"step": self.step, "loss": float(np.mean(losses)), "lr": self.lr(self.step),
                       "steps_per_s": rate, "elapsed_s": elapsed}
                self.say(f"step {self.step}/{c.steps}  loss {rec['loss']:.4g}  "
                         f"lr {rec['lr']:.2e}  {rate:.2f} steps/s  {elapsed:.0f} s")
                with open(log_path, "a", encoding="utf-8") as f:
                    f.write(json.dumps(rec) + "\n")
                losses.clear()
                last_report = now
            if (self.step % c.checkpoint_every == 0
                    or now - last_ckpt_time >= c.checkpoint_seconds):
                self.save()
                last_ckpt_time = now
            if c.time_limit is not None and elapsed >= c.time_limit:
                stopped = "time limit"
                break
        elapsed = time.perf_counter() - t0
        valid = self.validation_loss()
        path = self.save()
        rate = (self.step - start_step) / max(elapsed, 1e-9)
        self.say(f"stopped ({stopped}) at step {self.step} after {elapsed:.0f} s "
                 f"({rate:.2f} steps/s); validation one-step loss "
                 f"{'n/a' if valid is None else f'{valid:.4g}'}; checkpoint {path}")
        return {"step": self.step, "seconds": elapsed, "steps_per_s": rate,
                "valid_loss": valid, "checkpoint": str(path), "stopped": stopped}


def load_checkpoint(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A checkpoint written by :meth:`Trainer.save` (a file, or the folder holding
    ``model.pt``)."""
    p = Path(path)
    if p.is_dir():
        p = p / CHECKPOINT_NAME
    if not p.is_file():
        raise TrainingError(f"{str(path)!r}: no model checkpoint ({CHECKPOINT_NAME}); expected "
                            "the output folder of 'sphkit learn train' or its model.pt")
    try:
        ckpt = torch.load(p, map_location="cpu", weights_only=False)
    except Exception as e:  # torch raises many kinds for a damaged or foreign file
        raise TrainingError(f"{str(p)!r}: not a readable checkpoint ({type(e).__name__}: {e})") \
            from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != FORMAT:
        raise TrainingError(f"{str(p)!r}: not a sphkit GNS checkpoint")
    return ckpt


def load_simulator(path: str | os.PathLike[str], device: str = "cpu") -> tuple[Any, dict]:
    """A :class:`~sphkit.learn.sanchez_gonzalez2020.LearnedSimulator` from a checkpoint, and the
    checkpoint (metadata, configurations)."""
    from sphkit.learn.sanchez_gonzalez2020 import LearnedSimulator

    ckpt = load_checkpoint(path)
    model = GNS(GNSConfig(**ckpt["gns_config"]))
    model.load_state_dict(ckpt["model"])
    model.to(device)
    meta = ckpt["metadata"]
    tc = ckpt["train_config"]
    features = FeatureBuilder(Normalizer.from_state(ckpt["normalization"]), meta["bounds"],
                              float(tc["radius"]), meta.get("periodic_boundary_conditions"),
                              ckpt["gns_config"].get("history", "velocities"))
    return LearnedSimulator(model, features, device), ckpt
