"""How fluid starts (sphkit.world.startup): removed from inside walls, consistent next to them,
hydrostatic. The long runs (every solver and boundary model for 3 s, the WCSPH column's slope
per frame) are validation/startup.py."""

from __future__ import annotations

import json
import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from sphkit.core.kernels import Kernel
from sphkit.core.particles import ParticleSet
from sphkit.geometry.sampling import lattice_block
from sphkit.pressure.wcsph import WCSPH, state_equation
from sphkit.scene.files import load_scene
from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation
from sphkit.world.startup import column_depth

UNIT_BOX = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
G, RHO0 = 9.81, 1000.0


def _tank_scene(folder: Path, dim: int, r: float, solver: int, boundary: int,
                tank: tuple[float, float, float], start, end, stiffness: float = 50000.0,
                body=None) -> Path:
    """A SPlisHSPlasH scene: UnitBox.obj scaled to a tank ``tank`` (width, height, depth) with
    its floor at y = 0 (mapInvert), one fluid block [start, end] (SPlisHSPlasH's corners: its
    first particle lies 2r inside), standard viscosity 0.01 (SPlisHSPlasH's scenes)."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(UNIT_BOX, folder / "UnitBox.obj")
    w, h, d = tank
    cfg = {"particleRadius": r, "simulationMethod": solver, "boundaryHandlingMethod": boundary,
           "cflMethod": 1, "cflFactor": 1, "cflMaxTimeStepSize": 0.005,
           "WCSPH": {"stiffness": stiffness, "exponent": 7},
           "DFSPH": {"maxError": 0.01, "maxErrorV": 0.1}}
    if dim == 2:
        cfg["sim2D"] = True
    rigid = [{"geometryFile": "UnitBox.obj", "translation": [0, h / 2, 0], "scale": [w, h, d],
              "isDynamic": False, "mapInvert": True, "mapResolution": [16, 12, 8]}]
    if body is not None:
        rigid.append(body)
    path = folder / "scene.json"
    path.write_text(json.dumps({
        "Configuration": cfg,
        "Materials": [{"id": "Fluid", "viscosityMethod": 1,
                       "Standard viscosity": {"viscosity": 0.01}}],
        "RigidBodies": rigid,
        "FluidBlocks": [{"start": list(start), "end": list(end)}]}))
    return path


def _load(path: Path, start: bool = True) -> tuple[Simulation, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(path)
        scene.configuration.start.relax = start
        scene.configuration.start.hydrostatic = start
        sim = Simulation(scene)
    return sim, [str(w.message) for w in caught if "removed" in str(w.message)]


# -- pieces ---------------------------------------------------------------------------------------


def test_compact_keeps_order_renumbers_ids_and_shrinks_objects() -> None:
    ps = ParticleSet(2)
    ps.register("m")
    ps.add(np.zeros((4, 2)) + np.arange(4)[:, None], name="a", m=1.0)
    ps.add(np.zeros((3, 2)) + 10 + np.arange(3)[:, None], name="b", m=2.0)
    ps.add(np.zeros((2, 2)) + 20, name="c", m=3.0)
    ps.permute(np.array([8, 0, 5, 1, 7, 2, 6, 3, 4]))  # memory order differs from id order
    keep = ~np.isin(ps["id"], [1, 4, 5, 6])  # object b loses everything, a one particle
    x_kept = ps["x"][:, keep].copy()
    ps.compact(keep)
    assert ps.n == 5 and ps.next_id == 5
    np.testing.assert_array_equal(ps["x"], x_kept)  # the kept particles, in memory order
    assert sorted(ps["id"]) == [0, 1, 2, 3, 4]
    assert [(o.name, o.start, o.end) for o in ps.objects] == [("a", 0, 3), ("c", 3, 5)]
    order = ps.order_by_id()
    np.testing.assert_array_equal(ps["m"][order], [1, 1, 1, 3, 3])
    ps.add(np.zeros((1, 2)), name="d")  # ids continue after the kept ones
    assert ps["id"][-1] == 5


def test_column_depth_on_lattices_steps_gaps_and_air() -> None:
    """Depth below the free surface r above the top of each connected column: a square and
    a hexagonal block (exact: the lattice heights are known), a step in the surface, a column
    split by a gap wider than h, and a column that does not rest on anything (depth 0)."""
    r, h = 0.01, 0.04
    xs, ys = np.meshgrid(r + 2 * r * np.arange(10), r + 2 * r * np.arange(8), indexing="ij")
    x = np.stack([xs.ravel(), ys.ravel()], axis=1)
    np.testing.assert_allclose(column_depth(x, [0, -G], r, h), 16 * r - x[:, 1], atol=1e-12)
    rows = [np.stack([r + 2 * r * np.arange(10) + (r if j % 2 else 0.0),
                      np.full(10, r + j * math.sqrt(3) * r)], axis=1) for j in range(7)]
    hexa = np.concatenate(rows)
    top = r + 6 * math.sqrt(3) * r
    np.testing.assert_allclose(column_depth(hexa, [0, -G], r, h), top + r - hexa[:, 1],
                               atol=1e-12)
    step = x[(x[:, 0] < 0.1) | (x[:, 1] < 0.08)]  # the right half 4 rows high
    d = column_depth(step, [0, -G], r, h)
    surface = np.where(step[:, 0] < 0.1, 0.16, 0.08)
    np.testing.assert_allclose(d, surface - step[:, 1], atol=1e-12)
    split = x[(x[:, 1] < 0.06) | (x[:, 1] > 0.11)]  # a gap of 5r > h between rows 3 and 6
    d = column_depth(split, [0, -G], r, h)
    np.testing.assert_allclose(d, np.where(split[:, 1] < 0.06, 0.06, 0.16) - split[:, 1],
                               atol=1e-12)
    supported = split[:, 1] > 0.11  # only the upper part rests on something
    d = column_depth(split, [0, -G], r, h, supported)
    np.testing.assert_allclose(d, np.where(split[:, 1] < 0.06, 0.0, 0.16 - split[:, 1]),
                               atol=1e-12)
    # gravity along -x: the columns are the rows
    np.testing.assert_allclose(column_depth(x, [-G, 0], r, h), 20 * r - x[:, 0], atol=1e-12)


@pytest.mark.parametrize("equation", ["tait", "linear"])
def test_compressed_density_inverts_the_state_equation(equation: str) -> None:
    """WCSPH's start density carries the pressure it was made for (to round-off)."""
    solver = WCSPH(equation=equation, stiffness=50000.0 if equation == "tait" else 2000.0)
    p = np.linspace(0.0, 2e4, 50)
    rho = solver.compressed_density(p, np.full(50, RHO0))
    out = np.empty(50)
    state_equation(rho, np.full(50, RHO0), solver.equation, solver.stiffness, solver.exponent,
                   out, 0.0)
    np.testing.assert_allclose(out, p, rtol=1e-9, atol=1e-7)


