"""Preview pictures and videos of a run, drawn offscreen with matplotlib (``sphkit[plot]``).

* 2D runs: the particles as discs of their true size, coloured by speed |v|, pressure or density.
* 3D runs: the reconstructed surface meshes of ``sphkit surface`` (``<run>/surface``) when there
  are any, shaded by a headlight (Lambert); otherwise the particles as a depth-shaded 3D scatter,
  coloured as in 2D. The vertical axis of the picture is the axis of gravity.

One PNG per frame (``frame_00000.png``) and a video: MP4 (H.264, needs the ``ffmpeg`` program)
or an animated GIF (Pillow, which matplotlib installs). The colour range is fixed over the whole
sequence (1st to 99th percentile over up to 8 frames, or given), so colours compare across
frames.
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sphkit.io.atomic import atomic_open, atomic_path
from sphkit.io.frames import read_frame

logger = logging.getLogger("sphkit.io")

COLOR_FIELDS = ("velocity", "pressure", "density", "phase", "stress", "displacement",
                "object")
VIDEO_FORMATS = ("auto", "mp4", "gif", "none")
#: the colour of the moving rigid bodies in previews (RGB)
BODY_COLOR = (0.6, 0.6, 0.63)
#: the colour of a surface mesh of all the fluid, and of each phase's (``--by-phase``)
SURFACE_COLOR = (0.20, 0.45, 0.85)
PHASE_COLORS = ((0.20, 0.45, 0.85), (0.90, 0.45, 0.15), (0.25, 0.65, 0.30),
                (0.75, 0.25, 0.55), (0.85, 0.75, 0.20), (0.45, 0.35, 0.75))
_UNITS = {"velocity": "|v| [m/s]", "pressure": "pressure [Pa]", "density": "density [kg/m^3]",
          "phase": "phase (material index)", "stress": "von Mises stress [Pa]",
          "displacement": "|displacement| [m]", "object": "object (-1: fluid)"}


class PlotUnavailable(ImportError):
    """matplotlib is not installed."""


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise PlotUnavailable(
            "previews need matplotlib: pip install 'sphkit[plot]' (or pip install matplotlib)"
        ) from None
    return plt


def ffmpeg_path() -> str | None:
    """The ``ffmpeg`` program matplotlib would use, or None."""
    try:
        import matplotlib

        name = matplotlib.rcParams.get("animation.ffmpeg_path", "ffmpeg")
    except ImportError:
        name = "ffmpeg"
    return shutil.which(name)


def color_values(arrays: dict[str, np.ndarray], color: str, where: str = "") -> np.ndarray:
    """The per-particle values of ``color`` (|velocity|, pressure, density, phase: the
    material index that runs of several fluids write, or an elastic solid's von Mises stress,
    |displacement| or object index, which scenes with solids write)."""
    if color not in COLOR_FIELDS:
        raise ValueError(f"--color: got {color!r}; expected one of {', '.join(COLOR_FIELDS)}")
    if color not in arrays:
        have = ", ".join(k for k in arrays if k != "position")
        raise ValueError(
            f"--color {color}: the frame{where} has no {color!r} attribute (it has {have}); "
            "write it with the scene's output.attributes"
        )
    a = np.asarray(arrays[color], dtype=float)
    return np.linalg.norm(a, axis=1) if a.ndim == 2 else a


@dataclass
class RenderSettings:
    """What and how to draw; sizes in pixels."""

    color: str = "velocity"
    cmap: str = "viridis"
    vrange: tuple[float, float] | None = None
    width: int = 960
    height: int = 720
    dpi: int = 120
    surface: str = "auto"  #: 3D: draw meshes "auto" (if any) / "on" (required) / "off"
    max_points: int = 60000  #: 3D scatter: draw at most this many particles (every k-th)
    elev: float = 20.0
    azim: float = -60.0
    extra: dict[str, Any] = field(default_factory=dict)


class PreviewRenderer:
    """Draws the frames of one run into a reused figure."""

    def __init__(self, dim: int, radius: float, up_axis: int, bounds: np.ndarray,
                 settings: RenderSettings) -> None:
        plt = _pyplot()
        self.plt = plt
        self.dim, self.r, self.up, self.s = dim, radius, up_axis, settings
        self.bounds = bounds  # (2, 3): lower and upper corner [m]
        self.fig = plt.figure(figsize=(settings.width / settings.dpi,
                                       settings.height / settings.dpi), dpi=settings.dpi)
        self._cbar = None

    # axis order of the picture: (horizontal, depth, vertical) for 3D, (x, vertical) for 2D
    def _order(self) -> list[int]:
        others = [a for a in range(3) if a != self.up]
        return [others[0], others[1], self.up]

    def draw(self, arrays: dict[str, np.ndarray], time: float,
             mesh: tuple[np.ndarray, ...] | None = None,
             bodies: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Draw one frame (particle arrays, or a surface mesh in 3D) at simulated ``time``;
        ``mesh``: (vertices (V, 3), triangles (T, 3)) or with the triangles' colours (T, 3) as
        third item (:func:`merged_meshes`);
        ``bodies``: the moving rigid bodies' triangles (vertices (V, 3), triangles (T, 3)) at
        the frame's pose, drawn grey (:mod:`sphkit.io.bodies`; in 2D their outline in the
        xy-plane)."""
        self.fig.clf()
        self._cbar = None
        if self.dim == 2:
            ax = self._draw_2d(arrays)
            if bodies is not None and len(bodies[1]):
                from matplotlib.collections import PolyCollection

                ax.add_collection(PolyCollection(bodies[0][:, :2][bodies[1]], zorder=3,
                                                 facecolors=BODY_COLOR, edgecolors="none"))
        else:
            ax, order = self._draw_mesh(*mesh) if mesh is not None else self._draw_3d(arrays)
            if bodies is not None:
                self._add_mesh(ax, order, *bodies, np.array(BODY_COLOR))
        self.fig.suptitle(f"t = {time:.3f} s", y=0.97)

    def _norm(self):
        from matplotlib.colors import Normalize

        lo, hi = self.s.vrange if self.s.vrange else (0.0, 1.0)
        return Normalize(vmin=lo, vmax=hi if hi > lo else lo + 1.0)

    def _draw_2d(self, arrays: dict[str, np.ndarray]) -> Any:
        ax = self.fig.add_subplot(1, 1, 1)
        h, v = 0, 1  # 2D runs live in the xy-plane
        lo, hi = self.bounds
        ax.set_xlim(lo[h], hi[h])
        ax.set_ylim(lo[v], hi[v])
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        self.fig.canvas.draw()  # fixes the axes' size for the marker size below
        bbox = ax.get_window_extent()
        pts_per_m = bbox.width / (hi[h] - lo[h]) * 72.0 / self.fig.dpi
        pos = arrays["position"]
        c = color_values(arrays, self.s.color)
        sc = ax.scatter(pos[:, h], pos[:, v], s=(2 * self.r * pts_per_m) ** 2, c=c,
                        cmap=self.s.cmap, norm=self._norm(), linewidths=0)
        self._cbar = self.fig.colorbar(sc, ax=ax, label=_UNITS[self.s.color], shrink=0.8)
        return ax

    def _axes3d(self):
        ax = self.fig.add_subplot(1, 1, 1, projection="3d")
        order = self._order()
        lo, hi = self.bounds
        ax.set_xlim(lo[order[0]], hi[order[0]])
        ax.set_ylim(lo[order[1]], hi[order[1]])
        ax.set_zlim(lo[order[2]], hi[order[2]])
        ax.set_box_aspect([hi[a] - lo[a] for a in order])
        names = "xyz"
        ax.set_xlabel(f"{names[order[0]]} [m]")
        ax.set_ylabel(f"{names[order[1]]} [m]")
        ax.set_zlabel(f"{names[order[2]]} [m]")
        from matplotlib.ticker import MaxNLocator

        for axis, a in zip((ax.xaxis, ax.yaxis, ax.zaxis), order, strict=True):
            # about one tick per 0.4 of the longest side, so that thin sides stay legible
            n = max(2, int(round(5 * (hi[a] - lo[a]) / max(hi - lo))))
            axis.set_major_locator(MaxNLocator(n))
        ax.view_init(elev=self.s.elev, azim=self.s.azim)
        return ax, order

    def _draw_3d(self, arrays: dict[str, np.ndarray]) -> tuple[Any, list[int]]:
        ax, order = self._axes3d()
        pos = arrays["position"]
        c = color_values(arrays, self.s.color)
        step = max(1, int(np.ceil(len(pos) / self.s.max_points)))
        p, c = pos[::step], c[::step]
        # marker size: the particle diameter at the scale of the box's width (approximate in
        # a perspective view)
        self.fig.canvas.draw()
        lo, hi = self.bounds
        pts_per_m = (ax.get_window_extent().width * 72.0 / self.fig.dpi
                     / (np.linalg.norm(hi - lo) * 1.2))
        size = max(0.5, (2.0 * self.r * pts_per_m) ** 2)
        sc = ax.scatter(p[:, order[0]], p[:, order[1]], p[:, order[2]], c=c, s=size,
                        cmap=self.s.cmap, norm=self._norm(), depthshade=True, linewidths=0)
        self._cbar = self.fig.colorbar(sc, ax=ax, label=_UNITS[self.s.color], shrink=0.6,
                                          pad=0.12)
        return ax, order

    def _draw_mesh(self, vertices: np.ndarray, triangles: np.ndarray,
                   colors: np.ndarray | None = None) -> tuple[Any, list[int]]:
        ax, order = self._axes3d()
        self._add_mesh(ax, order, vertices, triangles,
                       np.array(SURFACE_COLOR) if colors is None else colors)
        return ax, order

    def _add_mesh(self, ax: Any, order: list[int], vertices: np.ndarray,
                  triangles: np.ndarray, base: np.ndarray) -> None:
        """Triangles shaded by a light above and left of the viewer, in colour ``base`` (3,)
        or one colour per triangle (T, 3)."""
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        if len(triangles) == 0:
            return
        tri = vertices[:, order][triangles]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        def direction(azim: float, elev: float) -> np.ndarray:
            az, el = np.radians(azim), np.radians(elev)
            return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])

        eye = direction(self.s.azim, self.s.elev)
        n *= np.where(n @ eye < 0.0, -1.0, 1.0)[:, None]  # normals towards the viewer
        # a light above and to the left of the viewer
        light = direction(self.s.azim - 40.0, min(self.s.elev + 40.0, 85.0))
        shade = 0.15 + 0.85 * np.clip(n @ light, 0.0, 1.0)
        colors = np.clip(shade[:, None] * (base if base.ndim == 2 else base[None, :]), 0, 1)
        coll = Poly3DCollection(tri, facecolors=colors, edgecolors="none", linewidths=0)
        ax.add_collection3d(coll)

    def save_png(self, path: Path) -> Path:
        """Save the current figure as PNG, atomically."""
        with atomic_open(path, "wb") as f:
            self.fig.savefig(f, format="png", dpi=self.s.dpi)
        return path

    def close(self) -> None:
        self.plt.close(self.fig)


