"""``sphkit learn``: train, roll out and evaluate learned simulators (GNS; ``sphkit[learn]``).

::

    sphkit learn train DATASET [--out MODELDIR] [--time-limit S] [--steps N] [--resume]
                       [--device cpu|cuda] [--threads N] [--latent L] [--layers M] [--batch B]
                       [--lr LR] [--lr-final LR] [--lr-decay-steps N] [--noise STD]
                       [--radius R] [--seed S]
    sphkit learn rollout MODEL SCENE [--until T | --steps N] [--out DIR] [--format vtk,...]
                         [--no-collisions]
    sphkit learn eval MODEL DATASET [--split test] [--out DIR] [--limit N] [--no-collisions]

``DATASET`` is a folder in LagrangeBench's layout (:mod:`sphkit.learn.data`); ``MODEL`` the
folder ``sphkit learn train`` wrote (or its ``model.pt``). ``train`` prints progress lines
(step, loss, learning rate, steps per second) on stderr and writes the checkpoint
``MODELDIR/model.pt`` every 500 steps, every minute and at the end; ``--resume`` continues it
(``--steps`` is the total). ``rollout`` writes frames and ``manifest.json`` like ``sphkit run``,
so ``sphkit render DIR`` works on them. ``eval`` prints the rollout MSE at 1, 5, 20 steps and
the full horizon against the dataset's solver frames and the constant-velocity baseline, the
kinetic-energy and density errors, and writes ``eval.json`` and plots
(:mod:`sphkit.learn.evaluate`).

PyTorch is imported only here: without it every ``sphkit learn`` command exits 2 with
"install sphkit[learn] (PyTorch)". Exit codes: 0 done, 1 an output could not be written, 2 bad
arguments, dataset or model (or ``--device cuda`` without a GPU), 3 the rollout became
non-finite, 130 interrupted.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sphkit.cli.common import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_UNSTABLE,
    EXIT_USAGE,
    Interrupts,
    UsageError,
    add_verbosity,
    choices_list,
    error,
    guarded,
    open_log,
    positive,
    positive_float,
    positive_int,
    say,
)
from sphkit.io.frames import FORMATS


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit learn`` and its subcommands."""
    p = sub.add_parser(
        "learn", help="train, roll out and evaluate learned simulators (GNS)",
        description="Learned simulators (Sanchez-Gonzalez et al. 2020's graph network "
                    "simulator) on datasets in LagrangeBench's HDF5 layout; needs "
                    "pip install 'sphkit[learn]' (PyTorch).",
        epilog="Exit codes: 0 done, 1 an output could not be written, 2 bad arguments, dataset, "
               "model or device, 3 the rollout became non-finite, 130 interrupted.")
    lsub = p.add_subparsers(dest="learn_command", metavar="COMMAND")
    lsub.required = True

    t = lsub.add_parser("train", help="train a GNS on a dataset folder",
                        description="Train a GNS on DATASET/train.h5; checkpoints in MODELDIR.")
    t.add_argument("dataset", type=Path, metavar="DATASET", help="dataset folder")
    t.add_argument("--out", type=Path, metavar="MODELDIR",
                   help="model folder (default: out/gns-<dataset folder name>)")
    t.add_argument("--time-limit", type=positive_float("seconds of training", "600"),
                   metavar="S", help="stop after S seconds of wall time (this invocation)")
    t.add_argument("--steps", type=positive_int, metavar="N",
                   help="train up to N steps in total (default 100000)")
    t.add_argument("--resume", action="store_true",
                   help="continue the checkpoint in MODELDIR (its settings are kept)")
    t.add_argument("--device", choices=("cpu", "cuda"), default="cpu",
                   help="cpu (default) or cuda (when PyTorch sees a GPU)")
    t.add_argument("--threads", type=positive_int, metavar="N",
                   help="PyTorch CPU threads (default: PyTorch's)")
    t.add_argument("--latent", type=positive_int, metavar="L", help="latent size (default 32)")
    t.add_argument("--layers", type=positive_int, metavar="M",
                   help="message-passing layers (default 3)")
    t.add_argument("--batch", type=positive_int, metavar="B",
                   help="trajectory windows per step (default 2)")
    t.add_argument("--lr", type=positive_float("learning rate", "1e-3"), metavar="LR",
                   help="initial learning rate (default 2e-3)")
    t.add_argument("--lr-final", type=positive_float("final learning rate", "1e-5"),
                   metavar="LR", help="final learning rate (default 1e-5)")
    t.add_argument("--lr-decay-steps", type=positive_int, metavar="N",
                   help="steps per tenfold decay of the learning rate (default 5000)")
    t.add_argument("--noise", type=positive("training noise std [m/frame]", allow_zero=True),
                   metavar="STD", help="random-walk noise std of the last input velocity "
                                       "[m per frame] (default 3e-4 x dx / 0.02 m)")
    t.add_argument("--radius", type=positive_float("connectivity radius [m]", "0.045"),
                   metavar="R", help="connectivity radius [m] (default: the dataset's)")
    t.add_argument("--seed", type=positive("random seed", integer=True, allow_zero=True),
                   default=0, metavar="S", help="random seed (default 0)")
    add_verbosity(t)
    t.set_defaults(handler=lambda a, argv: _run(cmd_train, a))

    r = lsub.add_parser("rollout", help="roll a model out from a scene, writing frames",
                        description="Roll MODEL out from the initial state of SCENE and write "
                                    "frames and manifest.json like 'sphkit run'.")
    r.add_argument("model", type=Path, metavar="MODEL", help="model folder or its model.pt")
    r.add_argument("scene", metavar="SCENE", help="built-in scene name or scene file")
    g = r.add_mutually_exclusive_group()
    g.add_argument("--until", type=positive_float("simulated end time in seconds", "2"),
                   metavar="T", help="simulated end time [s] (default: the scene's)")
    g.add_argument("--steps", type=positive_int, metavar="N", help="number of learned steps")
    r.add_argument("--out", type=Path, metavar="DIR",
                   help="output folder (default: out/<scene name>-gns)")
    r.add_argument("--format", type=choices_list(tuple(FORMATS), "vtk,ply", "the formats "),
                   dest="formats", metavar="LIST", help="frame formats (default: the scene's)")
    r.add_argument("--device", choices=("cpu", "cuda"), default="cpu", help="cpu or cuda")
    r.add_argument("--no-collisions", dest="collisions", action="store_false",
                   help="let the fluid move through the wall particles (the network alone; "
                        "default: it collides with them, see sphkit.learn.walls)")
    add_verbosity(r)
    r.set_defaults(handler=lambda a, argv: _run(cmd_rollout, a, argv))

    e = lsub.add_parser("eval", help="rollout errors against the solver and a baseline",
                        description="Roll MODEL out on DATASET's split and compare with the "
                                    "solver and the constant-velocity baseline.")
    e.add_argument("model", type=Path, metavar="MODEL", help="model folder or its model.pt")
    e.add_argument("dataset", type=Path, metavar="DATASET", help="dataset folder")
    e.add_argument("--split", choices=("train", "valid", "test"), default="test",
                   help="split to evaluate (default test)")
    e.add_argument("--out", type=Path, metavar="DIR",
                   help="folder for eval.json and the plots (default MODEL/eval-<split>)")
    e.add_argument("--limit", type=positive_int, metavar="N",
                   help="evaluate the first N trajectories only")
    e.add_argument("--no-collisions", dest="collisions", action="store_false",
                   help="let the fluid move through the wall particles (the network and the "
                        "baseline alone; default: it collides with them, see sphkit.learn.walls)")
    e.add_argument("--starts", type=positive_int, default=8, metavar="K",
                   help="also measure 20-step rollouts from K evenly spaced frames of each "
                        "trajectory (default 8)")
    e.add_argument("--device", choices=("cpu", "cuda"), default="cpu", help="cpu or cuda")
    add_verbosity(e)
    e.set_defaults(handler=lambda a, argv: _run(cmd_eval, a))