# -- the hydrostatic start ------------------------------------------------------------------------


def _column_scene(hydrostatic: bool, relax: bool = True) -> Scene:
    r, w, hgt = 0.01, 0.3, 0.3
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -G],
                          "pressure": {"method": "wcsph", "stiffness": 50000.0},
                          "start": {"hydrostatic": hydrostatic, "relax": relax}},
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [w, hgt]}],
        "boxes": [{"min": [0.0, 0.0], "max": [w, hgt + 0.1], "layers": 2}]})


def test_wcsph_column_starts_with_its_hydrostatic_density_and_pressure() -> None:
    """A 0.3 m WCSPH column (B = 50,000 Pa, Tait) sampled on the lattice of its box starts
    with p = rho0 g depth (depth below r above the top particle centres, i.e. below y = 0.3)
    and, where the kernel is full, with the Tait density of that pressure: the summation
    density, recomputed here from the particles (brute force, cubic spline, Akinci volumes
    of the walls), is within 1e-6 of ``rho0 (1 + p / B)^(1/7)`` (the start's fixed point is
    solved to 1e-6). The relaxation moves no particle farther than r from where it was
    sampled (the fluid next to the lattice walls starts up to 4.5 % too dense, and the
    column rises by the space they claim), and the pressure's least-squares slope is rho0 g.
    Without the hydrostatic start: rest density, p = 0 and the lattice masses."""
    sim = Simulation(_column_scene(True), settle=False)  # the start-up's state itself
    f, b, st = sim.fluid, sim.boundary, sim.state
    x, m = f.view("x"), f["m"]
    tops = np.array([x[np.abs(x[:, 0] - xi) < st.r, 1].max() for xi in x[:, 0]])
    p = RHO0 * G * (tops + st.r - x[:, 1])  # depth below r above the column's top particle
    np.testing.assert_allclose(f["p"], p, rtol=1e-12, atol=1e-9)
    kern = Kernel("cubic", st.h, 2)
    pts = np.concatenate([x, b.view("x")])
    psi = np.concatenate([m, RHO0 * b["V"]])  # fluid masses, boundary rho0 V_b
    tree = cKDTree(pts)
    full = (x[:, 1] < 0.3 - st.h - 0.5 * st.r)  # a full kernel of fluid or wall above
    rho = np.array([sum(psi[j] * kern.w(np.linalg.norm(pts[j] - x[i]))
                        for j in tree.query_ball_point(x[i], st.h)) for i in np.flatnonzero(full)])
    np.testing.assert_allclose(rho, RHO0 * (1.0 + p[full] / 50000.0) ** (1.0 / 7.0), rtol=1e-6)
    sampled = lattice_block([0.0, 0.0], [0.3, 0.3], st.r)  # in id order, nothing removed
    moved = np.linalg.norm(x[f.order_by_id()] - sampled, axis=1)
    assert moved.max() < st.r, moved.max()  # out of the walls' range, not rearranged
    slope = -np.polyfit(x[:, 1], f["p"], 1)[0] / (RHO0 * G)
    assert slope == pytest.approx(1.0, abs=1e-4)  # the columns' tops differ by < r
    assert sim.world.start.start_error[1] < 1e-6
    off = Simulation(_column_scene(False, relax=False))
    assert np.all(off.fluid["p"] == 0.0)
    assert np.all(off.fluid["m"] == off.fluid["m"][0])
    assert off.world.start.hydrostatic is False


