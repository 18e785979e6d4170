"""``sphkit surface`` and ``sphkit render``: post-processing of a run folder.

::

    sphkit surface OUTDIR [--format obj,ply,vtk] [--out DIR] [--radius R] [--smoothing-length 2]
                          [--cube-size 0.5] [--threshold 0.6] [--mesh-smoothing-iters 25]
                          [--mesh-cleanup] [--frames SPEC] [--quiet | --verbose]
    sphkit render OUTDIR [--color velocity|pressure|density] [--video auto|mp4|gif|none]
                         [--out DIR] [--fps F] [--size WxH] [--range LO,HI] [--cmap NAME]
                         [--surface auto|on|off] [--frames SPEC] [--quiet | --verbose]

Both read the run's ``manifest.json`` (the frames, their times, the particle radius and rest
density of the scene). ``surface`` writes ``OUTDIR/surface/surface_00000.obj`` ... and
``surface.json`` (parameters, files and mesh sizes per frame); ``render`` writes
``OUTDIR/render/frame_00000.png`` ... and ``preview.mp4`` or ``preview.gif``, drawing the surface
meshes of a 3D run when ``surface.json`` is there. ``--frames`` selects frame numbers: ``7``,
``0:50`` (end excluded), ``0:50:5`` or a comma-separated list of those. Exit codes as for
``sphkit run``: 0 done, 1 an output file could not be written, 2 bad arguments, a folder without
a manifest, a missing optional package (pysplashsurf, matplotlib), 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.io.atomic import atomic_write_text
from sphkit.io.log import get_logger
from sphkit.io.manifest import MANIFEST_NAME, read_manifest

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
SURFACE_DIR = "surface"
SURFACE_MANIFEST = "surface.json"
RENDER_DIR = "render"

log = get_logger("cli")


class _Usage(Exception):
    """A problem with the arguments or the run folder (exit code 2)."""


def _error(text: str) -> None:
    print(f"sphkit: error: {text}", file=sys.stderr, flush=True)
    log.error(text, extra={"console": False})


def _positive(what: str, integer: bool = False, allow_zero: bool = False):
    def parse(text: str) -> float:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = math.nan
        ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
        if not ok:
            kind = "an integer" if integer else "a number"
            raise argparse.ArgumentTypeError(
                f"got {text!r}; expected {kind} {'>= 0' if allow_zero else '> 0'}: {what}"
            )
        return value

    parse.__name__ = "number"
    return parse


def _choices_list(choices: tuple[str, ...], example: str):
    def parse(text: str) -> list[str]:
        names = [s.strip().lower() for s in text.split(",") if s.strip()]
        bad = [n for n in names if n not in choices]
        if bad or not names:
            what = f"unknown format {bad[0]!r} in {text!r}" if bad else f"got {text!r}"
            raise argparse.ArgumentTypeError(
                f"{what}; expected a comma-separated list of {', '.join(choices)} (e.g. {example})"
            )
        return list(dict.fromkeys(names))

    parse.__name__ = "format list"
    return parse


def parse_frames(text: str) -> list[tuple[int, int | None, int]]:
    """``7``, ``0:50``, ``0:50:5``, ``10:`` or a comma-separated list -> (start, stop, step)."""
    out = []
    for part in text.split(","):
        part = part.strip()
        try:
            if ":" in part:
                bits = part.split(":")
                if len(bits) > 3:
                    raise ValueError
                start = int(bits[0]) if bits[0] else 0
                stop = int(bits[1]) if len(bits) > 1 and bits[1] else None
                step = int(bits[2]) if len(bits) > 2 and bits[2] else 1
            else:
                start = int(part)
                stop, step = start + 1, 1
            if start < 0 or step < 1 or (stop is not None and stop < 0):
                raise ValueError
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"got {text!r}; expected frame numbers like 7, 0:50, 0:50:5 or 0,10,20"
            ) from None
        out.append((start, stop, step))
    return out


parse_frames.__name__ = "frame selection"


def _selected(k: int, spec: list[tuple[int, int | None, int]] | None) -> bool:
    if not spec:
        return True
    return any(k >= a and (b is None or k < b) and (k - a) % s == 0 for a, b, s in spec)


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


def _verbosity(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")
    g.add_argument("--verbose", "-v", action="store_true", help="also print the library's log")


def add_post_commands(sub: Any) -> None:
    """Add ``surface`` and ``render`` to the ``sphkit`` command's sub-parsers."""
    from sphkit.io.preview import COLOR_FIELDS, VIDEO_FORMATS
    from sphkit.io.surface import MESH_FORMATS

    s = sub.add_parser(
        "surface", help="reconstruct surface meshes of a run's frames (splashsurf)",
        description="Turn each particle frame of a 3D run folder into a triangle mesh with "
                    "splashsurf (pysplashsurf; pip install 'sphkit[surface]'). Lengths are in "
                    "multiples of the particle radius, as in splashsurf.",
    )
    s.add_argument("outdir", type=Path, metavar="OUTDIR", help="the folder of a run")
    s.add_argument("--format", type=_choices_list(tuple(MESH_FORMATS), "obj,ply"),
                   dest="formats", default=["obj"], metavar="LIST",
                   help=f"mesh formats out of {', '.join(MESH_FORMATS)} (vtk: .vtu; "
                        "default: obj)")
    s.add_argument("--out", type=Path, metavar="DIR", help="mesh folder (default OUTDIR/surface)")
    s.add_argument("--radius", type=_positive("particle radius [m]"), metavar="R",
                   help="particle radius [m] (default: the run's)")
    s.add_argument("--smoothing-length", type=_positive("kernel smoothing length / r"),
                   default=2.0, metavar="H", help="kernel smoothing length in radii (default 2)")
    s.add_argument("--cube-size", type=_positive("marching-cubes cell size / r"), default=0.5,
                   metavar="C", help="marching-cubes cell size in radii (default 0.5)")
    s.add_argument("--threshold", type=_positive("iso value of the colour field"), default=0.6,
                   metavar="T", help="iso-surface threshold of the colour field (default 0.6)")
    s.add_argument("--mesh-smoothing-iters", type=_positive("iterations", True, True),
                   default=25, metavar="N",
                   help="weighted Laplacian mesh smoothing iterations (default 25, 0: off)")
    s.add_argument("--mesh-cleanup", action="store_true",
                   help="marching-cubes mesh clean-up (fewer, better-shaped triangles)")
    s.add_argument("--frames", type=parse_frames, metavar="SPEC",
                   help="frame numbers: 7, 0:50, 0:50:5 or a comma-separated list (default all)")
    _verbosity(s)

    r = sub.add_parser(
        "render", help="preview pictures and a video of a run (matplotlib)",
        description="Draw each frame of a run folder into a PNG and join them into an MP4 "
                    "(ffmpeg) or GIF: 2D runs as coloured particles, 3D runs as the surface "
                    "meshes of 'sphkit surface' if present, else as a 3D scatter "
                    "(pip install 'sphkit[plot]').",
    )
    r.add_argument("outdir", type=Path, metavar="OUTDIR", help="the folder of a run")
    r.add_argument("--color", choices=COLOR_FIELDS, default="velocity",
                   help="particle colour: speed |v|, pressure or density (default velocity)")
    r.add_argument("--video", choices=VIDEO_FORMATS, default="auto",
                   help="video format: auto (mp4 with ffmpeg, else gif), mp4, gif, none")
    r.add_argument("--out", type=Path, metavar="DIR", help="picture folder (default OUTDIR/render)")
    r.add_argument("--fps", type=_positive("video frames per second"), metavar="F",
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
    _verbosity(r)


# -- shared ------------------------------------------------------------------------------------
def _run_info(outdir: Path) -> dict[str, Any]:
    if not (outdir / MANIFEST_NAME).is_file():
        raise _Usage(f"OUTDIR {str(outdir)!r}: no {MANIFEST_NAME}; expected the folder of a "
                     "'sphkit run'")
    try:
        m = read_manifest(outdir)
        scene = m.get("scene") or {}
        cfg = scene.get("configuration") or {}
        materials = scene.get("materials") or [{}]
        gravity = cfg.get("gravity") or [0.0, -9.81, 0.0]
        return {
            "manifest": m,
            "frames": list(m.get("frames") or []),
            "dim": int((m.get("output") or {}).get("dim") or cfg.get("dim") or 3),
            "fps": float((m.get("output") or {}).get("fps") or 25.0),
            "radius": float(cfg.get("particle_radius") or 0.025),
            "density0": float(materials[0].get("density0") or 1000.0),
            "up": int(np.argmax(np.abs(gravity))) if any(gravity) else 1,
            "boxes": scene.get("boxes") or [],
        }
    except (OSError, ValueError, TypeError, AttributeError) as e:
        raise _Usage(f"OUTDIR {str(outdir)!r}: unreadable {MANIFEST_NAME} ({e})") from None


def _frame_file(outdir: Path, rec: dict[str, Any]) -> Path | None:
    """The particle file of a frame record, preferring the fastest to read."""
    files = [outdir / f for f in rec.get("files", [])]
    rank = {".bgeo": 0, ".gz": 1, ".ply": 2, ".vtu": 3}
    files = [f for f in files if f.is_file()]
    files.sort(key=lambda f: rank.get(f.suffix.lower(), 9))
    return files[0] if files else None


def _selected_frames(info: dict[str, Any], spec) -> list[dict[str, Any]]:
    frames = [rec for rec in info["frames"] if _selected(int(rec["frame"]), spec)]
    if not frames:
        raise _Usage("no frames to process: the run has none"
                     + (" in the --frames selection" if spec else ""))
    return frames


def run_post_command(args: argparse.Namespace) -> int:
    """Dispatch ``surface`` / ``render``; return the exit code."""
    try:
        if args.command == "surface":
            return cmd_surface(args)
        return cmd_render(args)
    except _Usage as e:
        _error(str(e))
        return EXIT_USAGE
    except KeyboardInterrupt:
        _error("interrupted")
        return EXIT_INTERRUPTED


def _open_log(args: argparse.Namespace, folder: Path) -> None:
    session = getattr(args, "log_session", None)
    if session is not None:
        try:
            session.add_file(folder, append=True)
        except OSError as e:
            raise _Usage(f"cannot write the log file in {str(folder)!r}: {e}") from None


def _say(args: argparse.Namespace, text: str) -> None:
    if not args.quiet:
        print(text, file=sys.stderr, flush=True)
    log.info(text, extra={"console": False})


# -- surface -----------------------------------------------------------------------------------
def cmd_surface(args: argparse.Namespace) -> int:
    """``sphkit surface``: one mesh per frame; return the exit code."""
    from sphkit.io.frames import read_frame
    from sphkit.io.surface import (
        MESH_FORMATS,
        SurfaceParameters,
        SurfaceUnavailable,
        reconstruct_surface,
        write_mesh,
    )

    outdir: Path = args.outdir
    info = _run_info(outdir)
    if info["dim"] != 3:
        raise _Usage(f"OUTDIR {str(outdir)!r}: a {info['dim']}D run; surface reconstruction "
                     "needs a 3D run")
    try:
        import pysplashsurf  # noqa: F401
    except ImportError:
        raise _Usage(str(SurfaceUnavailable(
            "surface reconstruction needs pysplashsurf: pip install 'sphkit[surface]' "
            "(or pip install pysplashsurf)"))) from None
    frames = _selected_frames(info, args.frames)
    params = SurfaceParameters(
        particle_radius=args.radius or info["radius"], rest_density=info["density0"],
        smoothing_length=args.smoothing_length, cube_size=args.cube_size,
        iso_surface_threshold=args.threshold, mesh_smoothing_iters=int(args.mesh_smoothing_iters),
        mesh_cleanup=args.mesh_cleanup)
    dest: Path = args.out or outdir / SURFACE_DIR
    try:
        dest.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        _error(f"cannot create the mesh folder {str(dest)!r}: {e}")
        return EXIT_FAILED
    _open_log(args, outdir)
    _say(args, f"surface: {len(frames)} frame(s) of {outdir} -> {dest} as "
               f"{', '.join(args.formats)}; r = {params.particle_radius:g} m, smoothing length "
               f"{params.smoothing_length:g} r, cube size {params.cube_size:g} r, threshold "
               f"{params.iso_surface_threshold:g}, {params.mesh_smoothing_iters} smoothing "
               "iterations")
    records = []
    t0 = time.perf_counter()
    for rec in frames:
        k = int(rec["frame"])
        src = _frame_file(outdir, rec)
        if src is None:
            log.warning("frame %d: no particle file on disk (listed: %s); skipped", k,
                        ", ".join(rec.get("files", [])))
            continue
        pos = read_frame(src)["position"]
        vertices, triangles = reconstruct_surface(pos, params)
        files = []
        try:
            for fmt in args.formats:
                path = dest / f"surface_{k:05d}{MESH_FORMATS[fmt]}"
                write_mesh(path, vertices, triangles, fmt)
                files.append(path.name)
        except OSError as e:
            _error(f"writing the mesh of frame {k} failed: {e}")
            return EXIT_FAILED
        records.append({"frame": k, "time": rec.get("time"), "source": src.name, "files": files,
                        "n_particles": int(len(pos)), "n_vertices": int(len(vertices)),
                        "n_triangles": int(len(triangles))})
        _say(args, f"frame {k} (t = {rec.get('time', 0.0):.4g} s): {len(pos)} particles -> "
                   f"{len(vertices)} vertices, {len(triangles)} triangles")
        atomic_write_text(dest / SURFACE_MANIFEST, json.dumps({
            "format": "sphkit-surface", "format_version": 1, "run": str(outdir),
            "method": "splashsurf (pysplashsurf)", "parameters": params.as_dict(),
            "formats": args.formats, "frames": records}, indent=1) + "\n")
    _say(args, f"surface: {len(records)} mesh(es) in {time.perf_counter() - t0:.1f} s; in {dest}")
    return EXIT_OK


# -- render ------------------------------------------------------------------------------------
def _load_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    if path.suffix.lower() == ".vtu":
        import meshio

        m = meshio.read(path, file_format="vtu")
        tris = [c.data for c in m.cells if c.type == "triangle"]
        f = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
        return np.asarray(m.points, dtype=float), f
    import trimesh

    m = trimesh.load(path, process=False, force="mesh")
    return np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64)


