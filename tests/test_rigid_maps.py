"""Moving rigid bodies with volume maps (Bender et al. 2019) and density maps (Koschier and
Bender 2017): the map of a body is built once in its frame and queried in it each step
(:mod:`sphkit.boundary.maps`, "Moving rigid bodies"); the reaction of the fluid's boundary
force on the virtual particles moves the body (:mod:`sphkit.boundary.rigid`).

3D at r = 12.5 mm (h = 50 mm) as tests/test_rigid.py. The fluid starts 2 r off the walls and the
bodies: volume maps keep the fluid about 2.5-2.8 r off their surface, and fluid placed r off a
volume-map wall (the lattice's distance) is pushed apart at over 100 m/s in the first steps (a
plain block in a box, sphkit main as well).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation

R = 0.0125  # particle radius [m]


def _box_file(tmp_path: Path, extents, name="box.obj") -> str:
    f = tmp_path / name
    trimesh.creation.box(extents=extents).export(f)
    return str(f)


def _around(lo, hi, L, H, gap=2 * R):
    """Fluid blocks filling [gap, L - gap] x [gap, H] x [gap, L - gap] except the box [lo, hi]
    grown by ``gap`` (the fluid starts ``gap`` off the tank's walls and the body)."""
    (x0, y0, z0), (x1, y1, z1) = [a - gap for a in lo], [a + gap for a in hi]
    y1 = min(y1, H)
    w, e = gap, L - gap
    out = []
    if y0 > w:
        out.append(([w, w, w], [e, y0, e]))
    if y1 < H:
        out.append(([x0, y1, z0], [x1, H, z1]))
    out += [([w, y0, w], [x0, y1, e]), ([x1, y0, w], [e, y1, e]),
            ([x0, y0, w], [x1, y1, z0]), ([x0, y0, z1], [x1, y1, e])]
    return [{"start": a, "end": b, "material": "water"} for a, b in out]


def _scene(blocks, meshes, boundary, gravity=(0, -9.81, 0), box=None, method="dfsph",
           viscosity="xsph", tmp_path: Path | None = None) -> Scene:
    return Scene.model_validate({
        "configuration": {"dim": 3, "particle_radius": R, "gravity": list(gravity),
                          "time": {"until": 1.0, "cfl": True, "dt_max": 0.005},
                          "pressure": {"method": method},
                          "boundary": {"method": boundary, "map_cache_dir": str(tmp_path)}},
        "materials": [{"id": "water", "density0": 1000.0,
                       "viscosity": {"method": viscosity, "coefficient": 0.01}}],
        "fluid_blocks": blocks,
        "boxes": [] if box is None else [box],
        "meshes": meshes,
    })


@pytest.mark.parametrize("boundary", ["bender2019", "koschier2017"])
def test_kinematic_paddle_with_maps(tmp_path: Path, boundary: str) -> None:
    """A paddle turning at pi rad/s about the vertical axis of a tank, its walls and the paddle
    as maps: the fluid's torque on it (StepStats ``rigid_bodies``) opposes the rotation and the
    fluid picks up angular momentum in its sense (signs, averaged over the second half of
    0.3 s). Measured: -0.157 N m with volume maps (-0.220 N m on 2026-12-04), -0.101 N m with
    density maps (-0.16 N m
    with Akinci particles, tests/test_rigid.py). The virtual boundary particles of the paddle
    carry its surface velocity ``omega x (x_b - c)``, exactly (to round-off)."""
    L, H = 0.4, 0.2
    lo, hi = [0.1, 0.025, 0.175], [0.3, 0.225, 0.225]
    paddle = {"geometry_file": _box_file(tmp_path, [0.2, 0.2, 0.05]),
              "translation": [0.2, 0.125, 0.2], "angular_velocity": [0.0, np.pi, 0.0]}
    sim = Simulation(_scene(_around(lo, hi, L, H), [paddle], boundary,
                            box={"min": [0, 0, 0], "max": [L, 0.6, L], "open_top": True},
                            tmp_path=tmp_path))
    torque = []
    while sim.time < 0.3:
        st = sim.step()
        if sim.time > 0.15:
            torque.append(st.rigid_bodies[0]["torque"][1])
    print(f"{boundary}: mean torque {np.mean(torque):.4f} N m, pushed "
          f"{sim.boundary_model.pushed}")
    assert np.mean(torque) < 0.0, np.mean(torque)
    f = sim.fluid
    d = f["x"] - np.array([0.2, 0.0, 0.2])[:, None]
    lz = np.sum(f["m"] * (d[2] * f["v"][0] - d[0] * f["v"][2]))  # y component of r x m v
    assert lz > 0.0, lz
    # the virtual particles of the paddle, for its present pose: velocity omega x (x_b - c)
    # about the pivot
    sim._neighbors()
    bd = sim.boundary
    on = bd["rigid_body"] == 1
    assert on.sum() > 100
    q = bd["x"][:, on] - np.array([0.2, 0.125, 0.2])[:, None]
    np.testing.assert_allclose(bd["v"][:, on], np.cross([0.0, np.pi, 0.0], q.T).T, atol=1e-12)
    assert np.all(bd["v"][:, ~on] == 0.0)  # the tank's walls do not move


def test_floating_cube_volume_map(tmp_path: Path) -> None:
    """Archimedes with volume maps: a 0.2 m cube of density 500 floats half submerged.

    As tests/test_rigid.py's Akinci case: it starts 37.5 % submerged, the fraction (points of a
    40^3 grid in the rotated cube below the water level of the columns away from it) is
    averaged over t in [1, 2] s. Tolerance +-5 %, the issue's: the fluid's rest distance to a
    map surface (r, after the moving-body inset :data:`sphkit.boundary.bender2019.
    MOVING_INSET`, measured on a tank at rest, not fitted to this test) is uncertain
    by a fraction of r = 6 % of the side. Measured: 0.485 (0.219 without the inset)."""
    side, L, H = 0.2, 0.5, 0.3
    lo, hi = (L - side) / 2, (L + side) / 2
    yb = H - 0.375 * side
    mesh = {"geometry_file": _box_file(tmp_path, [side] * 3),
            "translation": [L / 2, yb + side / 2, L / 2], "dynamic": True, "density": 500.0}
    sim = Simulation(_scene(_around([lo, yb, lo], [hi, yb + side, hi], L, H), [mesh],
                            "bender2019",
                            box={"min": [0, 0, 0], "max": [L, 0.8, L], "open_top": True},
                            tmp_path=tmp_path))
    body = sim.rigid.bodies[0]
    g = (np.arange(40) + 0.5) / 40 * side - side / 2
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1)
    frac = []
    while sim.time < 2.0:
        sim.step()
        if sim.time > 1.0:
            x = sim.fluid["x"]
            far = (np.abs(x[0] - L / 2) > side / 2 + 0.05) | (np.abs(x[2] - L / 2) > side / 2
                                                              + 0.05)
            y = x[1, far]
            # the top layer of the far columns (layers: fluid height / 2r), plus r
            top = np.sort(y)[-int(len(y) / ((H - 2 * R) / (2 * R))):]
            level = float(top.mean()) + R
            frac.append(np.mean((body.c[:, None] + body.R @ grid)[1] < level))
    print(f"submerged fraction {np.mean(frac):.3f}, pushed {sim.boundary_model.pushed}")
    assert 0.45 <= np.mean(frac) <= 0.55, np.mean(frac)
    assert sim.boundary_model.pushed == 0  # no fluid particle got into the cube or the tank