def _run(command: Any, args: argparse.Namespace, *extra: Any) -> int:
    """Check the extra's packages and the device, then run ``command`` guarded (usage errors
    exit 2, Ctrl-C 130)."""
    from sphkit.learn import MISSING_MESSAGE, missing

    absent = missing()
    if absent:
        error(f"{MISSING_MESSAGE} (missing: {', '.join(absent)})")
        return EXIT_USAGE
    if args.device == "cuda":
        import torch

        if not torch.cuda.is_available():
            error("--device cuda: PyTorch sees no CUDA device (torch.cuda.is_available() is "
                  "False); use --device cpu")
            return EXIT_USAGE
    return guarded(lambda a: command(a, *extra), args)


def _out_folder(path: Path, what: str) -> Path:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UsageError(f"{what} {str(path)!r}: cannot create the folder ({e})") from None
    return path


def cmd_train(args: argparse.Namespace) -> int:
    """``sphkit learn train``."""
    import torch

    from sphkit.learn.data import DatasetError
    from sphkit.learn.sanchez_gonzalez2020 import GNSConfig
    from sphkit.learn.train import CHECKPOINT_NAME, TrainConfig, Trainer, TrainingError

    if not args.dataset.is_dir():
        raise UsageError(f"DATASET {str(args.dataset)!r}: not a folder; expected a dataset "
                         "folder (metadata.json, train.h5, ...)")
    out = args.out or Path("out") / f"gns-{args.dataset.resolve().name}"
    if not args.resume and (out / CHECKPOINT_NAME).exists():
        raise UsageError(f"--out {str(out)!r} already holds a model ({CHECKPOINT_NAME}); "
                         "continue it with --resume, or choose another --out")
    out = _out_folder(out, "--out")
    open_log(args, out)
    if args.threads:
        torch.set_num_threads(args.threads)
    gns = GNSConfig()
    if args.latent:
        gns.latent = args.latent
    if args.layers:
        gns.layers = args.layers
    cfg = TrainConfig(gns=gns, seed=int(args.seed), device=args.device,
                      time_limit=args.time_limit)
    for name, value in (("steps", args.steps), ("batch", args.batch), ("lr", args.lr),
                        ("lr_final", args.lr_final), ("lr_decay_steps", args.lr_decay_steps),
                        ("noise_std", args.noise), ("radius", args.radius)):
        if value is not None:
            setattr(cfg, name, value)
    try:
        trainer = Trainer(args.dataset, out, cfg, resume=args.resume,
                          say=lambda text: say(args, text))
    except DatasetError as e:
        raise UsageError(f"DATASET: {e}") from None
    except TrainingError as e:
        raise UsageError(str(e)) from None
    try:
        trainer.run()
    except KeyboardInterrupt:
        path = trainer.save()
        error(f"interrupted at step {trainer.step}; checkpoint {path}; continue with "
              f"sphkit learn train {args.dataset} --out {out} --resume")
        raise
    except OSError as e:
        error(f"writing the checkpoint failed: {e}")
        return EXIT_FAILED
    return EXIT_OK


