"""sphkit.backend.launch on the CPU: a body runs once per particle, the (sum, max) reduction,
the sum alone, argument checks. The CUDA side is tested against it in
tests/test_cuda_simulator.py."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from sphkit.backend import launch, launch_reduce, launch_sum
from sphkit.backend.launch import constant_positions, cpu_driver
from sphkit.core.kernels import Kernel, kernel_id, kernel_w


@numba.njit(cache=True, inline="always")
def _scale_body(i, x, c, out):
    out[i] = c * x[i]


@numba.njit(cache=True, inline="always")
def _error_body(i, x, active):
    if active[i]:
        return abs(x[i])
    return 0.0


def test_launch_runs_the_body_for_every_particle() -> None:
    x = np.arange(1000.0)
    out = np.full(1000, -1.0)
    launch(_scale_body, x.shape[0], x, 2.0, out)
    assert np.array_equal(out, 2.0 * x)
    launch(_scale_body, 0, x, 3.0, out)  # no particles: nothing written
    assert np.array_equal(out, 2.0 * x)


def test_launch_reduce_returns_sum_and_max_of_the_values() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=777)
    active = rng.uniform(size=777) > 0.3
    tot, mx = launch_reduce(_error_body, x.shape[0], x, active)
    e = np.where(active, np.abs(x), 0.0)
    assert tot == pytest.approx(e.sum(), rel=1e-14)
    assert mx == e.max()
    assert launch_reduce(_error_body, 0, x, active) == (0.0, 0.0)


@numba.njit(cache=True, fastmath=True, inline="always")
def _product_body(i, a, b):
    return a[i] * b[i]


@numba.njit(parallel=True, cache=True, fastmath=True)
def _dot_by_hand(a, b):
    s = 0.0
    for i in numba.prange(a.shape[0]):
        s += a[i] * b[i]
    return s


def test_launch_sum_is_the_hand_written_prange_sum() -> None:
    """Values of either sign; bit for bit the hand-written fast-math ``prange`` sum (the CG's dot
    products, core/krylov.py, keep their last bits). Exact equality: the same loop, compiled
    with the same flags, in the same thread count (this process's)."""
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=12345), rng.normal(size=12345)
    assert launch_sum(_product_body, a.shape[0], a, b) == _dot_by_hand(a, b)
    assert launch_sum(_product_body, 0, a, b) == 0.0


def test_the_driver_is_built_once_per_body_and_arity() -> None:
    x = np.arange(3.0)
    launch(_scale_body, 3, x, 1.0, np.empty(3))
    assert cpu_driver(_scale_body, 3) is cpu_driver(_scale_body, 3)
    assert cpu_driver(_scale_body, 3) is not cpu_driver(_scale_body, 3, "sum_max")


@numba.njit(cache=True, fastmath=True, inline="always")
def _kernel_body(i, r, h, kid, dim, out):
    out[i] = kernel_w(kid, r[i], h, dim)


def test_the_kernel_id_is_compiled_into_its_own_driver() -> None:
    """A body's ``kid`` reaches it as a constant: one driver per kernel id (so the kernel's
    dispatch folds away), each giving that kernel's values, and a driver per id is built
    once."""
    assert constant_positions(_kernel_body) == (2,)
    assert constant_positions(_scale_body) == ()
    r = np.linspace(0.0, 1.2, 257)
    for name in ("cubic", "wendland", "spiky"):
        kid = kernel_id(name)
        out = np.empty_like(r)
        launch(_kernel_body, r.shape[0], r, 1.0, kid, 3, out)
        # the same kernel through the generic loop (the id an argument): equal to rounding
        assert np.allclose(out, Kernel(name, 1.0, 3).w(r), rtol=1e-12, atol=0.0), name
        assert np.any(out > 0.0) and out[-1] == 0.0
    cubic, spiky = kernel_id("cubic"), kernel_id("spiky")
    assert cpu_driver(_kernel_body, 5, "each", (cubic,)) is cpu_driver(_kernel_body, 5, "each",
                                                                          (cubic,))
    assert cpu_driver(_kernel_body, 5, "each", (cubic,)) is not cpu_driver(_kernel_body, 5,
                                                                              "each", (spiky,))
    with pytest.raises(ValueError, match="2 constant values for the 1 constant parameters"):
        cpu_driver(_kernel_body, 5, "each", (cubic, cubic))


@numba.njit(cache=True, inline="always")
def _dim_body(i, x, dim, out):
    out[i] = x[i] * dim


