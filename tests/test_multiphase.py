"""Several fluids in one scene (Solenthaler & Pajarola 2008 number densities; sphkit.multiphase).

Small 2D scenes (r = 2 cm, a few hundred particles, tens of steps): the long studies (layers
that swap, a hydrostatic two-layer column) are in validation/multiphase.py.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from sphkit.cli import main
from sphkit.core.neighbors import neighbor_lists
from sphkit.io.frames import read_frame
from sphkit.io.manifest import read_manifest
from sphkit.multiphase import phase_lists
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

R = 0.02


def _scene(method: str, materials: list[dict], blocks: list[tuple[list, list, str]],
           start: dict | None = None, viscosity: bool = False,
           walls: str | None = None) -> Scene:
    """``walls``: None, the scene's default wall term; "symmetric"; "mls" (the MLS boundary
    pressure, ``solved`` false); "density" (every static wall particle solved)."""
    mats = []
    for m in materials:
        m = dict(m)
        if viscosity:
            m["viscosity"] = {"method": "standard", "coefficient": 0.01}
        mats.append(m)
    pressure = {"method": method}
    if method == "wcsph":
        pressure.update({"stiffness": 20000.0, "exponent": 7.0})
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": R, "gravity": [0.0, -9.81],
                          "pressure": pressure, "time": {"dt_max": 0.004},
                          **({"start": start} if start else {}),
                          **({"boundary": {"symmetric": True}} if walls == "symmetric"
                             else {"boundary": {"solved": False}} if walls == "mls"
                             else {"boundary": {"solved": walls}} if walls else {})},
        "materials": mats,
        "fluid_blocks": [{"start": s, "end": e, "material": k} for s, e, k in blocks],
        "boxes": [{"min": [0.0, 0.0], "max": [0.5, 1.0]}],  # the blocks fill its width
    })


def _run(scene: Scene, steps: int) -> dict[str, np.ndarray]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(scene)
    for _ in range(steps):
        sim.step()
    o = sim.fluid.order_by_id()
    return {k: sim.fluid[k][..., o] for k in ("x", "v", "rho", "p")}


BLOCKS = [([0.0, 0.0], [0.5, 0.24]), ([0.0, 0.24], [0.5, 0.48])]  # rows 2r apart across


@pytest.mark.parametrize("method", ["wcsph", "dfsph", "pbf"])
def test_one_material_or_two_identical_ones_give_the_same_numbers(method: str) -> None:
    """A fluid described as one material in two blocks, or as two materials of the same rest
    density (one per block), runs to the last bit the same: equal rest densities make every
    ratio rho0_j / rho0_i exactly 1 (RestArrays), so the phases differ only in name (no
    non-pressure force here: those act within a phase by design)."""
    one = _scene(method, [{"id": "water"}], [(s, e, "water") for s, e in BLOCKS])
    two = _scene(method, [{"id": "a"}, {"id": "b"}],
                 [(BLOCKS[0][0], BLOCKS[0][1], "a"), (BLOCKS[1][0], BLOCKS[1][1], "b")])
    ra, rb = _run(one, 15), _run(two, 15)
    for k in ra:
        assert np.array_equal(ra[k], rb[k]), k


def test_dynamics_depend_on_density_ratios_only() -> None:
    """Scaling every rest density by 2 (phases 1000/100 -> 2000/200) scales masses, densities
    and pressures by 2 and leaves the accelerations, hence positions, unchanged (SPH momentum
    equation divided by rho0). Tolerance 1e-9 m: only round-off differs (the scaled floats)."""
    blocks = [(BLOCKS[0][0], BLOCKS[0][1], "heavy"), (BLOCKS[1][0], BLOCKS[1][1], "light")]
    a = _scene("dfsph", [{"id": "heavy", "density0": 1000.0},
                         {"id": "light", "density0": 100.0}], blocks)
    b = _scene("dfsph", [{"id": "heavy", "density0": 2000.0},
                         {"id": "light", "density0": 200.0}], blocks)
    ra, rb = _run(a, 10), _run(b, 10)
    assert np.abs(ra["x"] - rb["x"]).max() < 1e-9
    np.testing.assert_allclose(rb["rho"], 2.0 * ra["rho"], rtol=1e-9)


def test_particles_added_by_hand_get_the_reference_rest_density() -> None:
    """Fluid added through the API without a rest density (``ParticleSet.add(x, m=...)``, as a
    user or a script building its own lattice does) gets the reference rest density, not 0
    (which made every rest-density ratio 0 and the first step NaN): the added copy of the block
    then computes the same densities as the scene's own particles, to round-off."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_scene("dfsph", [{"id": "water"}], [(BLOCKS[0][0], BLOCKS[0][1],
                                                                 "water")]))
    f = sim.fluid
    n = f.n
    x = f.view("x").copy()
    x[:, 1] += 0.6  # a second block, clear of the first, under the box's lid
    f.add(x, m=f["m"].copy(), V0=f["V0"].copy())
    assert np.all(f["rho0"][n:] == sim.state.rho0)
    sim.step()
    assert np.all(np.isfinite(f["rho"])) and np.all(np.isfinite(f.view("x")))


