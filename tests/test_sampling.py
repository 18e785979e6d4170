"""Geometry sampling: fluid lattices, box walls, mesh loading and surface sampling."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from sphkit.geometry import GeometryError
from sphkit.geometry.mesh_sampling import sample_mesh_surface
from sphkit.geometry.meshes import load_mesh
from sphkit.geometry.sampling import box_shell, box_walls, lattice_block, lattice_count


def _nn(points: np.ndarray) -> np.ndarray:
    d, _ = cKDTree(points).query(points, k=2)
    return d[:, 1]


def _box_surface_distance(p: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Distance of points to the surface of the box [-half, half] (exact for any point)."""
    q = np.abs(p) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return np.abs(outside + inside)


# -- lattices -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("start", "end", "counts"),
    [
        ([0.0], [0.3], [10]),
        ([0.0, 0.0], [0.5, 1.0], [16, 33]),
        ([0.0, 0.0, 0.0], [0.9, 1.2, 0.6], [30, 40, 20]),
        ([-1.0, 0.2, 0.5], [-0.7, 0.41, 0.52], [10, 7, 0]),
    ],
)
def test_lattice_block_count_and_spacing(start, end, counts) -> None:
    r = 0.015
    pts = lattice_block(start, end, r)
    assert pts.shape == (int(np.prod(counts)), len(start))
    if len(pts) == 0:
        return
    lo, hi = np.array(start), np.array(end)
    np.testing.assert_allclose(pts.min(axis=0), lo + r, atol=1e-12)
    assert np.all(pts.max(axis=0) <= hi - r + 1e-9 * r)
    # every coordinate on the lattice start + r + 2r k
    k = (pts - (lo + r)) / (2 * r)
    np.testing.assert_allclose(k, np.rint(k), atol=1e-9)
    if len(pts) > 1:
        np.testing.assert_allclose(_nn(pts), 2 * r, rtol=1e-12)


def test_lattice_tolerance() -> None:
    r = 0.01
    assert lattice_count(0.0, 1.0, r) == 50
    assert lattice_count(0.0, 1.0 - 1e-12, r) == 50  # within 1e-9 r of the last lattice point
    assert lattice_count(0.0, 1.0 - 1e-6, r) == 49
    assert lattice_count(0.0, 0.019, r) == 0
    assert lattice_block([0.0, 0.0], [0.019, 1.0], r).shape == (0, 2)


# -- box walls ------------------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("layers", [1, 2])
def test_box_walls_align_with_fluid_and_cover_corners(dim: int, layers: int) -> None:
    r = 0.025
    lo = np.zeros(dim)
    hi = np.array([1.0, 0.6, 0.4][:dim])
    walls = box_walls(lo, hi, r, layers=layers)
    fluid = lattice_block(lo, hi, r)
    n = np.rint((hi - lo) / (2 * r)).astype(int)
    assert len(walls) == np.prod(n + 2 * layers) - np.prod(n)
    assert len(np.unique(np.round(walls / r, 6), axis=0)) == len(walls)
    # the fluid lattice continues into the walls: nearest wall particle exactly 2r away
    d, _ = cKDTree(walls).query(fluid)
    assert d.min() == pytest.approx(2 * r, rel=1e-12)
    k = (walls - (lo + r)) / (2 * r)
    np.testing.assert_allclose(k, np.rint(k), atol=1e-9)
    # no wall particle inside the container, all within the enlarged box
    inside = np.all((walls > lo) & (walls < hi), axis=1)
    assert not inside.any()
    outer = 2 * r * layers
    assert np.all(walls >= lo - outer) and np.all(walls <= hi + outer)
    # every corner of every layer is there
    tree = cKDTree(walls)
    for layer in range(layers):
        off = r + 2 * r * layer
        for corner in np.array(np.meshgrid(*[[0, 1]] * dim, indexing="ij")).reshape(dim, -1).T:
            c = np.where(corner == 0, lo - off, hi + off)
            assert tree.query(c)[0] < 1e-12


