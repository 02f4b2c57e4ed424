"""A script's performance: one continuous track per speaker on the performance clock.

Every utterance is generated on its own (any engine; :func:`model.generate.clips_from_plan`),
at the place :meth:`dsl.plan.Plan.lay_out` gives it. A speaker's track covers the whole
performance: its own utterances where it speaks and, everywhere else, **listening motion**:
the rules engine's idle layer (:func:`model.teacher.teach` without words: arms at rest,
breathing, weight shifts of the torso, slow head drift) plus small nods shortly after the
other speakers' accented (content) words.

Joins: an utterance starts and ends wherever its engine put it (each is generated from its
own inputs alone, so ``sgt build`` caches exactly what ``sgt generate`` makes), so it is
eased in and out of the listening motion (:func:`place`). Each ease straddles the boundary (half
before the utterance's first frame, holding that frame, half inside it), and is as long as
the distance to cover needs (:data:`EASE_PER_METRE` frames per metre of the largest joint
distance, at least :data:`MIN_EASE`), so no joint steps more than a few centimetres a frame
at a boundary whatever the engine made. Eases before an utterance never reach back over the
same speaker's previous one.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np

from core import cancel
from core.controls import ControlArrays
from core.hands import SIDES, HandTrack, slerp, steady_palms
from core.motion import MotionClip, Track
from core.skeleton import BONE_INDEX, FPS, N_BONES, normalize_pose, positions_from_pose, slerp_poses
from model.face import speaker_face
from model.hands import limit_speed, with_gestures
from model.postprocess import blend_pose_controls, smoothstep

#: Shortest ease between listening and speaking motion, frames.
MIN_EASE = 6
#: Ease frames per metre of the largest joint distance at a boundary: a smoothstep's steepest
#: step is 1.5 / frames of the distance, so 50 frames per metre keeps it at 3 cm a frame.
EASE_PER_METRE = 50.0
#: Longest ease, frames (3 s: from arms down to arms up).
MAX_EASE = 45
#: Listening nods: chance per accented word of another speaker, delay after its onset (s),
#: amplitude (degrees) and width (s) of the nod.
NOD_CHANCE = 0.5
NOD_DELAY = 0.15
NOD_DEG = 4.0
NOD_WIDTH = 0.14

_WORD = re.compile(r"[^\W_]+(?:['\u2019][^\W_]+)*")


def accents(plan, listener) -> list[float]:
    """Seconds on the performance clock of the other speakers' content-word onsets."""
    from model.teacher import STOPWORDS  # lazy: the teacher loads the gesture library (the editor imports this)

    out = []
    for u in plan.utterances:
        if u.speaker == listener:
            continue
        for w in u.words:
            m = _WORD.search(w.word.lower())
            if m and m.group() not in STOPWORDS:
                out.append(u.start + w.start)
    return out


def listening(n_frames: int, accent_times, rng: np.random.Generator) -> np.ndarray:
    """Poses (n, 27) of a listener: idle motion at rest and nods after some of ``accent_times``."""
    from model.teacher import teach  # lazy: the teacher loads the gesture library (the editor imports this)

    if n_frames <= 0:
        return np.zeros((0, 3 * N_BONES), np.float32)
    dirs = teach([], n_frames, rng=rng).astype(np.float64).reshape(n_frames, N_BONES, 3)
    t = np.arange(n_frames) / FPS
    pitch = np.zeros(n_frames)
    # a nod's bell is exactly 0.0 in float64 beyond 38.6 widths of its centre: add it where it is not
    reach = int(math.ceil(38.7 * NOD_WIDTH * FPS)) + 1
    for a in accent_times:
        if rng.random() < NOD_CHANCE:
            c = int(round((a + NOD_DELAY) * FPS))
            near = slice(max(0, c - reach), max(0, min(n_frames, c + reach)))
            pitch[near] += math.radians(NOD_DEG) * np.exp(-0.5 * ((t[near] - a - NOD_DELAY) / NOD_WIDTH) ** 2)
    pitch = np.minimum(pitch, math.radians(1.5 * NOD_DEG))  # nods in a row do not add up to a bow
    c, s = np.cos(pitch), np.sin(pitch)
    for bone in ("nose", "head_top"):  # a positive pitch about +x turns the face (+z) down
        b = BONE_INDEX[bone]
        y, z = dirs[:, b, 1].copy(), dirs[:, b, 2].copy()
        dirs[:, b, 1], dirs[:, b, 2] = c * y - s * z, s * y + c * z
    return normalize_pose(dirs.reshape(n_frames, -1)).astype(np.float32)


