"""The virtual boundary particle of an implicit boundary density: Koschier and Bender 2017's
boundary density ``rho_B(x)`` and its gradient (density maps, paper Sec. 5) as one neighbour
``(x_b, V_b)`` that reproduces both exactly at the fluid particle x_i,

    V_b W(|x_i - x_b|) = rho_B,   V_b grad_i W(x_i - x_b) = grad rho_B,

i.e. ``x_b = x_i + s g / |g|`` (``g = grad rho_B``, pointing into the wall) with the distance s
solving ``|W'(s)| / W(s) = |g| / rho_B`` and ``V_b = rho_B / W(s)``, so that every solver's
boundary terms ``rho0 V_b W`` and ``V_b grad W`` are the density and its exact gradient. Used by
density maps (:mod:`sphkit.boundary.koschier2017`) and by volume maps with the symmetric wall
term (:mod:`sphkit.boundary.bender2019`, "Symmetric walls").
"""

from __future__ import annotations

import math

import numba

from sphkit.core.kernels import kernel_dw, kernel_w


@numba.njit(cache=True, fastmath=True)
def virtual_distance(ratio: float, h: float, kid: int, dim: int) -> float:
    """The distance s with ``|W'(s)| / W(s) = ratio`` [1/m] (bisection on [0, h); the ratio
    grows from 0 to infinity in s for the cubic, Wendland and poly6 kernels)."""
    a = 0.0
    b = h
    for _ in range(48):
        m = 0.5 * (a + b)
        w = kernel_w(kid, m, h, dim)
        g = -kernel_dw(kid, m, h, dim) * m
        if w > 0.0 and g < ratio * w:
            a = m
        else:
            b = m
    return 0.5 * (a + b)


@numba.njit(cache=True, fastmath=True, inline="always")
def place_virtual(i, x, rho, g0, g1, g2, h, kid, dim, xb, Vb):
    """Fluid particle i's virtual particle ``(xb[:, i], Vb[i])`` for the boundary density
    ``rho`` > 0 (in units of rho0) with gradient ``g`` at x_i (module docstring); none (``Vb[i]``
    left) where the kernel vanishes at s."""
    gl = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    s = virtual_distance(gl / rho, h, kid, dim)
    w = kernel_w(kid, s, h, dim)
    if w > 0.0:
        t = s / gl if gl > 0.0 else 0.0
        xb[0, i] = x[0, i] + t * g0
        xb[1, i] = x[1, i] + t * g1
        if dim == 3:
            xb[2, i] = x[2, i] + t * g2
        Vb[i] = rho / w