def test_box_wall_cells_are_the_lattice_cells_of_the_walls() -> None:
    """Each wall particle's cell (:func:`box_shell`, with the particles of :func:`box_walls`) is
    the product over the axes of its spacing there: 2r across a wall layer (a coordinate
    outside the box), and along a face the distance between neighbouring wall particles
    (measured on the walls themselves): (2r)^dim on the fluid's lattice, less where the box is
    not a multiple of 2r."""
    r = 0.025
    for lo, hi, layers, top in [([0.0, 0.0], [1.0, 0.6], 1, None),
                                ([0.0, 0.0, 0.0], [1.0, 0.6, 0.4], 2, None),
                                ([0.0, 0.0], [1.01, 0.63], 2, 1),
                                ([0.0, 0.0, 0.0], [0.33, 0.41, 0.2], 1, 1)]:
        lo, hi = np.array(lo), np.array(hi)
        dim = len(lo)
        walls, cells = box_shell(lo, hi, r, layers=layers, open_top_axis=top)
        np.testing.assert_array_equal(walls, box_walls(lo, hi, r, layers=layers,
                                                       open_top_axis=top))
        assert cells.shape == (len(walls),)
        expected = np.ones(len(walls))
        for e in range(dim):
            inside = (walls[:, e] > lo[e]) & (walls[:, e] < hi[e])
            spacing = np.diff(np.unique(np.round(walls[inside, e], 12)))
            assert np.ptp(spacing) < 1e-9 * r  # evenly spaced along the face
            expected *= np.where(inside, spacing.mean(), 2 * r)
        np.testing.assert_allclose(cells, expected, rtol=1e-9)
        multiple = np.allclose(np.rint((hi - lo) / (2 * r)), (hi - lo) / (2 * r))
        assert (cells.min() == pytest.approx((2 * r) ** dim, rel=1e-12)) == multiple


def test_box_walls_open_top() -> None:
    r = 0.05
    closed = box_walls([0.0, 0.0], [1.0, 1.0], r, layers=2)
    open_ = box_walls([0.0, 0.0], [1.0, 1.0], r, layers=2, open_top_axis=1)
    assert len(closed) - len(open_) == 2 * (10 + 4)
    assert open_[:, 1].max() < 1.0
    assert closed[:, 1].max() > 1.0
    with pytest.raises(ValueError):
        box_walls([0.0, 0.0], [1.0, 1.0], r, open_top_axis=2)
    with pytest.raises(ValueError):
        box_walls([0.0, 0.0], [1.0, 1.0], r, layers=0)


# -- meshes ---------------------------------------------------------------------------------------


@pytest.fixture
def box_obj(tmp_path: Path) -> Path:
    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=[1.0, 1.0, 1.0]).export(path)
    return path


def test_load_mesh_scales_then_rotates_then_translates(box_obj: Path) -> None:
    mesh = load_mesh(box_obj, translation=[1.0, 0.0, 0.0], rotation_axis=[0.0, 0.0, 2.0],
                     rotation_angle=np.pi / 2, scale=[2.0, 1.0, 1.0])
    # scaled: x in [-1, 1]; rotated 90 deg about z: y in [-1, 1]; then moved by +1 in x
    np.testing.assert_allclose(mesh.bounds, [[0.5, -1.0, -0.5], [1.5, 1.0, 0.5]], atol=1e-12)
    assert mesh.is_watertight


def test_load_mesh_errors_name_the_file(tmp_path: Path, box_obj: Path) -> None:
    with pytest.raises(GeometryError, match=r"nope\.obj.*not found"):
        load_mesh(tmp_path / "nope.obj")
    points = tmp_path / "points.obj"
    points.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(GeometryError, match=r"points\.obj.*no triangles"):
        load_mesh(points)
    with pytest.raises(GeometryError, match=r"box\.obj.*scale"):
        load_mesh(box_obj, scale=[1.0, 0.0, 1.0])
    with pytest.raises(GeometryError, match=r"box\.obj.*axis"):
        load_mesh(box_obj, rotation_axis=[0.0, 0.0, 0.0], rotation_angle=1.0)


def test_unit_box_surface_sampling() -> None:
    r = 0.03
    mesh = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    pts = sample_mesh_surface(mesh, r)
    assert pts.shape[1] == 3
    nn = _nn(pts)
    assert nn.min() >= 1.5 * r and nn.max() <= 2.5 * r
    assert _box_surface_distance(pts, np.full(3, 0.5)).max() < 1e-9
    # no holes: every surface point is near a sample
    cover, _ = cKDTree(pts).query(mesh.sample(5000, seed=1))
    assert cover.max() < 1.5 * r
    assert len(pts) == pytest.approx(mesh.area / (2 * r) ** 2, rel=0.1)


