"""Neighbourhood search against brute force and SciPy, edge cases, z-order, ParticleSet.permute.

sphkit's convention is strict: j is a neighbour of i when |x_i - x_j| < h. The oracles are the
exact NumPy distance test ``r^2 < h^2`` and scipy.spatial.cKDTree (whose ball includes r = h, so it
is asked with a radius a hair below h after checking that no pair lies in that hair).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from sphkit.core.neighbors import Grid, NeighborList, neighbor_lists
from sphkit.core.particles import ParticleSet
from sphkit.core.zorder import zorder_permutation


def _brute(xq: np.ndarray, x: np.ndarray, h: float, exclude_self: bool = False) -> list[np.ndarray]:
    """Sorted neighbour indices (r < h) in x (dim, N) of every column of xq (dim, M)."""
    out = []
    for i in range(xq.shape[1]):
        r2 = ((x - xq[:, i : i + 1]) ** 2).sum(axis=0)
        hits = np.flatnonzero(r2 < h * h)
        if exclude_self:
            hits = hits[hits != i]
        out.append(hits)
    return out


def _assert_lists(nl: NeighborList, expected: list[np.ndarray], n_searched: int) -> None:
    """CSR structure is valid and every list equals the expected set (order is free)."""
    assert len(nl) == len(expected)
    assert nl.offsets[0] == 0
    assert np.all(np.diff(nl.offsets) >= 0)
    assert nl.offsets[-1] == nl.indices.size
    if nl.indices.size:
        assert 0 <= nl.indices.min() and nl.indices.max() < n_searched
    for i, exp in enumerate(expected):
        got = np.sort(nl.neighbors(i))
        np.testing.assert_array_equal(got, exp, err_msg=f"neighbours of point {i}")


def _kdtree_lists(xq: np.ndarray, x: np.ndarray, h: float) -> list[np.ndarray]:
    tree = cKDTree(x.T)
    return [
        np.sort(np.asarray(v, dtype=np.int64)) for v in tree.query_ball_point(xq.T, h * (1 - 1e-9))
    ]


def _no_pair_near_h(xq: np.ndarray, x: np.ndarray, h: float) -> bool:
    """No distance within 1e-9 h of h: the r < h decision is then insensitive to rounding."""
    d = cKDTree(x.T).sparse_distance_matrix(cKDTree(xq.T), h * (1 + 1e-8), output_type="ndarray")
    return not np.any(np.abs(d["v"] - h) <= 1e-9 * h)


@pytest.fixture(params=["default", "hashed"], autouse=True)
def grid_mode(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Every test runs twice: with the grid as built by default (dense for compact sets,
    hashed for sparse ones) and with the hashed grid forced, so both searches are checked."""
    if request.param == "hashed":
        monkeypatch.setattr(Grid, "dense_cells_per_point", 0)
        monkeypatch.setattr(Grid, "dense_min_cells", 0)
    return request.param


def test_dense_for_compact_sets_hashed_for_sparse_ones(grid_mode: str) -> None:
    compact = np.random.default_rng(0).uniform(0.0, 1.0, size=(3, 2000))
    sparse = np.concatenate([compact, compact + 1000.0], axis=1)  # ~1e12 cells of size 0.05
    assert Grid(compact, 0.05).dense == (grid_mode == "default")
    assert not Grid(sparse, 0.05).dense


# -- random sets ---------------------------------------------------------------------------------
# about a dozen neighbours per particle, domains straddling 0 (negative cells are floored)
CASES = {1: (1500, 0.005), 2: (1500, 0.05), 3: (1500, 0.12)}


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_random_set_matches_brute_force_and_kdtree(dim: int) -> None:
    n, h = CASES[dim]
    rng = np.random.default_rng(10 + dim)
    x = rng.uniform(-0.4, 0.6, size=(dim, n))
    assert _no_pair_near_h(x, x, h)
    nl = neighbor_lists(x, h)
    expected = _brute(x, x, h, exclude_self=True)
    _assert_lists(nl, expected, n)
    assert nl.counts().mean() > 5  # the test exercises real lists, not empty ones
    # cKDTree as a second, independent oracle (it includes the point itself)
    kd = _kdtree_lists(x, x, h)
    for i in range(n):
        np.testing.assert_array_equal(np.sort(nl.neighbors(i)), kd[i][kd[i] != i])


