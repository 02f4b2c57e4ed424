"""Post-processing of generated motion, each step switchable.

- :func:`one_euro`: the 1-euro filter (Casiez et al. 2012), speed-adaptive low-pass: little lag
  on fast strokes, strong smoothing when the motion is slow (Kucherenko et al. 6: smoothing
  changes what people perceive more than the model does). The offline engine runs it both
  ways (:func:`one_euro_zero_phase`, no lag); the streaming service runs it causally.
- :func:`moving_average`: a centred moving average (the simpler smoother Kucherenko et al. use).
- :func:`blend_pose_controls`: the exact pose-control blend. Where a pose is requested the
  output *is* that pose; in ``ramp`` frames before and after each controlled span the output
  eases from the generated motion into the requested one (smoothstep weights), so there is no
  jump. SGToolkit lists imperfect pose following as its main limitation; this removes it.
- :func:`follow_speed`: where the speed style is requested, the motion's detail (what a low-pass
  leaves out) is scaled until the measured speed (SGToolkit Eq. 4) meets the request: the
  network alone reaches +1.26 for ``<speed:+2>`` and +0.17 for ``+1``.

All work on poses (T, 27) of unit bone directions and return renormalised poses.
"""

from __future__ import annotations

import math

import numpy as np

from core import cancel
from core.easing import smoothstep
from core.skeleton import FPS, N_BONES, normalize_pose
from model.style import load_stats, raw_style, window_mean


def moving_average(poses: np.ndarray, window: int = 5) -> np.ndarray:
    """Centred moving average over ``window`` frames (odd; cut at the ends)."""
    p = np.asarray(poses, np.float64)
    if window <= 1 or len(p) < 2:
        return np.asarray(poses, np.float32).copy()
    return normalize_pose(window_mean(p.T, window).T)


#: 1-euro settings of the causal filter (the streaming service), chosen on the validation split
#: with scripts/tune_smoothing.py (jerk within 25% of the reference while keeping style; docs/model.md).
ONE_EURO_MIN_CUTOFF = 4.0
ONE_EURO_BETA = 0.5
#: The offline engine runs the filter forwards and backwards (:func:`one_euro_zero_phase`): no
#: lag; at this cutoff the result is as smooth (jerk) as the causal filter at 4 Hz. Chosen on the
#: validation split over three training seeds (docs/model.md, "Choosing the post-filter").
ZERO_PHASE_MIN_CUTOFF = 8.0


def one_euro(poses: np.ndarray, min_cutoff: float = ONE_EURO_MIN_CUTOFF, beta: float = ONE_EURO_BETA,
             d_cutoff: float = 1.0, fps: float = FPS, state: dict | None = None) -> np.ndarray:
    """The 1-euro filter on every coordinate (cutoffs in Hz). It is causal: with ``state`` (a
    dict, empty at the start of a stream, updated by each call), a motion fed in pieces comes
    out exactly as when fed whole (:mod:`model.streaming` uses it)."""
    x = np.asarray(poses, np.float64)
    if state is None and len(x) < 2 or len(x) == 0:
        return np.asarray(poses, np.float32).copy()

    def alpha(cutoff):
        tau = 1.0 / (2 * math.pi * cutoff)
        return 1.0 / (1.0 + tau * fps)

    out = np.empty_like(x)
    if state:
        prev, dx_prev, first = state["out"], state["dx"], 0
    else:
        out[0] = prev = x[0]
        dx_prev, first = np.zeros(x.shape[1]), 1
    a_d = alpha(d_cutoff)
    for i in range(first, len(x)):
        if not i % cancel.EVERY:
            cancel.check()
        dx = (x[i] - prev) * fps
        dx_hat = a_d * dx + (1 - a_d) * dx_prev
        cutoff = min_cutoff + beta * np.abs(dx_hat)
        tau = 1.0 / (2 * math.pi * cutoff)
        a = 1.0 / (1.0 + tau * fps)
        out[i] = prev = a * x[i] + (1 - a) * prev
        dx_prev = dx_hat
    if state is not None:
        state.update(out=prev, dx=dx_prev)
    return normalize_pose(out)