def test_large_box_sampling_is_fast() -> None:
    r = 0.025
    mesh = trimesh.creation.box(extents=[4.0, 3.0, 1.5])
    t0 = time.perf_counter()
    pts = sample_mesh_surface(mesh, r)
    assert time.perf_counter() - t0 < 5.0
    assert 17_000 < len(pts) < 19_000
    nn = _nn(pts)
    assert nn.min() >= 1.5 * r and nn.max() <= 2.5 * r


def test_curved_mesh_sampling_spacing() -> None:
    r = 0.02
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=0.5)  # edges finer than 2r
    pts = sample_mesh_surface(mesh, r)
    nn = _nn(pts)
    assert nn.min() >= 1.5 * r * (1 - 1e-6)
    assert np.median(nn) <= 2.5 * r
    assert np.abs(np.linalg.norm(pts, axis=1) - 0.5).max() < 1e-3  # on the (faceted) sphere
    cover, _ = cKDTree(pts).query(mesh.sample(5000, seed=2))
    assert cover.max() < 2.5 * r


def test_section_2d_of_box_lies_on_rectangle() -> None:
    r = 0.01
    mesh = trimesh.creation.box(extents=[2.0, 1.0, 1.0])
    pts = sample_mesh_surface(mesh, r, dim=2)
    assert pts.ndim == 2 and pts.shape[1] == 2
    on_x = np.abs(np.abs(pts[:, 0]) - 1.0) < 1e-9
    on_y = np.abs(np.abs(pts[:, 1]) - 0.5) < 1e-9
    assert np.all(on_x | on_y)
    assert np.all(np.abs(pts) <= [1.0 + 1e-9, 0.5 + 1e-9])
    tree = cKDTree(pts)
    for corner in ([1.0, 0.5], [-1.0, 0.5], [1.0, -0.5], [-1.0, -0.5]):
        assert tree.query(corner)[0] < 1e-9
    nn = _nn(pts)
    assert nn.min() >= 1.5 * r and nn.max() <= 2.5 * r
    assert len(pts) == pytest.approx(6.0 / (2 * r), abs=2)


def test_section_2d_of_placed_cylinder(tmp_path: Path) -> None:
    r = 0.01
    path = tmp_path / "cyl.stl"
    trimesh.creation.cylinder(radius=0.5, height=1.0, sections=64).export(path)
    mesh = load_mesh(path, translation=[0.2, 0.0, 0.0])
    pts = sample_mesh_surface(mesh, r, dim=2)
    rad = np.linalg.norm(pts - [0.2, 0.0], axis=1)
    assert np.abs(rad - 0.5).max() < 2e-3  # on the 64-gon
    nn = _nn(pts)
    assert nn.min() >= 1.5 * r and nn.max() <= 2.5 * r
    empty = sample_mesh_surface(load_mesh(path, translation=[0.0, 0.0, 5.0]), r, dim=2)
    assert empty.shape == (0, 2)


