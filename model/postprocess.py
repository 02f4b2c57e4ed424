"""Post-processing of generated motion, each step switchable.

- :func:`one_euro`: the 1-euro filter (Casiez et al. 2012), speed-adaptive low-pass: little lag
  on fast strokes, strong smoothing when the motion is slow (Kucherenko et al. 6: smoothing
  changes what people perceive more than the model does).
- :func:`moving_average`: a centred moving average (the simpler smoother Kucherenko et al. use).
- :func:`blend_pose_controls`: the exact pose-control blend. Where a pose is requested the
  output *is* that pose; in ``ramp`` frames before and after each controlled span the output
  eases from the generated motion into the requested one (smoothstep weights), so there is no
  jump. SGToolkit lists imperfect pose following as its main limitation; this removes it.

All work on poses (T, 27) of unit bone directions and return renormalised poses.
"""

from __future__ import annotations

import math

import numpy as np

from core.skeleton import FPS, normalize_pose


def moving_average(poses: np.ndarray, window: int = 5) -> np.ndarray:
    """Centred moving average over ``window`` frames (odd; cut at the ends)."""
    p = np.asarray(poses, np.float64)
    if window <= 1 or len(p) < 2:
        return np.asarray(poses, np.float32).copy()
    half = window // 2
    c = np.concatenate([np.zeros((1, p.shape[1])), np.cumsum(p, axis=0)])
    idx = np.arange(len(p))
    lo = np.clip(idx - half, 0, len(p))
    hi = np.clip(idx + half + 1, 0, len(p))
    out = (c[hi] - c[lo]) / (hi - lo)[:, None]
    return normalize_pose(out)


#: 1-euro settings of the shipped engine, chosen on the validation split with
#: scripts/tune_smoothing.py (jerk within 25% of the reference while keeping style; docs/model.md).
ONE_EURO_MIN_CUTOFF = 4.0
ONE_EURO_BETA = 0.5


def one_euro(poses: np.ndarray, min_cutoff: float = ONE_EURO_MIN_CUTOFF, beta: float = ONE_EURO_BETA,
             d_cutoff: float = 1.0, fps: float = FPS) -> np.ndarray:
    """The 1-euro filter on every coordinate (cutoffs in Hz)."""
    x = np.asarray(poses, np.float64)
    if len(x) < 2:
        return np.asarray(poses, np.float32).copy()

    def alpha(cutoff):
        tau = 1.0 / (2 * math.pi * cutoff)
        return 1.0 / (1.0 + tau * fps)

    out = np.empty_like(x)
    out[0] = x[0]
    dx_prev = np.zeros(x.shape[1])
    a_d = alpha(d_cutoff)
    for i in range(1, len(x)):
        dx = (x[i] - out[i - 1]) * fps
        dx_hat = a_d * dx + (1 - a_d) * dx_prev
        cutoff = min_cutoff + beta * np.abs(dx_hat)
        tau = 1.0 / (2 * math.pi * cutoff)
        a = 1.0 / (1.0 + tau * fps)
        out[i] = a * x[i] + (1 - a) * out[i - 1]
        dx_prev = dx_hat
    return normalize_pose(out)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def blend_weights(mask: np.ndarray, ramp: int = 6) -> np.ndarray:
    """Per-frame weight of the requested pose: 1 on controlled frames, easing to 0 over ``ramp`` frames."""
    m = np.asarray(mask) > 0.5
    t = len(m)
    if not m.any():
        return np.zeros(t, np.float32)
    idx = np.arange(t)
    controlled = np.flatnonzero(m)
    # distance (in frames) to the nearest controlled frame
    pos = np.searchsorted(controlled, idx)
    left = np.where(pos > 0, idx - controlled[np.maximum(pos - 1, 0)], t + ramp)
    right = np.where(pos < len(controlled), controlled[np.minimum(pos, len(controlled) - 1)] - idx, t + ramp)
    dist = np.minimum(np.abs(left), np.abs(right))
    w = _smoothstep(1.0 - dist / float(ramp + 1)) if ramp > 0 else (dist == 0).astype(float)
    w[m] = 1.0
    return w.astype(np.float32)


def nearest_control(pose: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """For every frame, the requested pose of the nearest controlled frame (T, 27)."""
    m = np.asarray(mask) > 0.5
    controlled = np.flatnonzero(m)
    idx = np.arange(len(m))
    pos = np.clip(np.searchsorted(controlled, idx), 0, len(controlled) - 1)
    prev = controlled[np.maximum(pos - 1, 0)]
    nxt = controlled[pos]
    nearest = np.where(np.abs(idx - prev) <= np.abs(nxt - idx), prev, nxt)
    return pose[nearest]


def blend_pose_controls(generated: np.ndarray, pose: np.ndarray, mask: np.ndarray, ramp: int = 6) -> np.ndarray:
    """Exact pose following: requested poses where masked, smooth easing around them."""
    g = np.asarray(generated, np.float32)
    if not (np.asarray(mask) > 0.5).any():
        return g.copy()
    w = blend_weights(mask, ramp)[:, None]
    target = nearest_control(np.asarray(pose, np.float32), mask)
    out = normalize_pose((1 - w) * g + w * target)
    m = np.asarray(mask) > 0.5
    out[m] = normalize_pose(np.asarray(pose, np.float32)[m])
    return out


SMOOTHERS = ("one_euro", "moving_average", "none")


def finish(raw: np.ndarray, pose: np.ndarray, mask: np.ndarray, *, smoothing: str = "one_euro",
           blend: bool = True, ramp: int = 6) -> np.ndarray:
    """The post-processing chain of the neural engine: ``smoothing`` (one of :data:`SMOOTHERS`),
    then, if ``blend``, the exact pose-control blend of ``pose``/``mask``."""
    if smoothing == "one_euro":
        raw = one_euro(raw)
    elif smoothing == "moving_average":
        raw = moving_average(raw)
    elif smoothing != "none":
        raise ValueError(f"unknown smoothing '{smoothing}' (use one of {', '.join(SMOOTHERS)})")
    if blend:
        raw = blend_pose_controls(raw, pose, mask, ramp)
    return np.asarray(raw, np.float32)