@pytest.mark.parametrize("method", ["dfsph", "iisph", "pcisph"])
def test_momentum_exchange_volume_map(tmp_path: Path, method: str) -> None:
    """Gravity, no walls: a 1 kg cube moving at 1 m/s runs off-centre into a falling block of
    water, both as volume maps. The total momentum changes by the impulse of gravity,
    ``P(t) - P(0) = (M_fluid + M_body) g t``, and the angular momentum about the common centre
    of mass (on which uniform gravity exerts no torque) stays, both to round-off: bound 1e-12
    of the initial momentum / angular momentum (the body's force and torque are minus the
    fluid's boundary force, pair by pair, and symplectic Euler advances both alike). Measured
    1e-16 to 2e-15 (DFSPH, IISPH, PCISPH). The exchange is substantial: the fluid takes over
    10 % of the cube's momentum along x (measured 36-37 %) and the cube spins (1.5-2 rad/s)."""
    mesh = {"geometry_file": _box_file(tmp_path, [0.1] * 3),
            "translation": [0.3, 0.1, 0.17], "dynamic": True, "density": 1000.0,
            "velocity": [-1.0, 0.0, 0.0]}
    blocks = [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2], "material": "water"}]
    # no viscosity: its boundary term is not passed to bodies (see sphkit.boundary.rigid)
    sim = Simulation(_scene(blocks, [mesh], "bender2019", method=method, viscosity="none",
                            tmp_path=tmp_path))
    body = sim.rigid.bodies[0]
    f = sim.fluid
    M = f["m"].sum() + body.mass
    g = np.array([0.0, -9.81, 0.0])

    def momentum() -> np.ndarray:
        return (f["m"] * f["v"]).sum(axis=1) + body.mass * body.v

    def angular_momentum() -> np.ndarray:  # about the common centre of mass
        X = ((f["m"] * f["x"]).sum(axis=1) + body.mass * body.c) / M
        V = momentum() / M
        lf = (f["m"] * np.cross((f["x"] - X[:, None]).T, (f["v"] - V[:, None]).T).T).sum(axis=1)
        return lf + body.mass * np.cross(body.c - X, body.v - V) + body.world_inertia() @ body.omega

    p0, l0 = momentum(), angular_momentum()
    while sim.time < 0.12:
        sim.step()
    p, lm = momentum(), angular_momentum()
    dp = np.linalg.norm(p - p0 - M * g * sim.time) / np.linalg.norm(p0)
    dl = np.linalg.norm(lm - l0) / np.linalg.norm(l0)
    fluid = (f["m"] * f["v"]).sum(axis=1)
    print(f"{method}: |dP - M g t| / |P0| = {dp:.2e}, |dL| / |L0| = {dl:.2e}, fluid share "
          f"{fluid[0] / p0[0]:.3f}, omega {body.omega}, pushed {sim.boundary_model.pushed}")
    assert sim.boundary_model.pushed == 0  # the push-out fallback is not a pair force
    assert dp < 1e-12
    assert dl < 1e-12
    assert fluid[0] < 0.1 * p0[0], (fluid, p0)
    assert np.linalg.norm(body.omega) > 0.1