def test_number_density_has_no_jump_at_the_interface() -> None:
    """Two lattices (rest densities 1000 below, 100 above) touching along y = 0.24, sampled
    without start-up corrections: with number densities ``rho_i = rho0_i sum_j V0_j W_ij`` every
    particle with a full neighbourhood -- on either side of the interface -- is at its own rest
    density to round-off (1e-9; the lattice volume makes sum_j V0_j W_ij = 1 exactly in the
    interior). A mass-weighted sum would give the light particles next to the interface up to
    several times their rest density."""
    sc = _scene("dfsph", [{"id": "heavy", "density0": 1000.0},
                          {"id": "light", "density0": 100.0}],
                [(BLOCKS[0][0], BLOCKS[0][1], "heavy"), (BLOCKS[1][0], BLOCKS[1][1], "light")],
                start={"relax": False, "hydrostatic": False})
    sim = Simulation(sc)
    sim._neighbors()
    sim.compute_density()
    f = sim.fluid
    x = f.view("x")
    h = sim.state.h
    inner = ((x[:, 0] > h) & (x[:, 0] < 0.5 - h) & (x[:, 1] > h) & (x[:, 1] < 0.48 - h))
    near = inner & (np.abs(x[:, 1] - 0.24) < h)
    assert near.sum() > 20 and set(np.unique(f["phase"][near])) == {0, 1}
    np.testing.assert_allclose(f["rho"][inner] / f["rho0"][inner], 1.0, atol=1e-9)