def test_column_does_not_drop_and_bounce(tmp_path: Path) -> None:
    """The issue's 2D WCSPH column (SPlisHSPlasH format, stiffness 50,000, Akinci walls from a
    box mesh), 0.6 m wide and 0.48 m deep from wall to wall (the block 0.2 r off the walls, on
    the floor). Its surface -- the mean height of its 20 highest particles -- starts within r
    of the sampled lattice's top (0.48 m; the relaxation lifts it by the space the walls claim,
    measured 0.36 r) and stays within 0.5 r of that start for 0.4 s (measured 0.23 r): the time
    in which the old start threw it up and let it fall back. Without the start-up the walls'
    overdensity of the sampled fluid threw the surface 16 r up within 0.2 s (measured 7.5 r at
    0.06 s, 12.1 r at 0.1 s, 15.9 r at 0.18 s), and it fell back and bounced (2.2 r at 0.36 s);
    that contrast run stops at 0.1 s, by when it is past 5 r. (The slope per frame is not within
    the issue's 3 %: validation/startup.py, the column's pressure noise after 1 s.)"""
    r = 0.01
    path = _tank_scene(tmp_path, 2, r, 0, 0, (0.6, 0.7, 1.0), [-0.3 + 0.2 * r, 0.0, -0.5],
                       [0.3 - 0.2 * r, 0.5, 0.5])
    surfaces = {}
    for start in (True, False):
        sim, _ = _load(path, start)
        seen: list[float] = []

        def frame(s: Simulation, _k: int, seen: list[float] = seen) -> None:
            seen.append(float(np.sort(s.positions[:, 1])[-20:].mean()))

        sim.run(until=0.4 if start else 0.1, fps=50, on_frame=frame)
        surfaces[start] = np.array(seen)
    on = surfaces[True]
    assert abs(on[0] - 0.48) < r, on[0]
    assert np.abs(on - on[0]).max() < 0.5 * r, np.abs(on - on[0]).max()
    assert surfaces[False].max() > 0.48 + 5 * r  # the contrast: the old start threw it up


def test_fluid_filling_a_box_starts_on_its_lattice_and_rests() -> None:
    """Fluid filling a 3D box of its own size (0.4 x 0.6 x 0.2 m, r = 2 cm, the default two wall
    layers; every particle within two layers of a wall) continues the walls' lattice, whose
    particles have the fluid's lattice volume (:func:`sphkit.boundary.akinci2012.static_volumes`):
    as sampled it is at rest density to round-off (1e-9), so the start-up moves nothing and every
    mass stays the lattice mass. PCISPH (no warm start, SPlisHSPlasH's defaults) then holds
    it: after 0.1 s the fastest particle moves at < 0.15 m/s (measured 0.073: the column falls
    freely for the first steps, until its compression reaches the 0.05 % tolerance; g times
    those 6 steps is 0.08 m/s; the same with one layer). With Akinci's volumes of one-layer walls
    (1.36-1.65 lattice volumes) the sampled fluid was 15 % too dense at the walls, the relaxed
    start's first solve that had to hold the column diverged and the run stopped unstable at
    step 7 (validation/README.md, "Box walls: the lattice's volume")."""
    sim = Simulation(Scene.model_validate({
        "configuration": {"dim": 3, "particle_radius": 0.02, "gravity": [0.0, -G, 0.0],
                          "pressure": {"method": "pcisph", "max_error": 0.05},
                          "time": {"dt_max": 0.002}},
        "fluid_blocks": [{"start": [0.0, 0.0, 0.0], "end": [0.4, 0.6, 0.2]}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.4, 0.8, 0.2]}]}))
    start = sim.world.start
    assert start.sampled_error[1] < 1e-9 and start.max_displacement == 0.0
    m = sim.fluid["m"]
    assert np.ptp(m) == 0.0
    vmax = 0.0
    while sim.time < 0.1:
        vmax = max(vmax, sim.step().max_velocity)
    assert vmax < 0.15, vmax