def one_euro_zero_phase(poses: np.ndarray, min_cutoff: float = ZERO_PHASE_MIN_CUTOFF,
                        beta: float = ONE_EURO_BETA) -> np.ndarray:
    """The 1-euro filter run forwards, then backwards over its output (as a filtfilt): the lag
    of each pass cancels the other's, so strokes stay on their frames (a causal filter delays
    them by up to a frame). For whole takes; a stream needs :func:`one_euro`."""
    forward = one_euro(poses, min_cutoff, beta)
    return np.ascontiguousarray(one_euro(forward[::-1], min_cutoff, beta)[::-1])


def gauss_smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing along axis 0 with edge values held beyond the ends: the numbers of
    ``scipy.ndimage.gaussian_filter1d(x, sigma, axis=0, mode="nearest")`` (its kernel: radius
    ``int(4 sigma + 0.5)``; tests/test_teacher.py compares them) without importing scipy.ndimage
    (half a second of every cold ``sgt generate``, which runs the teacher's listening motion;
    the teacher and the take drifts of :mod:`model.training.takes` use it)."""
    if sigma <= 0 or len(x) < 3:
        return x
    x = np.asarray(x)
    radius = int(4.0 * float(sigma) + 0.5)
    taps = np.arange(-radius, radius + 1, dtype=np.float64)
    w = np.exp(-0.5 / (float(sigma) ** 2) * taps**2)
    w /= w.sum()
    padded = np.concatenate([np.repeat(x[:1], radius, 0), x, np.repeat(x[-1:], radius, 0)]).astype(np.float64)
    n = len(x)
    out = w[radius] * padded[radius : radius + n]
    for j in range(1, radius + 1):  # symmetric taps in pairs, as scipy sums them
        out = out + w[radius + j] * (padded[radius - j : radius - j + n] + padded[radius + j : radius + j + n])
    return out.astype(x.dtype, copy=False)


def _spans(m: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of every run of True in ``m``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], m.astype(np.int8), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def _max_angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """The largest angle (degrees) between corresponding bones of two poses (27,)."""
    a = np.asarray(a, np.float64).reshape(N_BONES, 3)
    b = np.asarray(b, np.float64).reshape(N_BONES, 3)
    cos = (a * b).sum(-1) / np.maximum(np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1), 1e-12)
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max())


def _ramp_length(ramp: int, max_step_deg: float | None, a: np.ndarray, b: np.ndarray) -> int:
    if max_step_deg is None:
        return ramp
    return max(ramp, int(math.ceil(_max_angle_deg(a, b) / max_step_deg)) + 1)


def _ramps(generated: np.ndarray, requested: np.ndarray, m: np.ndarray, ramp: int,
           max_step_deg: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Per frame: the weight of the requested pose (T,) and the controlled frame it eases towards (T,).

    Controlled frames weigh 1. A frame ``k`` frames before (after) a controlled span weighs
    ``smoothstep(1 - k / (L + 1))`` of the span's first (last) pose, for ``k`` up to the ramp
    length ``L``; a ramp stops at the neighbouring span and where two ramps meet the larger
    weight wins (the earlier span's on a tie)."""
    t = len(m)
    weight = m.astype(np.float64)
    source = np.arange(t)
    spans = _spans(m)
    for i, (s, e) in enumerate(spans):
        prev_end = spans[i - 1][1] if i > 0 else 0
        next_start = spans[i + 1][0] if i + 1 < len(spans) else t
        n_in = _ramp_length(ramp, max_step_deg, generated[max(0, s - 1)], requested[s])
        n_out = _ramp_length(ramp, max_step_deg, generated[min(t - 1, e)], requested[e - 1])
        for frames, anchor, length in ((np.arange(s - 1, max(prev_end, s - n_in) - 1, -1), s, n_in),
                                       (np.arange(e, min(next_start, e + n_out)), e - 1, n_out)):
            w = smoothstep(1.0 - np.abs(frames - anchor) / float(length + 1))
            better = w > weight[frames]
            weight[frames[better]] = w[better]
            source[frames[better]] = anchor
    return weight, source