@pytest.mark.parametrize("method", ["dfsph", "iisph"])
def test_light_over_heavy_layer_stays_at_rest(method: str) -> None:
    """A stable two-layer column (100 over 1000 kg/m^3) stays at rest: after 0.2 s the largest
    velocity is below 0.25 m/s (the same column of one density still settles from its start-up
    at 0.15 m/s then, DFSPH) and no particle has crossed the interface by more than a particle
    radius. Without the ratio rho0_i / rho0_j in the Jacobi diagonal (ppe.diagonal_cached)
    DFSPH blew up here within 0.1 s."""
    sc = _scene(method, [{"id": "heavy", "density0": 1000.0},
                         {"id": "light", "density0": 100.0}],
                [(BLOCKS[0][0], BLOCKS[0][1], "heavy"), (BLOCKS[1][0], BLOCKS[1][1], "light")],
                viscosity=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    sim.run(until=0.2)
    f = sim.fluid
    y = f.view("x")[:, 1]
    heavy = f["phase"] == 0
    assert np.sqrt((f["v"] ** 2).sum(axis=0)).max() < 0.25
    assert y[heavy].max() < y[~heavy].min() + R


def test_wcsph_pressure_force_of_two_fluids_conserves_momentum() -> None:
    """WCSPH's pressure force between particles of different rest densities (Solenthaler &
    Pajarola 2008: the neighbour's density taken to the particle's own rest density): the
    pair forces are equal and opposite, so the fluid's momentum does not change (sum of m_i
    a_i = 0 to round-off), and near rest it is ``-V (p_i + p_j) / rho0_i grad W``. With the
    neighbour's pressure over its own rest density a heavy particle took a light neighbour's
    pressure 4 times at 1:4: a body held between the layers felt 6 times Archimedes' force
    (validation/README.md, "A body between two layers")."""
    from sphkit.core.kernels import kernel_id
    from sphkit.core.operators import pressure_accel_cpu

    rng = np.random.default_rng(3)
    n, h, rho_ref = 400, 0.15, 1000.0
    x = rng.uniform(0.0, 1.0, (2, n))
    nl = neighbor_lists(x, h)
    rho0 = np.where(rng.uniform(size=n) < 0.5, 1000.0, 250.0)
    c = rho0 / rho_ref
    V = 0.05 ** 2
    m, rho = rho0 * V, rho0 * rng.uniform(0.99, 1.02, n)
    p = rng.uniform(0.0, 5000.0, n)
    a = np.zeros((2, n))
    none = np.zeros(1, dtype=np.int64)
    pressure_accel_cpu(x, m, rho, p, nl.offsets, nl.indices, np.zeros((2, 0)), np.zeros(0),
                       np.zeros(n + 1, dtype=np.int64), none[:0], rho_ref, h,
                       kernel_id("cubic"), 2, a, c=c, inv_c=1.0 / c)
    momentum = (m * a).sum(axis=1)
    scale = (m * np.abs(a)).sum(axis=1)
    np.testing.assert_allclose(momentum / scale, 0.0, atol=1e-13)  # round-off of n sums


def test_phase_lists_keep_the_pairs_within_a_phase() -> None:
    """The filtered CSR lists hold exactly the pairs of the full lists whose both ends are in
    the phase, renumbered, in the same order."""
    rng = np.random.default_rng(1)
    x = rng.uniform(0.0, 1.0, (2, 300))
    nl = neighbor_lists(x, 0.15)
    member = rng.uniform(size=300) > 0.4
    sub = phase_lists(nl, member)
    where = np.flatnonzero(member)
    assert len(sub) == where.size
    for k, i in enumerate(where):
        full = nl.neighbors(i)
        assert np.array_equal(where[sub.neighbors(k)], full[member[full]])


def test_run_writes_phase_and_rest_density(tmp_path: Path) -> None:
    """``sphkit run`` of a scene with two fluids: every frame holds the phase (material index)
    and the rest density of each particle, the manifest's frames the particles and density
    error of each material."""
    sc = _scene("dfsph", [{"id": "heavy", "density0": 1000.0},
                          {"id": "light", "density0": 100.0}],
                [(BLOCKS[0][0], BLOCKS[0][1], "heavy"), (BLOCKS[1][0], BLOCKS[1][1], "light")])
    d = sc.model_dump(mode="json", exclude_none=True)
    d["configuration"]["time"]["until"] = 0.02
    d["output"] = {"fps": 50.0, "formats": ["vtk"]}
    path = tmp_path / "two.json"
    path.write_text(json.dumps(d))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    frame = read_frame(out / "frame_00001.vtu")
    phase = np.asarray(frame["phase"])
    assert set(np.unique(phase)) == {0, 1}
    np.testing.assert_array_equal(np.asarray(frame["rest_density"]),
                                  np.where(phase == 0, 1000.0, 100.0))
    rec = read_manifest(out)["frames"][-1]
    assert [p["material"] for p in rec["phases"]] == ["heavy", "light"]
    assert sum(p["particles"] for p in rec["phases"]) == len(phase)


def test_hydrostatic_start_of_layers_carries_the_upper_layer() -> None:
    """The hydrostatic start of a light layer (100) over a heavy one (1000): the heavy layer's
    start pressure includes the weight of the light layer, ``p = g (rho_l H_l + rho_h (y_i -
    y))`` with the interface y_i = 0.24 m and H_l = 0.24 m (the surface r above the top row),
    not ``rho0_h g depth`` (that would be 10 % low at the bottom). Tolerance 1e-9 of the bottom
    pressure: the blocks fill the box on its walls' lattice, so the start-up moves no particle
    (measured 3e-16; with the walls' Akinci volumes the relaxation moved the particles by up to
    half r before the pressure was set, 2.1 % next to a side wall). Several fluids are not
    settled before t = 0 (``start.settle`` "auto"), so the run starts with these pressures."""
    sc = _scene("wcsph", [{"id": "heavy", "density0": 1000.0},
                          {"id": "light", "density0": 100.0}],
                [(BLOCKS[0][0], BLOCKS[0][1], "heavy"), (BLOCKS[1][0], BLOCKS[1][1], "light")])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    f = sim.fluid
    y = f.view("x")[:, 1]
    heavy = f["phase"] == 0
    g = 9.81
    expected = g * (100.0 * 0.24 + 1000.0 * (0.24 - y[heavy]))
    assert np.abs(f["p"][heavy] - expected).max() < 1e-9 * expected.max()
    assert sim.world.start.settle_steps == 0


def test_viscosity_acts_within_a_phase() -> None:
    """A material's viscosity acts between its own particles only (SPlisHSPlasH's
    forall_fluid_neighbors_in_same_phase, multiphase.PhaseForce): the acceleration it gives the
    lower block does not depend on the velocities of the upper block of another material, and
    it gives the upper block none; with both blocks one material it does depend on them."""
    def accel(two: bool, shake: bool) -> tuple[np.ndarray, np.ndarray]:
        visc = {"method": "standard", "coefficient": 0.05}
        names = ("lower", "upper") if two else ("water", "water")
        sc = Scene.model_validate({
            "configuration": {"dim": 2, "particle_radius": R, "gravity": [0.0, 0.0],
                              "pressure": {"method": "dfsph"}},
            "materials": [{"id": k, "viscosity": visc} for k in dict.fromkeys(names)],
            "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.4, 0.2], "material": names[0]},
                             {"start": [0.0, 0.2], "end": [0.4, 0.4], "material": names[1]}],
        })
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(sc)
        f = sim.fluid
        sim._neighbors()  # (reorders the particles)
        o = f.order_by_id()
        upper = f.view("x")[:, 1] > 0.2
        v = np.empty_like(f["v"])  # velocities by id, so that both runs get the same
        v[:, o] = np.random.default_rng(2).normal(0.0, 0.1, v.shape)
        f["v"][:, ~upper] = v[:, ~upper]
        if shake:
            f["v"][:, upper] = np.random.default_rng(3).normal(0.0, 1.0, (2, int(upper.sum())))
        sim.compute_density()
        f["a"][:] = 0.0
        sim.forces[0].apply(sim.state, 0.001)  # the lower block's viscosity
        return f["a"][:, ~upper].copy(), f["a"][:, upper].copy()

    calm, calm_up = accel(True, False)
    shaken, shaken_up = accel(True, True)
    assert np.array_equal(calm, shaken)
    assert not calm_up.any() and not shaken_up.any()
    one, _ = accel(False, False)
    one_shaken, _ = accel(False, True)
    assert np.abs(one - one_shaken).max() > 1.0  # one material: the upper block drags


