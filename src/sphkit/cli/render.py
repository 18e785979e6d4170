"""``sphkit render``: preview pictures and a video of a run (matplotlib).

::

    sphkit render OUTDIR [--color velocity|pressure|density|phase|stress|displacement|object]
                         [--video auto|mp4|gif|none]
                         [--out DIR] [--fps F] [--size WxH] [--range LO,HI] [--cmap NAME]
                         [--surface auto|on|off] [--frames SPEC] [--quiet | --verbose]

Reads the run's ``manifest.json`` (the frames, their times, the particle radius of the scene)
and writes ``OUTDIR/render/frame_00000.png`` ... and ``preview.mp4`` or ``preview.gif``
(:mod:`sphkit.io.preview`; pip install 'sphkit[plot]'), drawing the surface meshes of a 3D run
when ``sphkit surface`` wrote ``surface.json``. ``--frames`` selects frame numbers: ``7``,
``0:50`` (end excluded), ``0:50:5`` or a comma-separated list of those. Exit codes as for
``sphkit run``: 0 done, 1 an output file could not be written, 2 bad arguments, a folder without
a manifest, matplotlib missing, 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sphkit.cli.common import (
    EXIT_FAILED,
    EXIT_OK,
    SURFACE_DIR,
    SURFACE_MANIFEST,
    UsageError,
    add_verbosity,
    error,
    frame_file,
    guarded,
    log,
    open_log,
    parse_frames,
    positive,
    run_info,
    say,
    selected_frames,
)

RENDER_DIR = "render"


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        if w < 16 or h < 16 or w > 8192 or h > 8192:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"got {text!r}; expected WIDTHxHEIGHT in pixels (16 to 8192), e.g. 960x720"
        ) from None
    return w, h


_size.__name__ = "picture size"


def _range(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(","))
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"got {text!r}; expected LOW,HIGH with HIGH > LOW, e.g. 0,2.5"
        ) from None
    return lo, hi


_range.__name__ = "colour range"


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit render`` to the ``sphkit`` command's subcommands."""
    from sphkit.io.preview import COLOR_FIELDS, VIDEO_FORMATS

    r = sub.add_parser(
        "render", help="preview pictures and a video of a run (matplotlib)",
        description="Draw each frame of a run folder into a PNG and join them into an MP4 "
                    "(ffmpeg) or GIF: 2D runs as coloured particles, 3D runs as the surface "
                    "meshes of 'sphkit surface' if present, else as a 3D scatter "
                    "(pip install 'sphkit[plot]').",
    )
    r.add_argument("outdir", type=Path, metavar="OUTDIR", help="the folder of a run")
    r.add_argument("--color", choices=COLOR_FIELDS, default="velocity",
                   help="particle colour: speed |v|, pressure, density, phase (the material "
                   "of a fluid of several), or an elastic solid's von Mises stress, "
                   "|displacement| or object index (-1 for fluid); default velocity")
    r.add_argument("--video", choices=VIDEO_FORMATS, default="auto",
                   help="video format: auto (mp4 with ffmpeg, else gif), mp4, gif, none")
    r.add_argument("--out", type=Path, metavar="DIR", help="picture folder (default OUTDIR/render)")
    r.add_argument("--fps", type=positive("video frames per second"), metavar="F",
                   help="video frame rate (default: the run's frames per simulated second)")
    r.add_argument("--size", type=_size, default=(960, 720), metavar="WxH",
                   help="picture size in pixels (default 960x720)")
    r.add_argument("--range", type=_range, dest="vrange", metavar="LO,HI",
                   help="colour range (default: 1st to 99th percentile of the run)")
    r.add_argument("--cmap", default="viridis", metavar="NAME",
                   help="matplotlib colour map (default viridis)")
    r.add_argument("--surface", choices=("auto", "on", "off"), default="auto",
                   help="3D: draw the surface meshes (auto: when OUTDIR/surface has them)")
    r.add_argument("--frames", type=parse_frames, metavar="SPEC",
                   help="frame numbers: 7, 0:50, 0:50:5 or a comma-separated list (default all)")
    add_verbosity(r)
    r.set_defaults(handler=cmd_render)


def _surface_meshes(outdir: Path, mode: str) -> dict[int, list[tuple[int | None, Path]]]:
    """The surface meshes of each frame that ``sphkit surface`` listed: one ``(None, path)``,
    or ``(phase, path)`` per phase of a ``--by-phase`` reconstruction."""
    folder = outdir / SURFACE_DIR
    index = folder / SURFACE_MANIFEST
    if mode == "off":
        return {}
    if not index.is_file():
        if mode == "on":
            raise UsageError(f"--surface on: {str(index)!r} not found; run 'sphkit surface "
                         f"{outdir}' first")
        return {}
    data = json.loads(index.read_text(encoding="utf-8"))
    out = {}
    for rec in data.get("frames", []):
        parts = ([(int(e["phase"]), e.get("files", [])) for e in rec["phases"]]
                 if rec.get("phases") else [(None, rec.get("files", []))])
        found = []
        for phase, names in parts:
            files = [folder / f for f in names if (folder / f).is_file()]
            if files:
                found.append((phase, files[0]))
        if found:
            out[int(rec["frame"])] = found
    return out


