"""Small rotation helpers shared by the renderer and the BVH exporter (numpy only)."""

from __future__ import annotations

import numpy as np


def _unit(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, 1e-12)


def _perpendicular(a: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to unit vector ``a`` (deterministic)."""
    axis = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    return _unit(np.cross(a, axis))


def frame_from(up, forward_hint) -> np.ndarray:
    """A rotation whose columns are (x, y, z) with y along ``up`` and z towards ``forward_hint``."""
    y = _unit(up)
    z = np.asarray(forward_hint, dtype=np.float64) - np.dot(forward_hint, y) * y
    if np.linalg.norm(z) < 1e-6:
        z = _perpendicular(y)
    z = _unit(z)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=1)


def transform(rotation: np.ndarray, translation) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = translation
    return m


# -- batched helpers (arrays of directions / rotations, leading axes broadcast) -------------------

def shortest_arcs(a, b) -> np.ndarray:
    """The rotations of least angle that turn directions ``a`` into ``b``: (..., 3) -> (..., 3, 3).

    For opposite directions (a 180 degree turn, where the axis is not unique) the axis is a
    fixed perpendicular of ``a``, so the result is deterministic."""
    a = _unit(np.asarray(a, dtype=np.float64))
    b = _unit(np.asarray(b, dtype=np.float64))
    a, b = np.broadcast_arrays(a, b)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)
    vx = np.zeros(a.shape[:-1] + (3, 3))
    vx[..., 0, 1], vx[..., 0, 2] = -v[..., 2], v[..., 1]
    vx[..., 1, 0], vx[..., 1, 2] = v[..., 2], -v[..., 0]
    vx[..., 2, 0], vx[..., 2, 1] = -v[..., 1], v[..., 0]
    flipped = c < -1.0 + 1e-9
    scale = 1.0 / np.where(flipped, 1.0, 1.0 + c)
    out = np.eye(3) + vx + (vx @ vx) * scale[..., None, None]
    if np.any(flipped):
        for idx in np.argwhere(np.atleast_1d(flipped)):
            i = tuple(idx) if a.ndim > 1 else ()
            axis = _perpendicular(a[i])
            out[i] = 2.0 * np.outer(axis, axis) - np.eye(3)
    return out


def triads(primary, secondary) -> np.ndarray:
    """Orthonormal frames (..., 3, 3), columns (x, y, z): y along ``primary``, x towards the
    part of ``secondary`` perpendicular to it, z = x cross y."""
    y = _unit(np.asarray(primary, dtype=np.float64))
    s = np.asarray(secondary, dtype=np.float64)
    x = _unit(s - np.sum(s * y, axis=-1, keepdims=True) * y)
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=-1)


def matrix_to_quat(m) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4) as (x, y, z, w), w >= 0."""
    m = np.asarray(m, dtype=np.float64)
    t = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    cand = np.stack([
        np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1], 1 + t], -1),
        np.stack([1 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2], m[..., 0, 1] + m[..., 1, 0],
                  m[..., 0, 2] + m[..., 2, 0], m[..., 2, 1] - m[..., 1, 2]], -1),
        np.stack([m[..., 0, 1] + m[..., 1, 0], 1 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2],
                  m[..., 1, 2] + m[..., 2, 1], m[..., 0, 2] - m[..., 2, 0]], -1),
        np.stack([m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1],
                  1 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2], m[..., 1, 0] - m[..., 0, 1]], -1),
    ], axis=-2)  # (..., 4 candidates, 4); the one with the largest norm is the stable one
    best = np.argmax(np.linalg.norm(cand, axis=-1), axis=-1)
    q = np.take_along_axis(cand, best[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0, -q, q)


def quat_to_matrix(q) -> np.ndarray:
    """Quaternions (..., 4) as (x, y, z, w) -> rotation matrices (..., 3, 3)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], axis=-2)


def continuous_quats(q) -> np.ndarray:
    """Flip signs along axis 0 so consecutive quaternions (T, ..., 4) lie in one hemisphere
    (interpolating players then take the short way between keys)."""
    q = np.array(q, dtype=np.float64)
    for t in range(1, q.shape[0]):
        flip = np.sum(q[t] * q[t - 1], axis=-1) < 0
        q[t][flip] = -q[t][flip]
    return q


def axis_rotations(axis, angles) -> np.ndarray:
    """Rotations (T, 3, 3) by ``angles`` (T,) radians about one unit ``axis`` (3,) (Rodrigues)."""
    a = np.asarray(axis, dtype=np.float64)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    t = np.asarray(angles, dtype=np.float64)[:, None, None]
    return np.eye(3) + np.sin(t) * k + (1.0 - np.cos(t)) * (k @ k)


def continuous_axis_angle(m) -> np.ndarray:
    """Rotation matrices (T, ..., 3, 3) -> axis-angle vectors (T, ..., 3) that never jump
    between frames: from sign-continuous quaternions (:func:`continuous_quats`), so an angle
    passing pi goes on to 2 pi instead of flipping the axis (2 pi apart from the previous
    frame's vector, a one-frame spin for a tool that interpolates them)."""
    q = continuous_quats(matrix_to_quat(m))
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., 3:4])
    return np.where(s > 1e-12, v / np.maximum(s, 1e-12) * angle, 2.0 * v)
