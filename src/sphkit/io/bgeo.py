"""Houdini's classic binary geometry format (BGEO version 5) for particles, as partio writes it.

Houdini, partio (``Partio::read``/``write``) and SPlisHSPlasH's partio exporter exchange particles
in this format; SPlisHSPlasH writes ``partio/ParticleData_<fluid>_<frame>.bgeo``, gzip-compressed
despite the plain extension. Checked against partio's ``src/lib/io/BGEO.cpp`` (wdas/partio) and
against files written by SPlisHSPlasH 2.19 (``tests/data/splishsplash_partio.bgeo``).

Layout (every number big-endian, 32 bit unless stated)::

    "Bgeo" 'V' version=5
    nPoints nPrims nPointGroups nPrimGroups nPointAttrib nVertexAttrib nPrimAttrib nAttrib
    nPointAttrib x attribute definition:
        name (uint16 length + bytes), size (uint16: components), type (int32),
        type 0 float, 1 int, 5 vector: size default values (32 bit each);
        type 4 indexed string: int32 count, then count strings (uint16 length + bytes)
    nPoints x point record: x y z w (float32; w = 1), then every attribute's components
        (float32, int32, or int32 string indices) in the order of the definitions
    primitives (partio writes none; particle-system primitives 0x8000 are skipped on reading)
    nAttrib detail attribute definitions and one record of their values
    two trailing bytes 0x00 0xff

Everything is 32 bit: positions and attributes are stored as float32, ids as int32. 2D positions
and vectors are padded with zeros to 3 components by the caller (:mod:`sphkit.io.frames`).

The gzip-compressed variant is the same stream through gzip (partio compresses when the name ends
in ``.gz``; SPlisHSPlasH always does). :func:`read_bgeo` recognises it by gzip's magic bytes,
whatever the file name; :func:`write_bgeo` compresses when asked, or when the name ends in
``.gz``. The newer JSON-based BGEO of Houdini 12+ (magic ``0x7f 'NSJ'``) and Blosc-compressed
``.bgeo.sc`` files are not read: Houdini writes the classic format as ``.bhclassic``.
"""

from __future__ import annotations

import gzip
import io
import os
import struct
from collections.abc import Mapping
from pathlib import Path
from typing import IO

import numpy as np

from sphkit.io.atomic import atomic_open

__all__ = ["BgeoError", "read_bgeo", "write_bgeo", "is_gzip"]

_MAGIC = b"Bgeo"
_NEW_MAGIC = b"\x7fNSJ"
_GZIP_MAGIC = b"\x1f\x8b"
_VERSION = 5
#: Houdini attribute type numbers
_FLOAT, _INT, _STRING, _INDEXED_STRING, _VECTOR = 0, 1, 2, 4, 5
_TYPE_NAMES = {0: "float", 1: "int", 2: "string", 4: "indexed string", 5: "vector"}
_PARTICLE_SYSTEM = 0x8000


class BgeoError(ValueError):
    """A file that is not a BGEO file sphkit can read; the message names the file and why."""


def is_gzip(path: str | os.PathLike[str]) -> bool:
    """Whether the file starts with gzip's magic bytes."""
    with open(path, "rb") as f:
        return f.read(2) == _GZIP_MAGIC


class _Reader:
    def __init__(self, stream: IO[bytes], name: str) -> None:
        self.f = stream
        self.name = name

    def bytes(self, n: int) -> bytes:
        data = self.f.read(n)
        if len(data) != n:
            raise BgeoError(f"BGEO file {self.name!r}: ends early (truncated?)")
        return data

    def ints(self, n: int) -> tuple[int, ...]:
        return struct.unpack(f">{n}i", self.bytes(4 * n))

    def ushort(self) -> int:
        return struct.unpack(">H", self.bytes(2))[0]

    def text(self) -> str:
        return self.bytes(self.ushort()).decode("utf-8", errors="replace")

    def definitions(self, count: int, kind: str) -> list[tuple[str, int, int, list[str]]]:
        """``count`` attribute definitions: (name, components, type, string table)."""
        out = []
        for _ in range(count):
            name = self.text()
            size = self.ushort()
            (htype,) = self.ints(1)
            table: list[str] = []
            if htype in (_FLOAT, _INT, _VECTOR):
                self.bytes(4 * size)  # default values, unused
            elif htype == _INDEXED_STRING:
                (n,) = self.ints(1)
                table = [self.text() for _ in range(n)]
            else:
                what = _TYPE_NAMES.get(htype, "unknown type")
                raise BgeoError(
                    f"BGEO file {self.name!r}: {kind} attribute {name!r} has type {htype} "
                    f"({what}); expected float (0), int (1), indexed string (4) or vector (5)"
                )
            out.append((name, size, htype, table))
        return out