@pytest.mark.parametrize("lattice", ["layered", "close_packed"])
@pytest.mark.parametrize("dim", [2, 3])
def test_splishsplash_dense_modes_count_place_and_rest(lattice: str, dim: int) -> None:
    """SPlisHSPlasH's denseMode 1 / 2 (``SimulatorBase::createFluidBlocks``) on the block of
    its ReadWriteStateTest scene (box [-0.25, 0.25] x [0, 1] x [-0.25, 0.25], r = 0.025):
    per axis round(d / s) - 1 particles for the extent d (x and z less one diameter, mode 2's x
    less its spacing) and spacing s (layers sqrt(3) r apart; mode 2: sqrt(6) 2r / 3 along x),
    counted here from the rule: mode 1: x round(0.45 / 0.05) - 1 = 8, y round(1 / 0.0433) - 1
    = 22, z 8 -> 1408 in 3D (176 in 2D); mode 2: x round(0.4592 / 0.04082) - 1 = 10, y 22,
    z 8 -> 1760 (220). No two particles closer than their diameter less 20 % (mode 2's columns
    are 1.63 r apart in x but shifted by r in z or y), and with the block's volume
    (kernels.block_volume) the interior is at rest density within 0.5 % (lattice sums)."""
    from sphkit.core.kernels import Kernel, block_volume
    from sphkit.geometry.sampling import dense_block

    r = 0.025
    lo, hi = np.array([-0.25, 0.0, -0.25])[:dim], np.array([0.25, 1.0, 0.25])[:dim]
    pts = dense_block(lo + r, hi - r, r, lattice)
    per_plane = {"layered": 8 * 22, "close_packed": 10 * 22}[lattice]
    assert len(pts) == per_plane * (8 if dim == 3 else 1)
    assert np.isclose(pts[:, 1].min(), lo[1] + 2 * r)  # SPlisHSPlasH's first layer: lo + 2r
    ys = np.unique(np.round(pts[:, 1], 12))
    np.testing.assert_allclose(np.diff(ys), np.sqrt(3.0) * r + 1e-9, rtol=1e-12, atol=1e-12)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(pts).query(pts, k=2)
    assert d[:, 1].min() > 0.8 * 2 * r, d[:, 1].min()
    h = 4 * r
    V = block_volume(pts, "cubic", h)
    k = Kernel("cubic", h, dim)
    inner = pts[np.all((pts >= pts.min(0) + h) & (pts <= pts.max(0) - h), axis=1)]
    rho = np.array([V * k.w(np.linalg.norm(pts - q, axis=1)).sum() for q in inner])
    assert abs(rho.mean() - 1.0) < 1e-12  # the volume's definition
    assert np.abs(rho - 1.0).max() < 5e-3, np.abs(rho - 1.0).max()


def test_load_mesh_keeps_a_face_listed_twice_once(tmp_path: Path) -> None:
    # SPlisHSPlasH's older sphere.obj (560a87c) lists every triangle three times: read as is,
    # its area, surface samples and volume would count three times
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    lines = [f"v {x} {y} {z}" for x, y, z in box.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.repeat(box.faces, 3, axis=0)]
    path = tmp_path / "triple.obj"
    path.write_text("\n".join(lines) + "\n")
    mesh = load_mesh(path)
    assert len(mesh.faces) == 12 and mesh.is_volume
    assert mesh.volume == pytest.approx(1.0, rel=1e-12)


def test_dynamic_body_from_a_mesh_that_closes_but_is_not_watertight() -> None:
    from sphkit.boundary.rigid.construction import body_from_mesh

    # a unit cube whose top has a T-junction: one top triangle split at the midpoint of the
    # diagonal the other top triangle still spans (not watertight, but the faces close: the
    # mass properties are exact); SPlisHSPlasH's older sphere.obj has such seams
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    top = np.flatnonzero(box.face_normals[:, 2] > 0.5)[0]
    a, b, c = box.faces[top]
    v = box.vertices
    pairs = [(a, b), (b, c), (c, a)]
    i, j = next((p, q) for p, q in pairs if abs(v[p] - v[q])[:2].min() > 0.5)  # the diagonal
    k = ({a, b, c} - {i, j}).pop()
    verts = np.vstack([v, 0.5 * (v[i] + v[j])])
    m = len(v)
    faces = np.delete(box.faces, top, axis=0)
    faces = np.vstack([faces, [i, m, k], [m, j, k]])
    cracked = trimesh.Trimesh(verts, faces, process=False)
    cracked.fix_normals()
    assert not cracked.is_watertight
    with pytest.warns(UserWarning, match="not watertight, but its faces close"):
        body = body_from_mesh("cube", cracked, True, 500.0, None, None, None, 0.5)
    assert body.mass == pytest.approx(500.0, rel=1e-12)  # density x 1 m^3
    np.testing.assert_allclose(body.c, [0.0, 0.0, 0.0], atol=1e-12)
    # a unit cube's inertia about its centre: m (1 + 1) / 12 on each axis
    np.testing.assert_allclose(body.inertia, np.eye(3) * 500.0 / 6.0, atol=1e-9)
    # a real hole (the top's two triangles missing) stays refused
    holed = trimesh.Trimesh(v, np.delete(box.faces, np.flatnonzero(box.face_normals[:, 2] > 0.5),
                                         axis=0), process=False)
    with pytest.raises(ValueError, match="not a closed volume"):
        body_from_mesh("cube", holed, True, 500.0, None, None, None, 0.5)
