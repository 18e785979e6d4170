"""No-slip walls of Morris, Fox & Zhu 1997 in the Laplacian viscosities (``boundary_velocity:
"morris1997"`` of the standard and the Weiler 2018 viscosity), and a fast Poiseuille start-up in
Morris et al.'s setup (the long study is validation/poiseuille.py)."""

from __future__ import annotations

import numpy as np
import pytest
from _validation import load_validation

from sphkit.core.viscous import morris_beta
from sphkit.scene.files import scene_from_dict
from sphkit.scene.schema import Scene, SceneError
from sphkit.simulation import Simulation

GAMMA = 3.0  # shear rate [1/s]


def test_extrapolated_wall_velocity_vanishes_on_the_wall_plane() -> None:
    """For a linear shear u = gamma y over a wall at y = 0, the artificial velocity
    ``v_b = v_i - beta v_i`` (wall at rest) of a wall particle at depth d_b, seen from a fluid
    particle at height d_i, must (1) equal the shear profile continued into the wall,
    gamma (-d_b), and (2) make the straight line through (d_i, v_i) and (-d_b, v_b) pass
    through 0 on the wall plane (no slip). beta_max is set high so that it does not act. Pure
    arithmetic: 1e-12 relative leaves room for rounding."""
    n = (0.0, -1.0, 0.0)  # wall normal at b, from the fluid into the wall
    for di in (0.1, 0.5, 1.3):
        for db in (0.05, 0.5, 2.0):
            for xb in (-0.7, 0.0, 0.4):  # the pair need not be normal to the wall
                xi = np.array([0.2, di, 0.0])
                x_b = np.array([xb, -db, 0.0])
                d = xi - x_b
                beta = morris_beta(d[0], d[1], d[2], *n, db, 1e9)
                vi = GAMMA * di
                vb = vi - beta * vi
                assert vb == pytest.approx(-GAMMA * db, rel=1e-12)
                at_wall = vi + (vb - vi) * (di - 0.0) / (di + db)
                assert abs(at_wall) <= 1e-12 * vi
    # the bound: beta = min(beta_max, 1 + d_b/d_i), and beta_max for a particle behind the plane
    d = np.array([0.0, 0.1 + 1.0, 0.0])  # d_i = 0.1, d_b = 1
    assert morris_beta(d[0], d[1], d[2], *n, 1.0, 1.5) == 1.5
    d = np.array([0.0, 1.0 - 0.05, 0.0])  # the fluid particle 0.05 behind the wall plane
    assert morris_beta(d[0], d[1], d[2], *n, 1.0, 1.5) == 1.5
    # no wall distance known (0) or option "zero" (beta_max 0): the particle's own velocity
    assert morris_beta(d[0], d[1], d[2], *n, 0.0, 1.5) == 1.0
    assert morris_beta(d[0], d[1], d[2], *n, 1.0, 0.0) == 1.0


def _couette(method: str, wall_velocity: str, factors: list[float] | None = None
             ) -> Simulation:
    """2D plane Couette flow u = gamma y between box walls at y = 0 (at rest) and y = L (moving
    with gamma L), periodic in x; the walls are lattice fluid (their volume set to the fluid's),
    so that fluid and wall particles form one square lattice (the fluid as sampled: the start
    relaxation would move the rows next to the Akinci walls the scene starts with)."""
    r, lx, ly = 0.01, 0.2, 0.16
    vis = {"method": method, "coefficient": 1e-3, "boundary_coefficient": 1e-3,
           "boundary_velocity": wall_velocity, "morris_beta_max": 1e9}
    if method == "weiler2018":
        vis["max_error"] = 1e-12
    sim = Simulation(Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0],
                          "periodic_x": [0.0, lx], "zsort_every": 0,
                          # one lattice of fluid and walls, as sampled (no start relaxation)
                          "start": {"relax": False}},
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [lx, ly]}],
        "boxes": [{"min": [0.0, 0.0], "max": [lx, ly], "layers": 3,
                   "viscosity_factors": factors}],
        "materials": [{"viscosity": vis}]}))
    st = sim.state
    st.boundary["V"][:] = st.fluid["V0"][0]
    st.fluid["v"][0] = GAMMA * st.fluid["x"][1]
    st.boundary["v"][0] = GAMMA * np.clip(st.boundary["x"][1], 0.0, ly)  # wall surface speed
    sim._neighbors()
    sim.compute_density()
    return sim