def test_dfsph_warm_start_cap_bounds_the_same_pressure_in_every_phase() -> None:
    """DFSPH caps its warm start (SPlisHSPlasH's ``0.5 min(kappa dt^2, 0.00025) / dt^2``). The
    stored kappa is each particle's own ``p / rho0_i``, so one cap in kappa would allow a light
    particle (100 kg/m^3) a tenth of the pressure of a heavy one: the light layer under a heavy
    column needs about five times water's kappa to carry it. The cap is on ``p / rho0_ref``:
    both phases keep the same largest warm-start pressure (exact: the factors are powers of
    ten of the same floats, compared with a relative 1e-12)."""
    from sphkit.backend import launch
    from sphkit.pressure.dfsph import density_source_body

    dt = 0.002
    rho0 = np.array([1000.0, 100.0])
    inv_c = 1000.0 / rho0
    rho = rho0.copy()
    div = np.full(2, 1.0)  # compressing: the warm start applies
    kprev = np.full(2, 1.0)  # far above either cap
    s, kappa = np.empty(2), np.empty(2)
    launch(density_source_body, 2, rho, 1.0 / rho0, div, dt, kprev, inv_c, s, kappa)
    p = kappa * rho0  # the warm-start pressure per unit rho_hat^2
    np.testing.assert_allclose(p[1], p[0], rtol=1e-12)
    np.testing.assert_allclose(kappa[0], 0.5 * 0.00025 / dt ** 2, rtol=1e-12)


def test_pcisph_factor_follows_each_particles_diagonal() -> None:
    """PCISPH's template factor delta is 1 / (2 D0) for a particle among its own phase. In the
    own variable p / rho0_i a heavy particle among light neighbours (ratio 10) has about ten
    times that diagonal (ppe.diagonal_cached), and the template factor over-corrected it tenfold
    (the 1:10 heavy-over-light column blew up at 0.022 s). phase_factor scales delta by
    D_i(ratio 1) / D_i(ratios): about 1/10 for one heavy particle inside a light block (between
    0.1 and 0.11: 0.1 where the |G_i|^2 term vanishes, as on the block's unmoved lattice, more
    where it does not), slightly above 1 for its light neighbours, exactly 1 where every
    neighbour is of the own phase."""
    from sphkit.pressure.pcisph import phase_factor

    sc = _scene("pcisph", [{"id": "light", "density0": 100.0}],
                [([0.0, 0.0], [0.5, 0.48], "light")])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    f, st = sim.fluid, sim.state
    x = f.view("x")
    i = int(np.argmin(np.hypot(x[:, 0] - 0.25, x[:, 1] - 0.24)))  # a particle in the middle
    f["rho0"][i] = 1000.0
    f["m"][i] *= 10.0
    st.rho0 = 100.0  # the reference: the light fluid (RestArrays compares against it)
    sim._neighbors()  # (may reorder the particles)
    sim.compute_density()
    i = int(np.argmax(f["rho0"]))
    scale = phase_factor(st, st.pair_grads)
    assert 0.1 * (1.0 - 1e-12) < scale[i] < 0.11
    nbrs = st.nl_ff.indices[st.nl_ff.offsets[i]:st.nl_ff.offsets[i + 1]]
    assert np.all(scale[nbrs] > 1.0)
    others = np.setdiff1d(np.arange(f.n), np.append(nbrs, i))
    assert np.all(scale[others] == 1.0)


