"""Rotations: the matrix of a rotation about an axis (Rodrigues' formula) and its application.

A rotation by the angle ``theta`` about the unit axis ``k`` (right-hand rule) is

    R = I + sin(theta) K + (1 - cos(theta)) K^2,        K = [k]_x (the cross-product matrix),

Rodrigues' formula, which is also the matrix exponential ``exp(theta K)``; a body turning at the
constant angular velocity ``omega`` is rotated by ``exp([omega]_x t)`` after the time t
(:func:`rotation_exp`). Every rotation of sphkit is built here: meshes placed in a scene
(:func:`sphkit.geometry.meshes.load_mesh`), particle files, emitter frames and the poses of
rigid bodies. The compiled :func:`rotate` and :func:`rotate_t` apply a 3x3 matrix (or its
transpose) to a vector given as three scalars inside compiled loops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np


def rotation_matrix(axis: Sequence[float] | np.ndarray, angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` [rad] about ``axis`` (Rodrigues' formula, right-hand rule).

    Args:
        axis: rotation axis, 3 components of any length (normalized here).
        angle: rotation angle [rad].

    Returns:
        The (3, 3) float64 rotation matrix; the identity when ``angle`` is 0 or ``axis`` has
        zero length.
    """
    a = np.asarray(axis, dtype=np.float64)
    n = float(np.linalg.norm(a))
    if angle == 0.0 or n == 0.0:
        return np.eye(3)
    k = a / n
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def rotation_exp(omega: Sequence[float] | np.ndarray, t: float) -> np.ndarray:
    """``exp([omega]_x t)``: the rotation by the angle ``|omega| t`` about ``omega`` (angular
    velocity [rad/s], 3 components) after the time ``t`` [s] (:func:`rotation_matrix`)."""
    w = np.asarray(omega, dtype=np.float64)
    return rotation_matrix(w, float(np.linalg.norm(w)) * t)


@numba.njit(cache=True, fastmath=True)
def rotate(R, a0, a1, a2):
    """``R a`` for a 3x3 R and the vector a given as three scalars."""
    return (R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2,
            R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2,
            R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2)


@numba.njit(cache=True, fastmath=True)
def rotate_t(R, a0, a1, a2):
    """``R^T a`` for a 3x3 R and the vector a given as three scalars."""
    return (R[0, 0] * a0 + R[1, 0] * a1 + R[2, 0] * a2,
            R[0, 1] * a0 + R[1, 1] * a1 + R[2, 1] * a2,
            R[0, 2] * a0 + R[1, 2] * a1 + R[2, 2] * a2)