@pytest.mark.parametrize("capacity", [1, 2, 5, 12])
def test_rows_that_overflow_the_capacity_are_redone(capacity: int) -> None:
    # The one-pass search writes into rows of `capacity` slots; a particle with more neighbours
    # (here about 10 on average, up to about 25) must trigger the retry with wider rows,
    # and the result must still equal brute force, including at exactly `capacity` neighbours.
    n, h = CASES[3]
    x = np.random.default_rng(33).uniform(-0.4, 0.6, size=(3, n))
    grid = Grid(x, h)
    grid.capacity = capacity
    nl = grid.query(x, exclude_self=True)
    _assert_lists(nl, _brute(x, x, h, exclude_self=True), n)
    assert nl.counts().max() >= capacity


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_the_cell_by_cell_self_query_gives_the_per_point_lists(dim: int, grid_mode: str) -> None:
    """:meth:`Grid.query_own` (cell by cell, candidates in 64-bit masks) returns the lists of the
    per-point query with self excluded, in the same order, entry for entry: a random set, a
    cluster of 2,500 coincident points (more candidates than a cell's block holds: the per-point
    scan takes over there) and rows of 3 slots (redone wider). (A hashed grid answers through the
    per-point query.)"""
    from sphkit.core.densegrid import BLOCK

    n, h = CASES[dim]
    rng = np.random.default_rng(40 + dim)
    x = np.concatenate([rng.uniform(-0.4, 0.6, size=(dim, n)),
                        np.full((dim, BLOCK + 452), 0.3)], axis=1)
    for capacity in (64, 3):
        grid = Grid(x, h)
        assert grid.dense == (grid_mode == "default")
        grid.capacity = capacity
        own, per_point = grid.query_own(x), grid.query(x, exclude_self=True)
        np.testing.assert_array_equal(own.offsets, per_point.offsets)
        np.testing.assert_array_equal(own.indices, per_point.indices)
    assert own.counts().max() >= BLOCK  # the cluster took the per-point scan
    _assert_lists(own, _brute(x, x, h, exclude_self=True), x.shape[1])


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_exclude_self(dim: int) -> None:
    n, h = CASES[dim]
    x = np.random.default_rng(20 + dim).uniform(0.0, 1.0, size=(dim, n))
    grid = Grid(x, h)
    with_self = grid.query(x)
    without = grid.query(x, exclude_self=True)
    # self (r = 0 < h) is in every list exactly once without exclusion, and nowhere with it
    np.testing.assert_array_equal(with_self.counts(), without.counts() + 1)
    for i in range(n):
        assert np.count_nonzero(with_self.neighbors(i) == i) == 1
        assert i not in without.neighbors(i)
    # neighbor_lists is the self-query with exclusion
    nl = neighbor_lists(x, h)
    np.testing.assert_array_equal(nl.offsets, without.offsets)
    for i in range(n):
        np.testing.assert_array_equal(np.sort(nl.neighbors(i)), np.sort(without.neighbors(i)))


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_fluid_against_boundary(dim: int) -> None:
    h = CASES[dim][1]
    rng = np.random.default_rng(30 + dim)
    fluid = rng.uniform(0.0, 0.5, size=(dim, 800))
    # a boundary set with a different extent and origin; some fluid points lie outside its box
    boundary = rng.uniform(-0.2, 0.3, size=(dim, 600))
    assert _no_pair_near_h(fluid, boundary, h)
    fb = Grid(boundary, h).query(fluid)  # indices into the boundary set
    _assert_lists(fb, _brute(fluid, boundary, h), boundary.shape[1])
    bf = Grid(fluid, h).query(boundary)  # and the other way round
    _assert_lists(bf, _brute(boundary, fluid, h), fluid.shape[1])
    assert fb.indices.size == bf.indices.size  # the relation is symmetric: same number of pairs
    # query points far from the searched set (beyond its grid in both directions) have no neighbours
    far = np.concatenate([np.full((dim, 1), -50.0), np.full((dim, 1), 75.0)], axis=1)
    assert np.all(Grid(boundary, h).query(far).counts() == 0)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_a_grid_that_marks_its_near_cells_gives_the_same_lists(dim: int) -> None:
    """Walls of a box (points on its faces only) marked with Grid.mark_near: queries from
    cells with no wall point within reach return at once, the others scan as before; the lists
    equal the brute force ones, inside, near and outside the box, point by point and cell by
    cell of the fluid's grid."""
    h = CASES[dim][1]
    rng = np.random.default_rng(40 + dim)
    walls = rng.uniform(0.0, 1.0, size=(dim, 3000))
    face = rng.integers(0, dim, size=3000)
    walls[face, np.arange(3000)] = rng.integers(0, 2, size=3000)  # onto a face: 0 or 1
    fluid = rng.uniform(-0.3, 1.3, size=(dim, 1500))
    assert _no_pair_near_h(fluid, walls, h)
    grid = Grid(walls, h).mark_near()
    if grid.dense:
        assert 0 < grid.near.sum() < grid.near.size  # the box's interior cells are unmarked
    _assert_lists(grid.query(fluid), _brute(fluid, walls, h), walls.shape[1])
    # cell by cell of the fluid's own grid (Grid.query_grid, the step's fluid-wall search):
    # the same lists, entry for entry, for fluid inside, near and beyond the walls' grid
    by_cells = grid.query_grid(Grid(fluid, h), fluid)
    np.testing.assert_array_equal(by_cells.offsets, grid.query(fluid).offsets)
    np.testing.assert_array_equal(by_cells.indices, grid.query(fluid).indices)


