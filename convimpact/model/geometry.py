"""Dimension-generic rigid-body geometry: rotations and cross products, planar or spatial.

A planar mechanism lives in the x-y plane: positions are 2-vectors and angular quantities are
1-vectors (the z component). A spatial mechanism uses 3-vectors for both. Every function here
takes ``planar`` so that the kinematics code is written once for both cases and a planar scene
never pays for the third dimension.
"""

from __future__ import annotations

import numpy as np


def cross(planar: bool, w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``w x v`` for an angular vector ``w`` and a position-space vector ``v``.

    Planar: ``w`` has shape (1,) (or (1, n) columns), ``v`` (2,) (or (2, n)); the result is
    ``w (-v_y, v_x)``. Spatial: the ordinary cross product (columns along axis 0).
    """
    if planar:
        return w[0] * np.array([-v[1], v[0]])
    return cross3(w, v)


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product along axis 0 of 3-vectors or (3, n) columns (broadcasting), without the
    overhead of ``np.cross`` on tiny arrays."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def cross_ww(planar: bool, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for two angular vectors (zero in the plane, where all of them are along z)."""
    if planar:
        return np.zeros(np.broadcast_shapes(np.shape(a), np.shape(b)))
    return cross3(a, b)


def perp(v: np.ndarray) -> np.ndarray:
    """Planar rotation of ``v`` by +90 degrees: ``(-v_y, v_x)``."""
    return np.array([-v[1], v[0]])


def rot2(angle: float) -> np.ndarray:
    """2 x 2 rotation matrix by ``angle`` (radians, counter-clockwise)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def skew(w: np.ndarray) -> np.ndarray:
    """3 x 3 matrix with ``skew(w) @ v == np.cross(w, v)``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rot3(axis: np.ndarray, angle: float) -> np.ndarray:
    """3 x 3 rotation by ``angle`` about the unit vector ``axis`` (Rodrigues' formula)."""
    K = skew(axis)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def orthonormal_complement(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``t1, t2`` with ``(n, t1, t2)`` a right-handed orthonormal basis.

    ``t1`` is the projection onto the plane normal to ``n`` of the world axis least aligned
    with ``n`` (deterministic, smooth away from switching points).
    """
    e = np.zeros(3)
    e[int(np.argmin(np.abs(n)))] = 1.0
    t1 = e - (e @ n) * n
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)