def _ease_frames(a: np.ndarray, b: np.ndarray) -> int:
    """Frames needed to ease from pose ``a`` to pose ``b`` (the largest joint distance along
    the arcs the bones turn through: up to pi/2 times the straight distance)."""
    d = float(np.linalg.norm(positions_from_pose(a) - positions_from_pose(b), axis=-1).max())
    turn = np.arccos(np.clip((a.reshape(N_BONES, 3) * b.reshape(N_BONES, 3)).sum(-1), -1.0, 1.0)).max()
    d *= max(1.0, turn / (2.0 * math.sin(max(turn, 1e-6) / 2.0)))  # arc over chord
    return int(min(MAX_EASE, max(MIN_EASE, math.ceil(EASE_PER_METRE * d))))


def place(track: np.ndarray, poses: np.ndarray, start: int, free_before: int, free_after: int) -> None:
    """Put an utterance's ``poses`` into ``track`` (listening motion, changed in place) at frame
    ``start``, eased in and out. ``free_before``/``free_after``: frames of listening motion
    before and after it that an ease may use."""
    n = len(poses)
    end = start + n
    base = track[start:end].copy()
    # ease in: from the listening motion to the utterance (its first pose held before it)
    k = _ease_frames(track[max(0, start - 1)], poses[0])
    before = min(k // 2, free_before)
    inside = min(k - before, n // 2)
    a = start - before
    w = smoothstep((np.arange(before + inside) + 1) / (before + inside + 1))
    target = np.concatenate([np.repeat(poses[:1], before, 0), poses[:inside]])
    track[a : start + inside] = slerp_poses(track[a : start + inside], target, w)
    # the utterance's own frames
    mid = slice(start + inside, end)
    track[mid] = poses[inside:]
    # ease out: back to the listening motion (the last pose held after it)
    k = _ease_frames(poses[-1], track[min(len(track) - 1, end)] if end < len(track) else poses[-1])
    after = min(k // 2, free_after)
    inside_out = min(k - after, n - inside)
    b0 = end - inside_out
    w = 1.0 - smoothstep((np.arange(inside_out + after) + 1) / (inside_out + after + 1))
    listen = np.concatenate([base[n - inside_out :], track[end : end + after]])
    target = np.concatenate([poses[n - inside_out :], np.repeat(poses[-1:], after, 0)])
    track[b0 : end + after] = slerp_poses(listen, target, w)


def place_hands(track: HandTrack, hands: HandTrack, start: int) -> None:
    """Put an utterance's ``hands`` into a track's hands (relaxed while listening; changed in
    place) at frame ``start``, eased in and out over :data:`MIN_EASE` frames inside the
    utterance (palms turn along the arc, finger angles blend)."""
    n = hands.n_frames
    w = np.ones(n, np.float32)
    k = min(MIN_EASE, n // 2)
    if k:
        ramp = smoothstep((np.arange(k) + 1) / (k + 1))
        w[:k], w[n - k :] = ramp, ramp[::-1]
    frames = slice(start, start + n)
    for j, side in enumerate(SIDES):
        track.palm[frames, j] = slerp(track.palm[frames, j], hands.palm[:, j], w, 1.0 if side == "right" else -1.0)
    track.fingers[frames] = (1 - w)[:, None, None, None] * track.fingers[frames] + w[:, None, None, None] * hands.fingers


def listening_tracks(plan, seed: int = 0) -> dict:
    """Speaker -> poses (``plan.n_frames``, 27): its listening motion over the whole performance
    (deterministic for a plan and a seed)."""
    tracks = {}
    for k, speaker in enumerate(plan.speakers):
        cancel.check()
        tracks[speaker] = listening(plan.n_frames, accents(plan, speaker), np.random.default_rng([seed, k]))
    return tracks


@dataclass(frozen=True)
class Exact:
    """How a performance makes its pose controls exact on the tracks (:func:`perform`): the
    pose-control blend's ramp (frames; longer where a bone must turn more than ``max_step_deg``
    degrees a frame), or none (``--no-blend``: the engine's own following)."""

    ramp: int = 6
    max_step_deg: float = 40.0  # 600 deg/s: ramps never come near the 900 deg/s bound
    blend: bool = True


def perform(plan, clips: list[MotionClip], seed: int = 0, listening: dict | None = None,
            exact: Exact | None = None) -> tuple[list[MotionClip], list[Track]]:
    """The performance: one :class:`~core.motion.Track` per speaker of ``plan`` (in order of
    their first line), ``plan.n_frames`` long, and each utterance's clip as a view of its
    speaker's track.

    A track is its speaker's listening motion (:func:`listening_tracks`, or ``listening``
    computed before from the same plan and seed) with its utterances (``clips``, one per planned
    utterance, as the engine made them) eased in at their places (:func:`place`). Then every
    pose control of those utterances is made exact on the track (``exact``, the pose-control
    blend of :mod:`model.postprocess` over the whole track, its requests at their frames): the
    easing between utterances and the listening motion can never cut into a stroke, which is
    on its word. Hands likewise: the utterances' hands eased into relaxed hands, then the pose
    controls' hands exact on their frames, then the hands' speed limit, then their roll about
    the forearm kept continuous (:func:`core.hands.steady_palms`). The returned clips are
    the tracks' frames of each utterance (the same numbers), with the utterances' words and
    controls: the track is the product, the clip a view of it. Each track also has its
    speaker's face (:func:`model.face.speaker_face`: visemes of its lines' phonemes, blinks,
    brows, expressions, and gaze turned from the track's head), and each clip its frames of it;
    the face never changes the body or the hands."""
    exact = exact or Exact()
    n = plan.n_frames
    tracks, views = [], {}
    for speaker, listen in (listening if listening is not None else listening_tracks(plan, seed)).items():
        cancel.check()
        poses = listen.copy()
        hands = HandTrack.rest(n)
        own = [(u, c) for u, c in zip(plan.utterances, clips) if u.speaker == speaker]
        for i, (u, c) in enumerate(own):
            prev_end = own[i - 1][0].start_frame + own[i - 1][0].n_frames if i else 0
            next_start = own[i + 1][0].start_frame if i + 1 < len(own) else n
            end = u.start_frame + c.n_frames
            # the engine's poses as a motion file holds them (5 decimals), as sgt build's cache gives them back
            place(poses, np.round(np.asarray(c.poses, np.float32), 5), u.start_frame, (u.start_frame - prev_end) // 2,
                  (next_start - end + 1) // 2)
            place_hands(hands, c.hands, u.start_frame)
        requests = ControlArrays.empty(n)
        requests.bone_mask = np.zeros((n, N_BONES), np.float32)
        gesture_hands, hand_mask = HandTrack.rest(n), np.zeros((n, 2), np.float32)
        for u, _ in own:
            at = slice(u.start_frame, u.start_frame + u.n_frames)
            requests.pose[at], requests.pose_mask[at] = u.arrays.pose, u.arrays.pose_mask
            requests.bone_mask[at] = u.arrays.bones()
            h, m = u.hands
            gesture_hands.palm[at], gesture_hands.fingers[at], hand_mask[at] = h.palm, h.fingers, m
        cancel.check()
        if exact.blend and requests.pose_mask.any():
            poses = blend_pose_controls(poses, requests.pose, requests.pose_mask, exact.ramp,
                                        max_step_deg=exact.max_step_deg, bones=requests.bone_mask)
        if hand_mask.any():
            hands = limit_speed(with_gestures(hands, gesture_hands, hand_mask))
        poses = np.asarray(poses, np.float32)
        cancel.check()
        hands = steady_palms(positions_from_pose(poses), hands)  # no hand flips about the forearm, cuts included
        track = Track(speaker, poses, hands=hands, face=speaker_face(plan, speaker, poses, seed))
        tracks.append(track)
        for u, c in own:
            at = slice(u.start_frame, u.start_frame + c.n_frames)
            frames = np.arange(n)[at]
            views[id(c)] = replace(c, poses=track.poses[at].copy(), positions=None, hands=track.hands.take(frames),
                                   face=track.face.take(frames))
    return [views[id(c)] for c in clips], tracks