def _slope(y: np.ndarray, p: np.ndarray) -> float:
    """Least-squares -dp/dy over the middle 80 % of the column, in units of rho0 g."""
    lo, top = y.min(), y.max()
    m = (y > lo + 0.1 * (top - lo)) & (y < lo + 0.9 * (top - lo))
    return float(-np.polyfit(y[m], p[m], 1)[0] / (RHO0 * G))


def test_wcsph_column_settles_into_its_equilibrium(tmp_path: Path) -> None:
    """A 2D WCSPH column in SPlisHSPlasH format (stiffness 50,000, Akinci walls from a box
    mesh), its block written 3r off walls and floor as SPlisHSPlasH's column scenes are. The
    Akinci floor holds fluid about 2.1r off, so unsettled the lowest row carries no pressure at
    t = 0 and the whole column falls by the gap (mean vertical speed past 0.1 m/s within 0.05 s,
    measured 0.27 m/s at r = 1 cm) and rings at its acoustic period. Settled before t = 0
    (``start.settle`` "auto"), it starts at rest in its own equilibrium: the settling ran (its
    root mean square speed came below 1 cm/s), the mean vertical speed stays below 1 cm/s over
    0.3 s, the pressure slope averaged over the frames is within 3 % of rho0 g and that of
    every frame within 12 % (this 14-row column's pressure noise: measured 0.90-1.04; a 0.48 m
    column's frames lie within 1.021-1.053, README). Unsettled, the slope drops to 0 as the
    column falls."""
    r = 0.01
    path = _tank_scene(tmp_path, 2, r, 0, 0, (0.4, 0.5, 1.0), [-0.2 + r, r, -0.5],
                       [0.2 - r, 0.3, 0.5])
    runs = {}
    for settle in (True, False):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = load_scene(path)
            scene.configuration.start.settle = "auto" if settle else False
            sim = Simulation(scene)
        seen: list[tuple[float, float]] = []

        def frame(s: Simulation, _k: int, seen: list = seen) -> None:
            seen.append((float(s.velocities[:, 1].mean()),
                         _slope(s.positions[:, 1], s.pressures)))

        sim.run(until=0.3 if settle else 0.05, fps=50, on_frame=frame)
        runs[settle] = (sim.world.start, np.array(seen))
    start, on = runs[True]
    assert start.settle_steps > 0 and start.settle_speed < 0.01, start
    assert np.abs(on[:, 0]).max() < 0.01, on[:, 0]
    assert abs(on[1:, 1].mean() - 1.0) < 0.03, on[:, 1]
    assert np.abs(on[1:, 1] - 1.0).max() < 0.12, on[:, 1]
    off_start, off = runs[False]
    assert off_start.settle_steps == 0
    assert off[:, 0].min() < -0.1, off[:, 0]  # the contrast: unsettled, the column falls


def test_a_dam_break_is_not_settled(tmp_path: Path) -> None:
    """A dam break's block has a free face deep in its column: settling would let it flow, so
    "auto" does not settle it, and ``settle: true`` says why in a warning."""
    r = 0.01
    path = _tank_scene(tmp_path, 2, r, 0, 0, (0.8, 0.5, 1.0), [-0.4 + r, r, -0.5],
                       [0.0, 0.3, 0.5])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(path)
        assert Simulation(scene).world.start.settle_steps == 0
        scene.configuration.start.settle = True
        assert Simulation(scene).world.start.settle_steps == 0
    said = [str(w.message) for w in caught if "settle" in str(w.message)]
    assert len(said) == 1 and "free face" in said[0], said
    # a 3D dam break in a channel four particles wide (r = 2 cm, channel 0.2 m = 2.5 h): its
    # side walls lie within 2h of the whole face, but along it, not across it; before the wall
    # had to lie within 20 degrees of the face's direction, "auto" settled this column for 1,712
    # steps, and it collapsed before t = 0 (validation/dam_break.py --dim 3)
    r = 0.02
    path = _tank_scene(tmp_path / "channel", 3, r, 0, 0, (0.8, 0.5, 0.2), [-0.4 + r, r, -0.1],
                       [0.0, 0.3, 0.1])
    assert Simulation(load_scene(path)).world.start.settle_steps == 0