@pytest.mark.parametrize("method", ["standard", "weiler2018"])
def test_linear_shear_has_no_viscous_force_next_to_morris_walls(method: str) -> None:
    """Couette flow is steady: the viscous force of a linear profile is zero everywhere. With the
    Morris wall velocity the wall particles carry the profile continued into the walls, so the
    Laplacian sees one linear field on one lattice and vanishes next to the walls as in the
    bulk (to round-off: 1e-9 of the force the zero wall velocity gives there). With the walls'
    own velocity ('zero') the rows next to the walls feel a large force (the slip); this is the
    contrast the test needs to mean anything. Weiler 2018 is solved to 1e-12, so its velocity
    change is zero to that tolerance as well."""
    acc = {}
    for wv in ("zero", "morris1997"):
        sim = _couette(method, wv)
        sim.state.fluid["a"][:] = 0.0
        sim.forces[0].apply(sim.state, 1e-3)
        acc[wv] = np.abs(sim.state.fluid["a"][0]).max()
    assert acc["zero"] > 0.01 * GAMMA  # nu gamma / (spacing-scale) ~ 0.1 m/s^2
    assert acc["morris1997"] <= 1e-9 * acc["zero"]


def test_per_face_viscosity_factors_scale_each_wall_term() -> None:
    """``boxes[].viscosity_factors`` multiplies the standard viscosity's wall term per face. A
    uniform stream u = U between resting Morris walls (the Couette lattice, periodic in x) has no
    fluid-fluid viscous force (v_ij = 0), so the acceleration of each particle is its walls'
    term alone: with the floor's factor 0 the rows next to the floor feel nothing (exactly 0),
    while the rows under the top wall feel the same force as with factor 1 everywhere (the same
    arithmetic: equal to the last bit); a factor 2 doubles the floor's force (linear in the
    coefficient; 1e-12 relative for rounding) and halves the explicit viscous step bound
    (dt ~ 1 / nu_b)."""
    u = 0.1
    acc, dts = {}, {}
    for key, fac in (("ones", None), ("free floor", [1.0, 1.0, 0.0, 1.0]),
                     ("double floor", [1.0, 1.0, 2.0, 1.0])):
        sim = _couette("standard", "morris1997", fac)
        st = sim.state
        st.fluid["v"][:] = 0.0
        st.fluid["v"][0] = u
        st.boundary["v"][:] = 0.0
        st.fluid["a"][:] = 0.0
        # within the diffusion condition: one application of the term, no sub-steps
        sim.forces[0].apply(st, 0.5 * sim.forces[0].diffusion_bound(st))
        acc[key] = st.fluid["a"][0].copy()
        dts[key] = sim.forces[0].max_time_step(st)
    y = sim.state.fluid["x"][1]
    h = sim.state.h
    floor, top = y < h, y > 0.16 - h
    # the first row holds back (the second lies at the kernel's edge from the first layer)
    assert (acc["ones"][y < 0.02] < -1e-3 * u).all()
    assert (acc["free floor"][floor] == 0.0).all()
    assert (acc["free floor"][top] == acc["ones"][top]).all()
    assert acc["double floor"][floor] == pytest.approx(2.0 * acc["ones"][floor], rel=1e-12)
    assert (acc["double floor"][top] == acc["ones"][top]).all()
    assert dts["double floor"] == pytest.approx(0.5 * dts["ones"], rel=1e-12)


def test_box_face_factors_give_edges_the_larger_face() -> None:
    """A closed 2D box with friction on the floor only ([0, 0, 1, 0]): every wall particle
    below the floor, the corners included, gets 1, every side-wall or lid particle above it 0;
    a box without factors leaves the field at 1."""
    def walls(fac: list[float] | None) -> tuple[np.ndarray, np.ndarray]:
        sim = Simulation(Scene.model_validate({
            "configuration": {"dim": 2, "particle_radius": 0.01, "start": {"relax": False}},
            "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.1, 0.1]}],
            "boxes": [{"min": [0.0, 0.0], "max": [0.2, 0.2], "viscosity_factors": fac}],
            "materials": [{"viscosity": {"method": "standard", "coefficient": 1e-3,
                                         "boundary_coefficient": 1e-3}}]}))
        b = sim.state.boundary
        return b["x"][1].copy(), b["viscosity_factor"].copy()
    y, f = walls([0.0, 0.0, 1.0, 0.0])
    assert (f[y < 0.0] == 1.0).all() and (f[y > 0.0] == 0.0).all()
    assert (walls(None)[1] == 1.0).all()