def test_a_body_specialized_on_dim_gets_a_driver_per_dimension() -> None:
    """``specialize(body, "dim")``: the dimension is compiled in instead (the pressure solvers'
    iteration passes); each dimension's driver gives its own values; a name the body does not
    take is refused; ``specialize(body)`` leaves a body without constants."""
    from sphkit.backend import specialize
    from sphkit.core.ppe import jacobi_body, kappa_accel_body

    assert specialize(_dim_body, "dim") is _dim_body
    assert constant_positions(_dim_body) == (1,)
    x = np.arange(5.0)
    for dim in (2, 3):
        out = np.empty(5)
        launch(_dim_body, 5, x, dim, out)
        assert np.array_equal(out, dim * x)
    assert cpu_driver(_dim_body, 3, "each", (2,)) is not cpu_driver(_dim_body, 3, "each", (3,))
    names = jacobi_body.py_func.__code__.co_varnames
    assert constant_positions(jacobi_body) == (names.index("dim") - 1,)
    assert len(constant_positions(kappa_accel_body)) == 1
    with pytest.raises(ValueError, match="_dim_body: no parameter 'kid' to specialize on"):
        specialize(_dim_body, "kid")
    # no constants: a body that the constant kernel id makes slower keeps the generic driver;
    # a switch made a constant beside the id (PBF's artificial pressure)
    from sphkit.boundary.maps_hydrostatic import wall_moment_body
    from sphkit.core.projection import constraint_correction_body

    assert constant_positions(wall_moment_body) == ()
    names = constraint_correction_body.py_func.__code__.co_varnames
    assert constant_positions(constraint_correction_body) == (names.index("kid") - 1,
                                                              names.index("s_corr") - 1)


@numba.njit(cache=True, fastmath=True, inline="always")
def _switch_body(i, x, cached, out):
    out[i] = x[i] + 1.0 if cached else x[i] * 2.0


def test_fastmath_when_compiles_a_switchs_drivers_with_their_own_flags() -> None:
    """``specialize(..., fastmath_when={name: flags})``: the drivers in which the constant is
    true take ``flags`` (the standard viscosity's pass over cached pair gradients, scalar), the
    others the body's own (its kernel path, vectorised); both compute the body; a name that is
    not constant is refused."""
    from sphkit.backend import specialize
    from sphkit.core.ppe import GATHER_FASTMATH

    flags = set(GATHER_FASTMATH)
    specialize(_switch_body, "cached", fastmath_when={"cached": flags})
    x = np.arange(4.0)
    for cached, want in ((True, x + 1.0), (False, 2.0 * x)):
        out = np.empty(4)
        launch(_switch_body, 4, x, cached, out)
        assert np.array_equal(out, want)
    assert cpu_driver(_switch_body, 3, "each", (1,)).targetoptions["fastmath"] == flags
    assert cpu_driver(_switch_body, 3, "each", (0,)).targetoptions["fastmath"] is True
    with pytest.raises(ValueError, match="fastmath_when names a parameter that is not constant"):
        specialize(_switch_body, fastmath_when={"cached": flags})


def test_unknown_device_is_an_error() -> None:
    with pytest.raises(ValueError, match="device: 'gpu'; expected one of cpu, cuda"):
        launch(_scale_body, 1, np.zeros(1), 1.0, np.zeros(1), device="gpu")
    with pytest.raises(ValueError, match="device"):
        launch_reduce(_error_body, 1, np.zeros(1), np.ones(1, dtype=np.bool_), device="tpu")



