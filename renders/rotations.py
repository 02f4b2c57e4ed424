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


def shortest_arc(a, b) -> np.ndarray:
    """The 3x3 rotation of least angle that turns direction ``a`` into direction ``b``.

    For opposite directions (a 180 degree turn, where the axis is not unique) the axis is a
    fixed perpendicular of ``a``, so the result is deterministic.
    """
    a = _unit(a)
    b = _unit(b)
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if c < -1.0 + 1e-9:
        axis = _perpendicular(a)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx * (1.0 / (1.0 + c))


def frame_from(up, forward_hint) -> np.ndarray:
    """A rotation whose columns are (x, y, z) with y along ``up`` and z towards ``forward_hint``."""
    y = _unit(up)
    z = np.asarray(forward_hint, dtype=np.float64) - np.dot(forward_hint, y) * y
    if np.linalg.norm(z) < 1e-6:
        z = _perpendicular(y)
    z = _unit(z)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=1)


def align_z(direction) -> np.ndarray:
    """A rotation that turns +z into ``direction`` (for meshes built along +z)."""
    return shortest_arc(np.array([0.0, 0.0, 1.0]), direction)


def transform(rotation: np.ndarray, translation) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = translation
    return m
