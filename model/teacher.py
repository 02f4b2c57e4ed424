"""The rule-based teacher: words (and optionally audio) -> plausible co-speech motion.

It makes the procedural training corpus (:mod:`model.training.corpus`) and ships as the ``rules``
engine (:func:`generate`). The motion is built in layers:

1. **Arm holds** (parametric): rest while silent, a "talking" hold with the forearms raised in
   front while speaking; the hold drifts to a new variant every few seconds and drops towards
   rest during long pauses.
2. **Beats** on accents: energy / onset-strength peaks of the audio inside content words (or
   content-word onsets when there is no audio). A beat lifts the forearm slightly before the
   accent and strikes down on it. Hand by handedness, amplitude by space and speed,
   frequency and tempo by speed.
3. **Library gestures** triggered by words (deictics -> point_*, numbers -> count_*,
   negation -> head_shake/dismiss/reject, size -> big/small, greetings -> wave/welcome, ...),
   with the stroke on the word onset, at most one at a time, each trigger taken with some
   probability. One-handed gestures go to the dominant hand (sometimes the other).
4. **Idle**: breathing lean/sway of the torso, shoulder rise, slow head drift, small nods on
   accents, a torso twist towards the gesturing hand.
5. **Space** spreads the arms laterally; finally a light temporal smoothing and a per-bone
   angular velocity limit (:data:`MAX_STEP_DEG` per frame) so nothing jumps.

Style (speed, space, handedness in [-3, 3]) is given per clip (floats) or per frame (arrays).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from core.controls import STYLE_LIMIT, STYLE_NAMES
from core.hands import HandTrack
from core.skeleton import (
    BONE_INDEX,
    FPS,
    N_BONES,
    POSE_DIM,
    REST_POSE,
    normalize_pose,
)
from library import load_library
from library.words import load_word_rules
from model.features import HOP, SAMPLE_RATE, load_audio
from model import postprocess
from model.postprocess import MAX_STEP_DEG, blend_pose_controls, smoothstep, unit_vectors


# -- words ----------------------------------------------------------------------------------

STOPWORDS = frozenset(
    """a an the and or but if of at by for with about against between into through during before
    after above below to from in out on off over under again further then once is am are was were
    be been being have has had having do does did doing would should could ought i'm you're he's
    she's it's we're they're i've you've we've they've i'd you'd he'd she'd we'd they'd i'll you'll
    he'll she'll we'll they'll isn't aren't wasn't weren't hasn't haven't hadn't doesn't didn't
    won't wouldn't shan't shouldn't can't cannot couldn't mustn't let's that's who's what's here's
    there's when's where's why's how's it its itself he him his himself she her hers herself we us
    our ours they them their theirs what which who whom whose as until while so than too s t can
    will just also very much many some any such own same other each few more most nor only""".split()
)

#: Trigger words -> candidate library gestures: the entries of library/words.toml the rules
#: engine uses (:meth:`library.words.WordRules.triggers`; ``sgt suggest`` reads the same table).
TRIGGERS: dict[str, tuple[str, ...]] = load_word_rules().triggers()

#: Probability of using a trigger, before the speed factor.
TRIGGER_PROB = 0.6
_TOKEN_CLEAN = re.compile(r"[^a-z0-9']+")


def _norm_word(w: str) -> str:
    return _TOKEN_CLEAN.sub("", w.lower().replace("\u2019", "'"))


def _timed_words(words) -> list[tuple[str, float, float]]:
    """:class:`~core.words.TimedWord` list -> (word, start, end) sorted by start, end >= start."""
    return sorted(((w.word, float(w.start), float(max(w.start, w.end))) for w in words or ()), key=lambda x: x[1])


# -- style ----------------------------------------------------------------------------------


def _style_tracks(style, n: int) -> dict[str, np.ndarray]:
    out = {}
    for k in STYLE_NAMES:
        v = 0.0 if style is None else style.get(k, 0.0)
        arr = np.broadcast_to(np.asarray(v, np.float64), (n,)).astype(np.float64)
        out[k] = np.clip(np.nan_to_num(arr), -STYLE_LIMIT, STYLE_LIMIT)
    return out


def _at(track: np.ndarray, frame: float) -> float:
    return float(track[int(min(max(round(frame), 0), len(track) - 1))])


# -- geometry -------------------------------------------------------------------------------


def _upper_arm(side: float, abd, flex) -> np.ndarray:
    """Upper-arm direction: hanging, raised forward by ``flex`` and outward by ``abd`` (radians)."""
    abd, flex = np.asarray(abd), np.asarray(flex)
    d = np.stack([side * np.sin(abd), -np.cos(abd) * np.cos(flex), np.cos(abd) * np.sin(flex)], -1)
    return unit_vectors(d)


def _forearm(side: float, elev, azim) -> np.ndarray:
    """Forearm direction: forward (+z), raised by ``elev``, turned outward by ``azim`` (radians)."""
    elev, azim = np.asarray(elev), np.asarray(azim)
    d = np.stack([side * np.cos(elev) * np.sin(azim), np.sin(elev), np.cos(elev) * np.cos(azim)], -1)
    return unit_vectors(d)


def _rot(yaw, pitch, roll) -> np.ndarray:
    """(T, 3, 3) rotations: roll about z, then pitch about x, then yaw about y."""
    yaw, pitch, roll = (np.asarray(a, np.float64) for a in (yaw, pitch, roll))
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    z, o = np.zeros_like(yaw), np.ones_like(yaw)
    ry = np.stack([np.stack([cy, z, sy], -1), np.stack([z, o, z], -1), np.stack([-sy, z, cy], -1)], -2)
    rx = np.stack([np.stack([o, z, z], -1), np.stack([z, cp, -sp], -1), np.stack([z, sp, cp], -1)], -2)
    rz = np.stack([np.stack([cr, -sr, z], -1), np.stack([sr, cr, z], -1), np.stack([z, z, o], -1)], -2)
    return ry @ rx @ rz


def _slerp_dirs(a: np.ndarray, b: np.ndarray, w) -> np.ndarray:
    """Blend unit directions a -> b by weight w (broadcast), renormalised (nlerp with a guard)."""
    w = np.asarray(w, np.float64)
    out = a * (1.0 - w) + b * w
    n = np.linalg.norm(out, axis=-1, keepdims=True)
    bad = n[..., 0] < 1e-3  # opposite directions: fall back to the nearer end
    if np.any(bad):
        wb = np.broadcast_to(w, out.shape)[..., 0]
        out[bad] = np.where(wb[bad][:, None] < 0.5, a[bad] if a.shape == out.shape else np.broadcast_to(a, out.shape)[bad],
                            np.broadcast_to(b, out.shape)[bad])
        n = np.linalg.norm(out, axis=-1, keepdims=True)
    return out / np.maximum(n, 1e-9)


def limit_velocity(poses: np.ndarray, max_deg=MAX_STEP_DEG) -> np.ndarray:
    """Rotate each bone towards its target by at most ``max_deg`` per frame (T, 27) -> (T, 27)
    (:func:`model.postprocess.limit_velocity` with the teacher's limit by default)."""
    return postprocess.limit_velocity(poses, max_deg)


# -- accents --------------------------------------------------------------------------------


#: Weights of the frame's loudness and of its onset strength in :func:`accent_strength`.
ACCENT_MIX = (0.6, 0.4)


def accent_strength(audio, n: int, lead_in: float = 0.0) -> np.ndarray | None:
    """Per-frame accent strength in [0, 1] of ``audio`` (mono at SAMPLE_RATE starting ``lead_in``
    seconds into the ``n`` motion frames): 0.6 x the frame's log energy (scaled to the clip's
    range) + 0.4 x its onset strength (positive change of the log energy of four sub-frames,
    scaled by its 99th percentile). None without audio. The corpus stores it with each clip, so
    the teacher can be re-run (``sgt eval``'s ``rules`` row) on the same accents without the audio."""
    if audio is None or len(audio) == 0:
        return None
    y = np.asarray(audio, np.float32)
    off = int(round(lead_in * SAMPLE_RATE))
    y = np.concatenate([np.zeros(max(0, off), np.float32), y[max(0, -off):]])
    y = np.pad(y, (0, max(0, n * HOP - len(y))))[: n * HOP]
    frames = y.reshape(n, HOP).astype(np.float64)
    rms = np.sqrt((frames**2).mean(1) + 1e-12)
    # onset strength: positive change of the log energy in 4 sub-bands (quarters) of each frame
    quarter = HOP // 4
    sub = frames[:, : 4 * quarter].reshape(n, 4, quarter)
    loge = np.log(np.sqrt((sub**2).mean(-1)) + 1e-5).mean(1)
    flux = np.maximum(np.diff(loge, prepend=loge[:1]), 0.0)
    s = np.log(rms + 1e-5)
    s = (s - s.min()) / max(1e-6, s.max() - s.min())
    f = flux / max(1e-6, np.percentile(flux, 99))
    return np.clip(ACCENT_MIX[0] * s + ACCENT_MIX[1] * np.clip(f, 0, 1), 0.0, 1.0)


def _accents(words, n: int, strength, rng) -> list[tuple[int, float]]:
    """(frame, strength in [0, 1]) of accented syllables, at most one per content word: the
    strongest frame of :func:`accent_strength` in the first half of the word, or (no audio)
    the word's onset with a strength from its length."""
    out = []
    for text, a, b in words:
        w = _norm_word(text)
        if not w:
            continue
        content = w not in STOPWORDS
        fa = int(math.floor(a * FPS + 1e-6))
        fb = max(fa + 1, int(math.ceil(b * FPS - 1e-6)))
        if fa >= n or fb <= 0:
            continue
        fa, fb = max(0, fa), min(n, fb)
        if strength is not None:
            seg = strength[fa:max(fa + 1, fa + (fb - fa + 1) // 2 + 1)]
            k = int(np.argmax(seg))
            st = float(seg[k]) * (1.0 if content else 0.45)
            out.append((fa + k, st))
        else:
            st = (0.55 + 0.05 * min(len(w), 8)) if content else 0.2
            out.append((fa, float(np.clip(st + rng.normal(0, 0.08), 0, 1))))
    return out


# -- the teacher ----------------------------------------------------------------------------

_library = None


def _lib():
    global _library
    if _library is None:
        _library = load_library(use_config=False)
    return _library


def _gesture_bones(poses: np.ndarray) -> np.ndarray:
    """Bones (bool (9,)) a clip moves away from the rest pose by more than 3 degrees."""
    d = poses.reshape(len(poses), N_BONES, 3)
    cos = np.clip((d * REST_POSE.reshape(N_BONES, 3)).sum(-1), -1, 1)
    return np.degrees(np.arccos(cos)).max(0) > 3.0


def _beat_kernel(t: np.ndarray, dur: float) -> np.ndarray:
    """A beat's forearm elevation profile around the accent (t seconds from it): up, then strike."""
    up = np.exp(-0.5 * ((t + 0.45 * dur) / (0.22 * dur)) ** 2)
    down = np.exp(-0.5 * ((t - 0.03) / (0.2 * dur)) ** 2)
    return 0.7 * up - 1.0 * down


@dataclass
class _Clip:
    """What every step of :func:`teach` reads: the frames, the style per frame, the speaker's
    personality and the times of the hold variants."""

    n: int
    t_sec: np.ndarray  # (n,) seconds of every frame
    speed: np.ndarray  # (n,) tempo factor 0.5 .. 2 (style speed -3 .. 3)
    space: np.ndarray  # (n,) -1 .. 1
    hand: np.ndarray  # (n,) -1 (right-handed) .. 1 (left-handed)
    pers: dict  # per-clip personality, see _personality
    keys_t: list  # times (s) of the hold variants


@dataclass
class _Beats:
    elev: dict  # side (1.0 left, -1.0 right) -> (n,) forearm elevation offsets, radians
    flex: dict  # side -> (n,) upper-arm flexion offsets, radians
    frames: list  # frames of the beats


def _personality(rng) -> dict:
    """Per-clip personality: the resting hold, beat amplitude and rate, trigger and head factors."""
    return {
        "flex": math.radians(rng.uniform(12, 30)),
        "abd": math.radians(rng.uniform(4, 14)),
        "elev": math.radians(rng.uniform(-18, 6)),
        "azim": math.radians(rng.uniform(-28, -8)),
        "beat_amp": rng.uniform(0.8, 1.2),
        "beat_rate": rng.uniform(0.75, 1.15),
        "trigger": rng.uniform(0.75, 1.2),
        "head": rng.uniform(0.6, 1.4),
        "breath_period": rng.uniform(3.0, 5.0),
    }


def _speaking_envelope(tw, n: int) -> np.ndarray:
    """1 while talking (from a little before the first word to a little after the last of a
    run of words), 0 at rest; smooth. Long pauses drop part way towards rest, short gaps are
    bridged."""
    talk = np.zeros(n)
    for _, a, b in tw:
        fa, fb = int(math.floor((a - 0.45) * FPS)), int(math.ceil((b + 0.6) * FPS))
        talk[max(0, fa):max(0, min(n, fb))] = 1.0
    talk = postprocess.gauss_smooth(talk, 3.0)
    return smoothstep(talk * 1.15)


def _hold_times(n: int, speed: np.ndarray, rng) -> list:
    """Times of the hold variants: a new variant every 1.5-4 s (shorter when fast)."""
    keys_t = [0.0]
    while keys_t[-1] < n / FPS + 1.0:
        keys_t.append(keys_t[-1] + rng.uniform(1.5, 4.0) / float(np.mean(speed)) ** 0.5)
    return keys_t


def _hold_variants(nk: int, rng) -> tuple[dict, np.ndarray]:
    """Per side, random offsets of the hold angles at every hold time; and per hold time, a draw
    that sometimes rests the non-dominant hand while the dominant one talks."""
    var = {
        side: {
            "flex": rng.normal(0, math.radians(6), nk),
            "abd": rng.normal(0, math.radians(4), nk),
            "elev": rng.normal(0, math.radians(8), nk),
            "azim": rng.normal(0, math.radians(8), nk),
        }
        for side in (1.0, -1.0)
    }
    return var, rng.random(nk)


def _beats(accents, c: _Clip, rng) -> _Beats:
    """Beats on the accents: the forearm lifts slightly before the accent and strikes down on
    it; hand by handedness, amplitude by space and speed, frequency and tempo by speed."""
    n, t_sec, pers = c.n, c.t_sec, c.pers
    beats = _Beats({1.0: np.zeros(n), -1.0: np.zeros(n)}, {1.0: np.zeros(n), -1.0: np.zeros(n)}, [])
    last = -1e9
    for f, s in accents:
        sf = _at(c.speed, f)
        gap = 0.55 / sf
        p = np.clip((0.25 + 0.75 * s) * pers["beat_rate"] * (0.55 + 0.45 * sf), 0.0, 0.97)
        if (f - last) / FPS < gap or rng.random() > p:
            continue
        last = f
        beats.frames.append(f)
        q = _at(c.hand, f)
        both = rng.random() < 0.3 * (1.0 - abs(q))
        left = rng.random() < 0.5 + 0.48 * q
        amp = math.radians(14.0) * pers["beat_amp"] * (0.45 + 0.55 * sf) * (0.6 + 0.4 * s) * (1.0 + 0.25 * _at(c.space, f))
        dur = float(np.clip(0.6 / sf ** 0.7, 0.3, 1.0))
        lo, hi = max(0, f - int(dur * FPS) - 2), min(n, f + int(dur * FPS) + 2)
        k = _beat_kernel(t_sec[lo:hi] - f / FPS, dur)
        for side in (1.0, -1.0):
            if both or (side > 0) == left:
                w = 1.0 if not both else 0.8
                beats.elev[side][lo:hi] += -amp * w * k  # negative kernel peak -> strike down
                beats.flex[side][lo:hi] += -0.35 * amp * w * k
    return beats


def _arms(c: _Clip, talk: np.ndarray, var: dict, rest_other: np.ndarray, beats: _Beats) -> np.ndarray:
    """Bone directions (n, 9, 3): the rest pose with both arms in their holds (rest while
    silent, raised in front while talking, drifting between the hold variants) plus the beats."""
    n, t_sec, keys_t, pers, spc, hnd = c.n, c.t_sec, c.keys_t, c.pers, c.space, c.hand

    def hold_track(vals):
        return postprocess.gauss_smooth(np.interp(t_sec, keys_t, vals), 0.25 * FPS)

    dirs = np.repeat(REST_POSE.reshape(1, N_BONES, 3).astype(np.float64), n, axis=0)
    for side, ub, fb in ((1.0, "left_elbow", "left_wrist"), (-1.0, "right_elbow", "right_wrist")):
        dom = np.clip(0.5 + side * 0.5 * hnd, 0.0, 1.0)  # 1 for the dominant side
        # the non-dominant hand of a strongly handed speaker often stays down
        lazy = np.interp(t_sec, keys_t, (rest_other < 0.45).astype(float))
        lazy = postprocess.gauss_smooth(lazy, 0.3 * FPS) * np.clip(1.0 - dom * 2.0, 0.0, 1.0) * np.abs(hnd) * 1.5
        engage = talk * np.clip(1.0 - lazy, 0.0, 1.0)
        flex = pers["flex"] + hold_track(var[side]["flex"]) + 0.08 * spc
        abd = pers["abd"] + hold_track(var[side]["abd"]) + math.radians(10) * spc
        elev = pers["elev"] + hold_track(var[side]["elev"]) + math.radians(8) * spc
        azim = pers["azim"] + hold_track(var[side]["azim"]) + math.radians(22) * spc
        rest_abd, rest_flex = math.atan2(0.12, 1.0), 0.02
        rest_elev, rest_azim = math.asin(-0.75 / math.hypot(0.75, math.hypot(0.02, 0.66))), 0.03
        flex = rest_flex + engage * (flex - rest_flex) + beats.flex[side] * engage
        abd = rest_abd + engage * (abd - rest_abd)
        elev = rest_elev + engage * (elev - rest_elev) + beats.elev[side] * np.maximum(engage, 0.3)
        azim = rest_azim + engage * (azim - rest_azim)
        dirs[:, BONE_INDEX[ub]] = _upper_arm(side, abd, np.maximum(flex, -0.1))
        dirs[:, BONE_INDEX[fb]] = _forearm(side, elev, azim)
    return dirs


def _add_library_gestures(dirs: np.ndarray, tw, c: _Clip, trigger_prob: float | None, rng,
                          hands: tuple[HandTrack, np.ndarray] | None = None) -> None:
    """Blend library gestures triggered by words into ``dirs`` (in place): the stroke on the
    word's onset, one gesture at a time, one-handed ones mostly on the dominant side. With
    ``hands`` (a track and its weights, (n,)), the gestures' hands and blend weights go there."""
    n, pers = c.n, c.pers
    lib = _lib()
    busy_until = -1
    for text, a, b in tw:
        w = _norm_word(text)
        names = [g for g in TRIGGERS.get(w, ()) if g in lib]
        if not names:
            continue
        onset = int(math.floor(a * FPS + 1e-6))
        if onset >= n or onset < 0:
            continue
        sf = _at(c.speed, onset)
        p = TRIGGER_PROB * pers["trigger"] * (0.6 + 0.4 * sf)
        p = min(0.95, p) if trigger_prob is None else float(trigger_prob)
        if rng.random() >= p:
            continue
        name = names[int(rng.integers(len(names)))]
        g = lib.get(name)
        gspeed = float(np.clip(round(sf ** 0.5 * 4) / 4, 0.75, 1.25))
        hold = float(rng.choice([0.0, 0.0, 0.2, 0.4])) / sf
        q = _at(c.hand, onset)
        flip = bool(rng.random() < 0.5 + 0.45 * q)  # library one-handed gestures use the right hand
        if name in ("point_left", "point_right"):
            # keep the meaning (direction); usually point with the arm on that side
            flip = bool(rng.random() < (0.8 if name == "point_left" else 0.2) * (1 + 0.2 * q))
            name_dir = name
            if flip:
                name_dir = "point_right" if name == "point_left" else "point_left"
            g = lib.get(name_dir)
        clip = g.clip(speed=gspeed, flip=flip, hold=round(hold * FPS) / FPS)
        stroke = clip.stroke_frame if clip.stroke_frame is not None else clip.n_frames // 2
        start = onset - stroke
        if start < busy_until or start + clip.n_frames <= 0:
            continue
        busy_until = start + clip.n_frames
        gp = clip.poses.reshape(-1, N_BONES, 3).astype(np.float64)
        used = _gesture_bones(clip.poses)
        L = len(gp)
        idx = np.arange(L)
        ramp_in = smoothstep((idx + 1) / max(2, stroke + 1))
        post = L - 1 - stroke
        r0 = stroke + max(1, int(0.45 * post))
        ramp_out = 1.0 - smoothstep((idx - r0) / max(2, L - 1 - r0))
        wgt = np.minimum(ramp_in, ramp_out)
        lo, hi = max(0, start), min(n, start + L)
        sl = slice(lo - start, hi - start)
        for bi in np.flatnonzero(used):
            # head bones from the library: add the gesture's rotation on top of the base
            dirs[lo:hi, bi] = _slerp_dirs(dirs[lo:hi, bi], gp[sl, bi], wgt[sl, None])
        if hands is not None:
            track, weight = hands
            track.palm[lo:hi] = clip.hands.palm[sl]
            track.fingers[lo:hi] = clip.hands.fingers[sl]
            weight[lo:hi] = wgt[sl]


def _idle(dirs: np.ndarray, c: _Clip, talk: np.ndarray, beats: _Beats, rng) -> np.ndarray:
    """Add head drift and nods and the shoulders' breathing to ``dirs`` (in place); return the
    torso rotations (n, 3, 3): breathing lean and sway, a twist towards the more active hand."""
    t_sec, pers, nk = c.t_sec, c.pers, len(c.keys_t)
    ph = rng.uniform(0, 2 * np.pi, 8)
    bp = pers["breath_period"]
    breath = np.sin(2 * np.pi * t_sec / bp + ph[0])
    lean = math.radians(1.2) * breath + math.radians(1.5) * np.sin(2 * np.pi * t_sec / 9.0 + ph[1]) * talk
    roll = math.radians(1.0) * np.sin(2 * np.pi * t_sec / 7.3 + ph[2])
    # twist towards the more active hand
    act_l = postprocess.gauss_smooth(np.abs(np.diff(dirs[:, BONE_INDEX["left_wrist"]], axis=0, prepend=dirs[:1, BONE_INDEX["left_wrist"]])).sum(-1), 4)
    act_r = postprocess.gauss_smooth(np.abs(np.diff(dirs[:, BONE_INDEX["right_wrist"]], axis=0, prepend=dirs[:1, BONE_INDEX["right_wrist"]])).sum(-1), 4)
    twist = math.radians(5.0) * np.tanh(4.0 * (act_l - act_r)) + math.radians(1.5) * np.sin(2 * np.pi * t_sec / 11 + ph[3])
    torso = _rot(twist, lean, roll)

    hscale = pers["head"] * (0.7 + 0.3 * np.clip(c.speed, 0.5, 2.0))
    head_yaw = math.radians(7.0) * hscale * postprocess.gauss_smooth(np.interp(t_sec, c.keys_t, rng.uniform(-1, 1, nk)), 0.4 * FPS)
    head_pitch = math.radians(2.5) * np.sin(2 * np.pi * t_sec / 6.1 + ph[4]) * hscale
    head_roll = math.radians(3.0) * hscale * postprocess.gauss_smooth(np.interp(t_sec, c.keys_t, rng.uniform(-1, 1, nk)), 0.5 * FPS)
    for f in beats.frames:  # small nods on the beats
        if rng.random() < 0.6:
            head_pitch += math.radians(4.0) * hscale * np.exp(-0.5 * ((t_sec - f / FPS - 0.02) / 0.12) ** 2)
    # nose/head_top rotate about the neck: a positive pitch (about +x) lifts the face (+z) down
    head = _rot(head_yaw, head_pitch, head_roll)
    for bname in ("nose", "head_top"):
        bi = BONE_INDEX[bname]
        dirs[:, bi] = np.einsum("tij,tj->ti", head, dirs[:, bi])
    for bname, s in (("left_shoulder", 1.0), ("right_shoulder", -1.0)):
        bi = BONE_INDEX[bname]
        dirs[:, bi, 1] += 0.03 * breath + 0.04 * talk * np.maximum(0, 0.5 * (beats.elev[s] != 0))
    return torso


def _finish(dirs: np.ndarray, c: _Clip, talk: np.ndarray, torso: np.ndarray) -> np.ndarray:
    """Space spreads the arms, the torso carries everything, then a light temporal smoothing and
    the per-bone angular velocity limit: poses (n, 27) float32."""
    for side, ub, fb in ((1.0, "left_elbow", "left_wrist"), (-1.0, "right_elbow", "right_wrist")):
        dirs[:, BONE_INDEX[ub], 0] += side * 0.08 * c.space
        dirs[:, BONE_INDEX[fb], 0] += side * 0.22 * c.space * (0.4 + 0.6 * talk)
    dirs = unit_vectors(dirs)
    dirs = np.einsum("tij,tbj->tbi", torso, dirs)
    poses = dirs.reshape(c.n, POSE_DIM)
    poses = postprocess.gauss_smooth(poses, 0.7)
    poses = limit_velocity(normalize_pose(poses))
    return normalize_pose(poses).astype(np.float32)


def teach(words, n_frames: int, *, audio=None, lead_in: float = 0.0, style=None,
          rng: np.random.Generator | None = None, trigger_prob: float | None = None,
          strength: np.ndarray | None = None, hands_out: list | None = None) -> np.ndarray:
    """Poses (n_frames, 27) float32 of unit bone directions for timed ``words``.

    ``words``: timed words (seconds on the motion timeline; :class:`~core.words.TimedWord`).
    ``audio``: mono float32 at :data:`model.features.SAMPLE_RATE` starting ``lead_in``
    seconds into the motion, or None; or instead ``strength``, its :func:`accent_strength`
    (n_frames,) computed before. ``style``: dict of speed/space/handedness in [-3, 3],
    scalars (per clip) or arrays (per frame). ``trigger_prob`` overrides the chance that a
    trigger word gets its library gesture. Deterministic given ``rng``'s state (the steps
    draw from it in this order, which fixes the corpus). With ``hands_out`` (a list), the
    triggered gestures' hands and their blend weights are appended to it as one
    ``(HandTrack, weights)`` layer for :func:`model.hands.motion_hands`.
    """
    rng = np.random.default_rng(0) if rng is None else rng
    n = int(n_frames)
    if n <= 0:
        return np.zeros((0, POSE_DIM), np.float32)
    tw = _timed_words(words)
    st = _style_tracks(style, n)
    speed = 2.0 ** (st["speed"] / 3.0)  # 0.5 .. 2 per frame
    pers = _personality(rng)
    talk = _speaking_envelope(tw, n)
    c = _Clip(n, np.arange(n) / FPS, speed, st["space"] / 3.0, st["handedness"] / 3.0, pers, _hold_times(n, speed, rng))
    var, rest_other = _hold_variants(len(c.keys_t), rng)
    if strength is None:
        strength = accent_strength(audio, n, lead_in)
    beats = _beats(_accents(tw, n, strength, rng), c, rng)
    dirs = _arms(c, talk, var, rest_other, beats)
    hands = None if hands_out is None else (HandTrack.rest(n), np.zeros(n))
    _add_library_gestures(dirs, tw, c, trigger_prob, rng, hands)
    if hands is not None:
        hands_out.append(hands)
    torso = _idle(dirs, c, talk, beats, rng)
    return _finish(dirs, c, talk, torso)


# -- the ``rules`` engine -----------------------------------------------------------------


#: The ``rules`` engine eases into and out of pose controls over at least CONTROL_RAMP frames,
#: more when the arms must turn further than CONTROL_RAMP_STEP_DEG degrees a frame.
CONTROL_RAMP = 5
CONTROL_RAMP_STEP_DEG = 12.0


def generate(inputs, *, seed: int = 0, hands_out: list | None = None) -> np.ndarray:
    """The ``rules`` engine: teacher motion with the style controls, pose controls exact.
    ``hands_out``: see :func:`teach`."""
    arrays = inputs.arrays
    n = arrays.n_frames
    style = {}
    for k, name in enumerate(STYLE_NAMES):
        mask = arrays.style_mask[:, k] > 0.5
        style[name] = np.where(mask, arrays.style[:, k], 0.0).astype(np.float64)
    audio = None
    if inputs.audio_path is not None:
        audio = load_audio(inputs.audio_path)
    base = teach(inputs.words, n, audio=audio, lead_in=inputs.lead_in,
                 style=style, rng=np.random.default_rng(seed), hands_out=hands_out)
    out = blend_pose_controls(base, arrays.pose, arrays.pose_mask, CONTROL_RAMP, max_step_deg=CONTROL_RAMP_STEP_DEG,
                              bones=arrays.bone_mask)
    return normalize_pose(out).astype(np.float32)
