"""A script's performance: one continuous track per speaker on the performance clock.

Every utterance is generated on its own (any engine; :func:`model.generate.clips_from_plan`),
at the place :meth:`dsl.plan.Plan.lay_out` gives it. A speaker's track covers the whole
performance: its own utterances where it speaks and, everywhere else, **listening motion**
(:func:`listening`): the rules engine's idle layer (:func:`model.teacher.teach` without
words: arms at rest, breathing, sway of the torso, slow head drift) with small nods shortly
after the other speakers' accented (content) words (:func:`idle`), and on top what keeps a
listener alive (:class:`Listener`): deeper breathing in step with the teacher's, weight
shifts, arms and hands that settle now and then (:func:`listening_hands`), and nods or
tilts of the head shortly after the other speakers' phrase ends (:func:`phrase_ends`,
:func:`head_answers`).

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
from core.hands import SIDES, HandTrack, palm_direction, slerp, steady_palms
from core.motion import MotionClip, Track
from core.skeleton import BONE_INDEX, BONE_NAMES, FPS, JOINT_INDEX, N_BONES, normalize_pose, positions_from_pose, slerp_poses
from model.face import _after_words, phrases, speaker_face
from model.hands import limit_speed, with_gestures
from model.postprocess import blend_pose_controls, gauss_smooth, smoothstep

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


def phrase_ends(plan, listener) -> list[float]:
    """Seconds on the performance clock where the other speakers' phrases end (a clause mark
    after a word, a silence of :data:`model.face.PHRASE_GAP` or more before the next word, a
    pause, the end of a line: :func:`model.face.phrases`)."""
    out = []
    for u in plan.utterances:
        if u.speaker == listener or not u.words:
            continue
        for _, last in phrases(u.words, _after_words(u.text, u.words)):
            out.append(u.start + u.words[last].end)
    return sorted(out)


def idle(n_frames: int, accent_times, rng: np.random.Generator) -> np.ndarray:
    """Poses (n, 27): the teacher's idle layer at rest (:func:`model.teacher.teach` without
    words: breathing lean, small sway, slow head drift, arms hanging) and small nods after some
    of ``accent_times`` (:data:`NOD_CHANCE`). The ground :func:`listening` adds a listener to."""
    from model.teacher import teach  # lazy: the teacher loads the gesture library (the editor imports this)

    if n_frames <= 0:
        return np.zeros((0, 3 * N_BONES), np.float32)
    dirs = teach([], n_frames, rng=rng).astype(np.float64).reshape(n_frames, N_BONES, 3)
    t = np.arange(n_frames) / FPS
    pitch = np.zeros(n_frames)
    # a nod's bell is exactly 0.0 in float64 beyond 38.6 widths of its centre: add it where it is not
    reach = math.ceil(38.7 * NOD_WIDTH * FPS) + 1
    for a in accent_times:
        if rng.random() < NOD_CHANCE:
            c = round((a + NOD_DELAY) * FPS)
            near = slice(max(0, c - reach), max(0, min(n_frames, c + reach)))
            pitch[near] += math.radians(NOD_DEG) * np.exp(-0.5 * ((t[near] - a - NOD_DELAY) / NOD_WIDTH) ** 2)
    pitch = np.minimum(pitch, math.radians(1.5 * NOD_DEG))  # nods in a row do not add up to a bow
    _turn(dirs, HEAD, "x", pitch)  # a positive pitch about +x turns the face (+z) down
    return normalize_pose(dirs.reshape(n_frames, -1)).astype(np.float32)


def listening(n_frames: int, accent_times, rng: np.random.Generator, phrase_times=()) -> np.ndarray:
    """Poses (n, 27) of a listener: :func:`idle` and, on top, what keeps a listener alive
    (:class:`Listener`): visible breathing, weight shifts, arms that settle now and then, and
    nods or head tilts shortly after some of the other speakers' phrase ends
    (``phrase_times``, seconds). Deterministic for ``rng``'s state; the breathing, shifts and
    settles do not depend on the cue times, the head's answers only on ``phrase_times``."""
    if n_frames <= 0:
        return np.zeros((0, 3 * N_BONES), np.float32)
    body_rng, head_rng = (np.random.default_rng(s) for s in rng.integers(2**63, size=2))
    dirs = idle(n_frames, accent_times, rng).astype(np.float64).reshape(n_frames, N_BONES, 3)
    lively = LISTENER
    _breathe(dirs, lively)
    _settle_arms(dirs, body_rng, lively)
    _shift_weight(dirs, body_rng, lively)
    pitch, roll = head_answers(n_frames, phrase_times, head_rng, lively)
    _turn(dirs, HEAD, "z", roll)
    _turn(dirs, HEAD, "x", pitch)
    return normalize_pose(dirs.reshape(n_frames, -1)).astype(np.float32)