# -- fluid at the walls, and in them --------------------------------------------------------------


@pytest.mark.parametrize("boundary", [2, 0], ids=["volume-maps", "akinci"])
def test_block_at_the_walls_converges_at_step_1(boundary: int, tmp_path: Path) -> None:
    """SPlisHSPlasH's way of writing a dam break: the block from the floor and 0.2 r off the
    left, front and back walls of a UnitBox tank (0.8 x 0.6 x 0.4 m, r = 2 cm, DFSPH with
    SPlisHSPlasH's default error 0.01 %, volume maps -- SPlisHSPlasH's default boundary -- and
    Akinci particles). The first step's density solve converges (its average error within the
    tolerance), and in the collapse (0.15 s, before the front reaches the far wall) no particle
    is faster than Ritter's front speed 2 sqrt(g H) = 3.4 m/s, the bound of a frictionless dam
    break of height H = 0.3 m (measured 2.7 m/s), and none leaves the tank. With the start-up
    off, the fluid next to the volume maps is shot away: faster than that bound (measured
    21.6 m/s in the collapse, its first solve converged: the maps' surface on the mesh, as
    SPlisHSPlasH's; while sphkit's volume maps moved their surface 0.5 r into the fluid, the
    run blew up at step 3, 131.8 m/s, the issue's failure)."""
    r, w, d = 0.02, 0.8, 0.4
    path = _tank_scene(tmp_path, 3, r, 4, boundary, (w, 0.6, d),
                       [-w / 2 + 0.2 * r, 0.0, -d / 2 + 0.2 * r], [-w / 2 + 0.3, 0.3,
                                                                  d / 2 - 0.2 * r])
    bound = 2.0 * math.sqrt(G * 0.3)
    # the contrast (start-up off) is asserted for the volume maps only: with Akinci particles
    # that run checked nothing
    for start in (True, False) if boundary == 2 else (True,):
        sim, _ = _load(path, start)
        st = sim.step()
        converged = sim.last_solver.converged
        vmax = st.max_velocity
        try:
            while sim.time < 0.15:
                vmax = max(vmax, sim.step().max_velocity)
        except InstabilityError:  # the contrast below, as the scene (step 3)
            assert not start
            vmax = math.inf
        x = sim.positions
        inside = ((np.abs(x[:, 0]) <= w / 2 + 0.1 * r) & (x[:, 1] >= -0.1 * r)
                  & (np.abs(x[:, 2]) <= d / 2 + 0.1 * r))
        if start:
            assert converged and st.density_error_avg <= 1e-4, (st.iterations,
                                                               st.density_error_avg)
            assert vmax < bound, vmax
            assert inside.all()
            assert sim.world.start.removed_inside == {}
        elif boundary == 2:  # the contrast: shot away (or unstable, the failure)
            assert vmax > bound, vmax


def test_fluid_in_a_box_wall_is_removed_with_a_warning() -> None:
    """Own format, Akinci lattice walls (two layers): a 2D block reaching two particle rows past
    the right wall and under the floor of its box. The particles outside the box's interior
    (in its walls) are removed, with one warning naming the block, the count and the wall; the
    count is that of the block's lattice points outside the interior, counted here."""
    r = 0.01
    scene = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "pressure": {"method": "dfsph"}},
        "fluid_blocks": [{"start": [0.1, -0.04], "end": [0.45, 0.2]}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.4, 0.4], "layers": 2}]})
    xs = 0.1 + r + 2 * r * np.arange(17)  # the block's lattice: 0.11 .. 0.43
    ys = -0.04 + r + 2 * r * np.arange(12)  # -0.03 .. 0.19
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    expected = int(((gx > 0.4) | (gy < 0.0)).sum())
    assert expected == 17 * 12 - 15 * 10  # two columns and two rows of the block
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim = Simulation(scene)
    notes = [str(w.message) for w in caught if "removed" in str(w.message)]
    assert len(notes) == 1 and notes[0].startswith(f"fluid_blocks[0]: {expected} particle(s)")
    assert "boxes[0]" in notes[0]
    assert sim.fluid.n == 15 * 10
    assert sim.world.start.removed_inside == {"fluid_blocks[0]": expected}
    x = sim.positions
    assert x[:, 0].max() < 0.4 and x[:, 1].min() > 0.0
    for _ in range(20):  # and it runs
        sim.step()