def _open_stream(path: Path) -> IO[bytes]:
    raw = path.read_bytes()
    if raw[:2] == _GZIP_MAGIC:
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as e:
            raise BgeoError(f"BGEO file {str(path)!r}: broken gzip stream ({e})") from None
    return io.BytesIO(raw)


def _decode(values: np.ndarray, htype: int, table: list[str]) -> np.ndarray:
    """Big-endian 32-bit words (N, size) -> native float32 / int32 / str array."""
    if htype == _INT:
        a = values.view(">i4").astype(np.int32)
    elif htype == _INDEXED_STRING:
        idx = values.view(">i4").astype(np.int64)
        lookup = np.array(table + [""], dtype=object)
        a = lookup[np.where((idx >= 0) & (idx < len(table)), idx, len(table))]
    else:
        a = values.view(">f4").astype(np.float32)
    return a[:, 0] if a.shape[1] == 1 else a


def read_bgeo(path: str | os.PathLike[str], *, detail: bool = False
              ) -> dict[str, np.ndarray] | tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Read the points of a classic BGEO file (plain or gzip-compressed).

    Returns ``{"position": (N, 3) float32, <attribute>: ...}`` in the file's order: attributes
    of one component as (N,) arrays, of several as (N, k); float and vector attributes as
    float32, int attributes as int32 (e.g. partio's and SPlisHSPlasH's ``id``), indexed strings
    as object arrays of str. With ``detail=True`` also the detail (per-file) attributes, as a
    second dict of 1-D arrays.

    Raises:
        BgeoError: not a BGEO file, a version other than 5, the new JSON BGEO, a plain
            ``string`` attribute, an unknown primitive, or a truncated file.
    """
    p = Path(path)
    name = str(p)
    r = _Reader(_open_stream(p), name)
    magic = r.f.read(4)
    if magic != _MAGIC:
        if magic == _NEW_MAGIC:
            raise BgeoError(
                f"BGEO file {name!r}: the JSON-based BGEO of Houdini 12+ is not supported; "
                "expected classic BGEO (write .bhclassic from Houdini, or use partio)"
            )
        raise BgeoError(f"BGEO file {name!r}: starts with {magic!r}; expected b'Bgeo'")
    r.bytes(1)  # version character 'V'
    (version,) = r.ints(1)
    if version != _VERSION:
        raise BgeoError(f"BGEO file {name!r}: version {version}; expected 5")
    (n_points, n_prims, n_point_groups, n_prim_groups, n_point_attr, n_vertex_attr,
     n_prim_attr, n_detail_attr) = r.ints(8)
    if n_points < 0:
        raise BgeoError(f"BGEO file {name!r}: {n_points} points in the header")
    defs = r.definitions(n_point_attr, "point")
    width = 4 + sum(size for _, size, _, _ in defs)
    words = np.frombuffer(r.bytes(4 * width * n_points), dtype=">u4").reshape(n_points, width)
    out: dict[str, np.ndarray] = {
        "position": np.ascontiguousarray(words[:, :3]).view(">f4").astype(np.float32)
    }
    col = 4
    for attr, size, htype, table in defs:
        out[attr] = _decode(np.ascontiguousarray(words[:, col:col + size]), htype, table)
        col += size
    if not detail:
        return out
    if n_point_groups or n_prim_groups or n_vertex_attr:
        raise BgeoError(
            f"BGEO file {name!r}: has groups or vertex attributes; sphkit reads the detail "
            "attributes of particle files only"
        )
    prim_defs = r.definitions(n_prim_attr, "primitive")
    prim_width = sum(size for _, size, _, _ in prim_defs)
    for _ in range(n_prims):
        (ptype,) = r.ints(1)
        if ptype != _PARTICLE_SYSTEM:
            raise BgeoError(
                f"BGEO file {name!r}: primitive type {ptype:#x}; expected particle systems "
                f"({_PARTICLE_SYSTEM:#x})"
            )
        (count,) = r.ints(1)
        r.bytes(count * (4 if n_points >= 1 << 16 else 2) + 4 * prim_width)
    ddefs = r.definitions(n_detail_attr, "detail")
    dwidth = sum(size for _, size, _, _ in ddefs)
    dwords = np.frombuffer(r.bytes(4 * dwidth), dtype=">u4").reshape(1, dwidth)
    details: dict[str, np.ndarray] = {}
    col = 0
    for attr, size, htype, table in ddefs:
        v = _decode(np.ascontiguousarray(dwords[:, col:col + size]), htype, table)
        details[attr] = np.atleast_1d(v.reshape(-1))
        col += size
    return out, details


def _text(s: str) -> bytes:
    b = s.encode("utf-8")
    if len(b) > 0xFFFF:
        raise ValueError(f"BGEO output: attribute name of {len(b)} bytes; at most 65535")
    return struct.pack(">H", len(b)) + b


def write_bgeo(path: str | os.PathLike[str], arrays: Mapping[str, np.ndarray], *,
               compressed: bool | None = None) -> Path:
    """Write particles as a classic BGEO file, atomically; return ``path``.

    ``arrays`` holds ``"position"`` (N, 3) and further point attributes, each (N,) or (N, k):
    floating-point arrays become float attributes (type 5 "vector" when k = 3, as partio and
    SPlisHSPlasH write velocities), integer and boolean arrays int attributes (values must fit
    32 bits). All values are stored as 32-bit numbers. ``compressed``: gzip the file (partio's
    compressed variant); None (default) compresses when the name ends in ``.gz``.

    Raises:
        ValueError: a missing or misshapen position, an attribute of another length, a type
            BGEO cannot store, or integers beyond 32 bits (naming the attribute).
    """
    p = Path(path)
    if compressed is None:
        compressed = p.name.lower().endswith(".gz")
    if "position" not in arrays:
        raise ValueError("BGEO output: no 'position' array")
    pos = np.asarray(arrays["position"])
    if pos.ndim != 2 or pos.shape[1] != 3:
        raise ValueError(f"BGEO output: position of shape {pos.shape}; expected (N, 3)")
    n = pos.shape[0]
    columns = [pos.astype(">f4"), np.ones((n, 1), dtype=">f4")]
    header = []
    for attr, value in arrays.items():
        if attr == "position":
            continue
        a = np.asarray(value)
        if a.shape[:1] != (n,) or a.ndim not in (1, 2):
            raise ValueError(
                f"BGEO output: attribute {attr!r} of shape {a.shape}; expected ({n},) or ({n}, k)"
            )
        a2 = a.reshape(n, a.shape[1] if a.ndim == 2 else 1)  # (-1 is ambiguous for n = 0)
        k = a2.shape[1]
        if a.dtype.kind in "iub":
            if a2.size and (a2.min() < np.iinfo(np.int32).min or a2.max() > np.iinfo(np.int32).max):
                raise ValueError(
                    f"BGEO output: attribute {attr!r} holds integers up to {a2.max()}, beyond the "
                    "32 bits BGEO stores"
                )
            htype, col = _INT, a2.astype(">i4")
        elif a.dtype.kind == "f":
            htype, col = (_VECTOR if k == 3 else _FLOAT), a2.astype(">f4")
        else:
            raise ValueError(
                f"BGEO output: attribute {attr!r} of dtype {a.dtype}; expected floats or integers"
            )
        if k > 0xFFFF:
            raise ValueError(f"BGEO output: attribute {attr!r} has {k} components; at most 65535")
        header.append(_text(attr) + struct.pack(f">Hi{k}i", k, htype, *([0] * k)))
        columns.append(col)
    record = np.dtype([(f"c{i}", c.dtype, (c.shape[1],)) for i, c in enumerate(columns)])
    rec = np.empty(n, dtype=record)
    for i, c in enumerate(columns):
        rec[f"c{i}"] = c
    head = _MAGIC + b"V" + struct.pack(">9i", _VERSION, n, 0, 0, 0, len(header), 0, 0, 0)
    data = b"".join([head, *header, rec.tobytes(), b"\x00\xff"])
    if compressed:
        data = gzip.compress(data, compresslevel=6, mtime=0)
    with atomic_open(p, "wb") as f:
        f.write(data)
    return p
