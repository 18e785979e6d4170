"""``sphkit surface``: surface meshes of a run's frames (splashsurf).

::

    sphkit surface OUTDIR [--format obj,ply,vtk] [--out DIR] [--radius R] [--smoothing-length 2]
                          [--cube-size 0.5] [--threshold 0.6] [--mesh-smoothing-iters 25]
                          [--mesh-cleanup] [--by-phase] [--frames SPEC] [--quiet | --verbose]

Reads the run's ``manifest.json`` (the frames, their times, the particle radius and rest density
of the scene) and writes ``OUTDIR/surface/surface_00000.obj`` ... and ``surface.json``
(parameters, files and mesh sizes per frame), which ``sphkit render`` draws for a 3D run
(:mod:`sphkit.io.surface`; pip install 'sphkit[surface]'). ``--frames`` selects frame numbers:
``7``, ``0:50`` (end excluded), ``0:50:5`` or a comma-separated list of those. ``--by-phase``
(a run of several fluids, whose frames carry ``phase``): one mesh per phase of each frame,
``surface_00000_phase1.obj``, from that phase's particles alone (a renderer gives each liquid
its own material; the meshes of two phases meet at their interface), listed per phase in
``surface.json``; ``sphkit render`` draws them in a colour per phase. Exit codes as for
``sphkit run``: 0 done, 1 an output file could not be written, 2 bad arguments, a folder without
a manifest, a 2D run, pysplashsurf missing, 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
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
    choices_list,
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
from sphkit.io.atomic import atomic_write_text


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``sphkit surface`` to the ``sphkit`` command's subcommands."""
    from sphkit.io.surface import MESH_FORMATS

    s = sub.add_parser(
        "surface", help="reconstruct surface meshes of a run's frames (splashsurf)",
        description="Turn each particle frame of a 3D run folder into a triangle mesh with "
                    "splashsurf (pysplashsurf; pip install 'sphkit[surface]'). Lengths are in "
                    "multiples of the particle radius, as in splashsurf.",
    )
    s.add_argument("outdir", type=Path, metavar="OUTDIR", help="the folder of a run")
    s.add_argument("--format", type=choices_list(tuple(MESH_FORMATS), "obj,ply"),
                   dest="formats", default=["obj"], metavar="LIST",
                   help=f"mesh formats out of {', '.join(MESH_FORMATS)} (vtk: .vtu; "
                        "default: obj)")
    s.add_argument("--out", type=Path, metavar="DIR", help="mesh folder (default OUTDIR/surface)")
    s.add_argument("--radius", type=positive("particle radius [m]"), metavar="R",
                   help="particle radius [m] (default: the run's)")
    s.add_argument("--smoothing-length", type=positive("kernel smoothing length / r"),
                   default=2.0, metavar="H", help="kernel smoothing length in radii (default 2)")
    s.add_argument("--cube-size", type=positive("marching-cubes cell size / r"), default=0.5,
                   metavar="C", help="marching-cubes cell size in radii (default 0.5)")
    s.add_argument("--threshold", type=positive("iso value of the colour field"), default=0.6,
                   metavar="T", help="iso-surface threshold of the colour field (default 0.6)")
    s.add_argument("--mesh-smoothing-iters", type=positive("iterations", True, True),
                   default=25, metavar="N",
                   help="weighted Laplacian mesh smoothing iterations (default 25, 0: off)")
    s.add_argument("--mesh-cleanup", action="store_true",
                   help="marching-cubes mesh clean-up (fewer, better-shaped triangles)")
    s.add_argument("--by-phase", action="store_true",
                   help="several fluids: one mesh per phase (surface_00000_phase1.obj) instead "
                        "of one of all the fluid")
    s.add_argument("--frames", type=parse_frames, metavar="SPEC",
                   help="frame numbers: 7, 0:50, 0:50:5 or a comma-separated list (default all)")
    add_verbosity(s)
    s.set_defaults(handler=cmd_surface)


def cmd_surface(args: argparse.Namespace, argv: Sequence[str]) -> int:
    """``sphkit surface``: one mesh per frame; return the exit code."""
    return guarded(_surface, args)