def test_block_flush_against_mesh_walls_starts_inside_and_rests(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Own format, Akinci particles sampled on meshes, 2D: blocks written flush against the
    mesh surfaces, their first particles r from the surface samples.

    1. A block filling an inverted box mesh (a container, 0.2 m wide, r = 1 cm, DFSPH): the
       ring of particles r from the walls overlaps the wall particles by half a particle and
       is removed (closer than 1.5 r to a static mesh's surface, ``Akinci2012.start_reach``;
       10 + 4 + 4 of the 10 x 5 block), with the block's warning; the rest is
       consistent as sampled and stays inside for 0.1 s. Kept (the reach of r, as before), the
       relaxation squeezed the ring into the block, and in the floor's corners, where every
       fluid neighbour lies on one side, pushed the two corner particles out between the
       surface samples (0.7 r outside both walls; the first steps lost them and the run
       stopped as a leak, 3D too): such particles are now put back where they were sampled
       (``held_back``), where the masses step removes them.
    2. A pool filled over a solid box mesh standing on its floor (box walls 0.2 m wide, block
       0.12 m deep, r = 5 mm, PCISPH): with the reach of r the relaxation pressed particles to
       0.5 r above the floor and the first solves diverged (542 m/s at step 6); now the
       columns flush against the obstacle are removed, and the pool rests (largest speed after
       0.1 s below 5 cm/s: measured 1.5 cm/s)."""
    import trimesh

    import sphkit.boundary.akinci2012 as akinci

    r, w = 0.01, 0.2
    trimesh.creation.box(bounds=[[0.0, 0.0, -0.5], [w, 0.3, 0.5]]).export(tmp_path / "tank.obj")
    tank = {
        "configuration": {"dim": 2, "particle_radius": r, "pressure": {"method": "dfsph"}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [w, 0.1]}],
        "meshes": [{"geometry_file": str(tmp_path / "tank.obj"), "invert": True}]}
    for reach, removed, held in ((akinci.Akinci2012.start_reach, 18, 0), (0.0, 2, 2)):
        monkeypatch.setattr(akinci.Akinci2012, "start_reach", reach)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sim = Simulation(Scene.model_validate(tank))
        notes = [str(x.message) for x in caught if "removed" in str(x.message)]
        assert sim.world.start.held_back == held, reach
        assert len(notes) == 1, notes
        assert notes[0].startswith(f"fluid_blocks[0]: {removed} particle(s)"), notes
        assert sim.fluid.n == 10 * 5 - removed
        while sim.time < 0.1:
            sim.step()
            x = sim.positions
            assert x[:, 0].min() > 0.0 and x[:, 0].max() < w and x[:, 1].min() > 0.0, reach
    monkeypatch.undo()
    r = 0.005
    trimesh.creation.box(bounds=[[0.08, -0.05, -0.5], [0.14, 0.06, 0.5]]).export(
        tmp_path / "cube.obj")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(Scene.model_validate({
            "configuration": {"dim": 2, "particle_radius": r, "pressure": {"method": "pcisph"}},
            "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
            "fluid_blocks": [{"start": [0.0, 0.0], "end": [w, 0.12]}],
            "boxes": [{"min": [0.0, 0.0], "max": [w, 0.3], "open_top": True}],
            "meshes": [{"geometry_file": str(tmp_path / "cube.obj")}]}))
    assert sim.world.start.relax_iterations == 0  # consistent as sampled
    while sim.time < 0.1:
        sim.step()
    assert np.abs(sim.fluid["v"]).max() < 0.05


def test_pool_flush_against_volume_maps_loses_its_wall_layer_and_rests(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Own format, volume maps, 3D, PCISPH: a pool 0.12 m deep filling an open box of walls
    0.2 m wide, over a solid box mesh 0.06 m wide standing on the floor (r = 1 cm, the first
    particles r from every surface). A volume map claims more room than boundary particles:
    the layer r from the walls starts more than twice as dense, and kept (a reach of 0), the
    relaxation squeezes it into the pool, which rises to 0.185 m (the contrast: a top above
    0.15 m, or unstable: PCISPH's fourth solve diverged next to the obstacle at step 5 before
    its impact rule). Fluid within 1.5 r of a
    box's face or a static mesh's surface is removed (``Bender2019.start_reach``, measured on
    the geometry): every particle of the block's outer shell at the box walls and the floor and
    the columns flush against the obstacle, 351 of the 600. The rest stays inside and comes to
    rest: from 0.2 to 0.3 s no particle is faster than one falling a particle radius,
    sqrt(2 g r) = 0.44 m/s (measured 0.11 m/s). Before that it settles into the room the removal
    left: its first layer 3 r off the surfaces, where the fluid rests about 2.5 r off a volume
    map's surface, and shafts 2 r wide along the obstacle's vertical edges, into which the fluid
    above them slides; the pool's top sinks 1.5 r, and no particle is faster than a free fall
    through the pool's whole depth, sqrt(2 g 0.12 m) = 1.53 m/s (measured 0.69 m/s, at the
    obstacle's top corner; 0.35 m/s while the maps' surface stood 0.5 r into the fluid, where
    the 3 r layer rested as sampled)."""
    import trimesh

    import sphkit.boundary.bender2019 as bender

    r, w = 0.01, 0.2
    trimesh.creation.box(bounds=[[0.08, -0.05, 0.08], [0.14, 0.06, 0.14]]).export(
        tmp_path / "cube.obj")
    scene = {
        "configuration": {"dim": 3, "particle_radius": r, "pressure": {"method": "pcisph"},
                          "boundary": {"method": "bender2019",
                                       "map_cache_dir": str(tmp_path)}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0.0, 0.0, 0.0], "end": [w, 0.12, w]}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": [w, 0.3, w], "open_top": True}],
        "meshes": [{"geometry_file": str(tmp_path / "cube.obj")}]}
    rest, fall = math.sqrt(2.0 * G * r), math.sqrt(2.0 * G * 0.12)
    # the block's lattice (first particles r inside) against the exact geometry: within
    # 1.5 r of a wall face (not the open top) or of the solid box, or inside it
    g = np.arange(r, w, 2 * r)
    p = np.stack(np.meshgrid(g, np.arange(r, 0.12, 2 * r), g, indexing="ij"), -1).reshape(-1, 3)
    faces = np.minimum(np.minimum(p[:, 0], w - p[:, 0]), np.minimum(p[:, 2], w - p[:, 2]))
    cube = np.linalg.norm(np.maximum(np.maximum([0.08, -0.05, 0.08] - p,
                                                p - [0.14, 0.06, 0.14]), 0.0), axis=1)
    removed = int(((np.minimum(faces, p[:, 1]) < 1.5 * r) | (cube < 1.5 * r)).sum())
    for reach in (bender.Bender2019.start_reach, 0.0):
        monkeypatch.setattr(bender.Bender2019, "start_reach", reach)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(Scene.model_validate(scene))
        vmax, vrest = 0.0, 0.0
        try:
            while sim.time < 0.3:
                v = sim.step().max_velocity
                vmax = max(vmax, v)
                if sim.time > 0.2:
                    vrest = max(vrest, v)
        except InstabilityError:
            assert reach == 0.0  # the contrast
            continue
        if reach == 0.0:  # the contrast, stable: the pool stands far above its 0.12 m
            assert sim.positions[:, 1].max() > 0.15
            continue
        assert sum(sim.world.start.removed_inside.values()) == removed  # 351 of 600
        assert vmax < fall, vmax
        assert vrest < rest, vrest
        x = sim.positions
        assert x.min() > 0.0 and x[:, 0].max() < w and x[:, 2].max() < w


