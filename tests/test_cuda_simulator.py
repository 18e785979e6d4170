"""The GPU path: kernel bodies run through ``sphkit.backend.launch(..., device="cuda")``.

Runs in a subprocess with NUMBA_ENABLE_CUDASIM=1 (the simulator must be chosen before numba.cuda is
imported), on a small 2D and 3D case (a jittered block over a wall shell), and compares the
density, the pressure acceleration, the fused density and pair gradients, one Jacobi pass of the
iterative solvers (kappa acceleration, then the sweep with its (sum, max) reduction), the PPE
diagonal and pair divergence, DFSPH's factor and sources, the standard and XSPH viscosities, the
symplectic Euler step, the CFL speed and the leak check's count with the same bodies launched on
the CPU, and the neighbour search whose passes are bodies (:class:`sphkit.core.hashgrid.HashGrid`,
with the scan and the histogram of the counting sort; in 2D) against the CPU grid's lists, and one
whole DFSPH time step of ``Simulation(..., device="cuda")`` (tiny 3D scene: Akinci walls with the
default MLS boundary pressure, standard viscosity, the search of fluid and walls in 3D) against the
CPU's, with the fields resident on the device, in float64 and in float32 (the device's default;
against the CPU's float64 step), and one whole WCSPH, IISPH, PCISPH and PBF step (their
per-particle passes bodies too; WCSPH's with the MLS walls, the others' mirrored) in float64, one
DFSPH step of a material with Weiler 2018 viscosity (its CG on the device), Akinci 2013 surface
tension and micropolar vorticity, a DFSPH step with static density maps and with volume maps (their
queries and packing as bodies), a WCSPH step with volume maps and the symmetric wall term, and
two steps with an emitter (its layers appended to the fields on
the device, and particles reused there). Each kernel launch under the simulator starts a Python
thread per particle, so the cases are as small as their checks allow. Where a CUDA GPU is present
the same script also runs on it (skipped otherwise, e.g. in CI). The subprocess also checks that
importing sphkit and running on the CPU does not import numba.cuda.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent(
    """
    import os
    import sys
    import numpy as np

    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        # the simulator runs a block's threads as Python threads and the launching thread
        # polls them, holding the GIL for the whole switch interval (5 ms) before a thread
        # waiting for it can run: 1 ms hands it over sooner (the same kernels and results;
        # benchmarks/README.md: 40 -> 17 s of CPU time for this script)
        sys.setswitchinterval(1e-3)
    from sphkit.backend import launch, launch_reduce
    from sphkit.core.kernels import lattice_volume
    from sphkit.core.neighbors import Grid, neighbor_lists
    from sphkit.core.operators import density_body, pressure_accel_body
    from sphkit.core.ppe import (density_pair_gradients_body, diagonal_body, divergence_body,
                                 jacobi_body, kappa_accel_body)
    from sphkit.pressure.dfsph import (alpha_body, density_source_body,
                                       divergence_source_body)
    from sphkit.core.timestep import euler_body, outside_body, speed2_body
    from sphkit.viscosity.standard import standard_body
    from sphkit.viscosity.xsph import xsph_body

    def rel(a, b):
        return np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(b).max(), 1e-300)

    rng = np.random.default_rng(3)
    cpu = {}
    for dim in (2, 3):
        r = 0.05
        h = 4 * r
        n = 6 if dim == 2 else 3
        g = np.stack(np.meshgrid(*[np.arange(n) * 2 * r + r] * dim, indexing="ij"))
        x = g.reshape(dim, -1) + rng.uniform(-0.2 * r, 0.2 * r, (dim, n ** dim))
        bx = np.stack(np.meshgrid(*[np.arange(-1, n + 1) * 2 * r + r] * dim, indexing="ij"))
        bx = bx.reshape(dim, -1)
        bx = np.ascontiguousarray(bx[:, (bx < 0).any(axis=0)])  # a floor/wall shell below 0
        bV = rng.uniform(0.5, 1.5, bx.shape[1]) * (2 * r) ** dim
        N = x.shape[1]
        m = np.full(N, 1000.0 * lattice_volume(2 * r, 0, h, dim))
        nl = neighbor_lists(x, h)
        nb = Grid(bx, h).query(x)
        off, idx, boff, bidx = nl.offsets, nl.indices, nb.offsets, nb.indices
        p = rng.uniform(0, 1e4, N)
        mirror = rng.uniform(0.0, 1.0, bx.shape[1])
        kb = rng.uniform(0.0, 5.0, bx.shape[1])
        s = rng.uniform(-0.01, 0.01, N)
        active = rng.uniform(size=N) > 0.2
        wq = rng.uniform(0.5, 1.5, N)
        # two fluids of rest densities 1000 and 100 (c = rho0_i / 1000, RestArrays)
        c = np.where(rng.uniform(size=N) > 0.5, 1.0, 0.1)
        inv_c, mu, V = 1.0 / c, m / c, m / (1000.0 * c)
        vel = rng.normal(0.0, 0.1, (dim, N))
        bvel = rng.normal(0.0, 0.1, bx.shape)
        bn = rng.normal(size=bx.shape)
        bn /= np.linalg.norm(bn, axis=0)
        bd = rng.uniform(0.0, r, bx.shape[1])
        bf = np.linspace(0.0, 2.0, bx.shape[1])  # per-wall factors on the viscous wall term
        kprev = rng.uniform(0.0, 1e-3, N)

        def run(device):
            on = (lambda v: v) if device == "cpu" else cuda.to_device
            back = (lambda v: v) if device == "cpu" else (lambda v: v.copy_to_host())
            out = {}
            rho = on(np.empty(N))
            launch(density_body, N, *map(on, (x, mu, off, idx, bx, bV, boff, bidx)), 1000.0, h,
                   0, dim, rho, 0.0, on(c), device=device)
            out["rho"] = back(rho)
            a = on(np.zeros((dim, N)))
            launch(pressure_accel_body, N, *map(on, (x, m, out["rho"], p, off, idx, bx, bV,
                   boff, bidx)), 1000.0, h, 0, dim, a, 0.0, on(c), on(inv_c), device=device)
            out["a"] = back(a)
            rho2 = on(np.empty(N))
            gw = on(np.empty((dim, idx.shape[0])))
            gwb = on(np.empty((dim, bidx.shape[0])))
            launch(density_pair_gradients_body, N, *map(on, (x, mu, off, idx, bx, bV, boff,
                   bidx)), 1000.0, h, 0, dim, rho2, gw, gwb, 0.0, on(V), on(c), device=device)
            out["rho2"], out["gw"], out["gwb"] = back(rho2), back(gw), back(gwb)
            # one Jacobi pass: a = kappa_accel(k), then the sweep (q, k updated in place)
            q = on(p / 1e7)
            k = on(wq * p / 1e7)
            ak = on(np.empty((dim, N)))
            launch(kappa_accel_body, N, k, on(kb), *map(on, (off, idx, boff, bidx, mirror)),
                   gw, gwb, dim, ak, on(inv_c), device=device)
            out["ak"] = back(ak)
            out["err"] = launch_reduce(jacobi_body, N, ak, on(np.zeros_like(bx)),
                                       *map(on, (off, idx, boff, bidx)), gw, gwb,
                                       on(np.empty((dim, 0))), dim, q, on(s),
                                       1.0, on(np.full(N, 0.8)), 0.5, on(active), on(wq), k,
                                       0.0, 0.0, on(np.empty(0)), device=device)
            out["q"], out["k"] = back(q), back(k)
            # DFSPH's factor (PPE diagonal, alpha) and sources from the pair divergence
            D = on(np.empty(N))
            bsum = on(np.empty((dim, N)))
            div_d = on(np.empty(N))  # the divergence in the diagonal's pass
            launch(diagonal_body, N, *map(on, (off, idx, boff, bidx, mirror)), gw, gwb, dim,
                   True, on(c), on(inv_c), D, bsum, on(vel), on(bvel), div_d, device=device)
            out["bsum"] = back(bsum)
            alpha = on(np.empty(N))
            launch(alpha_body, N, D, 1e-5, alpha, device=device)
            div = on(np.empty(N))
            launch(divergence_body, N, on(vel), on(bvel), *map(on, (off, idx, boff, bidx)),
                   gw, gwb, dim, div, device=device)
            out["D"], out["alpha"], out["div"] = back(D), back(alpha), back(div)
            out["div_d"] = back(div_d)
            for name, body, args in (
                    ("dens", density_source_body, (on(out["rho"]), on(1.0 / (1000.0 * c)), div,
                                                   1e-3)),
                    ("divs", divergence_source_body, (div, on(active), 1e-3))):
                ss, kap = on(np.empty(N)), on(np.empty(N))
                launch(body, N, *args, on(kprev), on(inv_c), ss, kap, device=device)
                out[name + "_s"], out[name + "_k"] = back(ss), back(kap)
            # the explicit viscosities (standard with the no-slip wall factor, XSPH)
            # (the standard one by the kernel and from the cached pair gradients, rho0_j = m / V)
            walls = (*map(on, (bx, bvel, bV, bn, bd, bf, boff, bidx)), 1e-3, 2e-3, 1.5, 0.01,
                     1000.0, h, 0, dim, 0.0)
            av = on(np.zeros((dim, N)))
            launch(standard_body, N, *map(on, (x, vel, m, 1000.0 * c, out["rho"], off, idx)),
                   on(np.empty((dim, 0))), False, *walls, av, device=device)
            out["av_std"] = back(av).copy()
            avc = on(np.zeros((dim, N)))
            launch(standard_body, N, *map(on, (x, vel, m, 1000.0 * c, out["rho"], off, idx)),
                   gw, True, *walls, avc, device=device)
            out["avc"] = back(avc)
            launch(xsph_body, N, *map(on, (x, vel, m, out["rho"], off, idx, bx, bvel, bV, boff,
                   bidx)), 0.1, 0.2, 1000.0, h, 0, dim, 250.0, av, device=device)
            out["av"] = back(av)
            # the integration and the CFL speed
            xe, ve = on(x.copy()), on(vel.copy())
            launch(euler_body, N, xe, ve, av, 1e-3, dim, device=device)
            out["xe"], out["ve"] = back(xe), back(ve)
            out["vmax"] = launch_reduce(speed2_body, N, ve, av, 1e-3, dim, device=device)
            # the leak check: a box that ends at the block's middle along x, with the walls' top
            # at its middle along the last axis (the particles above it are not counted)
            mid = 0.5 * (x.min(axis=1) + x.max(axis=1))
            out["outside"] = launch_reduce(outside_body, N, on(x), dim, -1.0, -1.0, -1.0, mid[0],
                                           9.0, 9.0, dim - 1, mid[dim - 1], 1.0, device=device)
            return out

        cpu = run("cpu")
        if dim == 2:
            assert "numba.cuda" not in sys.modules, "the CPU path imported numba.cuda"
        from numba import cuda
        assert cuda.is_available()
        gpu = run("cuda")
        assert cpu["err"][0] > 0.0 and cpu["err"][1] > 0.0, cpu["err"]
        assert 0 < cpu["outside"][0] < N / 2, cpu["outside"]  # beyond the middle, not above
        for key in ("rho", "a", "rho2", "gw", "gwb", "ak", "q", "k", "D", "bsum", "alpha", "div",
                    "div_d", "dens_s", "dens_k", "divs_s", "divs_k", "av", "avc", "xe", "ve",
                    "vmax", "outside"):
            e = rel(gpu[key], cpu[key])
            assert e <= 1e-12, (dim, key, e)
        assert rel(cpu["div_d"], cpu["div"]) <= 1e-12, dim  # the fused pass: the same sums
        assert rel(cpu["avc"], cpu["av_std"]) <= 1e-12, dim  # the cached gradients: the same term
        assert rel(gpu["err"], cpu["err"]) <= 1e-12, (dim, gpu["err"], cpu["err"])
        print("dim", dim, "ok", N, "particles")

    # the neighbour search as bodies (HashGrid): the same sets as the CPU Grid, fluid-fluid
    # (self excluded, from a capacity of 4 slots so that the overflow regrowth runs) and
    # fluid-boundary; on the GPU only the order within a row may differ
    from sphkit.backend import exclusive_scan, to_device, to_host
    from sphkit.core.hashgrid import HashGrid, hash_origin

    from sphkit.backend.cuda import THREADS

    counts = rng.integers(0, 5, 2 * THREADS + 44)  # three blocks: their totals are scanned too
    out = cuda.device_array(counts.shape[0] + 1, np.int64)
    assert exclusive_scan(to_device(counts, "cuda"), out, device="cuda") == counts.sum()
    assert np.array_equal(out.copy_to_host(), np.concatenate([[0], np.cumsum(counts)]))

    def same_sets(nl, ref, n):
        off, idx = to_host(nl.offsets), to_host(nl.indices)
        return all(np.array_equal(np.sort(idx[off[i]:off[i + 1]]), np.sort(ref.neighbors(i)))
                   for i in range(n))

    for dim in (2,):  # in 3D: the whole step below searches its fluid and walls on the device
        h = 0.12
        x = rng.uniform(0.0, 0.5, (dim, 60))
        bx = rng.uniform(-0.2, 0.7, (dim, 40))
        origin = hash_origin(np.full(dim, 0.25), h)
        grid = HashGrid(dim, h, origin, device="cuda")
        grid.capacity = 4
        xd = to_device(x, "cuda")
        grid.build(xd)
        assert same_sets(grid.query(xd, exclude_self=True), neighbor_lists(x, h), 60)
        assert grid.capacity > 4
        walls = HashGrid(dim, h, origin, device="cuda")
        walls.build(to_device(bx, "cuda"))
        assert same_sets(walls.query(xd), Grid(bx, h).query(x), 60)
        print("hash grid", dim, "ok")

    # the z-order permutation found on the device (a counting sort by coarse Morton keys): a
    # permutation whose consecutive points are close (z-order keeps neighbours together: for 64
    # points in the unit cube the mean step along the exact z-order of the host is 0.33-0.35,
    # along a random order 0.65-0.69; the bound lies between)
    from sphkit.core.hashgrid import zorder_on_device

    xz = rng.uniform(0.0, 1.0, (3, 64))
    for dev in ("cpu", "cuda"):
        pz = to_host(zorder_on_device(to_device(xz, dev), 0.1, xz.mean(1), dev))
        assert np.array_equal(np.sort(pz), np.arange(64)), dev
        step = np.linalg.norm(np.diff(xz[:, pz], axis=1), axis=0).mean()
        assert step < 0.45, (dev, step)
    print("z-order ok", step)

    # a particle set moved to the device and back: fields registered and filled there, a
    # permutation gathered there (the z-order of the step below), a second round trip
    from sphkit.core.particles import ParticleSet

    ps = ParticleSet(3)
    ps.add(rng.uniform(size=(5, 3)))
    x0 = ps["x"].copy()
    ps.to("cuda")
    ps.register("w", fill=2.0)
    ps["id"] = 7
    ps.permute(np.array([4, 3, 2, 1, 0]))
    ps.to("cpu")
    ps.to("cuda")
    ps.to("cpu")
    assert np.array_equal(ps["x"], x0[:, ::-1]) and np.all(ps["w"] == 2.0)
    assert np.all(ps["id"] == 7) and type(ps["x"]) is np.ndarray

    # one whole DFSPH step (Akinci walls with the default MLS boundary pressure: the lists'
    # transpose by the counting sort's histogram and scan, the fit and the extrapolation as
    # bodies; standard viscosity, CFL, symplectic Euler, z-order) through Simulation on the
    # device against the CPU: a 2 x 2 x 2 block thrown into the corner of a box (every kernel
    # launch under the simulator starts a Python thread per particle: the fewer, the faster)
    from sphkit.scene.schema import Scene
    from sphkit.simulation import Simulation

    scene = {"configuration": {
                 "dim": 3, "particle_radius": 0.05, "zsort_every": 1,
                 "pressure": {"method": "dfsph", "max_error": 0.5, "max_error_v": 5.0},
                 "boundary": {"method": "akinci2012"}},
             "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
             "fluid_blocks": [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2],
                               "velocity": [0.3, -1.0, 0.2]}],
             "boxes": [{"min": [0, 0, 0], "max": [0.2, 0.3, 0.2]}]}
    Device = type(cuda.to_device(np.zeros(1)))
    host_copy = Device.copy_to_host
    copies = []

    def counted(a, *args, **kw):
        copies.append(a.shape)
        return host_copy(a, *args, **kw)

    res = {}
    for device in ("cpu", "cuda", "cuda32"):
        scene["configuration"]["precision"] = "float64"
        if device == "cuda32":  # unset: float32, the default on the device
            del scene["configuration"]["precision"]
        sim = Simulation(Scene.model_validate(scene), device=device[:4])
        if device == "cuda32":  # float32 on the device against the CPU's float64
            f = sim.fluid
            assert f["x"].dtype == np.float32 and sim.scene.configuration.precision == "float32"
            sim.step()
            assert sim._search.grid.sorted_x.dtype == np.float32
            f = sim.fluid
            o = f.order_by_id()
            e = rel(f["rho"][o], res["cpu"][0]["rho"])
            assert e <= 1e-5, ("float32 step", "rho", e)
            print("float32 step ok", e, [rel(f[k][..., o], res["cpu"][0][k]) for k in "xvp"])
            continue
        Device.copy_to_host = counted
        st = sim.step()
        Device.copy_to_host = host_copy
        if device == "cuda":  # the fields and the lists stayed on the device
            assert all(hasattr(a, "copy_to_host") for a in (
                sim.state.fluid["x"], sim.state.fluid["dfsph_kappa"], sim.state.boundary["V"],
                sim.state.nl_ff.indices, sim.state.nl_fb.indices))
        f = sim.fluid  # back on the host
        o = f.order_by_id()
        res[device] = ({k: f[k][..., o] for k in ("x", "v", "rho", "p")},
                       (st.iterations, st.divergence_iterations))
    n, nb = sim.state.fluid.n, sim.state.boundary.n
    # what the device step read back: scalars (reductions, scan totals), and the positions
    # twice: for the centres of the fluid's and the walls' grids (the z-order permutation is
    # found on the device)
    big = sorted(c for c in copies if np.prod(c) > 2)
    assert big == [(3, n), (3, nb)], big
    assert res["cuda"][1] == res["cpu"][1], (res["cuda"][1], res["cpu"][1])
    for key in ("x", "v", "rho", "p"):
        e = rel(res["cuda"][0][key], res["cpu"][0][key])
        assert e <= 1e-12, ("step", key, e)
    print("step ok", n, "particles", res["cpu"][1], "iterations")

    # one whole step of WCSPH (state equation, pressure force), IISPH (its setup and the Jacobi
    # solve), PCISPH (prediction, density at x*, the factor's cap check (no particle capped
    # here), pressure update) and PBF (prediction, the two projection passes with the artificial
    # pressure, the velocity update), the rest as above, on both devices in float64; WCSPH with
    # the MLS walls (its own once-a-step fit of the values and the swap of the mirrored term),
    # the others mirrored (their MLS passes are DFSPH's, above; each launch here costs a
    # Python thread per particle)
    scene["configuration"]["precision"] = "float64"
    scene["configuration"]["start"] = {"settle": False}  # hundreds of steps under the simulator
    # the inviscid WCSPH scene would take the symmetric wall term by default, which does not
    # run on the device: the MLS walls asked for by name
    scene["configuration"]["boundary"]["symmetric"] = False
    pressure = {"wcsph": {"stiffness": 1000.0}, "iisph": {"max_error": 0.5},
                "pcisph": {"max_error": 0.5}, "pbf": {"max_error": 0.5, "pbf_s_corr": True}}
    for method in ("wcsph", "iisph", "pcisph", "pbf"):
        scene["configuration"]["pressure"] = {"method": method, **pressure[method]}
        scene["configuration"]["boundary"]["pressure"] = "mls" if method == "wcsph" else "mirror"
        out, its = {}, {}
        for device in ("cpu", "cuda"):
            sim = Simulation(Scene.model_validate(scene), device=device)
            copies.clear()
            Device.copy_to_host = counted
            its[device] = sim.step().iterations
            Device.copy_to_host = host_copy
            if device == "cuda":  # resident, and only scalars and the grids' centres read back
                assert hasattr(sim.state.fluid["p"], "copy_to_host")
                big = sorted(c for c in copies if np.prod(c) > 2)
                assert big == [(3, n), (3, nb)], (method, big)
            f = sim.fluid
            o = f.order_by_id()
            out[device] = {k: f[k][..., o] for k in ("x", "v", "rho", "p")}
        assert out["cpu"]["p"].max() > 0.0  # the walls compress the block: the pressure acts
        assert its["cuda"] == its["cpu"], (method, its)
        for key in ("x", "v", "rho", "p"):
            e = rel(out["cuda"][key], out["cpu"][key])
            assert e <= 1e-12, (method, "step", key, e)
        print(method, "step ok", float(out["cpu"]["p"].max()), "Pa", its["cpu"], "iterations")

    # one whole DFSPH step with the non-pressure forces the device runs besides the standard
    # viscosity: Weiler 2018's implicit viscosity (its CG, block-Jacobi preconditioner and
    # warm start on the device), Akinci 2013 surface tension and adhesion (with its
    # colour-gradient normals) and the micropolar model (omega advanced on the device), against
    # the CPU (XSPH, the other viscosity, is one launch of xsph_body, compared above)
    scene["configuration"]["pressure"] = {"method": "dfsph", "max_error": 0.5,
                                          "max_error_v": 5.0}
    scene["materials"] = [{
        "viscosity": {"method": "weiler2018", "coefficient": 0.1,
                      "boundary_coefficient": 0.1},
        "surface_tension": {"method": "akinci2013", "coefficient": 0.5,
                            "boundary_coefficient": 0.5},
        "vorticity": {"method": "micropolar", "coefficient": 0.01}}]
    # the box a little wider than the block: with the block on the walls' lattice the densities
    # agreed to 1e-16 but after the step x differed by 2.7e-10 of its size and v by 1e-7, as if
    # the solvers' branches at rho* = 1 (a filled lattice is at 1 to round-off) went either way
    scene["boxes"] = [{"min": [0, 0, 0], "max": [0.21, 0.3, 0.21]}]
    keys = ("x", "v", "rho", "p", "omega", "normal")
    out, its = {}, {}
    for device in ("cpu", "cuda"):
        sim = Simulation(Scene.model_validate(scene), device=device)
        copies.clear()
        Device.copy_to_host = counted
        st = sim.step()
        Device.copy_to_host = host_copy
        its[device] = (st.iterations, st.divergence_iterations, st.viscosity_iterations)
        if device == "cuda":  # resident, and only scalars and the grids' centres read back
            assert hasattr(sim.state.fluid["omega"], "copy_to_host")
            assert hasattr(sim.state.fluid["weiler_dv"], "copy_to_host")
            big = sorted(c for c in copies if np.prod(c) > 2)
            nbw = sim.state.boundary.n
            assert big == [(3, n), (3, nbw)], ("forces", big)
        f = sim.fluid
        o = f.order_by_id()
        out[device] = {k: f[k][..., o] for k in keys}
    # the forces act: the walls spin the block up, its surface has normals, the viscosity solve
    # iterates
    assert np.abs(out["cpu"]["omega"]).max() > 0.0 and np.abs(out["cpu"]["normal"]).max() > 0.0
    assert its["cpu"][2] > 0, its
    assert its["cuda"] == its["cpu"], ("forces", its)
    for key in keys:
        e = rel(out["cuda"][key], out["cpu"][key])
        assert e <= 1e-12, ("forces", "step", key, e)
    print("forces step ok", its["cpu"], "iterations")

    # one whole DFSPH step with static density maps (mirrored pressure) and volume maps
    # (hydrostatic boundary pressure: the mirrored shares and the walls' moment too): the maps'
    # queries, the packing of the virtual particles into the boundary set and their lists run
    # on the device; a 3 x 3 x 3 block thrown at the floor of a box
    maps = {"configuration": {
                "dim": 3, "particle_radius": 0.05, "zsort_every": 1, "precision": "float64",
                "start": {"settle": False},
                "pressure": {"method": "dfsph", "max_error": 0.5, "max_error_v": 5.0}},
            "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
            "fluid_blocks": [{"start": [0, 0, 0], "end": [0.3, 0.3, 0.3],
                              "velocity": [0.3, -3.0, 0.2]}],
            "boxes": [{"min": [-0.06, -0.06, -0.06], "max": [0.36, 0.5, 0.36]}]}
    # then WCSPH with volume maps and the symmetric wall term: the virtual particles placed
    # for the exact gradient, the wall term swapped with a mask on the device
    dfsph = maps["configuration"]["pressure"]
    wcsph = {"method": "wcsph", "stiffness": 1000.0}
    for bnd, bp, walls, solver in (
            ("koschier2017", "mirror", {"pressure": "mirror"}, dfsph),
            ("bender2019", "hydrostatic", {"pressure": "hydrostatic"}, dfsph),
            ("bender2019", "symmetric", {"symmetric": True}, wcsph)):
        maps["configuration"]["boundary"] = {"method": bnd, **walls}
        maps["configuration"]["pressure"] = solver
        out, nbs = {}, {}
        for device in ("cpu", "cuda"):
            sim = Simulation(Scene.model_validate(maps), device=device)
            copies.clear()
            Device.copy_to_host = counted
            sim.step()
            Device.copy_to_host = host_copy
            nbs[device] = sim.state.boundary.n
            if device == "cuda":
                assert hasattr(sim.state.boundary["x"], "copy_to_host")
                n = sim.state.fluid.n
                big = sorted(c for c in copies if np.prod(c) > 2)
                assert big == [(3, n)], (bnd, big)  # the grid's centre
            f = sim.fluid
            o = f.order_by_id()
            out[device] = {k: f[k][..., o] for k in ("x", "v", "rho", "p")}
        assert nbs["cpu"] > 0 and nbs["cuda"] == nbs["cpu"], (bnd, nbs)
        # a particle at rest density to rounding (the block's centre with the density maps:
        # rho - rho0 = 1e-12 kg/m^3) gets the pressure of that rounding (2e-8 Pa), which the
        # CPU's vectorised density sum rounds differently: its pressure is checked to be that
        # small on both devices, the others' to the tolerance
        noise = np.abs(out["cpu"]["rho"] / 1000.0 - 1.0) < 1e-12
        for d in ("cpu", "cuda"):
            assert np.all(np.abs(out[d]["p"][noise]) < 1e-6), (bnd, d, out[d]["p"][noise])
            out[d]["p"] = np.where(noise, 0.0, out[d]["p"])
        for key in ("x", "v", "rho", "p"):
            e = rel(out["cuda"][key], out["cpu"][key])
            assert e <= 1e-12, (bnd, "step", key, e)
        print(bnd, bp, "step ok", nbs["cpu"], "virtual particles")

    # an emitter on the device: two DFSPH steps of 30 ms, its layers of 4 particles added to
    # the resident fields (due at t = 0 and 0.05 s) and its region animated, against the CPU
    # (a loose tolerance: the layer lands close to the block, and 100 iterations under the
    # simulator would take seconds; the comparison is of the two devices)
    emit = {"configuration": {
                "dim": 3, "particle_radius": 0.05, "zsort_every": 1, "precision": "float64",
                "start": {"settle": False}, "time": {"dt": 0.03, "cfl": False},
                "pressure": {"method": "dfsph", "max_error": 5.0, "max_error_v": 5.0},
                "boundary": {"method": "akinci2012", "pressure": "mirror"}},
            "materials": [{"viscosity": {"method": "standard", "coefficient": 0.01}}],
            "fluid_blocks": [{"start": [0, 0, 0], "end": [0.2, 0.2, 0.2]}],
            "emitters": [{"position": [0.1, 0.5, 0.1], "width": 0.2, "velocity": 2.0,
                          "rotation_axis": [0, 0, 1], "rotation_angle": -np.pi / 2,
                          "housing": False,
                          "reuse_box": {"min": [0.1, 0, 0], "max": [0.2, 0.8, 0.2]}}],
            "boxes": [{"min": [0, 0, 0], "max": [0.2, 0.8, 0.2]}]}
    out = {}
    for device in ("cpu", "cuda"):
        sim = Simulation(Scene.model_validate(emit), device=device)
        for _ in range(2):
            sim.step()
        if device == "cuda":
            assert hasattr(sim.state.fluid["x"], "copy_to_host")
        f = sim.fluid
        o = f.order_by_id()
        out[device] = {k: f[k][..., o] for k in ("x", "v", "rho", "p", "id")}
    # the layers first take the particles left of x = 0.1 (the reuse box; renewed on the
    # device), then add new ones: fewer than 8 + 2 layers of 4
    n_cpu = out["cpu"]["id"].shape[0]
    assert 8 < n_cpu < 16 and out["cuda"]["id"].shape[0] == n_cpu, n_cpu
    for key in ("x", "v", "rho", "p", "id"):
        e = rel(out["cuda"][key], out["cpu"][key])
        assert e <= 1e-12, ("emitter", key, e)
    print("emitter ok", out["cpu"]["id"].shape[0], "particles")
    """
)


def test_bodies_match_cpu_under_cuda_simulator() -> None:
    """Tolerance 1e-12 relative (float64): the CPU and the CUDA kernel run the same body, so the
    formulas and the order of each particle's pair sums are the same and only rounding differs
    (fast math on the CPU may contract and reassociate); the Jacobi pass's (sum, max) of the
    residuals is reduced in a different order (per block in shared memory, then atomically),
    which also changes the sum only by rounding.

    The whole step: the same tolerance. The device's neighbour lists hold the same pairs in
    another order (hashed grid, atomic counting sort), so the densities differ by rounding
    (1e-16 measured); the pressure solves divide that by their source ``1 - rho_hat - dt div``,
    a difference of nearly equal numbers, which amplifies it: measured 6e-16 for velocities and
    4e-16 for pressures of the thrown 8-particle block, 3e-14 for a thrown 27-particle block,
    3e-12 for a 48-particle block at rest (sources of 1e-4), which is why the scene throws it.
    The step with Weiler 2018 viscosity, Akinci 2013 surface tension and micropolar vorticity:
    the same tolerance (measured 9e-16 for velocities, 6e-16 for pressures, 5e-16 for omega and
    4e-16 for the normals; the CG's dot products are summed in another order on the device).

    The float32 step on the device against the CPU's float64 step: densities to 1e-5 relative
    (the issue's bound). Positions and masses are stored in float32 (rounding 6e-8 relative),
    the pair terms are computed from them (in float64 where a float64 scalar such as h, or a
    kernel constant, enters, as on the CPU) and the density is stored in float32, so it carries
    a few float32 roundings (7e-8 measured); the bound leaves room for a denser neighbourhood and
    for the solver's pressures feeding back into the positions, which are not compared (2e-6
    for v and p measured: the pressure solve amplifies the density's rounding, see above)."""
    _run_script(dict(os.environ, NUMBA_ENABLE_CUDASIM="1"))


def _without_simulator() -> dict:
    return {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}


def _run_script(env: dict) -> None:
    """Run SCRIPT in a subprocess with ``env``; both dimensions must report a match."""
    res = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "dim 2 ok" in res.stdout and "dim 3 ok" in res.stdout
    assert "hash grid 2 ok" in res.stdout and "z-order ok" in res.stdout
    assert "step ok" in res.stdout and "float32 step ok" in res.stdout
    for method in ("wcsph", "iisph", "pcisph", "pbf"):
        assert f"{method} step ok" in res.stdout, method
    for bp in ("koschier2017 mirror", "bender2019 hydrostatic", "bender2019 symmetric"):
        assert f"{bp} step ok" in res.stdout, bp
    assert "emitter ok" in res.stdout
    assert "forces step ok" in res.stdout


def _cuda_gpu() -> bool:
    """Whether numba.cuda sees a real GPU (asked in a subprocess, without the simulator)."""
    try:
        res = subprocess.run([sys.executable, "-c",
                              "from numba import cuda; print(cuda.is_available())"],
                             env=_without_simulator(), capture_output=True, text=True,
                             timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return res.returncode == 0 and res.stdout.strip().endswith("True")


@pytest.mark.skipif(not _cuda_gpu(), reason="no CUDA GPU")
def test_bodies_match_cpu_on_gpu() -> None:
    """The same launches on a real GPU. Tolerance 1e-12 relative: the GPU contracts a * b + c
    into fused multiply-adds, which changes only the last bits of each term, and reduces in a
    different order."""
    _run_script(_without_simulator())