def cmd_render(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit render``: PNG per frame and a video; return the exit code."""
    return guarded(_render, args)


def _render(args: argparse.Namespace) -> int:
    from sphkit.io.frames import read_frame
    from sphkit.io.preview import (
        PlotUnavailable,
        PreviewRenderer,
        RenderSettings,
        bounds_of,
        choose_video,
        color_values,
        load_mesh,
        merged_meshes,
        robust_range,
        write_gif,
        write_mp4,
    )

    outdir: Path = args.outdir
    info = run_info(outdir)
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise UsageError(str(PlotUnavailable(
            "previews need matplotlib: pip install 'sphkit[plot]' (or pip install matplotlib)"
        ))) from None
    video = choose_video(args.video)
    if args.video == "mp4" and video == "mp4":
        from sphkit.io.preview import ffmpeg_path

        if ffmpeg_path() is None:
            raise UsageError("--video mp4 needs the ffmpeg program, which was not found; "
                         "install ffmpeg or use --video gif")
    frames = [rec for rec in selected_frames(info, args.frames) if frame_file(outdir, rec)]
    if not frames:
        raise UsageError(f"OUTDIR {str(outdir)!r}: none of the frames has a particle file on disk")
    meshes = _surface_meshes(outdir, args.surface) if info["dim"] == 3 else {}
    dest: Path = args.out or outdir / RENDER_DIR
    try:
        dest.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        error(f"cannot create the picture folder {str(dest)!r}: {e}")
        return EXIT_FAILED
    open_log(args, outdir)

    # colour range and picture bounds from up to 8 frames spread over the run
    sample = [frames[i] for i in sorted({round(j * (len(frames) - 1) / 7) for j in range(8)})]
    arrays = [read_frame(frame_file(outdir, rec)) for rec in sample]
    try:
        values = [color_values(a, args.color, f" {rec['frame']}") for a, rec in zip(
            arrays, sample, strict=True)] if not (meshes and info["dim"] == 3) else []
    except ValueError as e:
        raise UsageError(str(e)) from None
    vrange = args.vrange or robust_range(values)
    positions = [a["position"] for a in arrays]
    for box in info["boxes"]:  # show the whole container
        lo = list(box.get("min", [])) + [0.0] * 3
        hi = list(box.get("max", [])) + [0.0] * 3
        positions.append(np.array([lo[:3], hi[:3]], dtype=float))
    bounds = bounds_of(positions, 2.0 * info["radius"])
    settings = RenderSettings(color=args.color, cmap=args.cmap, vrange=vrange,
                              width=args.size[0], height=args.size[1], surface=args.surface)
    what = ("surface meshes" if meshes else
            f"particles coloured by {args.color} in [{vrange[0]:.4g}, {vrange[1]:.4g}]")
    say(args, f"render: {len(frames)} frame(s) of {outdir} ({info['dim']}D, {what}) -> {dest}"
               + (f", video {video}" if video else ""))
    renderer = PreviewRenderer(info["dim"], info["radius"], info["up"], bounds, settings)
    pngs: list[Path] = []
    t0 = time.perf_counter()
    try:
        for rec in frames:
            k = int(rec["frame"])
            data = read_frame(frame_file(outdir, rec))
            mesh = merged_meshes([(phase, *load_mesh(path)) for phase, path in meshes[k]]
                                 ) if k in meshes else None
            body_files = [outdir / f for f in rec.get("body_files", []) if (outdir / f).is_file()]
            bodies = load_mesh(body_files[0]) if body_files else None
            try:
                renderer.draw(data, float(rec.get("time") or 0.0), mesh, bodies)
            except ValueError as e:
                raise UsageError(str(e)) from None
            pngs.append(renderer.save_png(dest / f"frame_{k:05d}.png"))
            log.debug("rendered frame %d", k)
    except OSError as e:
        error(f"writing the pictures failed: {e}")
        return EXIT_FAILED
    finally:
        renderer.close()
    fps = args.fps or info["fps"]
    if video:
        path = dest / f"preview.{video}"
        try:
            (write_mp4 if video == "mp4" else write_gif)(pngs, path, fps)
        except (OSError, RuntimeError) as e:
            error(f"writing the video {str(path)!r} failed: {e}")
            return EXIT_FAILED
        say(args, f"video: {path} ({len(pngs)} frames at {fps:g} frames/s)")
    say(args, f"render: {len(pngs)} picture(s) in {time.perf_counter() - t0:.1f} s; in {dest}")
    return EXIT_OK
