"""Numerical evaluation of generated gesture motion (numpy only; see docs/metrics.md).

Metrics of SGToolkit (Yoon et al., UIST 2021, section 5.3, Table 1):

- :func:`pcs`, pose compliance score (Eq. 8): mean absolute difference between requested and
  generated poses on the 27-number representation (unit bone directions), controlled frames only;
- :func:`scs`, style compliance score (Eq. 9): mean absolute difference between requested style
  values and the style statistics (:func:`model.style.style`) of the generated motion;
- :func:`fgd`, Fréchet gesture distance between two feature sets (features from
  :mod:`model.training.fgd`, the encoder of a motion autoencoder).

Metrics of Kucherenko et al. ("Moving fast and slow", sections 4.4-5.4, Tables 1-3):

- :func:`ape`, average position error in metres;
- :func:`motion_statistics`, mean speed, acceleration and jerk (m/s, m/s², m/s³), overall and
  per joint group, and :func:`ratio` to a reference (we report ``jerk_ratio``; the target is
  "within 25 % of the reference", :data:`JERK_TOLERANCE`);
- :func:`speed_histogram` and :func:`hellinger`, the distance between speed distributions, for
  all joints, the elbows and the wrists.

Beat alignment (the Beat Alignment Score of Li et al. 2021, as used for co-speech gesture by
BEAT, Liu et al. 2022, with speech onsets for music beats): :func:`audio_onsets`,
:func:`motion_beats` and :func:`beat_alignment`.

:func:`report` evaluates named conditions into table rows and :func:`format_table` prints them.

Joint positions come from forward kinematics (:func:`core.skeleton.positions_from_pose`) with
the root joint (``spine``) fixed at :data:`core.skeleton.ROOT_POSITION`, so every position is
already root-centred (the equivalent of Kucherenko's hip-centring); the root itself never
moves and is left out of the "all joints" group. Every motion argument may be poses ``(T, 27)``
or joint positions ``(T, 10, 3)`` in metres; both are recognised by shape.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from core.controls import ControlArrays
from core.skeleton import FPS, JOINT_INDEX, JOINTS, N_JOINTS, POSE_DIM, positions_from_pose
from model.features import N_MELS, level_db
from model.style import style
from model.training import fgd as fgd_module

# --------------------------------------------------------------------------- constants

#: Joint groups of the motion statistics and speed histograms. "all" leaves out the fixed root.
JOINT_GROUPS: dict[str, tuple[str, ...]] = {
    "all": tuple(j for j in JOINTS if j != "spine"),
    "head": ("neck", "nose", "head_top"),
    "shoulders": ("left_shoulder", "right_shoulder"),
    "elbows": ("left_elbow", "right_elbow"),
    "wrists": ("left_wrist", "right_wrist"),
}

#: Frames of the PCS pose control (SGToolkit Eq. 8), centred in the evaluated clip: see
#: :func:`pcs_frames`. ``sgt eval``, the training loop's validation and the tests all use it.
PCS_LENGTH = 5

#: Speed histogram bins (m/s): [0, 3) in 0.05 m/s steps; faster speeds fall in the last bin.
HIST_BIN_WIDTH = 0.05
HIST_MAX_SPEED = 3.0
HIST_EDGES = np.linspace(0.0, HIST_MAX_SPEED, int(round(HIST_MAX_SPEED / HIST_BIN_WIDTH)) + 1)

#: "Jerk within 25 % of the reference": |jerk_ratio - 1| <= JERK_TOLERANCE.
JERK_TOLERANCE = 0.25

#: Beat alignment: the Gaussian's sigma (seconds), the onset threshold (mean rise of the log-mel
#: bands from one frame to the next, in dB), the neighbourhood (frames each side) in which an
#: onset or a motion beat must be the extreme, the joints whose speed gives the motion beats
#: and how much (m/s) that speed must have dropped within the BEAT_LOOKBACK frames before a
#: beat (the end of a stroke, not a ripple of a hold).
BEAT_SIGMA = 0.1
ONSET_RISE_DB = 6.0
BEAT_ORDER = 2
BEAT_GROUP = "wrists"
BEAT_DROP = 0.05
BEAT_LOOKBACK = 5

#: Keys of a :func:`report` row, in table order.
ROW_KEYS = ("fgd", "pcs", "scs", "ape", "speed", "accel", "jerk", "jerk_ratio",
            "hellinger", "hellinger_elbows", "hellinger_wrists", "beat_align")


# --------------------------------------------------------------------------- helpers

def joint_positions(motion) -> np.ndarray:
    """Poses (..., T, 27) or positions (..., T, 10, 3) -> positions (..., T, 10, 3), metres."""
    x = np.asarray(motion, dtype=np.float64)
    if x.ndim >= 2 and x.shape[-2:] == (N_JOINTS, 3):
        return x
    if x.shape[-1] == POSE_DIM:
        return positions_from_pose(x)
    raise ValueError(f"expected poses (T, {POSE_DIM}) or joint positions (T, {N_JOINTS}, 3), got shape {x.shape}")


def _joint_indices(group: str | Sequence[str]) -> np.ndarray:
    names = JOINT_GROUPS[group] if isinstance(group, str) else tuple(group)
    try:
        return np.array([JOINT_INDEX[n] for n in names])
    except KeyError as exc:
        raise ValueError(f"unknown joint {exc.args[0]!r}; joints are {', '.join(JOINTS)}") from None


def _as_clips(clips) -> list[np.ndarray]:
    """One motion or a sequence of motions -> list of float64 arrays."""
    if isinstance(clips, np.ndarray):
        if clips.ndim == 2 or (clips.ndim == 3 and clips.shape[-2:] == (N_JOINTS, 3)):
            return [np.asarray(clips, np.float64)]
        return [np.asarray(c, np.float64) for c in clips]
    return [np.asarray(c, np.float64) for c in clips]


# --------------------------------------------------------------------------- SGToolkit PCS / SCS

def pcs(requested_poses, generated_poses, mask) -> float:
    """Pose compliance score (SGToolkit Eq. 8).

    ``mean |p~ - p^|`` over the 27 numbers of every frame where ``mask`` (T,) is non-zero.
    Arrays may carry leading batch axes: poses (..., T, 27), mask (..., T). Unitless (bone
    direction components); 0 is perfect compliance. NaN when no frame is controlled.
    """
    req = np.asarray(requested_poses, np.float64)
    gen = np.asarray(generated_poses, np.float64)
    m = np.asarray(mask, np.float64) > 0
    if req.shape != gen.shape or req.shape[:-1] != m.shape or req.shape[-1] != POSE_DIM:
        raise ValueError(f"pcs: shapes differ: requested {req.shape}, generated {gen.shape}, mask {m.shape}")
    if not m.any():
        return float("nan")
    return float(np.abs(req[m] - gen[m]).mean())


def pcs_frames(n_frames: int, length: int = PCS_LENGTH) -> slice:
    """The frames of the PCS pose control in an ``n_frames`` window: ``length`` frames centred
    on the middle frame (``n_frames // 2``), e.g. frames [13, 18) of a 30-frame window."""
    start = n_frames // 2 - length // 2
    return slice(start, start + length)


def pose_control(reference, length: int = PCS_LENGTH):
    """The PCS control: the reference poses of the :func:`pcs_frames` requested.

    ``reference`` is a (T, 27) motion; returns a :class:`core.controls.ControlArrays` with only
    that pose control set.
    """
    ref = np.asarray(reference, np.float32)
    if ref.ndim != 2 or ref.shape[1] != POSE_DIM:
        raise ValueError(f"pose_control: expected a (T, {POSE_DIM}) motion, got {ref.shape}")
    frames = pcs_frames(len(ref), length)
    if frames.start < 0 or frames.stop > len(ref) or length < 1:
        raise ValueError(f"pose_control: a {length}-frame control does not fit a {len(ref)}-frame motion")
    ctrl = ControlArrays.empty(len(ref))
    ctrl.set_pose(frames.start, ref[frames])
    return ctrl


def style_control(reference, stats=None):
    """The paper's SCS control: the reference's own style values requested on every frame."""
    ref = np.asarray(reference, np.float32)
    ctrl = ControlArrays.empty(len(ref))
    ctrl.style[:] = style(ref, stats)
    ctrl.style_mask[:] = 1.0
    return ctrl


def scs(requested_style, generated_poses, mask, stats=None) -> float:
    """Style compliance score (SGToolkit Eq. 9).

    ``mean |s~ - s^|`` over the masked (frame, element) pairs, where ``s^ = model.style.style``
    of the generated poses (normalised units, range [-3, 3]). ``mask`` is (T, 3) or (T,) (all
    three elements). NaN when nothing is controlled.
    """
    req = np.asarray(requested_style, np.float64)
    gen = np.asarray(generated_poses, np.float64)
    m = np.asarray(mask, np.float64) > 0
    if m.shape == req.shape[:-1]:
        m = np.repeat(m[..., None], req.shape[-1], axis=-1)
    if gen.shape[:-1] != req.shape[:-1] or m.shape != req.shape:
        raise ValueError(f"scs: shapes differ: requested {req.shape}, generated {gen.shape}, mask {np.shape(mask)}")
    if not m.any():
        return float("nan")
    got = np.asarray(style(gen, stats), np.float64)
    return float(np.abs(req[m] - got[m]).mean())


# --------------------------------------------------------------------------- Kucherenko APE / statistics

def ape(reference, generated, group: str | Sequence[str] = "all") -> float:
    """Average position error (Kucherenko Eq. 1), metres.

    Mean over frames and joints of the Euclidean distance between reference and generated joint
    positions. Positions are root-centred by construction (fixed root), so the error is the
    hip-centred APE; the root is left out (group "all").
    """
    a, b = joint_positions(reference), joint_positions(generated)
    if a.shape != b.shape:
        raise ValueError(f"ape: reference {a.shape} and generated {b.shape} differ in shape")
    idx = _joint_indices(group)
    return float(np.linalg.norm(a[..., idx, :] - b[..., idx, :], axis=-1).mean())


def derivative_magnitudes(motion, order: int) -> np.ndarray:
    """|k-th finite difference| x FPS^k per frame and joint: (T, 10, ...) -> (T-k, 10)."""
    x = joint_positions(motion)
    if x.shape[-3] <= order:
        return np.zeros((*x.shape[:-3], 0, N_JOINTS))
    d = np.diff(x, n=order, axis=-3) * float(FPS) ** order
    return np.linalg.norm(d, axis=-1)


def joint_speeds(motion) -> np.ndarray:
    """Per-frame joint speeds (T-1, 10) in m/s."""
    return derivative_magnitudes(motion, 1)


@dataclass(frozen=True)
class MotionStats:
    """Mean speed (m/s), acceleration (m/s²) and jerk (m/s³) of a joint group."""

    speed: float
    accel: float
    jerk: float

    def as_dict(self) -> dict[str, float]:
        return {"speed": self.speed, "accel": self.accel, "jerk": self.jerk}


def _pooled_mean(clips: list[np.ndarray], order: int, idx: np.ndarray) -> float:
    total, count = 0.0, 0
    for c in clips:
        m = derivative_magnitudes(c, order)[..., idx]
        total += float(m.sum())
        count += m.size
    return total / count if count else float("nan")


def motion_statistics(clips, groups: Iterable[str] = tuple(JOINT_GROUPS)) -> dict[str, MotionStats]:
    """Mean |1st|, |2nd|, |3rd| finite differences of joint positions, x FPS^k, per group.

    ``clips`` is one motion or a list of motions (poses or positions); frames of all clips are
    pooled (each clip contributes T-k differences, none across clip boundaries). Returns
    ``{group: MotionStats}``; a group without any difference (clips too short) gives NaN.
    """
    cl = _as_clips(clips)
    return {g: group_statistics(cl, g) for g in groups}


def group_statistics(clips, group: str | Sequence[str] = "all") -> MotionStats:
    """:class:`MotionStats` of one joint group, by name or as a list of joint names."""
    cl = _as_clips(clips)
    idx = _joint_indices(group)
    return MotionStats(*(_pooled_mean(cl, k, idx) for k in (1, 2, 3)))


def ratio(value: float, reference: float) -> float:
    """value / reference (NaN when the reference is 0 or NaN): e.g. generated jerk / true jerk."""
    if not np.isfinite(reference) or reference == 0:
        return float("nan")
    return float(value / reference)


def jerk_within_tolerance(jerk_ratio: float, tolerance: float = JERK_TOLERANCE) -> bool:
    """True when the generated jerk is within ``tolerance`` (25 %) of the reference jerk."""
    return bool(np.isfinite(jerk_ratio) and abs(jerk_ratio - 1.0) <= tolerance)


# --------------------------------------------------------------------------- speed histograms

def speed_histogram(clips, group: str | Sequence[str] = "all", edges: np.ndarray = HIST_EDGES) -> np.ndarray:
    """Normalised histogram (sums to 1) of per-frame joint speeds of a joint group.

    Fixed bins: :data:`HIST_EDGES` ([0, 3) m/s in 0.05 m/s steps); speeds at or above the last
    edge are counted in the last bin, so no frame is dropped. All zeros if there is no frame.
    """
    idx = _joint_indices(group)
    counts = np.zeros(len(edges) - 1)
    for c in _as_clips(clips):
        v = joint_speeds(c)[..., idx].ravel()
        v = np.clip(v, edges[0], np.nextafter(edges[-1], -np.inf))
        counts += np.histogram(v, bins=edges)[0]
    total = counts.sum()
    return counts / total if total > 0 else counts


def hellinger(p, q) -> float:
    """Hellinger distance H = sqrt(1 - sum_i sqrt(p_i q_i)) (Kucherenko Eq. 2), in [0, 1].

    ``p`` and ``q`` are histograms over the same bins; they are normalised here. NaN if either
    is empty.
    """
    p = np.asarray(p, np.float64)
    q = np.asarray(q, np.float64)
    if p.shape != q.shape:
        raise ValueError(f"hellinger: histograms of different bins {p.shape} vs {q.shape}")
    if np.any(p < 0) or np.any(q < 0):
        raise ValueError("hellinger: histograms must be non-negative")
    sp, sq = p.sum(), q.sum()
    if sp <= 0 or sq <= 0:
        return float("nan")
    # 1 - sum sqrt(p q) == 0.5 sum (sqrt p - sqrt q)^2 for normalised p, q; the second form
    # is exactly 0 for identical histograms (no rounding residue)
    h2 = 0.5 * float(((np.sqrt(p / sp) - np.sqrt(q / sq)) ** 2).sum())
    return float(math.sqrt(min(1.0, max(0.0, h2))))


def speed_hellinger(reference, generated, group: str | Sequence[str] = "all") -> float:
    """Hellinger distance between the speed histograms of two motions (or pooled clip lists)."""
    return hellinger(speed_histogram(reference, group), speed_histogram(generated, group))


# --------------------------------------------------------------------------- beat alignment

def _local_extrema(x: np.ndarray, order: int, kind: str) -> np.ndarray:
    """Frames where ``x`` is the strict max (``kind`` "max") or min ("min") of the ``order``
    frames on each side (the window cut at the ends); plateaus give their first frame."""
    x = np.asarray(x, np.float64)
    n = len(x)
    out = []
    for t in range(n):
        lo, hi = max(0, t - order), min(n, t + order + 1)
        seg = x[lo:hi]
        best = seg.max() if kind == "max" else seg.min()
        if x[t] == best and int(np.argmax(seg == best)) == t - lo and np.ptp(seg) > 0:
            out.append(t)
    return np.asarray(out, np.int64)


def onset_strength(audio_features: np.ndarray) -> np.ndarray:
    """(T,) spectral flux of the log-mel bands of :func:`model.features.audio_features`: the mean
    over bands of the positive change from the previous frame, in dB (0 on the first frame)."""
    db = level_db(np.asarray(audio_features, np.float64)[:, :N_MELS])
    rise = np.maximum(np.diff(db, axis=0), 0.0).mean(axis=1)
    return np.concatenate([[0.0], rise])


def audio_onsets(audio_features: np.ndarray, rise_db: float = ONSET_RISE_DB, order: int = BEAT_ORDER) -> np.ndarray:
    """Frames of the speech onsets: peaks of :func:`onset_strength` (the largest within
    ``order`` frames each side) at least ``rise_db`` dB high."""
    flux = onset_strength(audio_features)
    peaks = _local_extrema(flux, order, "max")
    return peaks[flux[peaks] >= rise_db] if len(peaks) else peaks


def motion_beats(motion, group: str | Sequence[str] = BEAT_GROUP, order: int = BEAT_ORDER,
                 drop: float = BEAT_DROP) -> np.ndarray:
    """Frames of the motion beats, the moments a stroke stops: local minima (within ``order``
    frames each side) of the mean joint speed of the group (the wrists by default) that lie at
    least ``drop`` m/s below the fastest of the :data:`BEAT_LOOKBACK` frames before them. The
    speed of frame ``t`` is the centred difference ``|x[t+1] - x[t-1]| / 2`` (frames 1 to T-2),
    so a stroke that stops at frame ``t`` has its minimum there."""
    x = joint_positions(motion)[..., _joint_indices(group), :]
    if len(x) < 3:
        return np.zeros(0, np.int64)
    speed = np.linalg.norm(x[2:] - x[:-2], axis=-1).mean(axis=-1) / 2 * FPS
    minima = _local_extrema(speed, order, "min")
    keep = [t for t in minima if t > 0 and speed[max(0, t - BEAT_LOOKBACK):t].max() - speed[t] >= drop]
    return np.asarray(keep, np.int64) + 1


def beat_alignment(beats, onsets, sigma: float = BEAT_SIGMA, fps: float = FPS) -> float:
    """Beat alignment score (Li et al. 2021):
    ``1/|B_m| sum_{m in B_m} exp(-min_{a in B_a} (m - a)^2 / (2 sigma^2))`` over the motion
    beats ``B_m`` and the audio onsets ``B_a`` (frames; times in seconds): 1 when every motion
    beat falls on an onset. NaN without motion beats, 0 without onsets."""
    m = np.asarray(beats, np.float64) / fps
    a = np.asarray(onsets, np.float64) / fps
    if len(m) == 0:
        return float("nan")
    if len(a) == 0:
        return 0.0
    d = np.abs(m[:, None] - a[None, :]).min(axis=1)
    return float(np.exp(-(d**2) / (2 * sigma**2)).mean())


def clips_beat_alignment(motions, audio_features, sigma: float = BEAT_SIGMA) -> float:
    """:func:`beat_alignment` pooled over clips (every motion beat of every clip weighs the
    same): motion ``i`` against the onsets of ``audio_features[i]``."""
    total, count = 0.0, 0
    for motion, feats in zip(motions, audio_features):
        beats = motion_beats(motion)
        if len(beats):
            total += beat_alignment(beats, audio_onsets(feats), sigma) * len(beats)
            count += len(beats)
    return total / count if count else float("nan")


# --------------------------------------------------------------------------- FGD

def fgd(features_a, features_b, eps: float = 1e-6) -> float:
    """Fréchet distance between Gaussians fitted to two feature sets (N_a, D) and (N_b, D).

    ``|mu_a - mu_b|^2 + Tr(S_a + S_b - 2 (S_a S_b)^(1/2))``. The matrix square root comes from
    :func:`scipy.linalg.sqrtm`; if it is not finite, ``eps`` is added to both diagonals and it
    is retried; a small imaginary part (numerical) is dropped; the result is clamped at 0.
    """
    from scipy import linalg

    a = np.asarray(features_a, np.float64)
    b = np.asarray(features_b, np.float64)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[1]:
        raise ValueError(f"fgd: expected (N, D) feature sets of the same D, got {a.shape} and {b.shape}")
    if len(a) < 2 or len(b) < 2:
        raise ValueError(f"fgd: need at least 2 feature vectors per set, got {len(a)} and {len(b)}")
    mu_a, mu_b = a.mean(0), b.mean(0)
    s_a = np.atleast_2d(np.cov(a, rowvar=False))
    s_b = np.atleast_2d(np.cov(b, rowvar=False))
    diff = mu_a - mu_b

    def _sqrt(x, y):
        with warnings.catch_warnings():  # singular products are handled below
            warnings.simplefilter("ignore")
            r = linalg.sqrtm(x @ y)
        return r[0] if isinstance(r, tuple) else r

    covmean = _sqrt(s_a, s_b)
    if not np.all(np.isfinite(covmean)):
        off = np.eye(len(s_a)) * eps
        covmean = _sqrt(s_a + off, s_b + off)
    if np.iscomplexobj(covmean):
        covmean = covmean.real  # imaginary parts are numerical noise for PSD inputs
    value = float(diff @ diff + np.trace(s_a) + np.trace(s_b) - 2.0 * np.trace(covmean))
    return max(0.0, value)


# --------------------------------------------------------------------------- report / table

def _control_fields(ctrl) -> dict[str, np.ndarray] | None:
    if ctrl is None:
        return None
    if hasattr(ctrl, "as_dict"):
        ctrl = ctrl.as_dict()
    if not isinstance(ctrl, Mapping):
        raise ValueError(f"control info must be ControlArrays or a dict of arrays, got {type(ctrl).__name__}")
    return {k: np.asarray(v) for k, v in ctrl.items()}


def _pcs_scs(generated: list[np.ndarray], controls, stats) -> tuple[float, float]:
    """Frame-weighted PCS and SCS over all clips that carry pose / style controls."""
    if controls is None:
        return float("nan"), float("nan")
    if not isinstance(controls, (list, tuple)):
        controls = [controls]
    if len(controls) != len(generated):
        raise ValueError(f"{len(controls)} control entries for {len(generated)} generated clips")
    pose_err, pose_n, style_err, style_n = 0.0, 0, 0.0, 0
    for gen, ctrl in zip(generated, controls):
        c = _control_fields(ctrl)
        if c is None:
            continue
        if "pose" in c and "pose_mask" in c:
            m = c["pose_mask"] > 0
            if m.any():
                pose_err += float(np.abs(c["pose"][m] - gen[m]).sum())
                pose_n += int(m.sum()) * POSE_DIM
        if "style" in c and "style_mask" in c:
            m = c["style_mask"] > 0
            if m.ndim == 1:
                m = np.repeat(m[:, None], c["style"].shape[-1], axis=1)
            if m.any():
                got = np.asarray(style(gen, stats), np.float64)
                style_err += float(np.abs(c["style"][m] - got[m]).sum())
                style_n += int(m.sum())
    return (pose_err / pose_n if pose_n else float("nan"),
            style_err / style_n if style_n else float("nan"))


def evaluate(reference, generated, controls=None, extractor=None, stats=None,
             reference_features=None, audio=None) -> dict[str, Any]:
    """One table row for paired clip lists (reference[i] <-> generated[i], same lengths).

    - ``fgd``: between extractor features of all reference windows and all generated windows
      (NaN without an extractor);
    - ``pcs`` / ``scs``: over every controlled frame of ``controls`` (one ControlArrays or dict
      per generated clip, or None), frame-weighted; NaN without controls;
    - ``ape``: frame-weighted over all clips, metres;
    - ``speed``/``accel``/``jerk`` of the generated clips (pooled), and ``*_ratio`` to the
      reference's; ``jerk_ok``: ratio within 25 %;
    - ``hellinger*``: per clip pair (as in Kucherenko Tables 2-3), then averaged; ``*_std``
      is the spread over clips;
    - ``beat_align``: :func:`clips_beat_alignment` of the generated clips against ``audio`` (the
      audio features of each clip, or None: NaN). Extra keys: ``reference_*`` statistics,
      ``n_clips``, ``n_frames``.
    """
    ref = _as_clips(reference)
    gen = _as_clips(generated)
    if len(ref) != len(gen):
        raise ValueError(f"{len(ref)} reference clips but {len(gen)} generated clips; they are compared in pairs")
    for i, (r, g) in enumerate(zip(ref, gen)):
        if r.shape != g.shape:
            raise ValueError(f"clip {i}: reference {r.shape} and generated {g.shape} differ in shape")
    row: dict[str, Any] = {}

    if extractor is not None:
        fa = reference_features if reference_features is not None else extractor.features(ref)
        row["fgd"] = fgd(fa, extractor.features(gen))
    else:
        row["fgd"] = float("nan")

    if controls is not None:
        row["pcs"], row["scs"] = _pcs_scs([_require_poses(g) for g in gen], controls, stats)
    else:
        row["pcs"] = row["scs"] = float("nan")

    frames = sum(len(r) for r in ref)
    row["ape"] = sum(ape(r, g) * len(r) for r, g in zip(ref, gen)) / frames if frames else float("nan")

    st_gen = motion_statistics(gen, ("all",))["all"]
    st_ref = motion_statistics(ref, ("all",))["all"]
    for k in ("speed", "accel", "jerk"):
        row[k] = getattr(st_gen, k)
        row[f"reference_{k}"] = getattr(st_ref, k)
        row[f"{k}_ratio"] = ratio(getattr(st_gen, k), getattr(st_ref, k))
    row["jerk_ok"] = jerk_within_tolerance(row["jerk_ratio"])

    for key, group in (("hellinger", "all"), ("hellinger_elbows", "elbows"), ("hellinger_wrists", "wrists")):
        hs = np.array([speed_hellinger(r, g, group) for r, g in zip(ref, gen)])
        hs = hs[np.isfinite(hs)]
        row[key] = float(hs.mean()) if len(hs) else float("nan")
        row[f"{key}_std"] = float(hs.std()) if len(hs) else float("nan")
    row["beat_align"] = clips_beat_alignment(gen, audio) if audio is not None else float("nan")
    row["n_clips"] = len(ref)
    row["n_frames"] = frames
    return row


def _require_poses(clip: np.ndarray) -> np.ndarray:
    """PCS/SCS need poses: reject joint positions with a clear message."""
    if clip.shape[-1] != POSE_DIM:
        raise ValueError(f"PCS and SCS need generated poses (T, {POSE_DIM}), got shape {clip.shape}")
    return clip


def report(conditions: Mapping[str, Any], extractor: Any = "default", stats=None, audio=None) -> list[dict[str, Any]]:
    """Evaluate named conditions into table rows (dicts with :data:`ROW_KEYS` and ``name``).

    ``conditions`` maps a name to ``(reference clips, generated clips)`` or ``(reference clips,
    generated clips, controls)``; controls are one ControlArrays/dict per generated clip (or
    None). ``extractor``: a :class:`model.training.fgd.FGDExtractor`, a weights path, ``"default"``
    (the shipped ``model/weights/fgd_extractor.pt``; raises if it is missing) or None (no FGD).
    ``audio``: the audio features of each clip (for ``beat_align``), the same for every condition.
    """
    if isinstance(extractor, str) or hasattr(extractor, "__fspath__"):
        extractor = fgd_module.load(None if extractor == "default" else extractor)
    rows = []
    cache: dict[int, np.ndarray] = {}
    for name, entry in conditions.items():
        if not isinstance(entry, (tuple, list)) or len(entry) not in (2, 3):
            raise ValueError(f"condition {name!r}: expected (reference, generated[, controls])")
        ref, gen = entry[0], entry[1]
        controls = entry[2] if len(entry) == 3 else None
        feats = None
        if extractor is not None:
            key = id(ref)
            if key not in cache:
                cache[key] = extractor.features(_as_clips(ref))
            feats = cache[key]
        row = {"name": name, **evaluate(ref, gen, controls, extractor, stats, reference_features=feats, audio=audio)}
        rows.append(row)
    return rows


_HEADERS = {  # key: (header, width)
    "fgd": ("FGD", 7), "pcs": ("PCS", 6), "scs": ("SCS", 6), "ape": ("APE", 6),
    "speed": ("spd", 6), "accel": ("acc", 6), "jerk": ("jerk", 7),
    "jerk_ratio": ("j/ref", 6), "hellinger": ("H all", 6),
    "hellinger_elbows": ("H elb", 6), "hellinger_wrists": ("H wri", 6), "beat_align": ("BA", 5),
}
_COLUMNS = tuple((key, *_HEADERS[key]) for key in ROW_KEYS)  # (key, header, width), in table order
_UNITS = ("units: APE m, spd m/s, acc m/s^2, jerk m/s^3; j/ref: jerk / the reference's (* = not within 25%);\n"
          "BA: beat alignment with the speech onsets (0-1, higher is better); - = n/a")


def _fmt(v, width: int) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-".rjust(width)
    v = float(v)
    for digits in (3, 2, 1, 0):
        s = f"{v:.{digits}f}"
        if len(s) <= width:
            return s.rjust(width)
    return f"{v:.2g}".rjust(width)


def format_table(rows: Sequence[Mapping[str, Any]], name_width: int = 15) -> str:
    """A plain-text table like SGToolkit's Table 1 (at most 100 columns); '-' = not applicable.

    Lower is better for every column except jerk/ref (1.00 is ideal; '*' marks a ratio outside
    the 25 % tolerance), the raw speed/accel/jerk, which should match the reference, and the
    beat alignment (higher is better).
    """
    header = "condition".ljust(name_width) + "".join(" " + h.rjust(w) for _, h, w in _COLUMNS)
    lines = [header, "-" * len(header)]
    for r in rows:
        name = str(r.get("name", ""))
        if len(name) > name_width:
            name = name[: name_width - 1] + "~"
        cells = []
        for key, _, w in _COLUMNS:
            value = r.get(key)
            if key == "jerk_ratio" and value is not None and np.isfinite(value) and not jerk_within_tolerance(value):
                cell = _fmt(value, w - 1) + "*"
            else:
                cell = _fmt(value, w)
            cells.append(" " + cell)
        lines.append(name.ljust(name_width) + "".join(cells))
    lines.append(_UNITS)
    return "\n".join(lines) + "\n"