def cmd_rollout(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit learn rollout``."""
    from sphkit.learn.rollout import RolloutError, rollout_scene
    from sphkit.learn.train import TrainingError
    from sphkit.scene.files import load_scene
    from sphkit.scene.schema import SceneError

    try:
        scene = load_scene(args.scene)
    except (SceneError, OSError) as e:
        raise UsageError(f"SCENE {args.scene!r}:\n{e}") from None
    out = _out_folder(args.out or Path("out") / f"{scene.name}-gns", "--out")
    open_log(args, out)
    try:
        res = rollout_scene(args.model, scene, out, steps=args.steps, until=args.until,
                            formats=args.formats, command=["sphkit", *argv],
                            device=args.device, say=lambda text: say(args, text),
                            check_interrupt=Interrupts.check, collisions=args.collisions)
    except TrainingError as e:
        raise UsageError(f"MODEL: {e}") from None
    except (RolloutError, SceneError) as e:
        raise UsageError(f"SCENE {args.scene!r}: {e}") from None
    except OSError as e:
        error(f"writing the output failed: {e}")
        return EXIT_FAILED
    if res["status"] != "finished":
        error(f"the rollout became unstable: {res['message']}; the {res['frames']} frame(s) so "
              f"far are in {out}")
        return EXIT_UNSTABLE
    say(args, f"finished: {res['frames']} frame(s) in {out}; fluid particles outside the "
              f"bounds (most at any frame): {res['max_outside']}")
    return EXIT_OK


def cmd_eval(args: argparse.Namespace) -> int:
    """``sphkit learn eval``."""
    from sphkit.learn.data import DatasetError
    from sphkit.learn.evaluate import evaluate
    from sphkit.learn.train import TrainingError

    if not args.dataset.is_dir():
        raise UsageError(f"DATASET {str(args.dataset)!r}: not a folder; expected a dataset "
                         "folder (metadata.json, train.h5, ...)")
    model_dir = args.model if args.model.is_dir() else args.model.parent
    out = args.out or model_dir / f"eval-{args.split}"
    try:
        evaluate(args.model, args.dataset, args.split, out, limit=args.limit,
                 device=args.device, starts=args.starts, say=lambda text: print(text, flush=True),
                 check_interrupt=Interrupts.check, collisions=args.collisions)
    except TrainingError as e:
        raise UsageError(f"MODEL: {e}") from None
    except DatasetError as e:
        raise UsageError(f"DATASET: {e}") from None
    except ValueError as e:
        raise UsageError(str(e)) from None
    except OSError as e:
        error(f"writing the results failed: {e}")
        return EXIT_FAILED
    return EXIT_OK