# -- edge cases -----------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_empty_sets(dim: int) -> None:
    h = 0.1
    x = np.random.default_rng(1).uniform(size=(dim, 10))
    empty = np.zeros((dim, 0))
    nl = Grid(empty, h).query(x)  # N = 0: every query point has an empty list
    assert len(nl) == 10 and nl.indices.size == 0
    np.testing.assert_array_equal(nl.offsets, np.zeros(11))
    nl = Grid(x, h).query(empty)  # M = 0: no lists
    assert len(nl) == 0 and nl.indices.size == 0
    np.testing.assert_array_equal(nl.offsets, [0])
    assert len(neighbor_lists(empty, h)) == 0
    assert zorder_permutation(empty, h).size == 0


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_one_particle(dim: int) -> None:
    h = 0.1
    x = np.full((dim, 1), 0.33)
    grid = Grid(x, h)
    assert grid.query(x, exclude_self=True).indices.size == 0
    np.testing.assert_array_equal(grid.query(x).indices, [0])
    # query points at 0.99 h (inside) and 1.01 h, 3 h (outside) along the first axis
    q = np.repeat(x, 3, axis=1)
    q[0] += np.array([0.99, 1.01, 3.0]) * h
    np.testing.assert_array_equal(grid.query(q).counts(), [1, 0, 0])


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_coincident_particles(dim: int) -> None:
    n, h = 40, 0.1
    x = np.full((dim, n), 0.7)
    nl = neighbor_lists(x, h)
    # all pairs are at r = 0 < h: each particle has the other n - 1
    np.testing.assert_array_equal(nl.counts(), np.full(n, n - 1))
    _assert_lists(nl, [np.delete(np.arange(n), i) for i in range(n)], n)
    np.testing.assert_array_equal(Grid(x, h).query(x).counts(), np.full(n, n))


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_sparse_set_over_a_million_cells(dim: int) -> None:
    h = 0.01
    rng = np.random.default_rng(40 + dim)
    base = np.zeros((dim, 500))
    base[0] = rng.uniform(0.0, 1e6 * h, 500)
    if dim > 1:
        base[1:] = rng.uniform(0.0, 3 * h, size=(dim - 1, 500))
    # each base point gets a partner closer than h/2, so there are neighbours to find
    partners = base + rng.uniform(-0.25 * h, 0.25 * h, size=base.shape) / np.sqrt(dim)
    x = np.concatenate([base, partners], axis=1)
    n = x.shape[1]
    assert _no_pair_near_h(x, x, h)
    grid = Grid(x, h)
    # memory is O(N) whatever the extent: a hash table of 2^k >= 2N buckets, never 1e6 cells
    assert grid.bucket_start.size <= 4 * n + 2
    assert grid.sorted_index.size == n and grid.sorted_key.size == n
    assert grid.sorted_x.shape == (3, n)
    nl = grid.query(x, exclude_self=True)
    _assert_lists(nl, _brute(x, x, h, exclude_self=True), n)
    assert np.all(nl.counts() >= 1)  # every point finds at least its partner