@dataclass(frozen=True)
class Listener:
    """How a listener moves on top of the teacher's idle layer (:func:`listening`). Ranges are
    (low, high) of a uniform draw; angles in degrees, times in seconds."""

    breath_shoulders: float = 0.02  # the shoulders rise this much more (of the bone's direction: 3.6 mm) ...
    breath_lean: float = 0.6  # ... and the body leans this much further forward at the top of a breath
    shift_every: tuple = (4.0, 9.0)  # weight shifts: from one to the next
    shift_length: tuple = (0.9, 1.6)
    shift_roll: tuple = (1.2, 2.8)  # the body's sideways lean over the standing leg, to either side
    shift_yaw: float = 2.0  # and a turn, within +-
    settle_every: tuple = (3.0, 8.0)  # each arm: from one resting place to the next
    settle_length: tuple = (0.8, 1.5)
    settle_forearm: tuple = (0.0, 20.0)  # the forearm raised forward from its hanging rest
    settle_upper_arm: tuple = (-2.0, 5.0)  # the upper arm forward
    settle_out: tuple = (-1.0, 3.0)  # the upper arm away from the body
    answer_delay: tuple = (0.1, 0.45)  # after a phrase end
    nod_chance: float = 0.35  # of a phrase end answered by a nod
    tilt_chance: float = 0.2  # ... by a tilt of the head
    nod_deg: tuple = (5.0, 9.0)
    nod_down: float = 0.2  # seconds down, then back up over nod_up
    nod_up: float = 0.35
    double_nod: float = 0.3  # chance that a nod is two (the second at 60 %)
    tilt_deg: tuple = (4.0, 7.0)
    tilt_hold: tuple = (0.8, 2.0)
    tilt_in: float = 0.5
    tilt_out: float = 0.7
    answer_gap: float = 1.5  # least seconds between two answers of the head


#: The listener of every track.
LISTENER = Listener()
#: The head's bones (they turn about the neck).
HEAD = ("nose", "head_top")
_ARMS = (("left", 1.0), ("right", -1.0))


def _turn(dirs: np.ndarray, bones, axis: str, angle) -> None:
    """Turn ``bones`` of ``dirs`` (n, 9, 3; in place) about the world ``axis`` by ``angle``
    (radians, (n,) or a number; right-handed)."""
    a = np.broadcast_to(np.asarray(angle, np.float64), dirs.shape[:1])
    c, s = np.cos(a), np.sin(a)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    for bone in bones:
        b = BONE_INDEX[bone]
        u, v = dirs[:, b, i].copy(), dirs[:, b, j].copy()
        dirs[:, b, i], dirs[:, b, j] = c * u - s * v, s * u + c * v


def _moves(n: int, rng: np.random.Generator, every, length, draw) -> np.ndarray:
    """(n,) a value that holds and moves to the next ``draw()`` every ``every`` seconds (a
    range), each move eased (smoothstep) over ``length`` seconds (a range); the first value
    is drawn too, and held from frame 0."""
    t = np.arange(n) / FPS
    value = draw()
    out = np.full(n, value, np.float64)
    at = rng.uniform(0.0, every[1])
    while at * FPS < n:
        new = draw()
        span = rng.uniform(*length)
        a, b = math.ceil(at * FPS), min(n, math.ceil((at + span) * FPS))
        out[a:b] += (new - value) * smoothstep(np.clip((t[a:b] - at) / span, 0.0, 1.0))
        out[b:] += new - value
        value = new
        at += rng.uniform(*every)
    return out


def _breathe(dirs: np.ndarray, how: Listener) -> None:
    """Deeper breathing (in place), in step with the teacher's own (:func:`teacher_breath`): the
    shoulders rise more and the body leans a little further on each breath in."""
    breath = teacher_breath(dirs)
    for bone in ("left_shoulder", "right_shoulder"):
        dirs[:, BONE_INDEX[bone], 1] += how.breath_shoulders * breath
    _turn(dirs, BONE_NAMES, "x", math.radians(how.breath_lean) * breath)


