"""The ``keyframe`` engine: SGToolkit's MANUAL condition.

Cubic-spline interpolation through the requested poses (every frame whose pose mask is set),
with the mean pose added as a key at the first and last frames when they are not controlled,
so nothing is extrapolated. The spline is the shape-preserving cubic Hermite kind (PCHIP): a
plain C2 spline through dense keys overshoots between distant keys and swings the arms
behind the body. Style controls are ignored, as in the paper's MANUAL condition.
"""

from __future__ import annotations

import numpy as np

from core.controls import ControlArrays
from core.skeleton import N_BONES, REST_POSE, normalize_pose


def generate(inputs, *, mean_pose: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
    """Poses (T, 27) through the pose controls; deterministic (``seed`` unused).

    ``inputs`` is an :class:`~model.generate.EngineInputs` or a bare :class:`ControlArrays`.
    """
    arrays = inputs if isinstance(inputs, ControlArrays) else inputs.arrays
    mean = REST_POSE if mean_pose is None else np.asarray(mean_pose, np.float32)
    t_count = arrays.n_frames
    bones = arrays.bones() > 0.5
    if (bones == bones[:, :1]).all():  # every controlled frame controls the whole pose
        return _through(np.flatnonzero(bones[:, 0]), arrays.pose, mean, t_count)
    out = np.empty((t_count, N_BONES * 3), np.float32)
    for b in range(N_BONES):  # a layered gesture: each bone through its own keys
        cols = slice(3 * b, 3 * b + 3)
        out[:, cols] = _through(np.flatnonzero(bones[:, b]), arrays.pose[:, cols], mean[cols], t_count, unit=False)
    return normalize_pose(out).astype(np.float32)


def _through(keys: np.ndarray, pose: np.ndarray, mean: np.ndarray, t_count: int, unit: bool = True) -> np.ndarray:
    """PCHIP through ``pose[keys]``, with ``mean`` added at the ends when they are not keys."""
    from scipy.interpolate import PchipInterpolator

    values = pose[keys]
    if len(keys) == 0 or keys[0] != 0:
        keys = np.concatenate([[0], keys])
        values = np.concatenate([mean[None], values])
    if keys[-1] != t_count - 1:
        keys = np.concatenate([keys, [t_count - 1]])
        values = np.concatenate([values, mean[None]])
    if len(keys) == 1:
        return np.repeat(values, t_count, axis=0).astype(np.float32)
    spline = PchipInterpolator(keys, values, axis=0)
    out = spline(np.arange(t_count))
    out[keys] = values  # exact on the keys
    return (normalize_pose(out) if unit else out).astype(np.float32)