def _poiseuille():
    return load_validation("poiseuille.py")


def test_poiseuille_start_up_with_morris_walls_matches_the_series_solution() -> None:
    """Coarse Poiseuille start-up (10 rows across) in Morris et al.'s setup
    (validation/poiseuille.py: hexagonal lattice, walls of resting lattice fluid, quintic spline
    with support 3 spacings, eps 0.01/9 h^2, WCSPH at the explicit viscous step) against the
    series solution (Morris Eq. 21), error = max |u - u_exact| / u_max over all particles at
    0.2, 0.5, 1.0 and 2.5 settling times. Measured (2026-11-27): standard 1.06 / 1.42 / 1.84 /
    2.29 %, weiler2018 2.04 / 2.26 / 2.91 / 3.45 % (backward Euler with the body force outside
    the solve adds an O(dt) wall error); the bounds are these plus about 30 %. At 20 rows the
    validation gives 1.5 % and 1.8 % (the 2 % target). With the walls' own velocity ('zero') the
    fluid slips and the steady error is 23.6 %: the Morris walls must be at least 5 times
    better."""
    P = _poiseuille()
    bound = {"standard": 0.03, "weiler2018": 0.045}
    for method in ("standard", "weiler2018"):
        sim = P.hex_channel(method, 10, walls="lattice", wall_velocity="morris1997",
                            beta_max=P.BETA_MAX, **P.MORRIS)
        res = P.run(sim)
        errs = [res[f][0] for f in (*P.FRACTIONS, P.STEADY)]
        assert max(errs) < bound[method], errs
    slip = P.run(P.hex_channel("standard", 10, walls="lattice", **P.MORRIS), (P.STEADY,))
    assert slip[P.STEADY][0] > 5 * 0.03


def test_bad_boundary_velocity_is_a_named_scene_error() -> None:
    base = {"configuration": {"dim": 2, "particle_radius": 0.01},
            "fluid_blocks": [{"start": [0, 0], "end": [0.1, 0.1]}]}
    for vis, words in (
        ({"method": "standard", "coefficient": 1e-3, "boundary_velocity": "noslip"},
         ("boundary_velocity", "noslip", "morris1997")),
        ({"method": "takahashi2015", "coefficient": 1e-3, "boundary_velocity": "morris1997"},
         ("boundary_velocity", "takahashi2015")),
        ({"method": "standard", "coefficient": 1e-3, "morris_beta_max": 0.5},
         ("morris_beta_max", "0.5")),
        ({"method": "xsph", "coefficient": 0.1, "laplacian_eps": 0.001},
         ("laplacian_eps", "xsph")),
    ):
        with pytest.raises(SceneError) as err:
            scene_from_dict({**base, "materials": [{"viscosity": vis}]})
        for w in words:
            assert w in str(err.value)
    # per-face wall factors: one per face, >= 0, the standard viscosity, a particle boundary
    std = {"method": "standard", "coefficient": 1e-3, "boundary_coefficient": 1e-3}
    for fac, vis, boundary, words in (
        ([1.0, 1.0, 0.0], std, "akinci2012", ("viscosity_factors", "3 values", "expected 4")),
        ([1.0, 1.0, -1.0, 0.0], std, "akinci2012", ("viscosity_factors", "-1.0", ">= 0")),
        ([1.0, 1.0, float("nan"), 0.0], std, "akinci2012", ("viscosity_factors", "nan")),
        ([0.0, 0.0, 1.0, 0.0], {"method": "xsph", "coefficient": 0.1}, "akinci2012",
         ("boxes[0].viscosity_factors", "xsph", "standard")),
        ([0.0, 0.0, 1.0, 0.0], std, "koschier2017",
         ("boxes[0].viscosity_factors", "koschier2017", "map")),
    ):
        with pytest.raises(SceneError) as err:
            scene_from_dict({**base, "configuration": {**base["configuration"],
                                                       "boundary": {"method": boundary}},
                             "boxes": [{"min": [0, 0], "max": [0.2, 0.2],
                                        "viscosity_factors": fac}],
                             "materials": [{"viscosity": vis}]})
        for w in words:
            assert w in str(err.value), (w, str(err.value))


