"""Monte Carlo surface tension of Zorilla, Ritter, Sappl, Rauch, Harders 2020 (survey Sec. 5.4,
SPlisHSPlasH ``surfaceTensionMethod`` 5).

Zorilla, Ritter, Sappl, Rauch, Harders 2020, "Accelerating Surface Tension Calculation in SPH
via Particle Classification and Monte Carlo Integration", Computers 9(2):23 (version "V2020"),
and its first version, Zorilla et al. 2019, CGVC (``V2019``), as SPlisHSPlasH implements them
(``SPlisHSPlasH/SurfaceTension/SurfaceTension_ZorillaRitter2020.cpp``; read, re-derived and
written anew here). With h the support radius, ``e_ij = x_j - x_i`` and n_i the number of fluid
neighbours of i (self excluded):

1. **Classification** (Sec. 3.1): ``c_i = |sum_j e_ij| / (h n_i)`` (the normalized offset of
   the neighbours' centre of mass); i is a surface candidate when ``n_i <= k c_i + d`` with
   the pre-trained slope ``k = 74.6888`` and the constant d (``surfTZRd``).
2. **Monte Carlo normal and curvature** (Sec. 3.2) of a candidate: S points ``h u_s`` on the
   sphere of radius ``r1 = h`` around i (``u_s``: unit vectors of a Halton sequence, or
   uniformly random), a point is *covered* when it lies within ``r2 = r_ratio h`` of a
   neighbour, ``|h u_s - e_ij| <= r2``. With the uncovered points U (fraction ``f = |U| / S``)
   the normal is ``n_i = sum_U u_s / |sum_U u_s|`` (outward) and the curvature, from the
   opening angle ``alpha`` of the uncovered cap (``cos alpha = 1 - 2 f`` on the sphere)::

       kappa_i = -2 / (h sqrt(1 - rho^2)) cos(alpha + asin rho),    rho = r2 / r1

   For a flat surface the cap angle is ``acos rho`` and kappa = 0; for a sphere of radius R the
   same construction (the fluid dilated by r2) gives ``cos alpha = rho - (1 - rho^2) h / (2R)``,
   and the formula above returns ``1/R`` to first order in h/R: the *mean* curvature in 3D
   (1/R of a sphere, half the sum of the principal curvatures). A candidate with no uncovered
   point is an inner particle after all (a false positive of the classifier) and gets no force.
3. **Smoothing** (V2019 and V2020): over the surface neighbours j (those with a normal), with
   the weight ``w_ij = 1 - |e_ij| / h`` and ``tau`` (``surfTZRtau``)::

       n~_i = normalize((1 - tau) n_i + tau normalize(sum_j w_ij n_j))
       kappa~_i = ((1 - tau) kappa_i + tau sum_j w_ij kappa_j) / ((1 - tau) + tau sum_j w_ij)

4. **PCA** (V2020 only, ``normal_mode`` "pca" or "mix"): the surface neighbours and the
   neighbours that pass the classifier with ``d + d_offset`` (against i's neighbour count, as
   in SPlisHSPlasH) form a point set; its centroid c includes x_i; the nearest
   ``neighbour_limit`` of them give the weighted covariance ``T = sum_j (W(|x_j - c|)/W(0))
   (x_j - c)(x_j - c)^T`` (cubic spline shape). With at least dim + 1 points the eigenvector of
   the smallest eigenvalue, oriented along n_i, is the PCA normal and ``s_i = dim lambda_min /
   tr T`` (the surface variation) its curvature, negative where the neighbours' centre lies on
   the outer side. Then ``s~_i = 0.75 mean_j s_j`` over the surface neighbours, scaled to a
   curvature ``20 s~_i / h`` and clamped to ``|.| <= 0.5 / h``.
5. **Blend** (V2020): "mc" uses (n~, kappa~); "pca" uses the PCA normal and curvature; "mix"
   uses ``normalize(m_n n_pca + (1 - m_n) n~)`` and, where ``kappa~ >= 0``,
   ``m_c kappa_pca + (1 - m_c) kappa~`` (else kappa~), falling back to (n~, kappa~) where PCA
   had too few points. ``temporal_smoothing``: ``K_i = 0.05 kappa + 0.95 K_i(previous step)``
   (inner particles decay with 0.95).
6. **Force** on each surface particle: ``a_i -= (gamma / m_i) K_i N_i`` with gamma =
   ``surfaceTension`` (``coefficient``). Inner particles get none.

Units and what gamma means: ``gamma K`` is a force [N], so gamma is in N m in 3D (N per unit
depth times m, i.e. N, in 2D with sphkit's per-depth masses). The force of one surface particle
stands for ``sigma (dim - 1) K A_i`` of a surface of tension sigma with the area (2D: length)
``A_i`` per surface particle, so ``sigma ~ gamma / ((dim - 1) A_i)``; with ``A_i ~ (2r)^(dim-1)``
the nominal tension is :meth:`ZorillaRitter2020.nominal_sigma`. Measured on relaxed drops
(validation/surface_tension.py, validation/README.md), the model's force per area of the drop,
``p_F = sum_i m_i a_r,i / (area of the sphere (circle) of the drop's volume radius R)``, follows
``p0 + (dim - 1) sigma_F / R`` with ``sigma_F`` = 0.95-1.00 (2D) and 1.00-1.05 (3D) times the
nominal sigma, plus a constant ``p0 = (dim - 1) sigma_F c0``: the Monte Carlo cover reads a flat
surface as curved by ``c0`` of about 0.08/h (2D) and 0.12/h (3D) (the gaps between the
neighbours' spheres leave samples uncovered), which pushes the whole drop like an extra
pressure and does not act on its shape modes; the mode-2 oscillation of a 3D drop has Rayleigh's
frequency of sigma_F within 10 %.

Conservation: the force is not a pair force. Linear momentum is conserved only as far as the
surface integral ``oint K N dA`` vanishes for a closed surface (it does in the continuum); the
discrete sum is a few per cent of the summed magnitudes (tests/test_surface_tension_zorilla.py).

2D: SPlisHSPlasH's implementation always samples the 3D sphere (its Halton table and random
points are 3D vectors). In a 2D simulation (all particles at z = 0) the points with
``|z| > r2`` are never covered, so every candidate, inner ones included, would get a normal and
a curvature of about ``1/h``: the method is 3D-only there. sphkit's 2D version samples the
circle of radius h instead (Halton base 2 / uniform angles), reads the cap angle from the
uncovered arc, ``alpha = pi f``, and uses the same curvature formula (the construction in item 2
is planar, so it holds unchanged in 2D and returns the curvature 1/R of a circle). The
classifier keeps d and k: a full 2D neighbourhood (about 12 neighbours at h = 4r) lies below
d = 12, so in 2D (nearly) every particle is a candidate and the Monte Carlo cover test alone
separates inner from surface particles (correct, only not accelerated). The PCA surface
variation uses ``dim lambda_min / tr T`` (3 lambda / tr in 3D as in SPlisHSPlasH).

Differences from SPlisHSPlasH (all documented here, none changes a default run):

* sample sets: particle i uses the S consecutive points of the precomputed table that start at
  ``id_i S`` (stable particle ids, so reordering does not change the result; SPlisHSPlasH
  starts particle i at ``i S / 3`` of its own Halton table). "Random" sampling uses a
  precomputed table of uniformly random directions (seeded) with an offset that changes every
  step instead of ``rand()``: runs are reproducible;
* eigenvalues below ``1e-6 tr T`` are set to 0 (SPlisHSPlasH: below 1e-6 m^2, which depends on
  the scale of the scene);
* ``smooth_passes`` > 1 repeats the neighbour averaging of s (item 4); SPlisHSPlasH's loop also
  re-scales s and adds the force once per pass.

Defaults (SPlisHSPlasH, ``reference/methods.md`` K4): gamma 0.05, version V2020, Csd 10000
samples per second, fixed samples -1 (use ``Csd dt``), r_ratio 0.8, tau 0.5, d 12,
d_offset 2, normal mode 1 (Monte Carlo), Halton sampling, PcaMixNrm 0.75, PcaMixCur 0.5,
neighbour limit 13, smooth passes 0 (one pass runs), no temporal smoothing.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.core.eigen import smallest_eigen
from sphkit.core.kernels import CUBIC, kernel_w
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import delta, pair_slots, point
from sphkit.core.params import checked_number
from sphkit.core.state import SimState

#: slope of the linear surface classifier (pre-trained, Zorilla et al. 2020)
CLASS_K = 74.688796680497925
#: size of the precomputed Halton table (directions) and of the random table
HALTON_TABLE = 4096
RANDOM_TABLE = 65536
#: normal modes (SPlisHSPlasH ``surfTZRnormal-mode``)
NORMAL_MODES = {"pca": 0, "mc": 1, "mix": 2}
#: versions (SPlisHSPlasH ``surfTZRversion``)
VERSIONS = {"v2019": 0, "v2020": 1}
SAMPLINGS = {"halton": 0, "random": 1}


def _radical_inverse(k: np.ndarray, base: int) -> np.ndarray:
    """Van der Corput radical inverse of the integers ``k`` in ``base``."""
    k = k.astype(np.int64).copy()
    out = np.zeros(k.shape)
    f = 1.0 / base
    while np.any(k > 0):
        out += f * (k % base)
        k //= base
        f /= base
    return out


def halton_directions(n: int, dim: int) -> np.ndarray:
    """(3, n) unit vectors of the Halton sequence (index 1..n): in 3D ``theta = 2 pi H_2``,
    ``cos phi = 1 - 2 H_3`` (uniform on the sphere); in 2D the angle ``2 pi H_2`` (z = 0)."""
    k = np.arange(1, n + 1)
    theta = 2.0 * np.pi * _radical_inverse(k, 2)
    out = np.zeros((3, n))
    if dim == 2:
        out[0], out[1] = np.cos(theta), np.sin(theta)
        return out
    cphi = 1.0 - 2.0 * _radical_inverse(k, 3)
    sphi = np.sqrt(np.maximum(1.0 - cphi * cphi, 0.0))
    out[0], out[1], out[2] = sphi * np.cos(theta), sphi * np.sin(theta), cphi
    return out


def random_directions(n: int, dim: int, seed: int = 2020) -> np.ndarray:
    """(3, n) uniformly random unit vectors (circle in 2D, sphere in 3D), seeded."""
    rng = np.random.default_rng(seed)
    out = np.zeros((3, n))
    if dim == 2:
        t = 2.0 * np.pi * rng.random(n)
        out[0], out[1] = np.cos(t), np.sin(t)
        return out
    v = rng.normal(size=(3, n))
    return v / np.linalg.norm(v, axis=0)


@numba.njit(cache=True, fastmath=True, inline="always")
def _classify(com, count, k, d):
    """The linear classifier: surface candidate when ``count <= k com + d``."""
    return count <= k * com + d


@numba.njit(cache=True, fastmath=True, inline="always")
def mc_curvature(f, rho, h, dim):
    """Curvature [1/m] from the uncovered fraction ``f`` of the samples (module docstring,
    item 2): the cap angle alpha (``cos alpha = 1 - 2f`` in 3D, ``alpha = pi f`` in 2D) and
    ``-2 / (h sqrt(1 - rho^2)) cos(alpha + asin rho)``."""
    if dim == 3:
        alpha = math.acos(min(max(1.0 - 2.0 * f, -1.0), 1.0))
    else:
        alpha = math.pi * f
    return -2.0 / (h * math.sqrt(1.0 - rho * rho)) * math.cos(alpha + math.asin(rho))


@numba.njit(parallel=True, cache=True, fastmath=True)
def _mc_pass(x, ids, off, idx, dirs, nsamp, shift, h, rho, k_class, d_class, dim, L,
             mc_n, mc_k, com, cls):
    """Pass 1: classifier input ``com``, and for candidates the Monte Carlo normal ``mc_n``
    (zero for inner particles), curvature ``mc_k`` and class (0 inner, 0.5 corrected false
    positive, 1 surface)."""
    ntab = dirs.shape[1]
    r2sq = (rho * h) * (rho * h)
    for i in numba.prange(x.shape[1]):
        for c in range(dim):
            mc_n[c, i] = 0.0
        mc_k[i] = 0.0
        cls[i] = 0.0
        nn = off[i + 1] - off[i]
        com[i] = 0.0
        if nn == 0:
            continue
        xi0, xi1, xi2 = point(x, i, dim)
        s0 = s1 = s2 = 0.0
        for kk in pair_slots(off, i):
            d0, d1, d2 = delta(xi0, xi1, xi2, x, idx[kk], dim, L)
            s0 -= d0
            s1 -= d1
            s2 -= d2
        com[i] = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2) / (h * nn)
        if not _classify(com[i], nn, k_class, d_class) or nsamp <= 0:
            continue
        base = (ids[i] * nsamp + shift) % ntab
        u0 = u1 = u2 = 0.0
        free = 0
        for s in range(nsamp):
            q = (base + s) % ntab
            p0 = h * dirs[0, q]
            p1 = h * dirs[1, q]
            p2 = h * dirs[2, q]
            covered = False
            for kk in pair_slots(off, i):
                d0, d1, d2 = delta(xi0, xi1, xi2, x, idx[kk], dim, L)
                # sample minus e_ij = p - (x_j - x_i) = p + d
                t0 = p0 + d0
                t1 = p1 + d1
                t2 = p2 + d2
                if t0 * t0 + t1 * t1 + t2 * t2 <= r2sq:
                    covered = True
                    break
            if not covered:
                free += 1
                u0 += dirs[0, q]
                u1 += dirs[1, q]
                u2 += dirs[2, q]
        ln = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if free == 0 or ln == 0.0:
            cls[i] = 0.5
            continue
        mc_n[0, i] = u0 / ln
        mc_n[1, i] = u1 / ln
        if dim == 3:
            mc_n[2, i] = u2 / ln
        mc_k[i] = mc_curvature(free / nsamp, rho, h, dim)
        cls[i] = 1.0


@numba.njit(cache=True, fastmath=True, inline="always")
def _is_surface(mc_n, j, dim):
    z = mc_n[0, j] != 0.0 or mc_n[1, j] != 0.0
    if dim == 3:
        z = z or mc_n[2, j] != 0.0
    return z


@numba.njit(parallel=True, cache=True, fastmath=True)
def _smooth_pass(x, off, idx, mc_n, mc_k, com, tau, h, k_class, d_pca, do_pca, limit, dim,
                 L, n_s, k_s, pca_n, pca_k):
    """Pass 2 (surface particles): the smoothed Monte Carlo normal ``n_s`` and curvature
    ``k_s`` (item 3) and, with ``do_pca``, the PCA normal and surface variation (item 4)."""
    w0 = kernel_w(CUBIC, 0.0, h, dim)
    for i in numba.prange(x.shape[1]):
        for c in range(dim):
            n_s[c, i] = 0.0
            pca_n[c, i] = 0.0
        k_s[i] = 0.0
        pca_k[i] = 0.0
        if not _is_surface(mc_n, i, dim):
            continue
        xi0, xi1, xi2 = point(x, i, dim)
        nn = off[i + 1] - off[i]
        c0 = c1 = c2 = 0.0  # centroid relative to x_i
        g0 = g1 = g2 = 0.0  # direction to the surface neighbours
        m0 = m1 = m2 = 0.0
        kc = 0.0
        wsum = 0.0
        npts = 0
        for kk in pair_slots(off, i):
            j = idx[kk]
            surf = _is_surface(mc_n, j, dim)
            cand = surf or (do_pca and _classify(com[j], nn, k_class, d_pca))
            if not cand:
                continue
            d0, d1, d2 = delta(xi0, xi1, xi2, x, j, dim, L)
            c0 -= d0
            c1 -= d1
            c2 -= d2
            npts += 1
            if surf:
                r = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                w = 1.0 - r / h
                m0 += w * mc_n[0, j]
                m1 += w * mc_n[1, j]
                if dim == 3:
                    m2 += w * mc_n[2, j]
                kc += w * mc_k[j]
                wsum += w
        ln = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        if ln > 0.0:
            m0 /= ln
            m1 /= ln
            m2 /= ln
        g0, g1, g2 = c0, c1, c2
        s0 = (1.0 - tau) * mc_n[0, i] + tau * m0
        s1 = (1.0 - tau) * mc_n[1, i] + tau * m1
        s2 = ((1.0 - tau) * mc_n[2, i] if dim == 3 else 0.0) + tau * m2
        ln = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        if ln > 0.0:
            n_s[0, i] = s0 / ln
            n_s[1, i] = s1 / ln
            if dim == 3:
                n_s[2, i] = s2 / ln
        k_s[i] = ((1.0 - tau) * mc_k[i] + tau * kc) / ((1.0 - tau) + tau * wsum)
        if not do_pca or npts < dim + 1:
            continue
        c0 /= npts + 1
        c1 /= npts + 1
        c2 /= npts + 1
        # weighted covariance of the nearest `limit` candidates (by distance to x_i, ties by
        # index), selected without a buffer: each round takes the next larger (r, j)
        a00 = a01 = a02 = a11 = a12 = a22 = 0.0
        last_r = -1.0
        last_j = -1
        for _ in range(min(limit, npts)):
            best_r = 1e300
            best_j = -1
            for kk in pair_slots(off, i):
                j = idx[kk]
                if not (_is_surface(mc_n, j, dim) or _classify(com[j], nn, k_class, d_pca)):
                    continue
                d0, d1, d2 = delta(xi0, xi1, xi2, x, j, dim, L)
                r = d0 * d0 + d1 * d1 + d2 * d2
                later = r > last_r or (r == last_r and j > last_j)
                if later and (r < best_r or (r == best_r and j < best_j)):
                    best_r = r
                    best_j = j
            if best_j < 0:
                break
            last_r = best_r
            last_j = best_j
            d0, d1, d2 = delta(xi0, xi1, xi2, x, best_j, dim, L)
            e0 = -d0 - c0
            e1 = -d1 - c1
            e2 = -d2 - c2
            w = kernel_w(CUBIC, math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), h, dim) / w0
            a00 += w * e0 * e0
            a01 += w * e0 * e1
            a02 += w * e0 * e2
            a11 += w * e1 * e1
            a12 += w * e1 * e2
            a22 += w * e2 * e2
        lam, tr, v0, v1, v2 = smallest_eigen(a00, a01, a02, a11, a12, a22, dim)
        if tr <= 0.0 or (v0 == 0.0 and v1 == 0.0 and v2 == 0.0):
            continue
        if v0 * mc_n[0, i] + v1 * mc_n[1, i] + (v2 * mc_n[2, i] if dim == 3 else 0.0) < 0.0:
            v0, v1, v2 = -v0, -v1, -v2
        pca_n[0, i] = v0
        pca_n[1, i] = v1
        if dim == 3:
            pca_n[2, i] = v2
        s = dim * lam / tr
        if g0 * v0 + g1 * v1 + g2 * v2 > 0.0:
            s = -s
        pca_k[i] = s


@numba.njit(parallel=True, cache=True, fastmath=True)
def _pca_average(off, idx, mc_n, src, first, dim, out):
    """One neighbour averaging of the surface variation (item 4): ``out_i = 0.25 src_i (not on
    the first pass) + 0.75 mean_j src_j`` over the surface neighbours (``src_i`` without
    any)."""
    for i in numba.prange(mc_n.shape[1]):
        out[i] = 0.0
        if not _is_surface(mc_n, i, dim):
            continue
        cnt = 0
        s = 0.0
        for kk in pair_slots(off, i):
            j = idx[kk]
            if _is_surface(mc_n, j, dim):
                s += src[j]
                cnt += 1
        if cnt > 0:
            out[i] = (0.0 if first else 0.25 * src[i]) + 0.75 * s / cnt
        else:
            out[i] = src[i]


@numba.njit(parallel=True, cache=True, fastmath=True)
def _force_pass(m, mc_n, n_s, k_s, pca_n, pca_s, mode, mix_n, mix_c, temporal, gamma, h, dim,
                nrm, curv, a):
    """Pass 3: blend (item 5), temporal smoothing and the force (item 6); writes the final
    normal ``nrm`` and curvature ``curv`` (``curv`` holds the previous step's on entry)."""
    for i in numba.prange(m.shape[0]):
        if not _is_surface(mc_n, i, dim):
            curv[i] = 0.95 * curv[i] if temporal else 0.0
            for c in range(dim):
                nrm[c, i] = 0.0
            continue
        ps = min(max(pca_s[i] * 20.0 / h, -0.5 / h), 0.5 / h)
        f0 = n_s[0, i]
        f1 = n_s[1, i]
        f2 = n_s[2, i] if dim == 3 else 0.0
        kap = k_s[i]
        has_pca = _is_surface(pca_n, i, dim)
        if mode == 0:  # PCA
            f0 = pca_n[0, i]
            f1 = pca_n[1, i]
            f2 = pca_n[2, i] if dim == 3 else 0.0
            kap = ps
        elif mode == 2 and has_pca:  # MIX
            f0 = mix_n * pca_n[0, i] + (1.0 - mix_n) * f0
            f1 = mix_n * pca_n[1, i] + (1.0 - mix_n) * f1
            if dim == 3:
                f2 = mix_n * pca_n[2, i] + (1.0 - mix_n) * f2
            ln = math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
            if ln > 0.0:
                f0 /= ln
                f1 /= ln
                f2 /= ln
            if kap >= 0.0:
                kap = mix_c * ps + (1.0 - mix_c) * kap
        if temporal:
            kap = 0.05 * kap + 0.95 * curv[i]
        curv[i] = kap
        nrm[0, i] = f0
        nrm[1, i] = f1
        if dim == 3:
            nrm[2, i] = f2
        c = gamma * kap / m[i]
        a[0, i] -= c * f0
        a[1, i] -= c * f1
        if dim == 3:
            a[2, i] -= c * f2


def _number(what: str, value: Any, lo: float, hi: float, expected: str) -> float:
    return checked_number(f"surface tension (zorilla2020): {what}", value, lo, hi, expected)


def _choice(what: str, value: Any, table: dict[str, int]) -> int:
    if isinstance(value, str) and value in table:
        return table[value]
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and \
            value in table.values():
        return int(value)
    raise ValueError(f"surface tension (zorilla2020): {what}: {value!r}; expected one of "
                     f"{sorted(table)} (or their numbers {sorted(table.values())})")


class ZorillaRitter2020(NonPressureForce):
    """Monte Carlo surface tension of Zorilla, Ritter et al. 2020 (module docstring).

    ``coefficient``: gamma [N m in 3D, N in 2D] (SPlisHSPlasH ``surfaceTension``; see
    :meth:`nominal_sigma`); ``boundary_coefficient`` is accepted and unused (the model has no
    adhesion; SPlisHSPlasH reads and ignores it too). The other arguments are SPlisHSPlasH's
    ``surfTZR*`` parameters (names in the module docstring). Registers the fluid fields
    ``normal`` (the final unit normal N, zero inside, 'vector'), ``curvature`` (the final K
    [1/m]) and ``surface_class`` (0 inner, 0.5 corrected false positive, 1 surface).
    """

    name = "zorilla2020"

    @classmethod
    def from_config(cls, p: Any) -> ZorillaRitter2020:
        """The ZorillaRitter2020 of a material's ``surface_tension`` (scene model)."""
        z = p.zorilla2020
        return cls(p.coefficient, p.boundary_coefficient, version=z.version,
                   samples_per_second=z.samples_per_second, samples=z.samples,
                   r_ratio=z.r_ratio, tau=z.tau, classifier_d=z.classifier_d,
                   d_offset=z.d_offset, sampling=z.sampling, normal_mode=z.normal_mode,
                   pca_mix_normal=z.pca_mix_normal, pca_mix_curvature=z.pca_mix_curvature,
                   neighbour_limit=z.neighbour_limit, smooth_passes=z.smooth_passes,
                   temporal_smoothing=z.temporal_smoothing)

    def __init__(self, coefficient: float = 0.05, boundary_coefficient: float = 0.0, *,
                 version: str | int = "v2020", samples_per_second: float = 10000.0,
                 samples: int = -1, r_ratio: float = 0.8, tau: float = 0.5,
                 classifier_d: float = 12.0, d_offset: float = 2.0,
                 sampling: str | int = "halton", normal_mode: str | int = "mc",
                 pca_mix_normal: float = 0.75, pca_mix_curvature: float = 0.5,
                 neighbour_limit: int = 13, smooth_passes: int = 0,
                 temporal_smoothing: bool = False) -> None:
        self.coefficient = _number("coefficient", coefficient, 0.0, math.inf,
                                   "a finite gamma >= 0 [N m in 3D, N in 2D]")
        self.boundary_coefficient = _number("boundary_coefficient", boundary_coefficient, 0.0,
                                            math.inf, "a finite number >= 0 (unused)")
        self.version = _choice("version", version, VERSIONS)
        self.samples_per_second = _number("samples_per_second", samples_per_second, 0.0,
                                          math.inf, "a finite number >= 0 [1/s]")
        if int(samples) != samples or samples == 0 or samples < -1:
            raise ValueError(f"surface tension (zorilla2020): samples: {samples!r}; expected a "
                             "positive integer, or -1 (samples_per_second * dt)")
        self.samples = int(samples)
        self.r_ratio = _number("r_ratio", r_ratio, 0.0, 1.0, "a number in (0, 1)")
        if not 0.0 < self.r_ratio < 1.0:
            raise ValueError(f"surface tension (zorilla2020): r_ratio: {r_ratio!r}; expected a "
                             "number in (0, 1)")
        self.tau = _number("tau", tau, 0.0, 1.0, "a number in [0, 1)")
        if self.tau >= 1.0:
            raise ValueError(f"surface tension (zorilla2020): tau: {tau!r}; expected a number "
                             "in [0, 1)")
        self.classifier_d = _number("classifier_d", classifier_d, -math.inf, math.inf,
                                    "a finite number")
        self.d_offset = _number("d_offset", d_offset, -math.inf, math.inf, "a finite number")
        self.sampling = _choice("sampling", sampling, SAMPLINGS)
        self.normal_mode = _choice("normal_mode", normal_mode, NORMAL_MODES)
        self.pca_mix_normal = _number("pca_mix_normal", pca_mix_normal, 0.0, 1.0,
                                      "a number in [0, 1]")
        self.pca_mix_curvature = _number("pca_mix_curvature", pca_mix_curvature, 0.0, 1.0,
                                         "a number in [0, 1]")
        if int(neighbour_limit) != neighbour_limit or neighbour_limit < 1:
            raise ValueError(f"surface tension (zorilla2020): neighbour_limit: "
                             f"{neighbour_limit!r}; expected an integer >= 1")
        self.neighbour_limit = int(neighbour_limit)
        if int(smooth_passes) != smooth_passes or smooth_passes < 0:
            raise ValueError(f"surface tension (zorilla2020): smooth_passes: {smooth_passes!r};"
                             " expected an integer >= 0")
        self.smooth_passes = int(smooth_passes)
        self.temporal_smoothing = bool(temporal_smoothing)
        self._dirs: np.ndarray | None = None
        self._dim = 0

    def nominal_sigma(self, r: float, dim: int) -> float:
        """The surface tension [N/m in 3D, N in 2D] that gamma stands for when each surface
        particle carries the area ``(2r)^2`` (3D; the length 2r in 2D):
        ``gamma / ((dim - 1) (2r)^(dim - 1))`` (module docstring, "Units")."""
        return self.coefficient / ((dim - 1) * (2.0 * r) ** (dim - 1))

    def sample_count(self, dt: float) -> int:
        """Monte Carlo samples per particle this step: ``samples`` when positive, else
        ``int(samples_per_second * dt)`` (SPlisHSPlasH; V2019 always uses the latter)."""
        if self.samples > 0 and self.version == 1:
            return self.samples
        return int(self.samples_per_second * dt)

    def init(self, state: SimState) -> None:
        """Register ``normal``, ``curvature`` and ``surface_class`` and build the sample
        table (Halton or random directions, once)."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"surface tension (zorilla2020): dimension {state.dim}; expected 2 or 3")
        f = state.fluid
        f.register("normal", "vector")
        f.register("curvature")
        f.register("surface_class")
        random = self.version == 0 or self.sampling == 1
        self._dirs = (random_directions(RANDOM_TABLE, state.dim) if random
                      else halton_directions(HALTON_TABLE, state.dim))
        self._dim = state.dim

    def apply(self, state: SimState, dt: float) -> None:
        """Classify, sample, smooth, blend and add the force (module docstring, items 1-6)."""
        f = state.fluid
        if f.n == 0:
            return
        if self._dirs is None or self._dim != state.dim or "surface_class" not in f:
            self.init(state)
        dirs = self._dirs
        dim, h, L, n = state.dim, state.h, state.period, f.n
        nl = state.nl_ff
        x = f["x"]
        nsamp = self.sample_count(dt)
        random = self.version == 0 or self.sampling == 1
        shift = (state.step * 7919 * max(nsamp, 1)) % dirs.shape[1] if random else 0
        mc_n = np.empty((dim, n))
        mc_k, com = np.empty(n), np.empty(n)
        _mc_pass(x, f["id"], nl.offsets, nl.indices, dirs, nsamp, shift, h, self.r_ratio,
                 CLASS_K, self.classifier_d, dim, L, mc_n, mc_k, com, f["surface_class"])
        v2020 = self.version == 1
        do_pca = v2020 and self.normal_mode != 1
        n_s, pca_n = np.empty((dim, n)), np.empty((dim, n))
        k_s, pca_k = np.empty(n), np.empty(n)
        _smooth_pass(x, nl.offsets, nl.indices, mc_n, mc_k, com, self.tau, h, CLASS_K,
                     self.classifier_d + self.d_offset, do_pca, self.neighbour_limit, dim, L,
                     n_s, k_s, pca_n, pca_k)
        pca_s = np.zeros(n)
        if do_pca:
            pca_s = pca_k
            for p in range(max(1, self.smooth_passes)):
                out = np.empty(n)
                _pca_average(nl.offsets, nl.indices, mc_n, pca_s, p == 0, dim, out)
                pca_s = out
        mode = self.normal_mode if v2020 else 1
        temporal = v2020 and self.temporal_smoothing
        _force_pass(f["m"], mc_n, n_s, k_s, pca_n, pca_s, mode, self.pca_mix_normal,
                    self.pca_mix_curvature, temporal, self.coefficient, h, dim, f["normal"],
                    f["curvature"], f["a"])


__all__ = ["CLASS_K", "ZorillaRitter2020", "halton_directions", "mc_curvature",
           "random_directions"]
