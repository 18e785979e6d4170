"""Wall pressures solved in the PPE (``configuration.boundary.solved``,
:meth:`sphkit.core.coupling.BoundaryCoupling.solved_walls`).

A square of 5 x 5 particles (r = 2 cm) fills a closed 2D box of its width and twice its height,
at rest under gravity with sphkit's hydrostatic start; 20 steps of 0.5 ms. The mechanical
energy ``KE + sum m g y`` of a closed box can only fall (the viscosity is off; the start's
settling changes it by about 1e-4 of the column's ``m g H / 2`` = 39 J/m). The solved wall
pressures make the walls' force the transpose of a constraint, which does no work; the default
MLS term does none on this box either since box walls keep the fluid's lattice volume (with
Akinci's volumes it gained 0.24 J/m in 10 ms, ``validation/wall_energy.py``).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

R = 0.02
G = 9.81


def _box(solver: str, solved: bool | str) -> Scene:
    L = 10 * R
    return Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": R, "gravity": [0.0, -G],
                          "pressure": {"method": solver, "max_error": 0.05},
                          "time": {"dt_max": 0.0005}, "boundary": {"solved": solved}},
        "materials": [{"id": "fluid", "density0": 1000.0}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [L, L], "material": "fluid"}],
        "boxes": [{"min": [0.0, 0.0], "max": [L, 2 * L]}],
    })


def _energies(solver: str, solved: bool) -> tuple[float, float, float]:
    """(kinetic energy, change of the mechanical energy [J/m], largest speed) after 20 steps."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_box(solver, solved))
    f = sim.fluid

    def energy() -> float:
        return float(0.5 * (f["m"] * (f["v"] ** 2).sum(axis=0)).sum()
                     + G * (f["m"] * f["x"][1]).sum())

    e0 = energy()
    for _ in range(20):
        sim.step()
    speed = np.sqrt((f["v"] ** 2).sum(axis=0))
    return float(0.5 * (f["m"] * speed ** 2).sum()), energy() - e0, float(speed.max())


@pytest.mark.parametrize("solver", ["iisph", "dfsph", "pcisph"])
@pytest.mark.parametrize("solved", [False, True])
def test_walls_do_no_work_on_a_closed_box(solver: str, solved: bool) -> None:
    """Default (MLS) and solved walls alike, IISPH, DFSPH and PCISPH: the energy does not grow
    (dE < 0.005 J/m; it falls by the column's compression to the 0.05 % tolerance, m g H / 2
    times 5e-4 = 0.02 J/m: measured -0.017 to -0.030) and the box stays at rest (< 4 cm/s;
    measured 2.1-3.2 cm/s, the free fall of the first steps before the compression reaches the
    tolerance).
    Before the box walls kept the fluid's lattice volume (Akinci's volumes of the one-layer
    walls, 1.42-1.47 lattice volumes) the default term gained +0.24 J/m in these 10 ms."""
    ke, de, vmax = _energies(solver, solved=solved)
    assert -0.05 < de < 0.005
    assert ke < 0.02
    assert vmax < 0.04


def test_solved_walls_move_with_the_box() -> None:
    """Galilean invariance: the closed box above and its fluid translate together at U = 1 m/s
    (the walls moved through ``state.boundary`` after every step, as validation/sloshing.py
    moves its tank), DFSPH, solved walls, 20 steps of 0.5 ms: the fluid stays at rest in the
    box as it does in the box at rest (the largest relative speed is the box at rest's to 1e-6,
    measured to 1e-14; < 4 cm/s, the test above's bound, measured 2.1 cm/s). The walls'
    constraint reads the fluid's velocity relative to the wall particle's, as the fluid's own
    divergence does; with the fluid's absolute velocity (before 2026-12-04) the walls braked
    the fluid against the box
    (measured 0.17 m/s, the fluid's mean 3.6 cm/s behind the box; in the swaying tank of
    validation/sloshing.py a 37 deg phase lag, validation/README.md). 0.04 s warm."""
    U = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_box("dfsph", solved=True))
    f, b = sim.fluid, sim.state.boundary
    x0 = b["x"].copy()
    f["v"][0] += U
    b["v"][0] = U
    for _ in range(20):
        sim.step()
        b["x"][0] = x0[0] + U * sim.time
        sim.boundary_model.rebuild(sim.state)
    rel = np.sqrt((f["v"][0] - U) ** 2 + f["v"][1] ** 2)
    _ke, _de, at_rest = _energies("dfsph", solved=True)
    assert rel.max() == pytest.approx(at_rest, rel=1e-6), (rel.max(), at_rest)
    assert rel.max() < 0.04, rel.max()