def write_gif(frames: Sequence[Path], path: Path, fps: float) -> Path:
    """An animated GIF of PNG files (Pillow), atomically."""
    from PIL import Image

    if not frames:
        raise ValueError("write_gif: no frames")
    duration = max(20, int(round(1000.0 / fps)))  # GIF delays are whole 1/100 s; 20 ms minimum
    first = Image.open(frames[0]).convert("RGB")

    def rest():
        for f in frames[1:]:
            with Image.open(f) as im:
                yield im.convert("RGB")

    with atomic_open(path, "wb") as fh:
        first.save(fh, format="GIF", save_all=True, append_images=rest(), duration=duration,
                   loop=0, optimize=False)
    return path


def write_mp4(frames: Sequence[Path], path: Path, fps: float) -> Path:
    """An H.264 MP4 of PNG files named ``<prefix>_%05d.png`` in one folder (ffmpeg)."""
    exe = ffmpeg_path()
    if exe is None:
        raise RuntimeError("--video mp4 needs the ffmpeg program, which was not found; "
                           "install ffmpeg or use --video gif")
    folder = frames[0].parent
    prefix = frames[0].name.rsplit("_", 1)[0]
    start = int(frames[0].stem.rsplit("_", 1)[1])
    with atomic_path(path) as tmp:
        cmd = [exe, "-y", "-loglevel", "error", "-framerate", f"{fps:g}",
               "-start_number", str(start), "-i", str(folder / f"{prefix}_%05d.png"),
               "-frames:v", str(len(frames)), "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
               "-c:v", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4", str(tmp)]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"ffmpeg failed ({res.returncode}): {res.stderr.strip()}")
    return path


def choose_video(video: str) -> str | None:
    """'auto' -> 'mp4' if ffmpeg is available, else 'gif'; 'none' -> None."""
    if video not in VIDEO_FORMATS:
        raise ValueError(f"--video: got {video!r}; expected one of {', '.join(VIDEO_FORMATS)}")
    if video == "none":
        return None
    if video == "auto":
        return "mp4" if ffmpeg_path() else "gif"
    return video


def robust_range(values: Sequence[np.ndarray]) -> tuple[float, float]:
    """1st and 99th percentile of the concatenated values (0, 1 without any)."""
    vals = [np.asarray(v, dtype=float).ravel() for v in values if np.size(v)]
    if not vals:
        return 0.0, 1.0
    allv = np.concatenate(vals)
    allv = allv[np.isfinite(allv)]
    if not allv.size:
        return 0.0, 1.0
    lo, hi = np.percentile(allv, [1.0, 99.0])
    return float(lo), float(hi if hi > lo else lo + 1e-12 + abs(lo) * 1e-6)


def bounds_of(positions: Sequence[np.ndarray], pad: float) -> np.ndarray:
    """(2, 3) lower/upper corner around all positions, padded by ``pad`` on every side."""
    pts = [p for p in positions if len(p)]
    if not pts:
        return np.array([[-1.0] * 3, [1.0] * 3])
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0) - pad, allp.max(axis=0) + pad
    return np.stack([lo, hi])