def _surface_meshes(outdir: Path, mode: str) -> dict[int, Path]:
    folder = outdir / SURFACE_DIR
    index = folder / SURFACE_MANIFEST
    if mode == "off":
        return {}
    if not index.is_file():
        if mode == "on":
            raise _Usage(f"--surface on: {str(index)!r} not found; run 'sphkit surface "
                         f"{outdir}' first")
        return {}
    data = json.loads(index.read_text(encoding="utf-8"))
    out = {}
    for rec in data.get("frames", []):
        files = [folder / f for f in rec.get("files", []) if (folder / f).is_file()]
        if files:
            out[int(rec["frame"])] = files[0]
    return out


def cmd_render(args: argparse.Namespace) -> int:
    """``sphkit render``: PNG per frame and a video; return the exit code."""
    from sphkit.io.frames import read_frame
    from sphkit.io.preview import (
        PlotUnavailable,
        PreviewRenderer,
        RenderSettings,
        bounds_of,
        choose_video,
        color_values,
        robust_range,
        write_gif,
        write_mp4,
    )

    outdir: Path = args.outdir
    info = _run_info(outdir)
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise _Usage(str(PlotUnavailable(
            "previews need matplotlib: pip install 'sphkit[plot]' (or pip install matplotlib)"
        ))) from None
    video = choose_video(args.video)
    if args.video == "mp4" and video == "mp4":
        from sphkit.io.preview import ffmpeg_path

        if ffmpeg_path() is None:
            raise _Usage("--video mp4 needs the ffmpeg program, which was not found; "
                         "install ffmpeg or use --video gif")
    frames = [rec for rec in _selected_frames(info, args.frames) if _frame_file(outdir, rec)]
    if not frames:
        raise _Usage(f"OUTDIR {str(outdir)!r}: none of the frames has a particle file on disk")
    meshes = _surface_meshes(outdir, args.surface) if info["dim"] == 3 else {}
    dest: Path = args.out or outdir / RENDER_DIR
    try:
        dest.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        _error(f"cannot create the picture folder {str(dest)!r}: {e}")
        return EXIT_FAILED
    _open_log(args, outdir)

    # colour range and picture bounds from up to 8 frames spread over the run
    sample = [frames[i] for i in sorted({round(j * (len(frames) - 1) / 7) for j in range(8)})]
    arrays = [read_frame(_frame_file(outdir, rec)) for rec in sample]
    try:
        values = [color_values(a, args.color, f" {rec['frame']}") for a, rec in zip(
            arrays, sample, strict=True)] if not (meshes and info["dim"] == 3) else []
    except ValueError as e:
        raise _Usage(str(e)) from None
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
    _say(args, f"render: {len(frames)} frame(s) of {outdir} ({info['dim']}D, {what}) -> {dest}"
               + (f", video {video}" if video else ""))
    renderer = PreviewRenderer(info["dim"], info["radius"], info["up"], bounds, settings)
    pngs: list[Path] = []
    t0 = time.perf_counter()
    try:
        for rec in frames:
            k = int(rec["frame"])
            data = read_frame(_frame_file(outdir, rec))
            mesh = _load_mesh(meshes[k]) if k in meshes else None
            try:
                renderer.draw(data, float(rec.get("time") or 0.0), mesh)
            except ValueError as e:
                raise _Usage(str(e)) from None
            pngs.append(renderer.save_png(dest / f"frame_{k:05d}.png"))
            log.debug("rendered frame %d", k)
    except OSError as e:
        _error(f"writing the pictures failed: {e}")
        return EXIT_FAILED
    finally:
        renderer.close()
    fps = args.fps or info["fps"]
    if video:
        path = dest / f"preview.{video}"
        try:
            (write_mp4 if video == "mp4" else write_gif)(pngs, path, fps)
        except (OSError, RuntimeError) as e:
            _error(f"writing the video {str(path)!r} failed: {e}")
            return EXIT_FAILED
        _say(args, f"video: {path} ({len(pngs)} frames at {fps:g} frames/s)")
    _say(args, f"render: {len(pngs)} picture(s) in {time.perf_counter() - t0:.1f} s; in {dest}")
    return EXIT_OK