@pytest.mark.parametrize("solver", ["iisph", "dfsph", "pcisph"])
def test_density_level_walls_hold_the_walls_density(solver: str,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """``solved: "density"``: the density solves hold the fluid's number density at each wall
    particle covered at the start (:meth:`~sphkit.core.coupling.BoundaryCoupling.wall_rest`) at
    its start value. The hold is tested with the walls' cap lifted (``solver.WALL_CAP``, a
    wall's value at most its fluid neighbours' largest, for the 1:10 columns' stability): on
    this box, whose fluid starts on the walls' lattice at rest density and rests at the
    tolerance in 2 iterations a step, the fluid's values next to the floor are too small for
    the capped walls to hold anything, and with the cap (the default) the floor's weakly
    covered wall particles (0.02-0.16 of a full kernel) rose 1.1-1.5 % of their coverage in the
    20 steps, as with the velocity-level walls; without it no held wall particle's density is
    more than 5e-4 above its start value (measured 1.2e-4 IISPH). The walls at the free surface
    (fluid neighbours without a full kernel at the start) keep the rate only. With the default
    cap the force still does no work (dE < 0.005 J/m, the bound of the closed-box test above)
    and the box stays at rest (< 4 cm/s, measured 3.0 / 2.3 cm/s)."""
    from sphkit.core import solver as solver_module

    for cap in (solver_module.WALL_CAP, 1e9):
        monkeypatch.setattr(solver_module, "WALL_CAP", cap)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim = Simulation(_box(solver, "density"))
        st, f = sim.state, sim.fluid
        cp = st.coupling
        start = cp.wall_density(st, cp.solved_walls(st))
        e0 = float(G * (f["m"] * f["x"][1]).sum())
        for _ in range(20):
            sim.step()
        held = st.boundary["wall_rest"] >= 0.0
        assert 0 < held.sum() < (start > 0).sum()  # the covered walls, not those at the surface
        assert np.array_equal(st.boundary["wall_rest"][held], start[held])
        rise = cp.wall_density(st, held)[held] / start[held] - 1.0
        if cap > 1.0:
            assert rise.max() < 5e-4
            continue
        speed = np.sqrt((f["v"] ** 2).sum(axis=0))
        de = float(0.5 * (f["m"] * speed ** 2).sum() + G * (f["m"] * f["x"][1]).sum()) - e0
        assert de < 0.005
        assert speed.max() < 0.04


def test_solved_walls_exclude_the_symmetric_term() -> None:
    """Two wall terms at once are refused, naming both fields."""
    with pytest.raises(ValidationError, match="symmetric true and solved true"):
        Scene.model_validate({"configuration": {"dim": 2, "boundary": {
            "symmetric": True, "solved": True}}, "materials": [{"id": "fluid"}]})
    with pytest.raises(ValidationError, match="symmetric true and solved 'density'"):
        Scene.model_validate({"configuration": {"dim": 2, "boundary": {
            "symmetric": True, "solved": "density"}}, "materials": [{"id": "fluid"}]})


@pytest.mark.parametrize("value", ["densty", 3, float("nan"), None, [True]])
def test_solved_walls_refuse_other_values(value: object) -> None:
    """``configuration.boundary.solved`` takes true/false, "velocity", "density" or
    "stratified"; anything else is refused naming the field and the words (the CLI's exit 2)."""
    with pytest.raises(ValidationError,
                       match=r"boundary\.solved[\s\S]*'velocity', 'density' or 'stratified'"):
        Scene.model_validate({"configuration": {"dim": 2, "boundary": {"solved": value}},
                              "materials": [{"id": "fluid"}]})


@pytest.mark.parametrize(("solver", "light", "boundary", "expected"), [
    ("iisph", 100.0, {}, "stratified"),  # rest densities 1:10: solved by default
    ("dfsph", 200.0, {}, "stratified"),  # 1:5
    ("dfsph", 250.0, {}, False),  # 1:4, where MLS was measured stable: kept
    ("iisph", 500.0, {}, False),  # 1:2 (the Rayleigh-Taylor validation's)
    ("dfsph", 1000.0, {}, False),  # two materials of one rest density: one fluid
    ("pcisph", 100.0, {}, "density"),  # PCISPH keeps every wall row
    ("iisph", 100.0, {"solved": "density"}, "density"),  # every static wall particle
    ("dfsph", 50.0, {}, "density"),  # 1:20: every wall row (the overturns' reach)
    ("wcsph", 100.0, {}, False),  # WCSPH does not solve the walls
    ("dfsph", 100.0, {"solved": False}, False),  # said: kept
    ("iisph", 100.0, {"solved": "velocity"}, "velocity"),
    ("dfsph", 100.0, {"symmetric": True}, False),
    ("dfsph", 100.0, {"method": "bender2019"}, False),  # maps: no wall particles to solve
])
def test_several_rest_densities_solve_the_walls_by_default(solver: str, light: float,
                                                           boundary: dict,
                                                           expected: bool | str) -> None:
    """``configuration.boundary.solved`` left out: ``"stratified"`` where the scene's fluids' rest
    densities differ by more than a factor 4 and at most 10 with IISPH or DFSPH, ``"density"``
    beyond and with PCISPH (``SOLVED_WALLS_RATIO``, ``STRATIFIED_WALLS_RATIO``), with boundary
    particles and IISPH, DFSPH or PCISPH (validation/README.md, "Several rest densities: the
    solved walls by default"); else false; a value given is kept. The unused material (10
    kg/m^3) does not count."""
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": R, "pressure": {"method": solver},
                          "boundary": boundary},
        "materials": [{"id": "heavy", "density0": 1000.0}, {"id": "light", "density0": light},
                      {"id": "unused", "density0": 10.0}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [0.2, 0.2], "material": "heavy"},
                         {"start": [0.0, 0.2], "end": [0.2, 0.4], "material": "light"}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.2, 0.6]}],
    })
    assert sc.configuration.boundary.solved == expected
    # the validated scene names the wall term that runs: a reload keeps it
    again = Scene.model_validate(sc.model_dump(mode="json"))
    assert again.configuration.boundary.solved == expected


@pytest.mark.parametrize("solver", ["iisph", "pcisph"])
def test_resumed_run_keeps_the_walls_warm_start(tmp_path: Path, solver: str) -> None:
    """The solved walls' ``k_b`` warm-starts each step from the last one's (the boundary field
    ``wall_kappa_<solve>``), so a checkpoint keeps it and a resumed run repeats the
    uninterrupted one bit for bit (positions and velocities, 5 steps on)."""
    from _restart import continued_from_checkpoint

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(_box(solver, "density"))
        for _ in range(5):
            sim.step()
        assert np.any(sim.state.boundary[f"wall_kappa_{solver}"] > 0.0)
        continued_from_checkpoint(sim, tmp_path, 5)