def load_frame(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """A particle frame of a run (any format :func:`sphkit.io.frames.read_frame` reads)."""
    return read_frame(path)


def merged_meshes(parts: list[tuple[int | None, np.ndarray, np.ndarray]]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One mesh of several ``(phase, vertices, triangles)``, with each triangle's colour:
    :data:`SURFACE_COLOR` for a mesh of all the fluid (phase None), else the phase's colour of
    :data:`PHASE_COLORS` (the meshes of ``sphkit surface --by-phase``)."""
    vertices, triangles, colors, start = [], [], [], 0
    for phase, v, t in parts:
        vertices.append(np.asarray(v, dtype=np.float64).reshape(-1, 3))
        triangles.append(np.asarray(t, dtype=np.int64).reshape(-1, 3) + start)
        c = SURFACE_COLOR if phase is None else PHASE_COLORS[phase % len(PHASE_COLORS)]
        colors.append(np.tile(np.asarray(c, dtype=np.float64), (len(triangles[-1]), 1)))
        start += len(vertices[-1])
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros((0, 3))
    return np.concatenate(vertices), np.concatenate(triangles), np.concatenate(colors)


def load_mesh(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """A triangle mesh of a run as (vertices (V, 3), triangles (T, 3)): a surface mesh of
    ``sphkit surface`` or a frame's rigid-body file (:mod:`sphkit.io.bodies`); VTU through
    meshio, OBJ and PLY through trimesh."""
    path = Path(path)
    if path.suffix.lower() == ".vtu":
        import meshio

        m = meshio.read(path, file_format="vtu")
        tris = [c.data for c in m.cells if c.type == "triangle"]
        f = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
        return np.asarray(m.points, dtype=float), f
    import trimesh

    m = trimesh.load(path, process=False, force="mesh")
    return np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64)
