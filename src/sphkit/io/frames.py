"""Frame output: one file per frame and format, written atomically.

Formats (the names are those of ``scene.output.formats``):

* ``"vtk"`` -- VTK XML unstructured grid ``frame_00000.vtu`` (written with meshio, one ``vertex``
  cell per particle, uncompressed binary), which ParaView opens. Beside the frames the writer keeps
  ``frame.vtu.series`` (ParaView's file-series format), so ParaView shows the simulated time of
  each frame instead of its number: open the ``.series`` file.
* ``"ply"`` -- binary little-endian PLY ``frame_00000.ply`` with one ``vertex`` element and no
  faces (Blender, Houdini, MeshLab and CloudCompare read it). Properties: ``x y z vx vy vz density
  pressure id``, floats in the simulation's precision (``double`` or ``float``), ``id`` as ``int``.
* ``"bgeo"`` -- Houdini's classic BGEO ``frame_00000.bgeo`` (:mod:`sphkit.io.bgeo`), as partio
  and SPlisHSPlasH's partio export write it: point attributes ``velocity`` (vector), ``density``,
  ``pressure`` (float) and ``id`` (int), all 32 bit. ``"bgeo.gz"``: the same, gzip-compressed
  (``frame_00000.bgeo.gz``; partio, Houdini and SPlisHSPlasH read it).

Every frame holds the fluid particles sorted by their id, so point ``i`` is the same particle in
every frame, with the point data

===========  =========  =========================================================
name         shape      meaning
===========  =========  =========================================================
(points)     (N, 3)     position [m]; 2D scenes are padded with z = 0
velocity     (N, 3)     velocity [m/s], padded like the positions
density      (N,)       density [kg/m^3]
pressure     (N,)       pressure [Pa]
id           (N,)       particle id (int64 in VTK, int32 in PLY)
===========  =========  =========================================================

Scenes with elastic solids also write their von Mises ``stress`` [Pa], ``rest_position``,
``displacement`` (``position - rest_position``; zero for fluid particles), ``fixed`` (1: pinned)
and ``object`` (the index of the scene object, fluid block or particle file, that made the
particle; -1 for fluid) by default, and plastic solids (a ``yield_stress``) their equivalent
``plastic_strain`` (:data:`SOLID_FIELDS`). Extra
fields a method registered with the ParticleSet can be added with ``extra_fields``.
``attributes`` (the scene's ``output.attributes``, SPlisHSPlasH's ``particleAttributes``)
replaces velocity, density and pressure by the named attributes: :data:`ATTRIBUTES` or any field
of the ParticleSet (:func:`resolve_attributes`); position and id are always written.
:func:`read_frame` reads a frame of any format back into the same arrays.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from sphkit.io.atomic import atomic_open, atomic_path, atomic_write_text
from sphkit.io.bgeo import read_bgeo, write_bgeo

#: format name -> file extension
FORMATS: dict[str, str] = {"vtk": ".vtu", "ply": ".ply", "bgeo": ".bgeo", "bgeo.gz": ".bgeo.gz"}

#: name in the frame file -> field of the ParticleSet
STANDARD_FIELDS: dict[str, str] = {"velocity": "v", "density": "rho", "pressure": "p", "id": "id"}

#: written besides the standard fields when the particle set has them (elastic solids,
#: :mod:`sphkit.solids.rest`): name in the frame file -> field
SOLID_FIELDS: dict[str, str] = {"stress": "solid_stress", "rest_position": "solid_x0",
                                "fixed": "solid_fixed", "object": "solid_object",
                                "plastic_strain": "solid_plastic_alpha"}

#: attribute names a scene may ask for (SPlisHSPlasH's spelling included) -> (name in the frame
#: file, field of the ParticleSet); any other field of the ParticleSet is written as it is named
ATTRIBUTES: dict[str, tuple[str, str]] = {
    "velocity": ("velocity", "v"), "density": ("density", "rho"), "pressure": ("pressure", "p"),
    "id": ("id", "id"), "acceleration": ("acceleration", "a"), "mass": ("mass", "m"),
    "angular velocity": ("angular_velocity", "omega"),
    "angular_velocity": ("angular_velocity", "omega"),
    # several fluids (sphkit.multiphase): the material index and the rest density [kg/m^3]
    "phase": ("phase", "phase"), "rest_density": ("rest_density", "rho0"),
    "rest density": ("rest_density", "rho0"),
}

#: the frame attributes written in addition to the others when the fluid has several
#: materials (``extra_fields`` of :class:`FrameWriter`)
MULTIPHASE_FIELDS: tuple[str, ...] = ("phase", "rest_density")


def resolve_attributes(names: Sequence[str], fluid: Any) -> dict[str, str]:
    """Attribute names (:data:`ATTRIBUTES` or ParticleSet fields) -> {frame name: field}.

    Raises:
        ValueError: a name that is neither, naming ``output.attributes``, the value and the
            names this simulation has.
    """
    out: dict[str, str] = {}
    for name in names:
        frame_name, field = ATTRIBUTES.get(name, (name, name))
        if field not in fluid or field == "x":
            known = sorted({k for k, (_, f) in ATTRIBUTES.items() if f in fluid and " " not in k}
                           | {f for f in fluid.fields if f not in ("x",)})
            raise ValueError(
                f"output.attributes: got {name!r}: this simulation has no such particle field; "
                f"expected one of {', '.join(known)}"
            )
        out[frame_name] = field
    return out


class FrameFormatError(ValueError):
    """A frame's arrays that the chosen format cannot hold (a PLY column of a type PLY does not
    have); ``sphkit run`` stops with the message and exit code 1, keeping the frames written."""


_PLY_TYPES = {
    np.dtype("<f8"): "double", np.dtype("<f4"): "float",
    np.dtype("<i4"): "int", np.dtype("<u4"): "uint",
    np.dtype("<i2"): "short", np.dtype("<u2"): "ushort",
    np.dtype("<i1"): "char", np.dtype("<u1"): "uchar",
}


def check_formats(formats: Sequence[str]) -> list[str]:
    """Return ``formats`` without duplicates, or raise ValueError naming the unknown one."""
    out: list[str] = []
    for f in formats:
        if f not in FORMATS:
            raise ValueError(
                f"output format {f!r} is not known; expected one of {', '.join(FORMATS)}"
            )
        if f not in out:
            out.append(f)
    return out


def _pad3(a: np.ndarray) -> np.ndarray:
    """(N, d) -> (N, 3) with zero columns appended (a copy, C-contiguous)."""
    out = np.zeros((a.shape[0], 3), dtype=a.dtype)
    out[:, : a.shape[1]] = a
    return out


def frame_arrays(fluid: Any, extra_fields: Sequence[str] = (),
                 attributes: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """The arrays of one frame from a ParticleSet, sorted by particle id.

    Returns ``{"position": (N, 3), "velocity": (N, 3), "density": (N,), "pressure": (N,),
    "id": (N,) int64, <extra>: ...}``; vectors are padded to 3 components. ``fluid`` needs the
    fields ``x``, ``v``, ``rho``, ``p`` and ``id`` (layout as in
    :class:`sphkit.core.particles.ParticleSet`) and those named in ``extra_fields``. With
    ``attributes`` (see :func:`resolve_attributes`) the frame holds position, those and id.
    """
    if attributes is None:
        wanted = {"position": "x", **STANDARD_FIELDS}
        wanted.update({k: f for k, f in SOLID_FIELDS.items() if f in fluid})
    else:
        wanted = {"position": "x", **resolve_attributes(attributes, fluid), "id": "id"}
    for name in extra_fields:
        frame_name, field = ATTRIBUTES.get(name, (name, name))
        if frame_name in wanted or field in wanted.values():
            continue
        wanted[frame_name] = field
    missing = [f for f in wanted.values() if f not in fluid]
    if missing:
        raise KeyError(
            f"cannot write a frame: the particle set has no field(s) {missing}; "
            f"it has {sorted(fluid.fields)}"
        )
    ids = np.asarray(fluid["id"])
    order = None if ids.size < 2 or bool(np.all(ids[1:] > ids[:-1])) else np.argsort(
        ids, kind="stable")
    out: dict[str, np.ndarray] = {}
    for name, field in wanted.items():
        a = np.asarray(fluid.view(field))
        if order is not None:
            a = a[order]
        if a.ndim == 2:
            a = _pad3(a)
        else:
            a = np.ascontiguousarray(a)
        out[name] = a.astype(np.int64) if name == "id" else a
    if attributes is None and "rest_position" in out and "solid_slot" in fluid:
        slot = np.asarray(fluid["solid_slot"])
        solid = (slot if order is None else slot[order]) >= 0
        out["displacement"] = np.where(solid[:, None], out["position"] - out["rest_position"],
                                       0.0)
    return out


def write_vtu(path: str | os.PathLike[str], arrays: dict[str, np.ndarray]) -> Path:
    """Write frame arrays (see :func:`frame_arrays`) as a VTK XML unstructured grid, atomically."""
    pos = arrays["position"]
    n = pos.shape[0]
    point_data = {k: v for k, v in arrays.items() if k != "position"}
    with atomic_path(path) as tmp:
        if n == 0:
            _write_empty_vtu(tmp, point_data)
        else:
            mesh = meshio.Mesh(
                pos, [("vertex", np.arange(n, dtype=np.int64).reshape(-1, 1))],
                point_data=point_data,
            )
            meshio.write(tmp, mesh, file_format="vtu", binary=True, compression=None)
    return Path(path)


_VTU_TYPES = {"f": "Float", "i": "Int", "u": "UInt"}


def _write_empty_vtu(path: Path, point_data: dict[str, np.ndarray]) -> None:
    """A VTU with no points (meshio cannot write one): the same arrays, empty."""
    arrays = []
    for name, a in point_data.items():
        vtype = f"{_VTU_TYPES[a.dtype.kind]}{8 * a.dtype.itemsize}"
        comps = f' NumberOfComponents="{a.shape[1]}"' if a.ndim == 2 else ""
        arrays.append(f'<DataArray type="{vtype}" Name="{name}"{comps} format="ascii"/>')
    text = (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">\n'
        '<UnstructuredGrid>\n<Piece NumberOfPoints="0" NumberOfCells="0">\n'
        '<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii"/></Points>\n'
        '<Cells><DataArray type="Int64" Name="connectivity" format="ascii"/>'
        '<DataArray type="Int64" Name="offsets" format="ascii"/>'
        '<DataArray type="UInt8" Name="types" format="ascii"/></Cells>\n'
        f'<PointData>{"".join(arrays)}</PointData>\n'
        '</Piece>\n</UnstructuredGrid>\n</VTKFile>\n'
    )
    path.write_text(text, encoding="utf-8")


def _ply_columns(arrays: dict[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    cols: list[tuple[str, np.ndarray]] = []
    for name, a in arrays.items():
        if a.ndim == 2:
            names = ("x", "y", "z") if name == "position" else (
                ("vx", "vy", "vz") if name == "velocity" else
                tuple(f"{name}_{c}" for c in "xyz")
            )
            cols.extend(zip(names, a.T, strict=True))
        elif a.dtype.kind in "iu" and a.dtype.newbyteorder("<") not in _PLY_TYPES:
            # 64-bit integers (ids, the phase of several fluids): PLY's 'int' has 32 bits
            i32 = np.iinfo(np.int32)
            if a.size and (a.min() < i32.min or a.max() > i32.max):
                raise FrameFormatError(
                    f"PLY output: field {name!r} holds values up to {a.max()}, which do not fit "
                    "the PLY 'int' type (32 bit); use the vtk or bgeo format"
                )
            cols.append((name, a.astype("<i4")))
        else:
            cols.append((name, a))
    return cols


def write_ply(path: str | os.PathLike[str], arrays: dict[str, np.ndarray],
              comment: str | None = None) -> Path:
    """Write frame arrays (see :func:`frame_arrays`) as a binary little-endian PLY point cloud."""
    cols = _ply_columns(arrays)
    n = arrays["position"].shape[0]
    dtype = np.dtype([(name, col.dtype.newbyteorder("<")) for name, col in cols])
    unknown = [f"{n_} ({dtype[n_]})" for n_ in dtype.names or () if dtype[n_] not in _PLY_TYPES]
    if unknown:
        raise FrameFormatError(f"PLY output: no PLY type for the field(s) {', '.join(unknown)}; "
                               "use the vtk or bgeo format")
    rec = np.empty(n, dtype=dtype)
    for name, col in cols:
        rec[name] = col
    header = ["ply", "format binary_little_endian 1.0"]
    if comment:
        header += [f"comment {line}" for line in comment.splitlines()]
    header.append(f"element vertex {n}")
    header += [f"property {_PLY_TYPES[dtype[name]]} {name}" for name in dtype.names or ()]
    header.append("end_header\n")
    with atomic_open(path, "wb") as f:
        f.write("\n".join(header).encode("ascii"))
        f.write(rec.tobytes())
    return Path(path)


def read_frame(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read a frame written by :class:`FrameWriter` (``.vtu``, ``.ply``, ``.bgeo``, ``.bgeo.gz``).

    Returns ``{"position": (N, 3), "velocity": (N, 3), "density", "pressure", "id", ...}`` --
    the arrays of :func:`frame_arrays`; PLY vector properties ``vx vy vz`` (and ``<name>_x``,
    ``_y``, ``_z``) are joined back into (N, 3) arrays. BGEO frames hold 32-bit numbers.
    """
    p = Path(path)
    if p.name.lower().endswith((".bgeo", ".bgeo.gz")):
        data = read_bgeo(p)
        assert isinstance(data, dict)
        return data
    fmt = {".vtu": "vtu", ".ply": "ply"}.get(p.suffix.lower())
    if fmt is None:
        raise ValueError(
            f"read_frame: {str(p)!r} is not a frame file; expected .vtu, .ply, .bgeo or .bgeo.gz"
        )
    if fmt == "vtu" and _is_empty_vtu(p):
        return _read_empty_vtu(p)
    mesh = meshio.read(p, file_format=fmt)
    out: dict[str, np.ndarray] = {"position": np.asarray(mesh.points)}
    pd = dict(mesh.point_data)
    if fmt == "ply":
        groups = {"velocity": ("vx", "vy", "vz")}
        for name in list(pd):
            if name.endswith("_x") and f"{name[:-2]}_y" in pd and f"{name[:-2]}_z" in pd:
                groups[name[:-2]] = (name, f"{name[:-2]}_y", f"{name[:-2]}_z")
        for name, comps in groups.items():
            if all(c in pd for c in comps):
                out[name] = np.column_stack([pd.pop(c) for c in comps])
    out.update({k: np.asarray(v) for k, v in pd.items()})
    return out