#: The teacher's idle body leans this far forward at the top of a breath (``model.teacher``'s
#: idle layer: its lean is this times the breath, -1 out .. 1 in, while it does not talk).
TEACHER_BREATH_LEAN = math.radians(1.2)


def teacher_breath(dirs: np.ndarray) -> np.ndarray:
    """(n,) the breath (-1 out .. 1 in) of the teacher's idle motion ``dirs`` (n, 9, 3), read from
    its lean: the spine bone's forward part (the sway and twist move it by less than 2 %)."""
    return np.clip(np.arcsin(np.clip(dirs[:, BONE_INDEX["neck"], 2], -1.0, 1.0)) / TEACHER_BREATH_LEAN, -1.0, 1.0)


def _settle_arms(dirs: np.ndarray, rng: np.random.Generator, how: Listener) -> None:
    """Each arm moves now and then to another resting place near its hanging rest (in place):
    the forearm a little forward, the upper arm forward and out by a few degrees."""
    n = len(dirs)
    for side, out in _ARMS:
        forearm = _moves(n, rng, how.settle_every, how.settle_length, lambda: rng.uniform(*how.settle_forearm))
        upper = _moves(n, rng, how.settle_every, how.settle_length, lambda: rng.uniform(*how.settle_upper_arm))
        away = _moves(n, rng, how.settle_every, how.settle_length, lambda: rng.uniform(*how.settle_out))
        _turn(dirs, (f"{side}_wrist",), "x", -np.radians(forearm))  # forward: -y towards +z
        _turn(dirs, (f"{side}_elbow",), "x", -np.radians(upper))
        _turn(dirs, (f"{side}_elbow", f"{side}_wrist"), "z", out * np.radians(away))  # out: towards the side's x


def _shift_weight(dirs: np.ndarray, rng: np.random.Generator, how: Listener) -> None:
    """Weight shifts (in place): the body leans over one leg, then the other, with a small turn;
    the head keeps half of the lean (a listener keeps it level)."""
    n = len(dirs)
    side = [1.0 if rng.random() < 0.5 else -1.0]

    def lean() -> float:
        if rng.random() < 0.75:  # mostly over the other leg
            side[0] = -side[0]
        return side[0] * rng.uniform(*how.shift_roll)

    roll = np.radians(_moves(n, rng, how.shift_every, how.shift_length, lean))
    yaw = np.radians(_moves(n, rng, how.shift_every, how.shift_length, lambda: rng.uniform(-how.shift_yaw, how.shift_yaw)))
    _turn(dirs, BONE_NAMES, "z", roll)
    _turn(dirs, BONE_NAMES, "y", yaw)
    _turn(dirs, HEAD, "z", -0.5 * roll)


def head_answers(n_frames: int, phrase_times, rng: np.random.Generator, how: Listener = LISTENER):
    """(pitch, roll) (n,) radians of a listener's head answering the other speakers' phrase ends
    (``phrase_times``, seconds): a nod (down, then back; sometimes two) or a tilt to a side
    (held a moment), each a little after the phrase end, by chance (:class:`Listener`), never two
    answers closer than ``how.answer_gap``."""
    t = np.arange(n_frames) / FPS
    pitch, roll = np.zeros(n_frames), np.zeros(n_frames)
    free = -math.inf
    for end in sorted(phrase_times):
        at = end + rng.uniform(*how.answer_delay)
        pick = rng.random()
        if at < free or at * FPS >= n_frames:
            continue
        if pick < how.nod_chance:
            deg = rng.uniform(*how.nod_deg)
            nod = how.nod_down + how.nod_up
            w = _frames(at, 2 * nod, n_frames)  # (a double nod starts as the first ends)
            pitch[w] += math.radians(deg) * _nod(t[w] - at, how)
            if rng.random() < how.double_nod:
                pitch[w] += math.radians(0.6 * deg) * _nod(t[w] - at - nod + 0.05, how)
            free = at + how.answer_gap + nod
        elif pick < how.nod_chance + how.tilt_chance:
            deg = rng.uniform(*how.tilt_deg) * (1.0 if rng.random() < 0.5 else -1.0)
            hold = rng.uniform(*how.tilt_hold)
            w = _frames(at, how.tilt_in + hold + how.tilt_out, n_frames)
            u = t[w] - at
            shape = smoothstep(np.clip(u / how.tilt_in, 0, 1)) - smoothstep(np.clip((u - how.tilt_in - hold) / how.tilt_out, 0, 1))
            roll[w] += math.radians(deg) * shape
            pitch[w] += math.radians(1.0) * shape  # a tilt comes with the chin a little down
            free = at + how.answer_gap + how.tilt_in + hold + how.tilt_out
    return pitch, roll


