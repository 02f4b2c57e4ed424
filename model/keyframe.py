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
from core.skeleton import REST_POSE, normalize_pose


def generate(inputs, *, mean_pose: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
    """Poses (T, 27) through the pose controls; deterministic (``seed`` unused).

    ``inputs`` is an :class:`~model.generate.EngineInputs` or a bare :class:`ControlArrays`.
    """
    from scipy.interpolate import PchipInterpolator

    arrays = inputs if isinstance(inputs, ControlArrays) else inputs.arrays
    mean = REST_POSE if mean_pose is None else np.asarray(mean_pose, np.float32)
    t_count = arrays.n_frames
    keys = np.flatnonzero(arrays.pose_mask > 0.5)
    values = arrays.pose[keys]
    if len(keys) == 0 or keys[0] != 0:
        keys = np.concatenate([[0], keys])
        values = np.concatenate([mean[None], values])
    if keys[-1] != t_count - 1:
        keys = np.concatenate([keys, [t_count - 1]])
        values = np.concatenate([values, mean[None]])
    if len(keys) == 1:
        return np.repeat(values, t_count, axis=0).astype(np.float32)
    spline = PchipInterpolator(keys, values, axis=0)
    out = normalize_pose(spline(np.arange(t_count)))
    out[keys] = normalize_pose(values)  # exact on the keys
    return out.astype(np.float32)