def _is_empty_vtu(path: Path) -> bool:
    with open(path, "rb") as f:
        head = f.read(512)
    return b'NumberOfPoints="0"' in head


def _read_empty_vtu(path: Path) -> dict[str, np.ndarray]:
    import xml.etree.ElementTree as ET

    out: dict[str, np.ndarray] = {"position": np.zeros((0, 3))}
    inv = {v: k for k, v in _VTU_TYPES.items()}
    for da in ET.parse(path).getroot().iter("DataArray"):
        name = da.get("Name")
        if name is None or name in ("connectivity", "offsets", "types"):
            continue
        vtype = da.get("type", "Float64")
        kind = vtype.rstrip("0123456789")
        dtype = np.dtype(f"{inv[kind]}{int(vtype[len(kind):]) // 8}")
        comps = int(da.get("NumberOfComponents", "1"))
        out[name] = np.zeros((0, comps) if comps > 1 else (0,), dtype=dtype)
    return out


class FrameWriter:
    """Writes the fluid particles of a simulation, one file per frame and format.

    ``out_dir`` is created if missing. ``formats`` are names of :data:`FORMATS`; ``dim`` the
    simulation's dimension (2D positions and velocities are padded with z = 0).
    ``extra_fields`` names further ParticleSet fields to write (vectors padded to 3 components);
    ``attributes`` replaces the default attributes (see :func:`frame_arrays`).

    After each :meth:`write`, :attr:`max_displacement` holds the largest distance [m] a particle
    moved since the previous frame (None for the first frame): sudden jumps in an exported
    sequence show up here.
    """

    def __init__(self, out_dir: str | os.PathLike[str], formats: Sequence[str], dim: int,
                 extra_fields: Sequence[str] = (), prefix: str = "frame",
                 attributes: Sequence[str] | None = None) -> None:
        if dim not in (2, 3):
            raise ValueError(f"FrameWriter dim: {dim!r}; expected 2 or 3")
        self.out_dir = Path(out_dir)
        self.formats = check_formats(formats)
        self.dim = dim
        self.extra_fields = tuple(extra_fields)
        self.attributes = None if attributes is None else tuple(attributes)
        self.prefix = prefix
        self.max_displacement: float | None = None
        self._prev: tuple[np.ndarray, np.ndarray] | None = None
        self._series: list[dict[str, Any]] = []
        self.out_dir.mkdir(parents=True, exist_ok=True)

    def path(self, frame: int, fmt: str) -> Path:
        """The file of ``frame`` in format ``fmt``: ``<out_dir>/frame_00042.vtu``."""
        return self.out_dir / f"{self.prefix}_{frame:05d}{FORMATS[fmt]}"

    @property
    def series_path(self) -> Path:
        """ParaView's file-series index of the VTK frames: ``<out_dir>/frame.vtu.series``."""
        return self.out_dir / f"{self.prefix}.vtu.series"

    def write(self, sim: Any, frame: int) -> list[Path]:
        """Write frame number ``frame`` of ``sim`` (needs ``.fluid`` and ``.time``) in every format.

        Returns the written paths, in the order of ``formats``.
        """
        if frame < 0:
            raise ValueError(f"frame number {frame}; expected >= 0")
        if sim.fluid.dim != self.dim:
            raise ValueError(
                f"FrameWriter was made for dim {self.dim}, the particles have dim {sim.fluid.dim}"
            )
        arrays = frame_arrays(sim.fluid, self.extra_fields, self.attributes)
        self._track_displacement(arrays)
        time = float(sim.time)
        paths: list[Path] = []
        for fmt in self.formats:
            path = self.path(frame, fmt)
            if fmt == "vtk":
                write_vtu(path, arrays)
                self._series = [e for e in self._series if e["name"] != path.name]
                self._series.append({"name": path.name, "time": time})
                atomic_write_text(self.series_path, json.dumps(
                    {"file-series-version": "1.0", "files": self._series}, indent=1) + "\n")
            elif fmt in ("bgeo", "bgeo.gz"):
                write_bgeo(path, arrays, compressed=fmt == "bgeo.gz")
            else:
                write_ply(path, arrays, comment=f"sphkit frame {frame} time {time!r} s")
            paths.append(path)
        return paths

    def resume_after(self, frame: int) -> None:
        """Continue a series whose frames up to ``frame`` are on disk (a resumed run): the VTK
        series index keeps their entries, and the displacement of the next frame is measured
        from frame ``frame`` (read back from the first format that has it)."""
        try:
            data = json.loads(self.series_path.read_text(encoding="utf-8"))
            entries = data.get("files", [])
        except (OSError, ValueError, AttributeError):
            entries = []
        keep = {self.path(k, "vtk").name for k in range(frame + 1)}
        self._series = [e for e in entries if e.get("name") in keep]
        self._prev = None
        for fmt in self.formats:
            path = self.path(frame, fmt)
            if path.is_file():
                try:
                    arrays = read_frame(path)
                except (OSError, ValueError):
                    continue
                self._prev = (arrays["id"], arrays["position"])
                break

    def _track_displacement(self, arrays: dict[str, np.ndarray]) -> None:
        ids, pos = arrays["id"], arrays["position"]
        if self._prev is None:
            self.max_displacement = None
        else:
            prev_ids, prev_pos = self._prev
            if prev_ids.shape == ids.shape and np.array_equal(prev_ids, ids):
                d = pos - prev_pos
            else:  # particles were added or removed: compare those in both frames
                _, i_new, i_old = np.intersect1d(ids, prev_ids, assume_unique=True,
                                                 return_indices=True)
                d = pos[i_new] - prev_pos[i_old]
            self.max_displacement = float(np.sqrt((d * d).sum(axis=1).max())) if len(d) else 0.0
        self._prev = (ids, pos)  # both are fresh copies (frame_arrays)
