"""``sphkit compat``: which of SPlisHSPlasH's own scenes sphkit loads and runs.

::

    sphkit compat [--steps 5] [--radius-scale 1] [--max-particles 200000] [--markdown FILE]
                  [--scenes DIR] [--only NAME ...]

Every ``*.json`` scene of the pysplishsplash wheel's ``data/Scenes`` folder (found through the
installed distribution's file list, so wherever pip put it; ``--scenes`` names another folder) is
loaded unchanged with :func:`sphkit.scene.splishsplash.from_splishsplash` and, when it loads, built
and run for ``--steps`` time steps. Each scene gets one line: ``runs`` (with its particle count and
the warnings the loader gave, e.g. the fields sphkit ignores), ``loads, not run`` (more particles
than ``--max-particles``), ``fails to run`` (the exception) or ``does not load`` with the missing
feature as the loader names it. ``--radius-scale F`` multiplies the scenes' ``particleRadius``
before loading (F = 2 has 8x fewer particles in 3D) to check big scenes quickly. ``--markdown FILE``
also writes the table as Markdown (``docs/compatibility.md`` is made this way). Without the wheel
the command says so and exits 0.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import date
from pathlib import Path
from typing import Any

from sphkit.cli.common import EXIT_OK, EXIT_USAGE, positive
from sphkit.io.atomic import atomic_write_text
from sphkit.scene.splishsplash.wheel import scene_folder as wheel_scene_folder
from sphkit.scene.splishsplash.wheel import version as wheel_version


@dataclass
class SceneResult:
    """What happened to one scene."""

    name: str
    status: str  #: "runs", "loads, not run", "fails to run", "does not load"
    detail: str = ""  #: the missing feature, the error, or the size
    particles: int | None = None  #: fluid + boundary particles when built
    dim: int | None = None
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def loads(self) -> bool:
        """Whether sphkit reads the scene."""
        return self.status != "does not load"


def _reason(err: BaseException, path: Path) -> str:
    """The message without the leading ``SPlisHSPlasH scene '<path>': ``."""
    text = str(err).strip()
    prefix = f"SPlisHSPlasH scene {str(path)!r}: "
    if text.startswith(prefix):
        text = text[len(prefix):]
    return " ".join(text.split())


def check_scene(path: Path, steps: int = 5, radius_scale: float = 1.0,
                max_particles: int | None = None) -> SceneResult:
    """Load the SPlisHSPlasH scene ``path`` unchanged (``particleRadius`` times
    ``radius_scale``), build it and run ``steps`` time steps."""
    from sphkit.scene.splishsplash import from_splishsplash
    from sphkit.simulation import Simulation

    t0 = time.perf_counter()
    name = path.name
    try:
        data: Any = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        return SceneResult(name, "does not load", f"unreadable JSON ({e})")
    if radius_scale != 1.0 and isinstance(data, dict):
        cfg = data.setdefault("Configuration", {})
        if isinstance(cfg, dict):
            cfg["particleRadius"] = float(cfg.get("particleRadius", 0.025)) * radius_scale
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scene = from_splishsplash(data, path)
        except Exception as e:  # SceneError names the feature; anything else is a bug to see
            return SceneResult(name, "does not load", _reason(e, path),
                               seconds=time.perf_counter() - t0)
        notes = [_reason(w.message, path) for w in caught]
        try:
            sim = Simulation(scene)
        except Exception as e:
            return SceneResult(name, "does not load", _reason(e, path), warnings=notes,
                               seconds=time.perf_counter() - t0)
        n = sim.fluid.n + sim.boundary.n
        result = SceneResult(name, "runs", "", particles=n, dim=sim.dim, warnings=notes)
        if max_particles is not None and n > max_particles:
            result.status = "loads, not run"
            result.detail = f"{n} particles > --max-particles {max_particles}"
        elif radius_scale != 1.0 and scene.fluid_files:
            # particle files keep their own spacing: with a coarsened radius the fluid would
            # start at radius_scale^dim times its rest density
            result.status = "loads, not run"
            result.detail = (f"particle files are not coarsened by --radius-scale "
                             f"{radius_scale:g}; run it with --radius-scale 1")
        else:
            try:
                for _ in range(steps):
                    sim.step()
                result.detail = f"{steps} steps to t = {sim.time:.4g} s"
            except Exception as e:
                result.status = "fails to run"
                result.detail = f"{type(e).__name__}: {_reason(e, path)}"
        result.warnings = [_reason(w.message, path) for w in caught]
    result.seconds = time.perf_counter() - t0
    return result


def check_folder(folder: Path, steps: int = 5, radius_scale: float = 1.0,
                 max_particles: int | None = None, only: list[str] | None = None,
                 progress: Any = None) -> list[SceneResult]:
    """:func:`check_scene` for every ``*.json`` in ``folder`` (sorted; ``only``: these names)."""
    out = []
    for path in sorted(folder.glob("*.json")):
        if only and path.name not in only and path.stem not in only:
            continue
        res = check_scene(path, steps, radius_scale, max_particles)
        out.append(res)
        if progress is not None:
            progress(res)
    return out


def _line(r: SceneResult) -> str:
    size = f" [{r.dim}D, {r.particles} particles]" if r.particles is not None else ""
    detail = f": {r.detail}" if r.detail else ""
    return f"{r.name:<42} {r.status}{size}{detail}"


def markdown(results: list[SceneResult], steps: int, radius_scale: float,
             max_particles: int | None, folder: Path | None = None,
             target: str = "docs/compatibility.md") -> str:
    """The results as the Markdown page ``docs/compatibility.md`` (``folder``: the scenes'
    folder when it is not the wheel's; ``target``: the file the page is written to)."""
    n_run = sum(r.status == "runs" for r in results)
    n_load = sum(r.loads for r in results)
    source = (f"the {len(results)} scenes of pysplishsplash "
              f"{wheel_version() or '(not installed)'} (`data/Scenes`)" if folder is None
              else f"the {len(results)} scenes in `{folder}`")
    command = "sphkit compat" + ("" if folder is None else f" --scenes {folder}")
    lines = [
        "# SPlisHSPlasH scene compatibility",
        "",
        f"Generated by `{command} --markdown {target}` on {date.today()} from "
        f"{source}: each scene is loaded unchanged"
        + (f" with `particleRadius` x {radius_scale:g}" if radius_scale != 1.0 else "")
        + f", built and run for {steps} time steps"
        + (f" when it has at most {max_particles} particles" if max_particles else "")
        + f". {n_load} load, {n_run} run.",
        "",
        "A scene that does not load names the missing feature with SPlisHSPlasH's field and "
        "number. Fields sphkit ignores are listed as warnings.",
        "",
        "| scene | result | particles | detail | warnings |",
        "|---|---|---|---|---|",
    ]
    for r in results:
        size = "" if r.particles is None else f"{r.particles} ({r.dim}D)"
        warn = "; ".join(r.warnings).replace("|", "\\|")
        lines.append(f"| {r.name} | {r.status} | {size} | {r.detail.replace('|', chr(92) + '|')}"
                     f" | {warn} |")
    return "\n".join(lines) + "\n"


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit compat`` to the ``sphkit`` command's subcommands."""
    p = sub.add_parser(
        "compat", help="check which SPlisHSPlasH scenes load and run",
        description="Load every scene of the pysplishsplash wheel unchanged, run a few steps "
                    "and report which load and run, naming the missing feature otherwise.")
    p.add_argument("--steps", type=positive("time steps per scene", integer=True), default=5,
                   metavar="N",
                   help="time steps to run per scene (default 5)")
    p.add_argument("--radius-scale", type=positive("scale of particleRadius"), default=1.0,
                   metavar="F",
                   help="multiply each scene's particleRadius by F (coarser: faster; default 1)")
    p.add_argument("--max-particles", type=positive("particles", integer=True),
                   default=200_000, metavar="N",
                   help="run only scenes with at most N particles (default 200000)")
    p.add_argument("--markdown", type=Path, metavar="FILE",
                   help="also write the table as Markdown (e.g. docs/compatibility.md)")
    p.add_argument("--scenes", type=Path, metavar="DIR",
                   help="folder of SPlisHSPlasH scenes (default: the pysplishsplash wheel's)")
    p.add_argument("--only", nargs="+", metavar="NAME", help="check only these scenes")
    p.set_defaults(handler=cmd_compat)


def cmd_compat(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit compat``: print one line per scene; 0 unless the arguments are bad."""
    folder = args.scenes or wheel_scene_folder()
    if folder is None:
        print("sphkit compat: pysplishsplash is not installed (pip install pysplishsplash), so "
              "its scenes are not available; nothing to check")
        return EXIT_OK
    if not Path(folder).is_dir():
        print(f"sphkit: error: --scenes {str(folder)!r}: not a folder of scene files")
        return EXIT_USAGE
    if args.steps < 0 or not args.radius_scale > 0:
        print(f"sphkit: error: --steps {args.steps} / --radius-scale {args.radius_scale}: "
              "expected steps >= 0 and a scale > 0")
        return EXIT_USAGE
    print(f"SPlisHSPlasH scenes in {folder}:", flush=True)
    results = check_folder(Path(folder), args.steps, args.radius_scale, args.max_particles,
                           args.only, progress=lambda r: print(_line(r), flush=True))
    n_run = sum(r.status == "runs" for r in results)
    print(f"{len(results)} scenes: {sum(r.loads for r in results)} load, {n_run} run")
    if args.markdown:
        args.markdown.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(args.markdown, markdown(results, args.steps, args.radius_scale,
                                                  args.max_particles, args.scenes,
                                                  str(args.markdown)))
        print(f"wrote {args.markdown}")
    return EXIT_OK