def test_block_overlapping_a_map_wall_is_removed_and_runs(tmp_path: Path) -> None:
    """SPlisHSPlasH format, volume maps, DFSPH, 2D: a block written 4 r into the tank's left
    wall (the issue: "stops at step 1 with 'try a smaller time step'"). The particles behind
    the wall's map surface (the mesh surface) -- here exactly the block's columns beyond the
    mesh, at 3 r and r behind it -- are removed with a warning
    naming the block and the count, and the rest runs 0.2 s without leaving the tank."""
    r, w = 0.01, 0.6
    path = _tank_scene(tmp_path, 2, r, 4, 2, (w, 0.5, 1.0), [-w / 2 - 4 * r, 0.0, -0.5],
                       [-w / 2 + 0.2, 0.2, 0.5])
    sim, notes = _load(path)
    # SPlisHSPlasH's block: first particle 2r inside its corner, round(span / 2r) - 1 per axis
    nx, ny = round((0.2 + 4 * r) / (2 * r)) - 1, round(0.2 / (2 * r)) - 1
    behind = 2 * ny  # the columns at x = -w/2 - 2r and -w/2 (on the surface, phi < 0)
    assert len(notes) == 1 and notes[0].startswith(f"fluid_blocks[0]: {behind} particle(s)")
    assert sim.fluid.n == (nx - 2) * ny
    while sim.time < 0.2:
        sim.step()
    x = sim.positions
    assert x[:, 0].min() > -w / 2 and x[:, 1].min() > 0.0