def _surface(args: argparse.Namespace) -> int:
    from sphkit.io.frames import read_frame
    from sphkit.io.surface import (
        MESH_FORMATS,
        SurfaceParameters,
        SurfaceUnavailable,
        reconstruct_surface,
        write_mesh,
    )

    outdir: Path = args.outdir
    info = run_info(outdir)
    if info["dim"] != 3:
        raise UsageError(f"OUTDIR {str(outdir)!r}: a {info['dim']}D run; surface reconstruction "
                     "needs a 3D run")
    try:
        import pysplashsurf  # noqa: F401
    except ImportError:
        raise UsageError(str(SurfaceUnavailable(
            "surface reconstruction needs pysplashsurf: pip install 'sphkit[surface]' "
            "(or pip install pysplashsurf)"))) from None
    frames = selected_frames(info, args.frames)
    params = SurfaceParameters(
        particle_radius=args.radius or info["radius"], rest_density=info["density0"],
        smoothing_length=args.smoothing_length, cube_size=args.cube_size,
        iso_surface_threshold=args.threshold, mesh_smoothing_iters=int(args.mesh_smoothing_iters),
        mesh_cleanup=args.mesh_cleanup)
    dest: Path = args.out or outdir / SURFACE_DIR
    try:
        dest.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        error(f"cannot create the mesh folder {str(dest)!r}: {e}")
        return EXIT_FAILED
    open_log(args, outdir)
    say(args, f"surface: {len(frames)} frame(s) of {outdir} -> {dest} as "
               f"{', '.join(args.formats)}; r = {params.particle_radius:g} m, smoothing length "
               f"{params.smoothing_length:g} r, cube size {params.cube_size:g} r, threshold "
               f"{params.iso_surface_threshold:g}, {params.mesh_smoothing_iters} smoothing "
               "iterations")
    records = []
    t0 = time.perf_counter()
    for rec in frames:
        k = int(rec["frame"])
        src = frame_file(outdir, rec)
        if src is None:
            log.warning("frame %d: no particle file on disk (listed: %s); skipped", k,
                        ", ".join(rec.get("files", [])))
            continue
        arrays = read_frame(src)
        pos = arrays["position"]
        if args.by_phase and "phase" not in arrays:
            raise UsageError(f"--by-phase: frame {k} ({src.name}) has no 'phase' attribute: the "
                             "run has one fluid (or its frames were written without it, "
                             "output.attributes)")
        parts = ([(int(p), pos[arrays["phase"] == p]) for p in np.unique(arrays["phase"])]
                 if args.by_phase else [(None, pos)])
        record: dict = {"frame": k, "time": rec.get("time"), "source": src.name, "files": [],
                        "n_particles": int(len(pos)), "n_vertices": 0, "n_triangles": 0}
        for phase, points in parts:
            vertices, triangles = reconstruct_surface(points, params)
            suffix = "" if phase is None else f"_phase{phase}"
            files = []
            try:
                for fmt in args.formats:
                    path = dest / f"surface_{k:05d}{suffix}{MESH_FORMATS[fmt]}"
                    write_mesh(path, vertices, triangles, fmt)
                    files.append(path.name)
            except OSError as e:
                error(f"writing the mesh of frame {k} failed: {e}")
                return EXIT_FAILED
            record["files"] += files
            record["n_vertices"] += int(len(vertices))
            record["n_triangles"] += int(len(triangles))
            if phase is not None:
                record.setdefault("phases", []).append({
                    "phase": phase, "files": files, "n_particles": int(len(points)),
                    "n_vertices": int(len(vertices)), "n_triangles": int(len(triangles))})
        records.append(record)
        each = (" (" + ", ".join(f"phase {e['phase']}: {e['n_particles']}"
                                 for e in record["phases"]) + ")") if args.by_phase else ""
        say(args, f"frame {k} (t = {rec.get('time', 0.0):.4g} s): {len(pos)} particles{each} -> "
                   f"{record['n_vertices']} vertices, {record['n_triangles']} triangles")
        atomic_write_text(dest / SURFACE_MANIFEST, json.dumps({
            "format": "sphkit-surface", "format_version": 1, "run": str(outdir),
            "method": "splashsurf (pysplashsurf)", "parameters": params.as_dict(),
            "formats": args.formats, "frames": records}, indent=1) + "\n")
    say(args, f"surface: {len(records)} mesh(es) in {time.perf_counter() - t0:.1f} s; in {dest}")
    return EXIT_OK
