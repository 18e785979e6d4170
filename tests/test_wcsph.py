"""WCSPH physics: hydrostatic column, momentum conservation, rest density of the sampling."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from _validation import load_validation

from sphkit.core.kernels import lattice_volume
from sphkit.pressure import wcsph
from sphkit.scene.schema import Scene
from sphkit.simulation import InstabilityError, Simulation

G = 9.81


def _column(width: float = 0.2, height: float = 0.5, r: float = 0.01, stiffness: float = 1e5,
            nu: float = 0.01, until: float = 2.0) -> Scene:
    return Scene.model_validate({
        "name": "column",
        "configuration": {
            "dim": 2, "particle_radius": r, "gravity": [0.0, -G],
            "pressure": {"method": "wcsph", "equation": "tait", "stiffness": stiffness,
                         "exponent": 7},
            "time": {"until": until},
        },
        "materials": [{"id": "fluid", "density0": 1000.0,
                       "viscosity": {"method": "standard", "coefficient": nu,
                                     "boundary_coefficient": nu}}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [width, height]}],
        "boxes": [{"min": [0.0, 0.0], "max": [width, height + 0.1], "layers": 2}],
    })


def test_hydrostatic_column_2d_pressure_slope_and_compression() -> None:
    """After 0.5 s (about six acoustic periods 4 H / c of the column; it is settled into its
    hydrostatic equilibrium before t = 0, ``start.settle`` "auto", so no start transient is left
    to damp), the least-squares slope of particle pressure over height in the middle 80% of the
    column is within 5% of rho0 g (the issue's bound), and the mean compression is below 1%
    (measured at 0.5 s: slope 1.015 rho0 g, compression 0.35 %, largest speed 0.011 m/s; every
    0.1 s from 0.1 s to 1.1 s: 1.007-1.016, 0.35 %, below 0.022 m/s; at 1.5 s, the earlier end:
    1.017, 0.35 %, 0.014 m/s)."""
    sim = Simulation(_column(until=0.5))
    sim.run(until=0.5)
    y = sim.positions[:, 1]
    top = y.max()
    sel = (y > 0.1 * top) & (y < 0.9 * top)
    slope = -np.polyfit(y[sel], sim.pressures[sel], 1)[0]
    compression = np.maximum(sim.densities - 1000.0, 0.0).mean() / 1000.0
    assert abs(slope / (1000.0 * G) - 1.0) < 0.05, slope
    assert compression < 0.01, compression
    # at rest: the largest speed is a small fraction of the free-fall speed sqrt(2 g H) = 3.1 m/s
    assert sim.last.max_velocity < 0.1


def test_free_blob_conserves_linear_momentum() -> None:
    """No gravity, no boundary: pressure and viscosity pair forces are antisymmetric, so total
    momentum stays at its initial value up to round-off (1e-10 relative to sum m|v|) over 100
    steps, whatever the particles do."""
    sc = Scene.model_validate({
        "configuration": {"dim": 3, "particle_radius": 0.02, "gravity": [0, 0, 0],
                          "pressure": {"stiffness": 2e4}, "time": {"dt_max": 1e-3}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0, 0, 0], "end": [0.4, 0.3, 0.3]}],
    })
    sim = Simulation(sc)
    rng = np.random.default_rng(0)
    sim.fluid["v"][...] = rng.normal(0.0, 0.5, sim.fluid["v"].shape)
    sim.fluid["x"][...] += rng.uniform(-0.004, 0.004, sim.fluid["x"].shape)
    m = sim.fluid["m"]
    p0 = (m * sim.fluid["v"]).sum(axis=1)
    scale = (m * np.linalg.norm(sim.fluid["v"], axis=0)).sum()
    for _ in range(100):
        sim.step()
    p1 = (sim.fluid["m"] * sim.fluid["v"]).sum(axis=1)
    assert np.abs(p1 - p0).max() / scale < 1e-10


@pytest.mark.parametrize("dim", [2, 3])
def test_lattice_sampling_reproduces_rest_density(dim: int) -> None:
    """Mass m = rho0 V with V = 1 / sum_k W(k * 2r) over the lattice: the interior density
    (particles farther than h from the block's surface) equals rho0 within 0.5% (the issue's
    bound; it is exact up to round-off on a regular lattice)."""
    r = 0.02
    end = [0.6, 0.6, 0.6][:dim]
    sc = Scene.model_validate({"configuration": {"dim": dim, "particle_radius": r,
                                                 "gravity": [0.0] * dim},
                               "fluid_blocks": [{"start": [0.0] * dim, "end": end}]})
    sim = Simulation(sc)
    sim.run(until=1e-9, fps=1.0)  # builds neighbours and densities at t = 0 (one tiny step)
    x = sim.positions
    h = 4 * r
    inner = np.all((x > h) & (x < np.asarray(end) - h), axis=1)
    assert inner.sum() > 10
    rho = sim.densities[inner]
    assert np.abs(rho / 1000.0 - 1.0).max() < 0.005
    assert np.allclose(sim.fluid["m"], 1000.0 * lattice_volume(2 * r, "cubic", h, dim))


def test_symmetric_walls_do_no_work_on_fluid_at_rest() -> None:
    """``boundary.symmetric``: WCSPH's wall term is ``V_b k_i`` alone, the derivative of the
    elastic energy of the summation density, so without viscosity the total energy (kinetic,
    gravity, Tait elastic ``int p / rho^2 drho``) of fluid at rest in a box stays constant. 2D,
    50 particles, 0.5 s: measured |dE| <= 0.008 J/m (symplectic Euler's oscillating error);
    bound 0.05 J/m. The mirrored default gains 2.2 J/m by 0.5 s and 82 J/m by 1 s, then blows
    up (validation/README.md, "WCSPH in the tank at rest")."""
    sc = _column(width=0.4, height=0.2, r=0.02, stiffness=7e4, nu=0.0, until=0.5)
    sc.configuration.boundary.symmetric = True
    sim = Simulation(sc)
    b = sc.configuration.pressure.stiffness

    def energy() -> float:
        m, rho = sim.fluid["m"], np.maximum(sim.densities, 1000.0)
        e = b * ((rho**6 - 1e18) / (6 * 1e21) + 1 / rho - 1e-3)  # Tait, p = 0 below rho0
        v2 = (sim.velocities**2).sum(axis=1)
        return float((m * (0.5 * v2 + G * sim.positions[:, 1] + e)).sum())

    e0 = energy()
    sim.run(until=0.5)
    assert abs(energy() - e0) < 0.05, energy() - e0


def test_an_inviscid_dam_break_takes_the_symmetric_walls_and_keeps_its_energy() -> None:
    """A scene as a user writes it first: WCSPH (the default solver), no viscosity, a 2D block
    0.2 m square collapsing in a closed box (25 particles, r = 2 cm). ``boundary.symmetric``
    left out resolves to true for WCSPH where a fluid's kinematic viscosity is below (2r)^2 x
    1/s, and the total energy (kinetic and gravity) after 1 s of sloshing is within 5 % of
    its start (measured -0.4 %, at most -3.4 % over 8 s: the exchange with the elastic energy
    and symplectic Euler's oscillation). The MLS wall term (symmetric false, the default before)
    pumped energy in: +83 % at 1 s, and a particle leaked through the ceiling at 2.6 s. With
    the standard viscosity 0.01 m^2/s (the built-in dam breaks' and SPlisHSPlasH's scenes') the
    default stays the MLS term. The same with density and volume maps (below)."""

    def scene(nu: float | None = None, **boundary: object) -> Scene:
        viscosity = {} if nu is None else {"method": "standard", "coefficient": nu}
        return Scene.model_validate({
            "configuration": {"dim": 2, "particle_radius": 0.02, "boundary": boundary},
            "materials": [{"viscosity": viscosity}],
            "fluid_blocks": [{"start": [0.1, 0.1], "end": [0.3, 0.3]}],
            "boxes": [{"min": [0.0, 0.0], "max": [0.6, 0.5]}]})

    energy = load_validation("energy.py").energy  # kinetic and gravity

    assert scene().configuration.boundary.symmetric
    assert scene(nu=1e-6).configuration.boundary.symmetric  # water's: (2r)^2 x 1/s = 1.6e-3
    assert not scene(nu=0.01).configuration.boundary.symmetric
    change = {}
    for symmetric in (None, False):
        sim = Simulation(scene() if symmetric is None else scene(symmetric=False))
        e0 = energy(sim)
        while sim.time < 1.0:
            sim.step()
        change[symmetric] = energy(sim) / e0 - 1.0
    assert abs(change[None]) < 0.05, change
    assert change[False] > 0.3, change  # the contrast: the pump
    # density maps: the symmetric term also drops the hydrostatic pressure's wall moment (a
    # separate force), which pumped too (+8 % in 4 s); without it the energy stays (measured
    # -1 % at 4 s, at most +0.4 %)
    maps = scene(method="koschier2017")
    assert maps.configuration.boundary.symmetric
    sim = Simulation(maps)
    assert not any(type(f).__name__ == "WallMomentForce" for f in sim.world.forces)
    e0 = energy(sim)
    while sim.time < 1.0:
        sim.step()
    assert abs(energy(sim) / e0 - 1.0) < 0.05, energy(sim) / e0
    # volume maps: with the symmetric term the virtual particle carries the exact gradient of
    # the density it gives (bender2019's "Symmetric walls"); measured +2.8 % at 1 s (+3.6 % at
    # 2 s); SPlisHSPlasH's placement, whose V_b grad W is not that gradient, +28 % at 1 s
    # (x2.1 at 2 s, x12 at 4 s). The WCSPH stiffness bound binds against the map's walls and
    # grows by at most STEP_GROWTH a step, and a checkpoint keeps it.
    change = {}
    for exact in (True, False):
        sim = Simulation(scene(method="bender2019"))
        sim.world.boundary_model.symmetric = exact
        e0, bound = energy(sim), []
        while sim.time < 1.0:
            sim.step()
            bound.append(sim.pressure.stiffness_bound)
        change[exact] = energy(sim) / e0 - 1.0
    assert abs(change[True]) < 0.05 and change[False] > 0.15, change
    held = [k for k in range(1, len(bound)) if np.isfinite(bound[k - 1]) and np.isfinite(bound[k])]
    assert len(held) > 0.5 * len(bound), (len(held), len(bound))  # the bound binds here
    assert max(bound[k] / bound[k - 1] for k in held) <= wcsph.STEP_GROWTH * (1 + 1e-12)
    kept = sim.pressure.checkpoint_state()
    fresh = Simulation(scene(method="bender2019")).pressure
    fresh.restore_checkpoint_state(kept)
    assert fresh.stiffness_bound == sim.pressure.stiffness_bound


def test_instability_is_diagnosed() -> None:
    """A column with a far too soft state equation and a tiny velocity bound stops with an
    InstabilityError naming step, time, max velocity, CFL number and density error."""
    sc = _column(height=0.3, until=0.5)
    sc.configuration.max_velocity = 0.5  # free fall reaches 0.5 m/s after ~0.05 s
    sc.configuration.pressure.stiffness = 10.0
    sim = Simulation(sc)
    with pytest.raises(InstabilityError) as e:
        sim.run()
    msg = str(e.value)
    for word in ("step", "time", "max velocity", "CFL number", "density error"):
        assert word in msg
    assert e.value.stats.max_velocity > 0.5


def test_a_state_equation_too_soft_for_the_fall_is_warned_about() -> None:
    """The world warns when WCSPH's speed of sound c = sqrt(B gamma / rho0) is below 5 times
    the speed v = sqrt(2 g H) the fluid reaches falling H from its highest particle to the
    lowest wall particle: a 1 m column at r = 5 cm (H = 1.1 m, v = 4.6 m/s) with B = 50,000 Pa
    (c = 18.7 m/s, 4 v) is named with both speeds and the stiffness that gives c = 10 v, B (10 v
    / c)^2; at that stiffness nothing is said (the built-in dam breaks are set so)."""
    from sphkit.world.build import build_world

    sc = _column(width=0.3, height=1.0, r=0.05)
    sc.configuration.pressure.stiffness = 50000.0
    with pytest.warns(UserWarning, match="speed of sound") as rec:
        world = build_world(sc)
    msg = next(str(w.message) for w in rec if "speed of sound" in str(w.message))
    y, yb = world.state.fluid["x"][1], world.state.boundary["x"][1]
    H = y.max() - min(y.min(), yb.min())
    c, v = np.sqrt(50000.0 * 7.0 / 1000.0), np.sqrt(2.0 * G * H)
    assert 1.0 < H < 1.2 and 4.0 < c / v < 5.0
    assert "configuration.pressure.stiffness: 50000" in msg and f"falling {H:.3g} m" in msg
    assert f"{c:.3g} m/s" in msg and f"{v:.3g} m/s" in msg
    need = 50000.0 * (10.0 * v / c) ** 2
    assert f"{need:.3g}" in msg
    sc.configuration.pressure.stiffness = need
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        build_world(sc)


def test_a_splash_over_an_open_box_is_no_leak() -> None:
    """The leak check leaves fluid above the walls' top alone: a drop thrown over an open box
    flies beside it, not through a wall (the dam-break impact's WCSPH runs stopped so,
    validation/README.md "Where WCSPH's dam-break impact lost a particle"); below the top,
    10 h beside the walls, it is a leak. In a closed box with all its fluid inside, fluid
    10 h above the lid went through it: a leak (the built-in 3D dam break with too soft a
    WCSPH threw particles through its lid at 0.64 s and was stopped only at 2.9 s, when they
    fell beside the box)."""
    sc = _column(width=0.1, height=0.1, until=0.5)
    sc.boxes[0].open_top = True  # walls 0.2 m high, 10 h = 0.4 m
    sim = Simulation(sc)
    x = sim.fluid["x"]
    x[:, 0] = (-1.0, 0.7)  # above the top, 1 m beside the walls
    sim.step()
    x = sim.fluid["x"]
    x[:, int(np.argmin(x[1]))] = (-1.0, 0.15)  # below the top
    with pytest.raises(InstabilityError, match="left the domain"):
        sim.step()
    sc.boxes[0].open_top = False
    sim = Simulation(sc)
    x = sim.fluid["x"]
    x[:, 0] = (0.05, 0.7)  # 0.5 m above the lid at 0.2 m, right above the fluid
    with pytest.raises(InstabilityError, match="left the domain"):
        sim.step()


@pytest.mark.parametrize("case", ["clean", "nan_velocity", "huge_velocity", "inf_position",
                                  "outside", "above_the_top", "no_domain"])
def test_step_check_agrees_with_the_separate_checks(case: str) -> None:
    """The step's one-pass check (``step_check``) gives what the separate passes give: the
    largest finite speed, the count of non-finite velocities, and ``clean`` exactly when no
    velocity or position is non-finite and no particle is outside the domain (above the walls'
    top is not outside); where it is not clean the counts come from the separate passes."""
    from sphkit.core.timestep import (
        Domain,
        nonfinite_count,
        outside_count,
        speed_check,
        step_check,
    )

    rng = np.random.default_rng(5)
    x = rng.uniform(0.0, 1.0, (3, 500))
    v = rng.normal(0.0, 2.0, (3, 500))
    dom = Domain(np.zeros(3), np.ones(3), up=1, top=1.0, sgn=1.0)
    if case == "nan_velocity":
        v[1, 17] = np.nan
    elif case == "huge_velocity":  # finite components whose square overflows
        v[0, 3] = 1e200
    elif case == "inf_position":
        x[2, 40] = np.inf
    elif case == "outside":
        x[0, 99] = -0.5
    elif case == "above_the_top":
        x[:, 5] = (-0.5, 1.5, 0.5)  # beside the box but above the walls' top: not a leak
    if case == "no_domain":
        x[0, 9] = 7.0  # no box: nothing is outside
        dom = None
    vmax, bad, clean = step_check(x, v, dom)
    vref, bref = speed_check(v)
    outside = 0 if dom is None else outside_count(x, *dom)
    assert (vmax, bad) == (vref, bref)
    assert clean == (bref == 0 and nonfinite_count(x) == 0 and outside == 0)
    assert clean == (case in ("clean", "above_the_top", "no_domain"))


def test_lone_particle_bounces_off_a_volume_map_wall_without_gaining_speed(tmp_path) -> None:
    """A lone particle thrown at 6 m/s against a volume-map wall (3D, a 0.3 m box, no gravity,
    r = 1.5 cm, stiffness 50,000) comes back no faster than it came. The wall is a stiff
    spring: the virtual particle's density rises about 1.4 rho0 per r at first contact, and at
    the acoustic step (0.64 ms) omega dt reaches 1.6 there and beyond 2 deeper in, so
    symplectic Euler gave the particle energy (measured 23.5 m/s after the bounce, 3.9x; the
    3D dam break of validation/startup.py went unstable at 0.69 s this way). WCSPH's local
    stiffness bound keeps omega dt <= 0.8: measured 7.01 m/s (1.17x). Bound 1.3x: the step
    that enters the wall's range is not resolved (the particle carries no pressure before it),
    so some gain remains."""

    box = Path(__file__).resolve().parent.parent / "benchmarks" / "scenes" / "UnitBox.obj"
    r = 0.015
    scene = Scene.model_validate({
        "configuration": {
            "dim": 3, "particle_radius": r, "gravity": [0.0, 0.0, 0.0],
            "pressure": {"method": "wcsph", "stiffness": 50000.0, "exponent": 7},
            "boundary": {"method": "bender2019", "map_cache_dir": str(tmp_path)},
        },
        "materials": [{"id": "fluid", "density0": 1000.0}],
        "fluid_blocks": [{"start": [-r, -r, -r], "end": [r, r, r],
                          "velocity": [0.0, 0.0, -6.0]}],
        "meshes": [{"geometry_file": str(box), "scale": [0.3, 0.3, 0.3], "invert": True,
                    "map_resolution": [8, 8, 8]}],
    })
    sim = Simulation(scene)
    assert sim.fluid.n == 1
    z0 = float(sim.fluid["x"][2, 0])
    for _ in range(2000):  # about 0.05 s: to the wall (0.15 m away) and back
        sim.step()
        v, z = sim.fluid["v"][:, 0], float(sim.fluid["x"][2, 0])
        if v[2] > 0.0 and z >= z0:
            break
    assert v[2] > 0.0 and z >= z0, (v, z)  # it came back
    speed = float(np.linalg.norm(v))
    assert speed < 1.3 * 6.0, speed


def test_elliptical_drop_semi_axis_follows_the_incompressible_solution() -> None:
    """Monaghan 1994's elliptical drop, coarse (validation/elliptical_drop.py: R = 1 m,
    A0 = 100 1/s, no gravity, no walls; particle radius 0.05 m, 316 particles; Tait WCSPH,
    c = 1400 m/s) to t = 0.0076 s, where the exact semi-axis b has grown from 1 to 1.9445 m.
    The second-moment semi-axis (exact for any sampling under the analytic linear flow) stays
    within 2.5 % of the exact b at every step: measured 1.77 % (2026-12-03; 1.27 % at r = 0.01 m,
    the issue's target is 2 %), the bound is that plus 40 %. The largest compression stays below
    1 %: the centre pressure 5 MPa over rho0 c^2 gives 0.26 % (measured 0.19 %). Measured 0.4 s
    warm (pytest, after test_free_blob; 0.6 s as a second call in a loaded process; 2.6 s when
    it is the first to load the compiled kernels)."""
    mod = load_validation("elliptical_drop.py")
    out = mod.run(mod.drop("wcsph", 0.05))
    assert abs(out["b_exact"][-1] / 1.9445 - 1.0) < 1e-3  # the exact solution's end state
    assert out["err_mom"] < 0.025, out["err_mom"]
    assert out["rho_max"] < 0.01, out["rho_max"]
