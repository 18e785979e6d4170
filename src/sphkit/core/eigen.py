"""Eigen decomposition of small symmetric matrices inside compiled per-particle loops.

Scalar in, scalars out (no arrays, nothing allocated), so that a kernel body can call it for
the covariance of a neighbourhood (the PCA normals of
:mod:`sphkit.surface_tension.zorilla2020`). 3x3: the closed-form roots of the characteristic
polynomial (trigonometric form for a symmetric matrix) and the eigenvector from the largest
cross product of two rows of ``A - lambda I``; 2x2: the closed form.
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, fastmath=True)
def smallest_eigen(a00, a01, a02, a11, a12, a22, dim):
    """(lambda_min, trace, v0, v1, v2) of a symmetric positive semi-definite matrix (2x2 from
    the a00, a01, a11 entries when dim == 2): the smallest eigenvalue (set to 0 below 1e-6 of
    the trace) and a unit eigenvector of it (zero when it is not unique enough to find)."""
    if dim == 2:
        tr = a00 + a11
        mean = 0.5 * tr
        rad = math.sqrt(0.25 * (a00 - a11) * (a00 - a11) + a01 * a01)
        lam = mean - rad
        x0, x1 = a01, lam - a00
        y0, y1 = lam - a11, a01
        if x0 * x0 + x1 * x1 >= y0 * y0 + y1 * y1:
            v0, v1 = x0, x1
        else:
            v0, v1 = y0, y1
        ln = math.sqrt(v0 * v0 + v1 * v1)
        if ln <= 1e-12 * max(tr, 1e-300):
            return lam, tr, 0.0, 0.0, 0.0
        if abs(lam) < 1e-6 * tr:
            lam = 0.0
        return lam, tr, v0 / ln, v1 / ln, 0.0
    tr = a00 + a11 + a22
    q = tr / 3.0
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    p = math.sqrt(p2 / 6.0)
    if p <= 1e-300:
        return q, tr, 0.0, 0.0, 0.0
    c00, c11, c22 = b00 / p, b11 / p, b22 / p
    c01, c02, c12 = a01 / p, a02 / p, a12 / p
    detb = (c00 * (c11 * c22 - c12 * c12) - c01 * (c01 * c22 - c12 * c02)
            + c02 * (c01 * c12 - c11 * c02))
    r = min(max(0.5 * detb, -1.0), 1.0)
    phi = math.acos(r) / 3.0
    lam = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)  # the smallest root
    # eigenvector: the largest cross product of two rows of (A - lam I)
    r00, r11, r22 = a00 - lam, a11 - lam, a22 - lam
    x0 = a01 * a12 - a02 * r11
    x1 = a02 * a01 - r00 * a12
    x2 = r00 * r11 - a01 * a01
    y0 = a01 * r22 - a02 * a12
    y1 = a02 * a02 - r00 * r22
    y2 = r00 * a12 - a01 * a02
    z0 = r11 * r22 - a12 * a12
    z1 = a12 * a02 - a01 * r22
    z2 = a01 * a12 - r11 * a02
    nx = x0 * x0 + x1 * x1 + x2 * x2
    ny = y0 * y0 + y1 * y1 + y2 * y2
    nz = z0 * z0 + z1 * z1 + z2 * z2
    if nx >= ny and nx >= nz:
        v0, v1, v2, ln2 = x0, x1, x2, nx
    elif ny >= nz:
        v0, v1, v2, ln2 = y0, y1, y2, ny
    else:
        v0, v1, v2, ln2 = z0, z1, z2, nz
    if ln2 <= 1e-24 * tr * tr * tr * tr or ln2 <= 0.0:
        return lam, tr, 0.0, 0.0, 0.0
    ln = math.sqrt(ln2)
    if abs(lam) < 1e-6 * tr:
        lam = 0.0
    return lam, tr, v0 / ln, v1 / ln, v2 / ln


__all__ = ["smallest_eigen"]