def _couette_validation():
    return load_validation("couette.py")


def test_couette_start_up_with_a_moving_wall_matches_the_series_solution() -> None:
    """Coarse Couette start-up (validation/couette.py, 10 rows across, Morris et al.'s setup:
    the upper wall's boundary particles get v = U through ``state.boundary["v"]``) against the
    series solution at t = 0.0225, 0.1125 and 0.225 s; error = max |u - u_exact| / U over all
    particles. Measured (2026-12-03): 1.03 / 0.34 / 0.19 % with the Morris wall velocity; the
    bound 1.5 % is the largest of these plus 50 % (at 20 rows: 0.38 / 0.21 / 0.14 %). With the
    walls' own velocity the fluid slips at both walls: 18 % at 0.0225 s, so the bound 9 % (half
    of it) checks that the wall velocity enters through the moving wall's term. It also checks
    (couette.run) that nothing in the step overwrites the plate's velocity. Measured 0.5 s
    warm (pytest, after this file's other tests; 0.8-1.3 s as a second call in a loaded
    process; 3.5-4.6 s when it is the first to load the compiled kernels)."""
    C = _couette_validation()
    res = C.run(C.channel(10, "morris1997"), (0.0225, 0.1125, 0.225))
    errs = [e for e, _l, _y, _u in res.values()]
    assert max(errs) < 0.015, errs
    slip = C.run(C.channel(10, "zero"), (0.0225,))
    assert slip[0.0225][0] > 0.09, slip[0.0225][0]


def test_lid_driven_cavity_centrelines_against_ghia() -> None:
    """Coarse lid-driven cavity at Re 100 (validation/cavity.py: WCSPH at Mach 0.1 with the
    transport velocity of Adami et al. 2013, Morris walls, the lid's wall particles moving with
    U; 20 particles across, to t = 10 s, the velocity averaged over the last 4 s) against Ghia
    et al. 1982's centrelines at their points more than one particle spacing from the walls
    (nearer ones lie in the walls' boundary layers, which 20 particles do not resolve: there
    the errors reach 15 % of U). At this resolution the flow does not settle (its kinetic
    energy moves by up to 11 % over the window) and its state at 10 s depends on round-off:
    over ten runs with the positions moved by 1e-11 to 1e-3 of a spacing (and one on two
    threads) the largest error was 2.5-4.9 % of U on u(y) and 3.3-4.9 % on v(x), the rms
    1.2-2.8 % and 1.5-3.3 % (measured 2026-12-06). Bounds: 7.5 % on the largest error (the
    largest measured plus 50 %), 4.5 % on the rms. A lid that did not drive the fluid is far
    outside (Ghia's velocities at these points reach 0.21 U on u and 0.25 U on v); the loss of
    the transport velocity (v 6-7 %) or of the Morris wall velocity (u 6-7 %, rms 3.5 %), and
    even the viscosity off by a factor 2 (Re 50: u 4.4 %, v 5.1 %; Re 200: 5.4 % / 3.8 %), are
    within the spread of a coarse run and are the validation's to show (2.0 and 1.9 % at 60
    across: issue 21's 5 %)."""
    C = load_validation("cavity.py")
    C.AVERAGE, C.SAMPLES = 4.0, 21
    n = 20
    res = C.run(n, 100.0, t_end=10.0)
    yg, ug, xg, vg = C.ghia(100.0)
    in_u, in_v = (yg > 0.0) & (yg < 1.0), (xg > 0.0) & (xg < 1.0)  # run()'s 15 points each
    far_u = (yg[in_u] > 1.0 / n) & (yg[in_u] < 1.0 - 1.0 / n)
    far_v = (xg[in_v] > 1.0 / n) & (xg[in_v] < 1.0 - 1.0 / n)
    eu = np.abs(res["u"] - ug[in_u])[far_u]
    ev = np.abs(res["v"] - vg[in_v])[far_v]
    assert eu.size >= 9 and ev.size >= 10, (eu.size, ev.size)
    assert eu.max() < 0.075 and ev.max() < 0.075, (eu, ev)
    assert np.sqrt((eu ** 2).mean()) < 0.045 and np.sqrt((ev ** 2).mean()) < 0.045, (eu, ev)