def test_pbf_lambda_is_the_newton_step_of_a_heavy_particle_among_light_ones() -> None:
    """PBF's lambda_i = -C_i / (sum_k w_k |grad_k C_i|^2): the correction moves particle i by
    lambda_i grad_i C_i and each neighbour j by (rho0_i / rho0_j) lambda_i V_i grad W_ji
    (``constraint_correction``, SPlisHSPlasH's neighbour weight), so the Newton step of C_i
    weighs neighbour j's term by rho0_i / rho0_j. One heavy particle (1000) in a light block
    (100), compressed 0.5 %: the change of C_i that lambda_i alone causes to first order,
    ``-lambda_i dC_i/dlambda_i`` from the correction's own displacements, is -C_i within 1 %
    with the ratio weights (measured 1.005: the gradient is that of rho_hat, C_i that of
    rho_hat / 1.005); without them (SPlisHSPlasH's denominator) it is 10.05 times C_i, the
    overshoot that made the 1:10 heavy-over-light column blow up at 1.07 s (2D) and 0.51 s
    (3D)."""
    from sphkit.core.pairs import period_arg
    from sphkit.core.projection import constraint_correction, constraint_lambda

    sc = _scene("pbf", [{"id": "light", "density0": 100.0}], [([0.0, 0.0], [0.5, 0.48], "light")])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    f, st = sim.fluid, sim.state
    x = f.view("x")
    i = int(np.argmin(np.hypot(x[:, 0] - 0.25, x[:, 1] - 0.24)))
    f["rho0"][i] = 1000.0
    f["m"][i] *= 10.0
    st.rho0 = 100.0
    sim._neighbors()
    sim.compute_density()
    i = int(np.argmax(f["rho0"]))
    rest = st.rest()
    xx, b = f["x"], st.boundary
    nl, nb = st.nl_ff, st.nl_fb
    n = f.n
    target = np.full(n, 1.0 / 1.005)  # C_i = 0.005 on the lattice (rho_hat about 1)
    L = period_arg(st.pair_period)
    ones = np.ones(n)

    def newton_ratio(weights: tuple) -> float:
        lam, rho_hat = np.empty(n), np.empty(n)
        constraint_lambda(xx, f["V0"], target, nl.offsets, nl.indices, b["x"], b["V"],
                          nb.offsets, nb.indices, st.h, st.kid, st.dim, L, 1e-6, 0.0, lam,
                          rho_hat, None, *weights)
        c_i = rho_hat[i] / target[i] - 1.0
        only = np.zeros(n)
        only[i] = lam[i]
        dx = np.empty_like(xx)
        constraint_correction(xx, f["V0"], only, nl.offsets, nl.indices, b["x"], b["V"],
                              nb.offsets, nb.indices, st.h, st.kid, st.dim, L, False, 0.0, 0.0,
                              1.0, 0.0, dx, rest.c, rest.inv_c)
        eps = 1e-4  # a finite-difference probe of the linear change of C_i along dx
        rho_eps = np.empty(n)
        constraint_lambda(xx + eps * dx, f["V0"], target, nl.offsets, nl.indices, b["x"],
                          b["V"], nb.offsets, nb.indices, st.h, st.kid, st.dim, L, 1e-6, 0.0,
                          np.empty(n), rho_eps, None, ones, ones)
        dc = (rho_eps[i] - rho_hat[i]) / target[i] / eps
        return -dc / c_i

    weighted, plain = newton_ratio((rest.c, rest.inv_c)), newton_ratio(())
    assert weighted == pytest.approx(1.0, rel=0.01)
    assert plain > 5.0