def _frames(at: float, seconds: float, n_frames: int) -> slice:
    """The frames from ``at`` (seconds) to ``seconds`` after it (and one more), within the clip."""
    return slice(max(0, math.floor(at * FPS)), max(0, min(n_frames, math.ceil((at + seconds) * FPS) + 1)))


def _nod(u: np.ndarray, how: Listener) -> np.ndarray:
    """A nod's depth (0 .. 1) ``u`` seconds after its start: down over ``nod_down``, back over ``nod_up``."""
    down = smoothstep(np.clip(u / how.nod_down, 0, 1))
    up = smoothstep(np.clip((u - how.nod_down) / how.nod_up, 0, 1))
    return down - up


#: A listener's hands (:func:`listening_hands`): seconds from one resting shape to the next
#: (a range) and the move's length; how much more (or less) the fingers curl than relaxed; how
#: far the palm turns from facing the thigh towards the back (degrees; negative: forward); how
#: much a moving wrist opens the hand (per m/s).
HAND_SETTLE_EVERY = (2.5, 7.0)
HAND_SETTLE_LENGTH = (0.6, 1.2)
HAND_CURL = (-0.3, 0.35)
HAND_PALM_TURN = (-10.0, 25.0)
HAND_OPEN_PER_SPEED = 2.0


def listening_hands(poses: np.ndarray, rng: np.random.Generator) -> HandTrack:
    """Hands for a listener's body ``poses`` (T, 27): relaxed, each hand moving now and then to
    another resting shape (the fingers' flexion scaled by a draw from :data:`HAND_CURL`, the palm
    turned by one from :data:`HAND_PALM_TURN`), eased, and opening a little while its wrist
    moves (the arm settling). Never a gesture's hand. Deterministic for ``rng``'s state."""
    n = len(poses)
    rest = HandTrack.rest(n)
    palm, fingers = rest.palm.astype(np.float64), rest.fingers.astype(np.float64)
    pos = positions_from_pose(poses)
    for s, side in enumerate(SIDES):
        curl = _moves(n, rng, HAND_SETTLE_EVERY, HAND_SETTLE_LENGTH, lambda: rng.uniform(*HAND_CURL))
        turn = np.radians(_moves(n, rng, HAND_SETTLE_EVERY, HAND_SETTLE_LENGTH, lambda: rng.uniform(*HAND_PALM_TURN)))
        wrist = pos[:, JOINT_INDEX[f"{side}_wrist"]]
        speed = np.linalg.norm(np.diff(wrist, axis=0, prepend=wrist[:1]), axis=-1) * FPS
        curl = curl - HAND_OPEN_PER_SPEED * gauss_smooth(speed, 2.0)
        fingers[:, s, :, 1:] *= np.clip(1.0 + curl, 0.4, 1.6)[:, None, None]  # flexion; spreads and the thumb's abduction kept
        palm[:, s] = np.cos(turn)[:, None] * palm_direction("in", side) + np.sin(turn)[:, None] * palm_direction("back", side)
    return HandTrack(palm, fingers)


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
    """Put an utterance's ``hands`` into a track's hands (a listener's; changed in
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
        tracks[speaker] = listening(plan.n_frames, accents(plan, speaker), np.random.default_rng([seed, k]),
                                    phrase_ends(plan, speaker))
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
    on its word. Hands likewise: the utterances' hands eased into the listener's hands
    (:func:`listening_hands`, drawn with the seed and the speaker's place), then the pose
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
    for k, (speaker, listen) in enumerate((listening if listening is not None else listening_tracks(plan, seed)).items()):
        cancel.check()
        poses = listen.copy()
        hands = listening_hands(listen, np.random.default_rng([seed, k, 0x4A4E]))
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