def test_checkpoint_resumes_map_body_bit_for_bit(tmp_path: Path) -> None:
    """A run with a dynamic body as a volume map continued from a checkpoint equals the
    uninterrupted run exactly (before the fix, the restore built the body's map a second time
    and the resumed run differed by 29 mm)."""
    mesh = {"geometry_file": _box_file(tmp_path, [0.1] * 3),
            "translation": [0.3, 0.1, 0.17], "dynamic": True, "density": 1000.0,
            "velocity": [-1.0, 0.0, 0.0]}
    blocks = [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2], "material": "water"}]

    def make() -> Simulation:
        return Simulation(_scene(blocks, [mesh], "bender2019", gravity=(0, -1.0, 0),
                                 tmp_path=tmp_path))

    full = make()
    full.run(until=0.1, fps=50)
    half = make()
    half.run(until=0.05, fps=50)
    half.save_checkpoint(tmp_path / "run" / "checkpoints" / "checkpoint_000000001.npz")
    resumed = Simulation.from_checkpoint(tmp_path / "run")
    resumed.run(until=0.1, fps=50)
    assert len(resumed.boundary_model.maps) == len(full.boundary_model.maps)
    assert (full.time, full.step_count) == (resumed.time, resumed.step_count)
    for name in full.fluid.fields:
        np.testing.assert_array_equal(full.fluid[name], resumed.fluid[name], err_msg=name)
    for name in ("c", "R", "v", "omega", "force", "torque"):
        np.testing.assert_array_equal(getattr(full.rigid.bodies[0], name),
                                      getattr(resumed.rigid.bodies[0], name), err_msg=name)
    assert np.linalg.norm(full.rigid.bodies[0].omega) > 0.0


def test_density_map_inset_is_the_shell_it_keeps_fluid_out_of() -> None:
    """``koschier2017.MOVING_INSET_3D`` is the shell a plane density map keeps fluid out of,
    ``delta = integral_0^inf (rho_B(d) - F(d)) dd``: the map's density (``0.8 integral
    gamma(phi) W``, f = 5) less the kernel's share beyond the wall ``F(d)``, which fluid filling
    the half-space up to the wall would miss (cubic kernel, h = 4 r, through the kernel's 1D
    marginal). Tolerance 0.01 r: the constant is rounded to 0.4 r; this quadrature gives 0.401 r
    (a 3D lattice of 201^3 points: 0.403 r)."""
    from sphkit.boundary import koschier2017 as k
    from sphkit.core.kernels import KERNEL_IDS, kernel_w

    h, f, kid = 4.0, k.FACTOR_3D, KERNEL_IDS["cubic"]
    q = np.linspace(0.0, h, 4001)
    wq = np.array([kernel_w(kid, v, h, 3) for v in q]) * q  # W(q) q
    tail = np.concatenate(([0.0], np.cumsum((wq[1:] + wq[:-1]) / 2 * np.diff(q))))
    z = np.linspace(-h, h, 4001)
    marg = 2 * np.pi * (tail[-1] - np.interp(np.abs(z), q, tail))  # int over the plane z
    dz = z[1] - z[0]
    assert abs(marg.sum() * dz - 1.0) < 1e-3  # the marginal carries the kernel's unit mass
    d = np.linspace(0.0, 1.3 * h, 521)
    phi = d[:, None] + z[None, :]
    gamma = np.where(phi < h / f, 1.0 - f * phi / h, 0.0)
    rho_b = k.SCALE * (gamma * marg).sum(axis=1) * dz
    missing = ((phi < 0.0) * marg).sum(axis=1) * dz
    excess = rho_b - missing
    delta = float(((excess[1:] + excess[:-1]) / 2 * np.diff(d)).sum())  # in r (r = 1)
    assert abs(delta - k.MOVING_INSET_3D) < 0.01, delta