def test_device_choice_names_the_methods_that_keep_a_scene_on_the_cpu(tmp_path) -> None:
    """``Simulation(device=...)`` / ``sphkit run --device``: a scene whose methods lack the
    registry's ``gpu`` capability (here projective fluids) is refused on ``cuda`` with the
    fields and names of those methods (never a silent CPU fallback), before anything is built;
    ``auto`` runs it on the CPU without probing for a GPU, and an unknown device names the
    choices. DFSPH with Akinci walls, mirrored or MLS boundary pressure and the standard
    viscosity is accepted (the whole step on the device: tests/test_cuda_simulator.py), unless a
    feature of the scene that the device step lacks (Verlet lists) is named; float32 is accepted
    (and the default there). (The manifest's record of the device: tests/test_cli.py's tiny run.)"""
    from sphkit.cli import main
    from sphkit.scene.checks import check_device, methods_in_use
    from sphkit.scene.files import load_scene
    from sphkit.scene.schema import SceneError

    scene = load_scene("dambreak-2d")
    scene.configuration.pressure.method = "pf"
    used = methods_in_use(scene)
    assert ("configuration.pressure.method", "pressure", scene.configuration.pressure.method) \
        in used

    def no_probe() -> bool:
        raise AssertionError("auto probed for a GPU although a method is CPU-only")

    assert check_device(scene, "auto", no_probe) == "cpu"
    assert check_device(scene, "cpu", no_probe) == "cpu"
    with pytest.raises(SceneError, match="configuration.pressure.method 'pf'"):
        check_device(scene, "cuda", lambda: True)
    with pytest.raises(SceneError, match="expected one of auto, cpu, cuda"):
        check_device(scene, "gpu", lambda: True)
    cfg = scene.configuration
    cfg.pressure.method, cfg.boundary.pressure = "dfsph", "mirror"
    scene.materials[0].viscosity.method = "standard"
    assert check_device(scene, "cuda", lambda: True) == "cuda"
    assert check_device(scene, "auto", lambda: True) == "cuda"
    assert check_device(scene, "auto", lambda: False) == "cpu"
    cfg.boundary.pressure = "mls"  # the default of Akinci walls runs there too
    assert check_device(scene, "cuda", lambda: True) == "cuda"
    cfg.boundary.pressure, cfg.precision = "mirror", "float32"
    assert check_device(scene, "cuda", lambda: True) == "cuda"  # float32 runs there too
    # the precision of a run: the scene's where it sets one, else float32 on the GPU only
    from sphkit.scene.checks import device_precision
    from sphkit.scene.schema import Scene

    unset = Scene.model_validate({})
    assert device_precision(unset, "cuda") == "float32"
    assert device_precision(unset, "cpu") == "float64"
    assert device_precision(Scene.model_validate({"configuration": {"precision": "float64"}}),
                            "cuda") == "float64"
    assert device_precision(scene, "cpu") == "float32"
    scene.configuration.neighbor_skin = 0.2
    with pytest.raises(SceneError, match=r"GPU yet: configuration.neighbor_skin \(Verlet lists\); "
                       "expected"):
        check_device(scene, "cuda", lambda: True)
    assert main(["run", "dambreak-2d", "--device", "cuda", "--quiet",
                 "--out", str(tmp_path / "refused")]) == 2
    assert not (tmp_path / "refused").exists()


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("densities", [(1000.0,), (1000.0, 123.4567)])
def test_rest_arrays_are_the_element_wise_forms(dtype: type, densities: tuple) -> None:
    """The rest arrays of one pass (``RestArrays.of``, :func:`sphkit.core.state.rest_body`)
    equal NumPy's element-wise forms to the last bit in the fields' precision: ``c = rho0 /
    rho0_ref`` (exactly 1 for one rest density), ``1 / rho0``, ``V = m * (1 / rho0)``, ``mu =
    m / c`` and ``1 / c`` (c and m themselves for one density)."""
    from sphkit.core.particles import ParticleSet
    from sphkit.core.state import RestArrays

    rng = np.random.default_rng(8)
    f = ParticleSet(3, dtype)
    f.register("rho0")
    f.register("m")
    f.add(rng.random((700, 3)))
    f["rho0"][:] = rng.choice(densities, 700)
    f["m"][:] = rng.uniform(1e-3, 1e-2, 700)
    r = RestArrays.of(f, 1000.0)
    rho0, m, ref = f["rho0"], f["m"], dtype(1000.0)
    c = rho0 / ref
    inv = dtype(1.0) / rho0
    assert r.uniform == (len(densities) == 1)
    assert np.array_equal(r.c, c) and np.array_equal(r.inv_rho0, inv)
    assert np.array_equal(r.V, m * inv)
    if r.uniform:
        assert np.all(r.c == 1.0) and r.mu is m and r.inv_c is r.c
    else:
        assert np.array_equal(r.mu, m / c) and np.array_equal(r.inv_c, dtype(1.0) / c)
    for a in (r.c, r.V, r.inv_rho0, r.mu, r.inv_c):
        assert a.dtype == dtype


def test_absent_arrays_are_kept_and_empty() -> None:
    """``arrays.absent`` gives one empty array per shape and type on the CPU (what a kernel
    body reads as "no such array"), refuses a shape with entries, and ``arrays.added`` is the
    element-wise sum."""
    from sphkit.core import arrays

    like = np.zeros(3)
    a = arrays.absent(0, np.float64, like)
    assert a.size == 0 and a is arrays.absent(0, np.float64, like)
    assert arrays.absent((3, 0), np.float32, like).shape == (3, 0)
    with pytest.raises(ValueError, match="absent: shape"):
        arrays.absent(4, np.float64, like)
    x, y = np.array([0.1, 2.0, -3.0]), np.array([0.2, 1e-17, 3.0])
    assert np.array_equal(arrays.added(x, y), x + y)