def test_coordinates_beyond_int64_cells_raise() -> None:
    # a blown-up particle at 1e25 m: its cell index does not fit in int64; the grid must say so
    # (the dense layout declines, the hashed one names the extent) instead of wrapping around
    x = np.random.default_rng(3).uniform(0.0, 1.0, size=(3, 100))
    x[0, 0] = 1e25
    with pytest.raises(ValueError, match="extent"):
        Grid(x, 0.1)


def test_extent_beyond_grid_limit_raises() -> None:
    x = np.array([[0.0, 3e6]])  # 3e6 cells of size 1 > 2^21 - 4
    with pytest.raises(ValueError, match="^positions"):
        Grid(x, 1.0)


@pytest.mark.parametrize(
    ("x", "h", "field"),
    [
        (np.zeros((4, 3)), 0.1, "positions"),  # dim 4
        (np.zeros(3), 0.1, "positions"),  # not (dim, N)
        (np.array([[0.0, np.nan]]), 0.1, "positions"),
        (np.array([[0.0, np.inf]]), 0.1, "positions"),
        (np.array([[0.0, 0.1, 0.2], [0.0, 0.0, 0.0], [0.3, np.nan, 0.1]]), 0.1, "positions"),
        (np.array([[0.0, 0.1], [-np.inf, 0.0]]), 0.1, "positions"),
        (np.zeros((2, 3)), 0.0, "h"),
        (np.zeros((2, 3)), -1.0, "h"),
    ],
)
def test_bad_input_raises(x: np.ndarray, h: float, field: str) -> None:
    with pytest.raises(ValueError, match=f"^{field}"):
        Grid(x, h)


def test_query_dimension_mismatch_raises() -> None:
    grid = Grid(np.zeros((3, 4)), 0.1)
    with pytest.raises(ValueError, match="dim"):
        grid.query(np.zeros((2, 4)))


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_points_exactly_on_cell_boundaries_binary_exact(dim: int) -> None:
    # h = 1/4 and positions k h/2 are exact binary fractions: x / h, distances and r^2 < h^2 are
    # computed without rounding, so every other lattice plane is exactly on a cell boundary and the
    # pairs at exactly r = h must be rejected (strict r < h). Tolerance: none, the lists are exact.
    h = 0.25
    k = np.arange(-6, 7)
    x = np.stack(np.meshgrid(*[k * (h / 2)] * dim, indexing="ij")).reshape(dim, -1).copy()
    n = x.shape[1]
    nl = neighbor_lists(x, h)
    _assert_lists(nl, _brute(x, x, h, exclude_self=True), n)
    # an interior point's neighbours are the lattice offsets o with |o|^2 (h/2)^2 < h^2, |o|^2 < 4:
    # 1D 2, 2D 8, 3D 26 (o = 2 e_d, at exactly h, is excluded)
    idx = np.stack(np.meshgrid(*[k] * dim, indexing="ij")).reshape(dim, -1)
    interior = np.all(np.abs(idx) <= 4, axis=0)
    assert np.all(nl.counts()[interior] == {1: 2, 2: 8, 3: 26}[dim])


@pytest.mark.parametrize("dim", [2, 3])
def test_points_on_cell_boundaries_up_to_rounding(dim: int) -> None:
    # h = 0.15 with points on multiples of 0.1: every third plane falls on a cell boundary up to
    # rounding (0.3 / 0.15 is 2 or 1.999...), while every distance (0.1, 0.141, 0.173, 0.2, ...)
    # is at least 0.008 from h, so the expected lists do not depend on rounding
    h = 0.15
    k = np.arange(-9, 10)
    x = np.stack(np.meshgrid(*[k * 0.1] * dim, indexing="ij")).reshape(dim, -1).copy()
    assert _no_pair_near_h(x, x, h)
    nl = neighbor_lists(x, h)
    _assert_lists(nl, _brute(x, x, h, exclude_self=True), x.shape[1])


