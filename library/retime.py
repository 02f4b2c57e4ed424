"""Playing a gesture at a speed: which moment of the spec each frame shows.

A gesture played at ``speed`` x gets about ``duration / speed`` seconds, but not by sampling
its spec evenly over fewer frames (that cuts the corners of a fast wave and lands the stroke
a frame early or late). Instead (McNeill's phases: preparation, stroke, retraction):

- every keyframe lands exactly on a frame, so every repetition keeps its extremes and the
  stroke keyframe is the stroke frame;
- the segments between keyframes share the frames: the preparation (the first segment) and
  the retraction (the last) are compressed more than the segments in between (the stroke
  and its repetitions), which are compressed by ``speed ** CORE_EXPONENT`` where they can,
  and never more than the preparation and retraction;
- no bone turns faster than :data:`MAX_DEG_PER_S` on the played frames. Where the frames of
  ``duration / speed`` seconds cannot hold the gesture under that bound, the clip gets the
  frames it needs (a 2.5 Hz wave played "3x" would be a 7.5 Hz flutter no arm makes), so the
  gesture keeps its shape and plays as fast as a person could.

At speed 1 the spec's own timing is kept: keyframe k lands on frame
``round(time_k / duration * (frame_count(duration) - 1))``.
"""

from __future__ import annotations

import math

import numpy as np

from core.skeleton import FPS, N_BONES, frame_count

#: The fastest a bone direction may turn on played frames, in degrees per second. Peak
#: angular velocities of the arm in fast conversational gestures are a few hundred degrees
#: per second and ballistic elbow flexions reach about 1000 deg/s; 720 deg/s (48 degrees a
#: frame at 15 fps, a forearm tip at 3.3 m/s) is the fastest beat a person makes while
#: talking, and every built-in gesture at speed 1 stays below it (tests/test_library.py).
MAX_DEG_PER_S = 900.0
#: The stroke phase of a gesture played at speed s is compressed by s ** CORE_EXPONENT, its
#: preparation and retraction by s ** EDGE_EXPONENT (both then scaled to fit the frames).
CORE_EXPONENT = 0.6
EDGE_EXPONENT = 1.4
_SAMPLES = 48  # per segment, to find its peak angular speed


def _segment_peaks(times: np.ndarray, key_dirs: np.ndarray, curve) -> np.ndarray:
    """The peak angular speed (degrees per spec-second) of each segment of ``curve``."""
    peaks = []
    for a, b in zip(times[:-1], times[1:]):
        ts = np.linspace(a, b, _SAMPLES)
        p = curve(ts).reshape(len(ts), N_BONES, 3).astype(np.float64)
        cos = np.clip(np.sum(p[1:] * p[:-1], axis=-1), -1.0, 1.0)
        peaks.append(float(np.degrees(np.arccos(cos)).max()) / ((b - a) / (_SAMPLES - 1)))
    return np.array(peaks)


def _integer_shares(want: np.ndarray, floor: np.ndarray, total: int) -> np.ndarray:
    """Integers >= ``floor`` summing to ``total``, close to ``want`` (largest remainders)."""
    n = np.maximum(floor, np.floor(want)).astype(int)
    while n.sum() > total:  # rounding down against a floor can still overshoot: take from the richest
        spare = np.flatnonzero(n > floor)
        j = spare[np.argmax((n - want)[spare])]
        n[j] -= 1
    order = np.argsort(-(want - n), kind="stable")
    i = 0
    while n.sum() < total:
        n[order[i % len(n)]] += 1
        i += 1
    return n


def key_frames(times: np.ndarray, duration: float, key_dirs: np.ndarray, curve, speed: float) -> np.ndarray:
    """The frame of every keyframe when the gesture plays at ``speed`` (the first is 0, the
    last the clip's last frame). ``curve(ts)`` gives the spec's poses at spec times ``ts``."""
    t = np.asarray(times, np.float64)
    n1 = frame_count(duration)
    f1 = np.round(t / duration * (n1 - 1)).astype(int) if n1 > 1 else np.zeros(len(t), int)
    if len(t) == 1:
        return f1
    f1 = np.maximum.accumulate(f1)
    for i in range(1, len(f1)):  # keyframes closer than a frame still get a frame each
        f1[i] = max(f1[i], f1[i - 1] + 1)
    if speed == 1:
        return f1
    x1 = np.diff(f1).astype(np.float64)  # frames per segment at speed 1
    peaks = _segment_peaks(t, key_dirs, curve)
    need = np.maximum(1, np.ceil(peaks * np.diff(t) * FPS / MAX_DEG_PER_S - 1e-9)).astype(int)
    need = np.minimum(need, x1.astype(int))  # never more than the author's own timing
    total = max(frame_count(duration / speed) - 1, int(need.sum()))
    edge = np.zeros(len(x1), bool)
    if len(x1) > 1:
        edge[[0, -1]] = True
    want = x1 / np.where(edge, speed ** EDGE_EXPONENT, speed ** CORE_EXPONENT)
    fixed = np.zeros(len(x1), bool)
    for _ in range(len(x1)):  # scale the free segments to fit; pin those below their floor
        free_total = total - need[fixed].sum()
        scaled = np.where(fixed, need, want * free_total / max(want[~fixed].sum(), 1e-12))
        low = ~fixed & (scaled < need)
        if not low.any():
            break
        fixed |= low
    if edge.any() and not edge.all():  # the stroke phase never compressed more than the edges
        e = x1[edge].sum() / scaled[edge].sum()
        c = x1[~edge].sum() / scaled[~edge].sum()
        if c > e:
            scaled[~edge] *= c / e
            total = max(total, int(math.ceil(scaled.sum() - 1e-6)))
    frames = _integer_shares(scaled, need, total)
    return np.concatenate([[0], np.cumsum(frames)])


def frame_times(times: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """The spec time shown on every frame: linear between consecutive keyframes' frames."""
    return np.interp(np.arange(int(frames[-1]) + 1), frames, times)