def test_fluid_inside_a_floating_body_is_removed(tmp_path: Path) -> None:
    """A pool from wall to wall with a dynamic cube (density 500) placed in it, Akinci particles,
    3D: the fluid sampled inside the cube's mesh is removed (the count is the lattice points in
    the cube, counted here), with a warning naming the block and the body's mesh
    (``meshes[1]``: SPlisHSPlasH's second RigidBodies entry)."""
    r, w, d, side = 0.02, 0.6, 0.4, 0.16
    c = np.array([0.01, 0.21, 0.01])  # no lattice point on a face of the cube
    body = {"geometryFile": "UnitBox.obj", "translation": c.tolist(),
            "scale": [side] * 3, "isDynamic": True, "density": 500}
    path = _tank_scene(tmp_path, 3, r, 4, 0, (w, 0.5, d), [-w / 2, 0.0, -d / 2],
                       [w / 2, 0.24, d / 2], body=body)
    sim, notes = _load(path)
    scene = load_scene(path)
    blk = scene.fluid_blocks[0]
    axes = [np.arange(blk.start[k] + r, blk.end[k] - r + 1e-9, 2 * r) for k in range(3)]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    expected = int(np.all(np.abs(g - c) < side / 2, axis=1).sum())
    assert expected > 0
    assert len(notes) == 1 and notes[0].startswith(f"fluid_blocks[0]: {expected} particle(s)")
    assert "meshes[1]" in notes[0]
    # none is left inside: the relaxation moves the fluid next to the cube by less than r (at
    # Akinci bodies the fluid rests at the mesh surface: the body's particles lie 1.2 r inside)
    x = sim.positions
    assert not np.any(np.all(np.abs(x - c) < side / 2 - r, axis=1))


def test_relaxation_is_skipped_where_the_sampled_fluid_meets_its_constraint(
        tmp_path: Path) -> None:
    """The start-up first measures the relaxation's constraint with the density pass (which
    every run compiles anyway): where no particle is over half the relaxation's tolerance
    (1 %), the projection is neither run nor compiled. Its value agrees with the projection's
    own first sweep (``relax_pass``) to round-off, on a 2D block at the walls (the projection
    moves it) and the same block 3 r off them (nothing to move: no sweep at all)."""
    import sphkit.world.startup as su

    r, w = 0.02, 0.8
    seen: dict[str, list] = {"density": [], "projection": []}
    real_constraint, real_pass = su._constraint, su.relax_pass

    def constraint(*args):  # noqa: ANN002, ANN202 - recorded and passed on
        seen["density"].append(real_constraint(*args))
        return seen["density"][-1]

    def sweep(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202 - recorded and passed on
        out = real_pass(*args, **kwargs)
        seen["projection"].append(out[:2])
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(su, "_constraint", constraint)
        mp.setattr(su, "relax_pass", sweep)
        for gap, moved in ((0.0, True), (3.0, False)):
            seen["density"].clear()
            seen["projection"].clear()
            path = _tank_scene(tmp_path / f"gap{gap:g}", 2, r, 4, 0, (w, 0.6, 0.1),
                               [-w / 2 + gap * r, gap * r, 0.0], [-w / 2 + 0.3, 0.3, 0.0])
            sim, _ = _load(path)
            report = sim.world.start
            (avg, mx), = seen["density"]
            if moved:
                assert mx > su.RELAX_TOLERANCE and report.relax_iterations > 0
                assert seen["projection"][0] == pytest.approx((avg, mx), rel=1e-9, abs=1e-15)
            else:
                assert mx <= 0.5 * su.RELAX_TOLERANCE and seen["projection"] == []
                assert report.relax_iterations == 0 and report.max_displacement == 0.0
                assert report.sampled_error == (avg, mx)