# -- z-order --------------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_zorder_is_a_permutation_that_improves_locality(dim: int) -> None:
    rng = np.random.default_rng(50 + dim)
    n, h = 5000, 0.05
    x = rng.uniform(-0.3, 0.7, size=(dim, n))
    perm = zorder_permutation(x, h)
    np.testing.assert_array_equal(np.sort(perm), np.arange(n))

    def step(y: np.ndarray) -> float:
        return float(np.linalg.norm(np.diff(y, axis=1), axis=0).mean())

    # random order: mean step ~ 0.33 (1D), 0.52 (2D), 0.66 (3D) of the unit box; along a Morton
    # curve of cells of size h = 0.05 consecutive points are mostly in the same or an adjacent cell:
    # measured ratio 0.06 (2D), 0.12 (3D); 0.25 leaves room and still fails for any random order
    assert step(x[:, perm]) < 0.25 * step(x)
    # points of one cell are contiguous in z-order (the code is a function of the cell only)
    cells = np.floor(x[:, perm] / h).astype(np.int64)
    _, first = np.unique(cells, axis=1, return_index=True)
    changes = np.count_nonzero(np.any(np.diff(cells, axis=1) != 0, axis=0))
    assert changes == first.size - 1


# -- ParticleSet.permute ------------------------------------------------------------------------
def test_particleset_permute_keeps_fields_with_their_particles() -> None:
    rng = np.random.default_rng(60)
    ps = ParticleSet(3)
    v = ps.register("v", "vector")
    assert v.shape == (3, 0)
    ps.register("p", "scalar")
    a = ps.add(rng.uniform(0, 1, (300, 3)), "block-a")
    b = ps.add(rng.uniform(2, 3, (200, 3)), "block-b", p=7.0)
    ps["v"] = 2.0 * ps["x"] + 1.0  # a field that is a known function of the position
    ps["p"][a.start : a.end] = ps["id"][a.start : a.end] * 0.5
    x0 = ps["x"].copy()
    ids0 = ps["id"].copy()
    np.testing.assert_array_equal(ids0, np.arange(500))  # ids 0..N-1 in creation order

    perm = zorder_permutation(ps["x"], 0.1)
    assert not np.array_equal(perm, np.arange(500))  # the test really reorders
    ps.permute(perm)
    ids = ps["id"]
    # every field travels with its particle: exact equality (only copies, no arithmetic)
    np.testing.assert_array_equal(ids, ids0[perm])
    np.testing.assert_array_equal(ps["x"], x0[:, ids])
    np.testing.assert_array_equal(ps["v"], 2.0 * ps["x"] + 1.0)
    in_a = (ids >= a.start) & (ids < a.end)
    in_b = (ids >= b.start) & (ids < b.end)
    np.testing.assert_array_equal(ps["p"][in_a], ids[in_a] * 0.5)
    np.testing.assert_array_equal(ps["p"][in_b], 7.0)
    assert np.all(ps["x"][:, in_b] >= 2.0)  # the object ranges still select their particles
    for name in ("x", "v", "p", "id"):
        assert ps[name].flags.c_contiguous
    assert ps.view("x").shape == (500, 3)
    # and the id order undoes the permutation
    back = ps.order_by_id()
    np.testing.assert_array_equal(ps["x"][:, back], x0)
    np.testing.assert_array_equal(ps["id"][back], ids0)


def test_particleset_add_after_resize_keeps_the_resized_values() -> None:
    """A set resized (the maps' virtual particles) and then added to keeps what was written after
    the resize: the buffers that add grows are the resized fields (they were the old buffers)."""
    ps = ParticleSet(2)
    ps.register("V")
    ps.add(np.zeros((40, 2)))  # a capacity of at least 40
    ps.resize(3)
    ps["x"][...] = np.arange(6.0).reshape(2, 3)
    ps["V"][...] = [1.0, 2.0, 3.0]
    ps.add(np.full((2, 2), 9.0), V=5.0)
    np.testing.assert_array_equal(ps["x"], [[0, 1, 2, 9, 9], [3, 4, 5, 9, 9]])
    np.testing.assert_array_equal(ps["V"], [1, 2, 3, 5, 5])



def test_search_rows_in_a_scratch_block_give_the_same_lists() -> None:
    # The step's searches write their fixed-stride rows into one kept block (Scratch) instead
    # of fresh arrays: the lists must be the same, also when a row overflows the capacity and
    # the search is redone in a larger take, and a second search must reuse the block.
    from sphkit.core.arrays import Scratch

    n, h = CASES[3]
    x = np.random.default_rng(41).uniform(-0.4, 0.6, size=(3, n))
    scratch = Scratch()
    for capacity in (64, 5):
        grid = Grid(x, h)
        grid.capacity = capacity
        fresh = grid.query(x, exclude_self=True)
        kept = grid.query(x, exclude_self=True, scratch=scratch)
        np.testing.assert_array_equal(kept.offsets, fresh.offsets)
        np.testing.assert_array_equal(kept.indices, fresh.indices)
    size = scratch.nbytes
    again = neighbor_lists(x, h, scratch=scratch)
    np.testing.assert_array_equal(again.indices, fresh.indices)
    assert scratch.nbytes == size  # the same block, not a new one