def _nlerp(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Blend poses a -> b (T, 27) by per-frame weights w (T, 1), bone by bone, renormalised; a bone
    whose two directions (nearly) cancel takes the nearer end instead of a random direction."""
    out = (1 - w) * a + w * b
    n = np.linalg.norm(out.reshape(len(out), N_BONES, 3), axis=-1)
    bad = n < 1e-3
    if bad.any():
        near = np.where(w < 0.5, a, b).reshape(len(out), N_BONES, 3)
        out = np.where(bad[..., None], near, out.reshape(len(out), N_BONES, 3)).reshape(out.shape)
    return normalize_pose(out)


def blend_pose_controls(generated: np.ndarray, pose: np.ndarray, mask: np.ndarray, ramp: int = 6, *,
                        max_step_deg: float | None = None, bones: np.ndarray | None = None) -> np.ndarray:
    """Exact pose following: requested poses where masked, smooth easing around them.

    The output is the requested pose on every controlled frame; ``ramp`` frames before and
    after each controlled span ease from ``generated`` into the span's first pose and out of
    its last (smoothstep weights, bone directions blended and renormalised). With
    ``max_step_deg``, a ramp is lengthened to ``ceil(angle / max_step_deg) + 1`` frames when
    the largest bone rotation between the generated pose next to the span and the requested
    one needs it (the ``rules`` engine's limit). A requested bone of zero length keeps the
    generated bone. The neural engine and ``sgt eval`` use it with ``ramp`` = 6, the ``rules``
    engine with ``ramp`` = 5 and ``max_step_deg`` = 12.

    ``bones`` (T, 9), 1 on the controlled bones of each frame (a layered gesture), makes the
    blend per bone: each bone follows its own controlled spans, with its own ramps in and out,
    and a bone never controlled keeps the generated motion untouched."""
    g = np.asarray(generated, np.float32)
    m = np.asarray(mask) > 0.5
    if not m.any():
        return g.copy()
    req = np.asarray(pose, np.float32).reshape(len(g), N_BONES, 3)
    zero = np.linalg.norm(req, axis=-1, keepdims=True) < 1e-6
    req = np.where(zero, g.reshape(len(g), N_BONES, 3), req).reshape(g.shape)
    if bones is None or (np.asarray(bones)[m] > 0.5).all():
        weight, source = _ramps(g, req, m, ramp, max_step_deg)
        out = _nlerp(g, req[source], weight.astype(np.float32)[:, None])
        out[m] = normalize_pose(req[m])
        return out
    per_bone = m[:, None] & (np.asarray(bones) > 0.5)
    out = g.copy()
    for b in range(N_BONES):
        mb = per_bone[:, b]
        if not mb.any():
            continue
        cols = slice(3 * b, 3 * b + 3)
        weight, source = _ramps(g, req, mb, ramp, max_step_deg)
        w = weight.astype(np.float32)[:, None]
        mix = (1 - w) * g[:, cols] + w * req[source][:, cols]
        n = np.linalg.norm(mix, axis=-1, keepdims=True)
        near = np.where(w < 0.5, g[:, cols], req[source][:, cols])
        mix = np.where(n < 1e-3, near, mix / np.maximum(n, 1e-12))
        mix[mb] = req[mb][:, cols] / np.linalg.norm(req[mb][:, cols], axis=-1, keepdims=True)
        out[:, cols] = mix
    return normalize_pose(out)


SMOOTHERS = ("one_euro", "moving_average", "none")


def finish(raw: np.ndarray, pose: np.ndarray, mask: np.ndarray, *, smoothing: str = "one_euro",
           blend: bool = True, ramp: int = 6, bones: np.ndarray | None = None, words=None,
           style: np.ndarray | None = None, style_mask: np.ndarray | None = None) -> np.ndarray:
    """The post-processing chain of the neural engine: ``smoothing`` (one of :data:`SMOOTHERS`),
    if ``blend`` and with ``style``/``style_mask`` (T, 3) the requested speed met
    (:func:`follow_speed`), with timed ``words`` the pauses between them calmed
    (:func:`calm_pauses`), then, if ``blend``, the exact pose-control blend of ``pose``/``mask``
    (per bone with ``bones``). ``blend=False`` leaves control following to the network."""
    if smoothing == "one_euro":
        raw = one_euro_zero_phase(raw)
    elif smoothing == "moving_average":
        raw = moving_average(raw)
    elif smoothing != "none":
        raise ValueError(f"unknown smoothing '{smoothing}' (use one of {', '.join(SMOOTHERS)})")
    if blend and style is not None and style_mask is not None:
        raw = follow_speed(raw, style, style_mask)
    if words is not None:
        raw = calm_pauses(raw, words)
    if blend:
        raw = blend_pose_controls(raw, pose, mask, ramp, bones=bones)
    return np.asarray(raw, np.float32)


#: :func:`follow_speed`: the low-pass (a centred mean over this many frames, 1.4 s) whose
#: residual is scaled, the passes of measuring and rescaling, and the largest factor either way.
#: Chosen on the validation split over three training seeds (docs/model.md, "Following the
#: speed style"): 15 or 21 frames, 2 or 3 passes, factors up to 3 or 4.
SPEED_LOW_WINDOW = 21
SPEED_PASSES = 2
SPEED_MAX_GAIN = 4.0
#: The factor is itself averaged over this many frames, so it never changes abruptly.
SPEED_GAIN_WINDOW = 9


def follow_speed(poses: np.ndarray, style: np.ndarray, style_mask: np.ndarray, stats=None) -> np.ndarray:
    """Meet the requested speed style where it is requested (``style_mask[:, 0]``).

    The motion is split into a low-pass (a centred mean over :data:`SPEED_LOW_WINDOW` frames)
    and the detail around it; on frames with a speed request the detail is multiplied by the
    ratio of the requested raw speed (``stats``: the shipped style statistics) to the measured
    one (SGToolkit Eq. 4), re-measured and rescaled :data:`SPEED_PASSES` times, the factor
    kept within [1/:data:`SPEED_MAX_GAIN`, :data:`SPEED_MAX_GAIN`] and averaged over
    :data:`SPEED_GAIN_WINDOW` frames. Uncontrolled frames keep a factor of 1, so the motion
    without a speed request is unchanged, and the factor eases in and out at a request's ends.
    Timing stays: strokes land on the same frames, they are only larger or smaller.
    (T, 27) -> (T, 27) float32."""
    m = np.asarray(style_mask, np.float64)[:, 0] > 0
    if not m.any() or len(poses) < 2:
        return np.asarray(poses, np.float32)
    stats = stats or load_stats()
    p = np.asarray(poses, np.float64)
    target = np.maximum(stats.mean[0] + np.asarray(style, np.float64)[:, 0] * stats.std[0], 1e-4)
    low = window_mean(p.T, SPEED_LOW_WINDOW).T
    detail = p - low
    gain = np.ones(len(p))
    for _ in range(SPEED_PASSES):
        measured = np.maximum(raw_style(normalize_pose(low + gain[:, None] * detail))[:, 0], 1e-4)
        gain = np.where(m, np.clip(gain * target / measured, 1 / SPEED_MAX_GAIN, SPEED_MAX_GAIN), 1.0)
        gain = window_mean(gain, SPEED_GAIN_WINDOW)
    return normalize_pose(low + gain[:, None] * detail).astype(np.float32)


def unit_vectors(v: np.ndarray) -> np.ndarray:
    """``v`` (..., 3) scaled to unit length along the last axis (zero vectors stay near zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def limit_velocity(poses: np.ndarray, max_deg) -> np.ndarray:
    """Rotate each bone towards its target by at most ``max_deg`` degrees per frame: a number,
    or one per frame (the limit on the step into that frame). (T, 27) -> (T, 27) float64."""
    d = unit_vectors(np.asarray(poses, np.float64).reshape(len(poses), N_BONES, 3).copy())
    lim = np.radians(np.broadcast_to(np.asarray(max_deg, np.float64), (len(d),)))
    # Frames are limited one after another, but a frame left as it was hands the next one its
    # own input: the loop only visits the frames whose input step is too large, and those after a
    # frame it changed (the same decisions as visiting all; most of a calm take is skipped).
    steps = np.arccos(np.clip((d[:-1] * d[1:]).sum(-1), -1.0, 1.0))
    steep = np.flatnonzero((steps > lim[1:, None]).any(-1)) + 1
    t = int(steep[0]) if len(steep) else len(d)
    while t < len(d):
        prev, cur = d[t - 1], d[t]
        cosang = np.clip((prev * cur).sum(-1), -1.0, 1.0)
        ang = np.arccos(cosang)
        over = ang > lim[t]
        if not over.any():  # this frame keeps its input: go to the next steep one
            k = int(np.searchsorted(steep, t, side="right"))
            t = int(steep[k]) if k < len(steep) else len(d)
            continue
        p, c, a = prev[over], cur[over], ang[over]
        perp = c - p * cosang[over][:, None]
        pn = np.linalg.norm(perp, axis=-1, keepdims=True)
        # exactly opposite: pick any perpendicular axis
        fallback = np.cross(p, np.array([0.0, 0.0, 1.0]))
        fallback = np.where(np.linalg.norm(fallback, axis=-1, keepdims=True) < 1e-6, np.cross(p, [1.0, 0.0, 0.0]), fallback)
        perp = np.where(pn < 1e-9, fallback, perp)
        perp = unit_vectors(perp)
        step = np.minimum(a, lim[t])[:, None]
        d[t, over] = p * np.cos(step) + perp * np.sin(step)
        t += 1
    return d.reshape(len(poses), 3 * N_BONES)


#: The largest per-frame rotation of any bone direction the engines let through, degrees (the
#: teacher's own limit; its corpus never moves faster).
MAX_STEP_DEG = 22.0
#: A silence between two words at least this long is a pause, where the body settles.
PAUSE_MIN_S = 0.4
#: How much of a pause holds the pose the speaker paused in (the rest: the network's motion),
#: and over how many frames at each end of the pause the hold eases in and out (chosen by
#: measurement: docs/model.md, "Pauses").
PAUSE_HOLD = 0.8
PAUSE_EASE = 6


def pause_frames(words, n_frames: int) -> np.ndarray:
    """(n_frames,) bool: the frames strictly inside a silence of at least PAUSE_MIN_S between
    two consecutive words (seconds on the motion timeline)."""
    quiet = np.zeros(n_frames, bool)
    for (_, _, end), (_, start, _) in zip(words, list(words)[1:]):
        if start - end >= PAUSE_MIN_S:
            first, last = math.floor(end * FPS) + 1, math.ceil(start * FPS) - 1
            quiet[max(0, first) : max(0, min(n_frames, last + 1))] = True
    return quiet


def calm_pauses(poses: np.ndarray, words, hold: float | None = None, ease: int | None = None) -> np.ndarray:
    """``poses`` held, inside each pause (:func:`pause_frames`), towards the pose at the
    pause's start by ``hold`` (easing in and out over ``ease`` frames at its ends): the speaker
    stays in the pose it paused in and keeps a damped share of the network's motion, where its
    teacher (and so the network) makes fast moves to rest and back."""
    hold = PAUSE_HOLD if hold is None else hold
    ease = PAUSE_EASE if ease is None else ease
    quiet = pause_frames(words, len(poses))
    if not quiet.any():
        return poses
    g = np.asarray(poses, np.float32)
    target = g.copy()
    weight = np.zeros(len(g), np.float32)
    for a, b in _spans(quiet):
        target[a:b] = g[max(0, a - 1)]
        weight[a:b] = pause_hold_weight(np.arange(b - a), b - a, hold, ease)
    return hold_pose(g, target, weight)


def pause_hold_weight(k, length, hold: float | None = None, ease: int | None = None) -> np.ndarray:
    """The hold of :func:`calm_pauses` on frame ``k`` (an array) of a pause ``length`` frames long
    (``math.inf``: its end not yet known, so no easing out): ``hold`` times a smoothstep that
    eases in and out over ``ease`` frames at the pause's ends."""
    hold = PAUSE_HOLD if hold is None else hold
    ease = PAUSE_EASE if ease is None else ease
    k = np.asarray(k)
    edge = np.minimum(k + 1, length - k) / (ease + 1)  # 1/(ease+1) ... 1 ... from both ends
    return (hold * smoothstep(np.minimum(edge, 1.0))).astype(np.float32)


def hold_pose(poses: np.ndarray, target: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """``poses`` drawn towards ``target`` (both (T, 27)) by ``weight`` (T,); frames of weight 0
    keep their bits."""
    out = np.array(poses, np.float32)
    on = np.asarray(weight) > 0
    if on.any():
        out[on] = _nlerp(out[on], np.asarray(target, np.float32)[on], np.asarray(weight, np.float32)[on, None])
    return out