def _ppe_matrix(sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
    """The PPE operator of the solvers' Jacobi iterations, column by column (``-dAp_i / dq_j``
    of jacobi_ppe's pressure acceleration and divergence, with the coupling's boundary term),
    and the Jacobi diagonal D_i (PairGradients.diagonal)."""
    from sphkit.core.ppe import kappa_accel_cached, pair_divergence_cached
    from sphkit.core.solver import PairGradients

    st = sim.state
    sim._neighbors()
    sim.compute_density()
    g = PairGradients(st)
    rest = st.rest()
    nl, nb, n = st.nl_ff, st.nl_fb, st.fluid.n
    mirror, kb = st.coupling.mirror(st), st.coupling.boundary_kappa(st)
    a = np.empty_like(st.fluid["x"])
    col = np.empty(n)
    zb = np.zeros_like(st.boundary["x"])
    A = np.empty((n, n))
    for j in range(n):
        k = np.zeros(n)
        k[j] = rest.c[j]  # q_j = 1
        kappa_accel_cached(k, kb(k), nl.offsets, nl.indices, nb.offsets, nb.indices, mirror,
                           g.gw, g.gwb, st.dim, a, rest.inv_c, kb.phase)
        pair_divergence_cached(a, zb, nl.offsets, nl.indices, nb.offsets, nb.indices, g.gw,
                               g.gwb, st.dim, col)
        A[:, j] = -col
    return A, g.diagonal()


@pytest.mark.parametrize("walls", ["symmetric", "density", "mls"])
def test_two_phase_ppe_is_positive_with_a_consistent_diagonal(walls: str) -> None:
    """Heavy (1000) over light (100) between walls, with the symmetric wall term
    (configuration.boundary.symmetric) or with every static wall particle solved
    (``solved: "density"``, whose fluid rows see the walls through the same symmetric term
    ``V_b k_i``; the walls' own pressures are further unknowns, not in this fluid operator):
    the operator of the Jacobi PPE solvers (DFSPH, IISPH, PCISPH) in the pressure
    p = rho0_i q_i is symmetric positive semidefinite (-A = D C^-1 D^T for equal rest volumes),
    and the Jacobi diagonal D_i is its diagonal. Tolerances: symmetry 2 % of the largest entry
    (the rest volumes of the start-up lattice differ by up to 1.5 %), diagonal 2 % (the same),
    the smallest eigenvalue of D^-1 A >= -1e-9 (round-off). With the walls' mirrored or MLS
    pressure the smallest eigenvalue was negative (the light layer's pressure mode; -0.0018 /
    -0.0025 after 5 steps of a 1:10 column) and the Jacobi iterations diverged along it: DFSPH
    and IISPH blew up at 1.1-1.6 s. The MLS case (``solved`` false) is checked to stay
    asymmetric (in this smaller box its smallest eigenvalue is still positive: 0.015 with each
    phase's MLS fit on its own, 0.024 with one fit over both phases). The default,
    ``"stratified"``, solves the wall particles beside the light fluid below the heavy one and
    takes MLS at the others (test_stratified_walls_solve_where_light_lies_below_heavy)."""
    sc = _scene("dfsph", [{"id": "heavy", "density0": 1000.0},
                          {"id": "light", "density0": 100.0}],
                [(BLOCKS[0][0], BLOCKS[0][1], "light"), (BLOCKS[1][0], BLOCKS[1][1], "heavy")],
                walls=walls)
    assert sc.configuration.boundary.solved == (False if walls != "density" else "density")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    for _ in range(5):
        sim.step()
    A, D = _ppe_matrix(sim)
    c = sim.state.rest().c
    Ap = A / c[None, :]  # columns in p / rho0_ref
    ev = np.linalg.eigvals(A / D[:, None])
    if walls == "mls":
        assert np.abs(Ap - Ap.T).max() > 0.1 * np.abs(Ap).max()
        return
    assert np.abs(Ap - Ap.T).max() < 0.02 * np.abs(Ap).max()
    np.testing.assert_allclose(np.diag(A), D, rtol=0.02)
    assert ev.real.min() > -1e-9


def test_stratified_walls_solve_where_light_lies_below_heavy() -> None:
    """The default wall term of fluids whose rest densities differ by more than a factor 4,
    ``solved: "stratified"``: a wall particle's pressure is solved only where a lighter fluid
    lies below the heaviest among its fluid neighbours; elsewhere the MLS value. Light over
    heavy (at rest) gives no rows; heavy over light gives rows on the side walls at the
    interface's height (within a kernel support) and none elsewhere, and every row has a light
    neighbour lower than a heavy one (counted from the step's lists here)."""
    mats = [{"id": "heavy", "density0": 1000.0}, {"id": "light", "density0": 100.0}]
    for lower, upper, rows_expected in (("heavy", "light", False), ("light", "heavy", True)):
        sc = _scene("dfsph", mats, [(BLOCKS[0][0], BLOCKS[0][1], lower),
                                    (BLOCKS[1][0], BLOCKS[1][1], upper)])
        assert sc.configuration.boundary.solved == "stratified"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(sc)
        sim.step()
        st = sim.state
        use = st.coupling.solved_walls(st)
        if not rows_expected:
            assert not use.any(), int(use.sum())
            continue
        bx = np.asarray(st.boundary["x"])
        assert use.sum() >= 2  # both side walls
        interface = BLOCKS[0][1][1]
        assert np.abs(bx[1, use] - interface).max() < st.h
        assert bx[0, use].min() < 0.0 and bx[0, use].max() > BLOCKS[0][1][0]  # left and right
        # each row, from the lists: a light neighbour below a heavy one
        f = st.fluid
        boff, bidx = st.nl_fb.offsets, st.nl_fb.indices
        owner = np.repeat(np.arange(f.n), np.diff(boff))
        y = np.asarray(f["x"])[1][owner]
        light = np.asarray(f["rho0"])[owner] < 1000.0
        for b in np.flatnonzero(use):
            here = bidx == b
            assert y[here & light].min() < y[here & ~light].max()


def test_stratified_walls_resume_bit_for_bit(tmp_path: Path) -> None:
    """A heavy-over-light column with the stratified walls (DFSPH, rows switching on as the
    overturn starts) continued from a checkpoint repeats the uninterrupted run bit for bit: the
    rows are recomputed from the step's lists, and the rest values and warm starts of the rows
    are boundary fields that the checkpoint keeps."""
    from _restart import continued_from_checkpoint

    mats = [{"id": "heavy", "density0": 1000.0}, {"id": "light", "density0": 100.0}]
    sc = _scene("dfsph", mats, [(BLOCKS[0][0], BLOCKS[0][1], "light"),
                                (BLOCKS[1][0], BLOCKS[1][1], "heavy")])
    assert sc.configuration.boundary.solved == "stratified"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
        sim.run(until=0.3)
        assert sim.state.coupling.solved_walls(sim.state).any()
        continued_from_checkpoint(sim, tmp_path, 100)


def test_rest_arrays_are_held_within_a_step_only() -> None:
    """The step holds the rest arrays from its densities to the end of its pressure solve
    (``SimState.hold_rest``: made once, not at each of the solvers' calls); outside that window
    a change of the fields ``rho0`` / ``m`` in place is seen at the next call."""
    sc = _scene("dfsph", [{"id": "light", "density0": 100.0}],
                [([0.0, 0.0], [0.5, 0.2], "light")])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    st, f = sim.state, sim.fluid
    st.rho0 = 100.0
    seen = []
    solve = sim.pressure.solve

    def spy(state, dt):  # noqa: ANN001, ANN202 - the solver's own signature
        seen.append((state.rest(), state.rest()))
        return solve(state, dt)

    sim.pressure.solve = spy
    sim.step()
    assert seen[0][0] is seen[0][1] and seen[0][0].uniform  # held: one object in the step
    assert st.rest() is not st.rest()  # after the step: made at each call
    f["rho0"][0] = 1000.0  # a change in place between steps
    assert not st.rest().uniform
    sim.step()
    held = seen[1][0]
    assert not held.uniform and held.c[np.argmax(f["rho0"])] == 10.0


def test_rayleigh_taylor_mode_grows_at_the_linear_rate() -> None:
    """Issue 16's Rayleigh-Taylor line, fast: validation/rayleigh_taylor.py's periodic box
    (DFSPH, heavy 2000 over light 1000 kg/m^3, Atwood 1/3, one wavelength of 0.2 m, rigid walls
    H = 0.1 m above and below, the eigenmode's displacement of 0.005 lambda) at 20 particles
    per wavelength. Linear theory (inviscid, walls at H; the phase-local viscosity does not
    damp the mode, the script's docstring) gives n0 = sqrt(A g k tanh(kH)) = 10.12 1/s. The
    rate fitted over the first e-folding and the one from the time the mode takes to grow by
    e must both lie within the issue's 15 % of n0 (measured here +3.8 % and +1.8 %; at 40, 80
    and 120 per wavelength the validation gives +12.0 / -1.7 / +13.7 % for the fit: the 15 %
    are the issue's own line, not this resolution's error)."""
    from _validation import load_validation

    rt = load_validation("rayleigh_taylor.py")
    n0, _ = rt.theory(1.0 / 3.0, 0.001)
    o = rt.grow("dfsph", 0.005, 1.0 / 3.0, 0.001, 0.005, until=0.25)
    assert not o["note"], o["note"]
    assert o["eta"][-1] > np.e * o["eta0"]  # it grew by e within 0.25 s (t_e = 0.16 s)
    assert abs(o["first"] / n0 - 1.0) < 0.15, o["first"] / n0
    assert abs(o["first_te"] / n0 - 1.0) < 0.15, o["first_te"] / n0


@pytest.mark.parametrize("method", ["iisph", "dfsph"])
def test_heavy_over_light_overturns(method: str) -> None:
    """Issue 16's heavy-over-light line, fast: validation/multiphase.py's ``layers`` column
    (2D, 0.4 m wide, 0.3 m of heavy fluid, 1000 kg/m^3, over 0.3 m of light, 100 kg/m^3, the
    lattice jittered by 0.1 r, nu = 0.01 m^2/s, the default walls: solved at this ratio) at
    r = 2 cm, 2 s. Buoyancy must overturn it: the heavy phase's mean height ends below the
    light phase's, and the potential energy released is at least 60 % of what swapping the two
    layers releases (measured 71 % IISPH, 81 % DFSPH; the rest is the motion still under way at
    1.4 m/s and the single light particles the validation counts as stragglers). A run that
    blows up at 1:10 fails here too."""
    from _validation import load_validation

    mp = load_validation("multiphase.py")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(mp._perturbed_world(mp.scene(method, R, True, 10.0), 0.1))
    f = sim.fluid
    heavy = f["phase"] == 0

    def energy() -> float:
        return float((f["m"] * f.view("x")[:, 1]).sum() * 9.81)

    y0 = f.view("x")[:, 1].copy()
    # the swapped layers: each phase's mass at the other phase's mean start height
    m_h, m_l = float(f["m"][heavy].sum()), float(f["m"][~heavy].sum())
    swapped = 9.81 * (m_h * y0[~heavy].mean() + m_l * y0[heavy].mean())
    e0 = energy()
    sim.run(until=2.0)
    y = f.view("x")[:, 1]
    heavy = f["phase"] == 0  # the reorder of the fluid permutes the fields
    assert y[heavy].mean() < y[~heavy].mean()
    assert (e0 - energy()) / (e0 - swapped) > 0.6


@pytest.mark.parametrize("method", ["pbf", "iisph", "dfsph"])
def test_each_rest_density_meets_the_tolerance_on_its_own(method: str) -> None:
    """With several rest densities a solve stops when each rest density's own average error is
    within the tolerance (SPlisHSPlasH tests each fluid model's), not the average over all
    particles (PCISPH keeps that, :mod:`sphkit.pressure.pcisph`): heavy particles 1 %
    compressed (masses and rest volumes 1 % up) under light ones 1 % expanded (which count 0),
    no gravity, ``max_error`` 0.2 %. After one solve the heavy phase's mean compression, read
    from the next step's densities (not from the solver), is within 1.1 times the tolerance: the
    solves predict the density linearly in their correction, and over one step of a column at
    rest that prediction is what the next density evaluation finds to within a few per cent of
    the tolerance (measured 0.77-0.92 times it). An average over all particles let the heavy
    phase stop at 1.22-1.62 times it (measured)."""
    tol = 0.002
    sc = _scene(method, [{"id": "heavy", "density0": 1000.0}, {"id": "light", "density0": 100.0}],
                [(*BLOCKS[0], "heavy"), (*BLOCKS[1], "light")])
    d = sc.model_dump(exclude_unset=True)
    d["configuration"]["pressure"]["max_error"] = 100 * tol
    d["configuration"]["gravity"] = [0.0, 0.0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(Scene.model_validate(d))
    f = sim.fluid
    heavy = f["phase"] == 0
    for name, factor in (("m", 1.01), ("V0", 1.01)):
        f[name][heavy] *= factor
        f[name][~heavy] *= 2.0 - factor
    sim.step()
    after = {p["material"]: p["density_error_avg"] for p in sim.step().phases}
    assert after["heavy"] <= 1.1 * tol, after
    assert after["light"] <= 1.1 * tol, after


def test_deep_two_layer_column_comes_to_rest_with_dfsph() -> None:
    """A deep light-over-heavy column at 1:10 (two 0.6 m layers of 30 rows, r = 1 cm, filling a
    0.4 m box, DFSPH at the multiphase scenes' 0.05 %, dt_max 2 ms, the default walls) comes to
    rest. Its start ends in a landing whose solves stop at the 100 iterations just above the
    tolerance; when the step bound shrank the step after each such solve, the column went to
    steps of 1-1.5 ms, where it does not rest, and its light layer bounced at an rms speed of
    0.04-0.26 m/s for good (validation/README.md, "The step bound's slack"). With the bound
    shrinking only after solves that miss by more than 1.5 tolerances it rests by 2 s (light
    rms 0.002-0.005 m/s at 3 s in every trajectory tried, a fresh clone's included). The bound
    0.01 m/s sits between the two with margin both ways."""
    layer, r = 0.6, 0.01
    visc = {"method": "standard", "coefficient": 0.01}
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, -9.81],
                          "pressure": {"method": "dfsph", "max_error": 0.05},
                          "time": {"dt_max": 0.002}},
        "materials": [{"id": "heavy", "density0": 1000.0, "viscosity": visc},
                      {"id": "light", "density0": 100.0, "viscosity": visc}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.4, layer], "material": "heavy"},
                         {"start": [0.0, layer], "end": [0.4, 2 * layer], "material": "light"}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.4, 2 * layer + 0.2]}],
    })
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(sc)
    sim.run(until=2.7)
    capped = 0
    while sim.time < 3.0:
        capped += sim.step().iterations >= 100
    f = sim.fluid
    light = f["phase"] == 1
    rms = np.sqrt((f["v"][:, light] ** 2).sum(axis=0).mean())
    assert rms < 0.01, rms
    assert capped == 0