def test_lists_in_kept_memory_are_the_same_aligned_and_reused() -> None:
    # With a ``slot`` the lists' indices lie in memory the scratch keeps for that slot from step
    # to step (Scratch.kept) instead of a fresh array mapped every step: the same lists, on
    # ALIGN bytes (so the vectorised pair loops peel alike in every run, whatever the heap's
    # layout: validation/README.md), each slot in its own memory, reused by the slot's next
    # query while the other slot's lists stay intact.
    from sphkit.core.arrays import Scratch

    n, h = CASES[3]
    rng = np.random.default_rng(43)
    x, y = rng.uniform(-0.4, 0.6, size=(3, n)), rng.uniform(-0.4, 0.6, size=(3, n // 2))
    scratch = Scratch()
    grid, other = Grid(x, h), Grid(y, h)
    own = grid.query_own(x, scratch=scratch, slot="fluid")
    cross = other.query(x, scratch=scratch, slot="boundary")
    for kept, fresh in ((own, grid.query_own(x)), (cross, other.query(x))):
        np.testing.assert_array_equal(kept.offsets, fresh.offsets)
        np.testing.assert_array_equal(kept.indices, fresh.indices)
        assert kept.indices.ctypes.data % Scratch.ALIGN == 0
    assert not np.shares_memory(own.indices, cross.indices)
    before = cross.indices.copy()
    half = x[:, : n // 2].copy()
    again = Grid(half, h).query_own(half, scratch=scratch, slot="fluid")
    assert again.indices.ctypes.data == own.indices.ctypes.data  # the slot's memory reused
    np.testing.assert_array_equal(cross.indices, before)  # the other slot's lists intact


def test_scratch_views_are_aligned_and_share_the_block() -> None:
    from sphkit.core.arrays import Scratch

    s = Scratch()
    a, b, c = s.take(((3, 7), np.float64), ((5,), np.int32), ((2, 3), np.float32))
    for v in (a, b, c):
        assert v.flags["C_CONTIGUOUS"] and v.ctypes.data % Scratch.ALIGN == 0
    assert (a.shape, b.shape, c.shape) == ((3, 7), (5,), (2, 3))
    a[...] = 1.0
    b[...] = 7
    c[...] = 2.0
    assert a.sum() == 21.0 and b.sum() == 35 and c.sum() == 12.0  # the views do not overlap
    (d,) = s.take(((4,), np.float64))  # a smaller take lies in the same memory
    assert d.ctypes.data == a.ctypes.data


def test_a_grown_row_width_is_kept_for_the_slot(grid_mode: str) -> None:
    # A search whose rows overflow is redone wider; with a scratch and a slot (the step's
    # searches) the width it grew to is kept, so the next step's search of that slot (a new
    # Grid, as every step builds one) starts wide enough and fills its rows once, not twice.
    import sphkit.core.neighbors as nb
    from sphkit.core.arrays import Scratch

    x = np.random.default_rng(42).uniform(0.0, 1.0, size=(3, 2000))
    h = 0.12  # about 14 neighbours a point
    dense = Grid(x, h).dense
    name, at = ("_dense_cell_query", 15) if dense else ("_query", 10)  # the row width's place
    widths = []
    real = getattr(nb, name)

    def counted(*args):  # noqa: ANN002, ANN202 - the compiled search's arguments, passed on
        widths.append(args[at])
        return real(*args)

    scratch = Scratch()
    lists = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nb, name, counted)
        for _ in range(2):
            grid = Grid(x, h)
            grid.capacity = 3  # fewer slots than the points' neighbours
            lists.append(grid.query_own(x, scratch=scratch, slot="fluid"))
    assert len(widths) == 3 and widths[0] == 3 and widths[1] == widths[2] > 3, widths
    assert scratch.widths["fluid"] == widths[1]
    _assert_lists(lists[1], _brute(x, x, h, exclude_self=True), x.shape[1])
