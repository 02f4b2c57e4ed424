"""The face of a performance: ARKit blendshapes and gaze per frame (:class:`core.face.FaceTrack`).

Deterministic for a plan and a seed; numpy only. Made per speaker over the whole performance
(:func:`speaker_face`, which :func:`model.performance.perform` calls for every track; each
utterance's clip holds its frames of it):

**Mouth (visemes).** Every phoneme (espeak-ng's phoneme events for synthesized speech, a
recording's dictionary phonemes spread over its words, or the letters of the words when the
timing is only estimated) is a viseme (:data:`VISEMES`, :func:`viseme_classes`: a diphthong
or a syllabic consonant is two, one after the other). Neighbours blend (co-articulation, after
Cohen and Massaro's dominance functions): each viseme dominates its own time and reaches
:data:`REACH` seconds into its neighbours' with a strength of its own (:data:`DOMINANCE`:
vowels and lip consonants strongly, tongue consonants weakly, so a ``t`` takes the lips of
the ``u`` after it), and each frame averages the blend at :data:`SUBSAMPLES` instants. Then
what must be seen is made exact on its frames: **p, b and m close the lips** (jaw at most
:data:`CLOSED_JAW`, ``mouthClose`` equal to ``jawOpen``, nothing parting the lips) on every
frame whose centre falls in them, or the frame that holds their middle when none does; **f
and v** roll the lower lip in under the upper teeth; a frame that no phoneme touches
(**silence**: pauses, the breaks between phrases, listening) has the mouth at rest, closed.
A stressed vowel opens the jaw :data:`STRESSED_JAW` times wider, an unstressed one less.

**Blinks** (``eyeBlink*``): a renewal process of about :data:`BLINK_INTERVAL` seconds between
blinks, plus blinks at the start of pauses and at large gaze shifts (:data:`PAUSE_BLINK`,
:data:`SHIFT_BLINK`), never closer than :data:`BLINK_GAP`, and never with the lids down
through a stressed vowel of the speaker's own (a blink that would be is moved off it, or
dropped). **Brows** rise on each phrase's nuclear accent (its last content word) and from
the last content word of a question to its end. **Expressions**: the plan's face controls
(``<face:NAME>`` spans and the built-in presets' own, :data:`core.face.EXPRESSIONS`), eased
in and out over :data:`EXPRESSION_EASE` frames, an inner span over an outer one.

**Gaze.** The speakers stand on a circle facing its centre (in order of their first line; an
F-formation), so speaker ``j`` is at a fixed yaw from speaker ``i`` (:func:`seat_yaw`: 0 for
two, 30 degrees either side for three); a script with one speaker talks to the audience,
ahead. A speaker looks at its addressee (the next line's speaker, else the previous one's;
with three or more now and then another listener) and away at phrase starts (aversion: at
its line's start with :data:`AVERT_FIRST`, at later phrases with :data:`AVERT_PHRASE`, for
0.5-1.3 s, up or down and to a side), and back before the phrase ends; a ``[look:...]``
control aims the eyes over its frames (from :data:`LOOK_LEAD` before them, at least
:data:`LOOK_MIN` seconds). A listener looks at whoever speaks (between lines at the last
speaker until the next line's motion starts) with short glances away. Head and eyes share
the job: the body's head already turns (listening drift, nods, gestures), the eyes take the
rest (the gaze is relative to the head, within :data:`core.face.EYE_YAW_LIMIT` and the
vertical limits), and the ``eyeLook*`` weights say the same as the gaze.
"""

from __future__ import annotations

import math
import re

import numpy as np

from core import cancel
from core.face import (
    ARKIT_INDEX,
    EXPRESSIONS,
    EYE_DOWN_LIMIT,
    EYE_UP_LIMIT,
    EYE_YAW_LIMIT,
    LOOK_DIRECTIONS,
    N_BLENDSHAPES,
    FaceTrack,
    blendshapes,
    expression_weights,
    set_eye_looks,
)
from core.skeleton import BONE_INDEX, FPS, REST_DIRECTIONS

# -- visemes ------------------------------------------------------------------------------

#: Mouth shapes (ARKit weights; a name without its side sets both) of the viseme classes.
VISEMES: dict[str, dict[str, float]] = {
    "rest": {},
    "PP": {"jawOpen": 0.05, "mouthClose": 0.05, "mouthPress": 0.3},  # p b m
    "FF": {"jawOpen": 0.08, "mouthRollLower": 0.55, "mouthUpperUp": 0.15},  # f v
    "TH": {"jawOpen": 0.14, "tongueOut": 0.3, "mouthLowerDown": 0.1},  # θ ð
    "DD": {"jawOpen": 0.16, "mouthLowerDown": 0.1, "mouthStretch": 0.05},  # t d n l
    "kk": {"jawOpen": 0.22, "mouthStretch": 0.1},  # k g ŋ h
    "CH": {"jawOpen": 0.12, "mouthFunnel": 0.45, "mouthPucker": 0.2, "mouthUpperUp": 0.15, "mouthLowerDown": 0.15},
    "SS": {"jawOpen": 0.06, "mouthStretch": 0.25, "mouthUpperUp": 0.1, "mouthLowerDown": 0.1},  # s z
    "RR": {"jawOpen": 0.12, "mouthFunnel": 0.3, "mouthPucker": 0.25},  # ɹ r
    "W": {"jawOpen": 0.05, "mouthPucker": 0.7, "mouthFunnel": 0.3},  # w
    "aa": {"jawOpen": 0.6, "mouthLowerDown": 0.2, "mouthStretch": 0.05},  # a ɑ æ ʌ
    "E": {"jawOpen": 0.35, "mouthStretch": 0.2, "mouthLowerDown": 0.15},  # e ɛ ə ɜ
    "I": {"jawOpen": 0.2, "mouthStretch": 0.35, "mouthSmile": 0.1, "mouthLowerDown": 0.05, "mouthUpperUp": 0.05},
    "O": {"jawOpen": 0.45, "mouthFunnel": 0.5, "mouthPucker": 0.2},  # o ɔ ɒ
    "U": {"jawOpen": 0.2, "mouthPucker": 0.65, "mouthFunnel": 0.35},  # u ʊ
}
VOWEL_CLASSES = frozenset({"aa", "E", "I", "O", "U"})
#: How strongly a class holds its shape against its neighbours' (co-articulation).
DOMINANCE = {"rest": 1.0, "PP": 1.0, "FF": 0.9, "W": 0.9, "CH": 0.8, "TH": 0.6, "RR": 0.6, "SS": 0.6, "DD": 0.35,
             "kk": 0.3, "aa": 1.0, "E": 0.9, "I": 1.0, "O": 1.0, "U": 1.0}
#: Seconds over which a viseme's dominance falls to 1/e outside its own time.
REACH = 0.045
#: Instants per frame at which the blend is sampled and averaged.
SUBSAMPLES = 4
#: The jaw of closed lips at most; a stressed / unstressed vowel's jaw scale.
CLOSED_JAW = 0.1
STRESSED_JAW, UNSTRESSED_JAW = 1.15, 0.85

#: IPA characters (and two-character affricates) -> viseme class; other characters (length,
#: aspiration, diacritics) are skipped.
_DIGRAPHS = {"tʃ": "CH", "dʒ": "CH", "ts": "SS", "dz": "SS"}
_CHARS: dict[str, str] = {}
for _cls, _chars in {
    "PP": "pbmʙ", "FF": "fvɱʋ", "TH": "θð", "DD": "tdnlɾɫɬɮʈɖɳɭ", "kk": "kgɡŋxɣhɦqɢχʁʔc",
    "CH": "ʃʒɕʑ", "SS": "sz", "RR": "ɹrʀɻɚɝ", "W": "wʍɥ", "I": "iɪjʎɲɨᵻeɘ",
    "aa": "aɑæɐʌɶä", "E": "ɛəɜɞ", "O": "oɔɒøœɵ", "U": "uʊɯɤʉyʏ",
}.items():
    for _c in _chars:
        _CHARS[_c] = _cls
_CHARS["e"] = "E"  # (e is closer to E than I: listed last to win)


def viseme_classes(phoneme: str) -> list[str]:
    """The viseme classes of one phoneme (IPA), in order: ``oʊ`` is O then U, ``əl`` E then
    DD, ``tʃ`` one CH; consecutive equal classes are one. Unknown symbols are skipped; a
    phoneme with none is DD (the tongue, not the lips)."""
    out: list[str] = []
    i = 0
    while i < len(phoneme):
        cls = _DIGRAPHS.get(phoneme[i : i + 2])
        if cls is not None:
            i += 2
        else:
            cls = _CHARS.get(phoneme[i])
            i += 1
        if cls is not None and (not out or out[-1] != cls):
            out.append(cls)
    return out or ["DD"]


#: Letters -> classes for words without phonemes (estimated timing): a rough reading.
_LETTERS = {**{c: "PP" for c in "pbm"}, **{c: "FF" for c in "fv"}, "w": "W", "a": "aa", "e": "E", "i": "I", "y": "I",
            "o": "O", "u": "U", "s": "SS", "z": "SS", "r": "RR", "k": "kk", "g": "kk", "c": "kk", "q": "kk", "h": "kk"}


def letter_segments(words) -> list[tuple[str, float, float, int]]:
    """Viseme segments read off the letters of timed ``words`` (no phonemes known: an
    estimate's timing): each letter a class (:data:`_LETTERS`, else DD), runs of one class
    one segment, spread over the word with vowels twice as long."""
    out = []
    for w in words:
        classes: list[str] = []
        for ch in w.word.lower():
            if not ch.isalnum():
                continue
            cls = _LETTERS.get(ch, "DD")
            if not classes or classes[-1] != cls:
                classes.append(cls)
        if not classes or w.end <= w.start:
            continue
        shares = [2.0 if c in VOWEL_CLASSES else 1.0 for c in classes]
        total, at = sum(shares), 0.0
        for cls, share in zip(classes, shares):
            a = w.start + (w.end - w.start) * at / total
            at += share
            out.append((cls, a, w.start + (w.end - w.start) * at / total, 0))
    return out


def phoneme_segments(phonemes) -> list[tuple[str, float, float, int]]:
    """(class, start, end, stress) segments of timed phonemes: a phoneme of several classes
    (a diphthong) splits its time, the first part longer (60 %) when there are two."""
    out = []
    for p in phonemes:
        classes = viseme_classes(p.phoneme)
        n = len(classes)
        cuts = [0.0, 0.6, 1.0] if n == 2 else [k / n for k in range(n + 1)]
        for k, cls in enumerate(classes):
            a = p.start + (p.end - p.start) * cuts[k]
            b = p.start + (p.end - p.start) * cuts[k + 1]
            out.append((cls, a, b, p.stress if cls in VOWEL_CLASSES else 0))
    return out


_VISEME_VECTORS = {name: blendshapes(shape) for name, shape in VISEMES.items()}
_J = ARKIT_INDEX
_LIP_PARTING = [_J[n] for n in ("mouthFunnel", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
                                 "mouthUpperUpRight", "tongueOut")]
_MOUTH = sorted({i for v in _VISEME_VECTORS.values() for i in np.flatnonzero(v)} | set(_LIP_PARTING)
                | {_J["mouthClose"], _J["jawOpen"], _J["mouthRollLower"]})


def mouth(segments, n_frames: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Mouth weights (n_frames, 52) of viseme ``segments`` (class, start, end, stress; seconds
    from frame 0), and the frames where each rule was made exact: ``closed`` (p b m),
    ``lip_roll`` (f v) and ``silent`` (no phoneme touches the frame). See the module's docstring."""
    out = np.zeros((n_frames, N_BLENDSHAPES), np.float32)
    marks = {k: np.zeros(n_frames, bool) for k in ("closed", "lip_roll", "silent")}
    if n_frames == 0:
        return out, marks
    touched = np.zeros(n_frames, bool)
    segs = sorted((s for s in segments if s[2] > s[1]), key=lambda s: (s[1], s[2]))
    if segs:
        n_samples = n_frames * SUBSAMPLES
        t = (np.arange(n_samples) + 0.5) / (SUBSAMPLES * FPS)
        num = np.zeros((n_samples, len(_MOUTH)), np.float64)
        den = np.zeros(n_samples, np.float64)
        rests = [("rest", -math.inf, segs[0][1], 0)]
        for (_, _, e0, _), (_, s1, _, _) in zip(segs, segs[1:]):
            if s1 > e0 + 1e-4:
                rests.append(("rest", e0, s1, 0))
        rests.append(("rest", max(s[2] for s in segs), math.inf, 0))
        far = 5 * REACH
        for k, (cls, a, b, stress) in enumerate(segs + rests):
            if not k % cancel.EVERY:
                cancel.check()
            lo = 0 if a == -math.inf else max(0, int((a - far) * SUBSAMPLES * FPS))
            hi = n_samples if b == math.inf else min(n_samples, int(math.ceil((b + far) * SUBSAMPLES * FPS)) + 1)
            if hi <= lo:
                continue
            tt = t[lo:hi]
            dist = np.maximum(np.maximum(a - tt, tt - b), 0.0)
            d = DOMINANCE[cls] * np.exp(-dist / REACH)
            target = _VISEME_VECTORS[cls][_MOUTH].astype(np.float64)
            if cls in VOWEL_CLASSES:
                target = target.copy()
                target[_MOUTH.index(_J["jawOpen"])] *= STRESSED_JAW if stress == 2 else UNSTRESSED_JAW if stress == 0 else 1.0
            num[lo:hi] += d[:, None] * target[None, :]
            den[lo:hi] += d
        blend = num / np.maximum(den, 1e-12)[:, None]
        out[:, _MOUTH] = blend.reshape(n_frames, SUBSAMPLES, len(_MOUTH)).mean(axis=1)
        for _, a, b, _ in segs:
            f0, f1 = max(0, int(math.floor(a * FPS))), min(n_frames, int(math.ceil(b * FPS)))
            touched[f0:f1] = True
        for cls, a, b, _ in segs:
            if cls in ("PP", "FF"):
                marks["closed" if cls == "PP" else "lip_roll"][_frames_of(a, b, n_frames)] = True
    marks["silent"] = ~touched
    marks["lip_roll"] &= ~marks["closed"]
    out[marks["silent"]] = 0.0
    _close_lips(out, marks["closed"])
    f = marks["lip_roll"]
    out[f, _J["mouthRollLower"]] = np.maximum(out[f, _J["mouthRollLower"]], 0.55)
    out[f, _J["jawOpen"]] = np.minimum(out[f, _J["jawOpen"]], 0.12)
    for name in ("mouthLowerDownLeft", "mouthLowerDownRight", "mouthFunnel"):
        out[f, _J[name]] = np.minimum(out[f, _J[name]], 0.05)
    for name in ("mouthUpperUpLeft", "mouthUpperUpRight"):
        out[f, _J[name]] = np.maximum(out[f, _J[name]], 0.15)
    return np.clip(out, 0.0, 1.0), marks


def _frames_of(a: float, b: float, n_frames: int) -> np.ndarray:
    """The frames a segment [a, b) owns: those whose centre falls in it, else the one that
    holds its middle."""
    first = int(math.ceil(a * FPS - 0.5 - 1e-9))
    last = int(math.ceil(b * FPS - 0.5 - 1e-9))  # exclusive
    frames = np.arange(max(0, first), min(n_frames, last))
    if len(frames) == 0:
        mid = min(n_frames - 1, max(0, int(math.floor((a + b) / 2 * FPS))))
        frames = np.array([mid])
    return frames


def _close_lips(w: np.ndarray, frames: np.ndarray) -> None:
    """Closed lips on ``frames`` (bool mask): the jaw at most :data:`CLOSED_JAW`, ``mouthClose``
    as far as the jaw opens, nothing parting the lips, and the lips pressed."""
    if not frames.any():
        return
    jaw = np.minimum(w[frames, _J["jawOpen"]], CLOSED_JAW)
    w[frames, _J["jawOpen"]] = jaw
    w[frames, _J["mouthClose"]] = jaw
    for i in _LIP_PARTING:
        w[frames, i] = 0.0
    for name in ("mouthPressLeft", "mouthPressRight"):
        w[frames, _J[name]] = np.maximum(w[frames, _J[name]], 0.3)


# -- expressions and brows ----------------------------------------------------------------

#: Frames over which an expression eases in before its span and out after it.
EXPRESSION_EASE = 4


def expressions(controls, n_frames: int) -> np.ndarray:
    """(n_frames, 52) weights of face controls (``(name, start_frame, end_frame)`` in opening
    order), each eased in and out over :data:`EXPRESSION_EASE` frames, a later (inner) one
    over an earlier."""
    out = np.zeros((n_frames, N_BLENDSHAPES), np.float32)
    f = np.arange(n_frames)
    for name, a, b in controls:
        if name not in EXPRESSIONS:
            continue
        k = EXPRESSION_EASE
        w = np.clip(np.minimum((f - (a - k) + 1) / (k + 1), ((b + k) - f) / (k + 1)), 0.0, 1.0)
        w = (w * w * (3 - 2 * w)).astype(np.float32)[:, None]
        out = out * (1 - w) + expression_weights(name)[None, :] * w
    return out


#: Brow raises: on a phrase's nuclear accent, and over a question's end (inner, outer).
ACCENT_BROWS = (0.3, 0.25)
QUESTION_BROWS = (0.45, 0.4)
_BROWS = [_J["browInnerUp"], _J["browOuterUpLeft"], _J["browOuterUpRight"]]


def _bump(n_frames: int, a: float, peak: float, b: float) -> np.ndarray:
    """(n_frames,) a smooth rise from ``a`` to 1 at ``peak``, held to ``b``, falling over 0.3 s."""
    t = (np.arange(n_frames) + 0.5) / FPS
    up = np.clip((t - a) / max(peak - a, 1e-3), 0, 1)
    down = np.clip(1 - (t - b) / 0.3, 0, 1)
    w = np.minimum(up, down)
    return w * w * (3 - 2 * w)


def brows(words, text: str, n_frames: int, stopwords) -> np.ndarray:
    """(n_frames, 52) brow raises of one utterance's ``words`` (seconds from frame 0): the last
    content word of each phrase (:func:`phrases`) and a question's end."""
    out = np.zeros((n_frames, N_BLENDSHAPES), np.float32)
    if not words:
        return out
    after = _after_words(text, words)
    for first, last in phrases(words, after):
        content = [i for i in range(first, last + 1) if _is_content(words[i].word, stopwords)] or [last]
        w = words[content[-1]]
        bump = _bump(n_frames, w.start - 0.15, w.start + 0.35 * (w.end - w.start), w.end)
        out[:, _BROWS[0]] = np.maximum(out[:, _BROWS[0]], ACCENT_BROWS[0] * bump)
        out[:, _BROWS[1]] = np.maximum(out[:, _BROWS[1]], ACCENT_BROWS[1] * bump)
        if "?" in after[last]:
            bump = _bump(n_frames, w.start - 0.15, w.start + 0.1, words[last].end + 0.25)
            out[:, _BROWS[0]] = np.maximum(out[:, _BROWS[0]], QUESTION_BROWS[0] * bump)
            out[:, _BROWS[1]] = np.maximum(out[:, _BROWS[1]], QUESTION_BROWS[1] * bump)
    out[:, _BROWS[2]] = out[:, _BROWS[1]]
    return out


_WORD = re.compile(r"[^\W_]+(?:['\u2019][^\W_]+)*")


def _is_content(word: str, stopwords) -> bool:
    m = _WORD.search(word.lower())
    return bool(m) and m.group() not in stopwords


def _after_words(text: str, words) -> list[str]:
    """The text after each word up to the next one (punctuation, spaces), found in order."""
    at, ends = 0, []
    for w in words:
        k = text.find(w.word, at)
        if k < 0:
            ends.append(None)
            continue
        at = k + len(w.word)
        ends.append((k, at))
    out = []
    for i, span in enumerate(ends):
        nxt = next((e[0] for e in ends[i + 1 :] if e is not None), len(text))
        out.append(text[span[1] : nxt] if span is not None else "")
    return out


#: A silence between two words at least this long ends a phrase (a pause, a breath).
PHRASE_GAP = 0.25


def phrases(words, after: list[str]) -> list[tuple[int, int]]:
    """(first, last) word indices of each phrase: words up to a clause mark (``,.;:!?``)
    after one, or a silence of :data:`PHRASE_GAP` before the next."""
    out, first = [], 0
    for i in range(len(words)):
        end = i + 1 == len(words)
        if end or any(c in ",.;:!?" for c in after[i]) or words[i + 1].start - words[i].end >= PHRASE_GAP:
            out.append((first, i))
            first = i + 1
    return out


# -- gaze ---------------------------------------------------------------------------------

AVERT_FIRST, AVERT_PHRASE = 0.75, 0.35
#: Seconds before a look control's frames that the eyes move, and the least it holds them.
LOOK_LEAD, LOOK_MIN = 0.15, 0.8
#: Listeners: mean seconds between glances away from the speaker, and how long one lasts.
GLANCE_INTERVAL, GLANCE_LENGTH = 6.0, (0.4, 1.0)
#: With three or more speakers, the chance that a phrase is addressed to another listener.
OTHER_LISTENER = 0.3


def seat_yaw(speakers: int, i: int, j: int | None) -> float:
    """Degrees from speaker ``i`` to speaker ``j`` (positive: to ``i``'s left) when ``speakers``
    stand on a circle facing its centre, in order; ``j`` None (or one speaker): the audience,
    ahead (0)."""
    if j is None or speakers < 2 or i == j:
        return 0.0
    ang = [2 * math.pi * k / speakers for k in range(speakers)]
    pi, pj = np.array([math.cos(ang[i]), math.sin(ang[i])]), np.array([math.cos(ang[j]), math.sin(ang[j])])
    forward = -pi
    left = np.array([forward[1], -forward[0]])
    d = pj - pi
    return math.degrees(math.atan2(float(d @ left), float(d @ forward)))


def head_angles(poses: np.ndarray) -> np.ndarray:
    """(T, 2) yaw and pitch (degrees) of the head from the body's poses: the nose bone's turn
    from its rest direction (yaw positive to the left, pitch positive up)."""
    b = BONE_INDEX["nose"]
    d = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)[:, b]
    rest = np.asarray(REST_DIRECTIONS["nose"])
    yaw = np.degrees(np.arctan2(d[:, 0], d[:, 2]) - math.atan2(rest[0], rest[2]))
    pitch = np.degrees(np.arcsin(np.clip(d[:, 1], -1, 1)) - math.asin(rest[1]))
    return np.stack([yaw, pitch], axis=1)


def eyes_for(target: np.ndarray, head: np.ndarray) -> np.ndarray:
    """(T, 2, 2) gaze of both eyes aiming at ``target`` (T, 2: yaw, pitch from the body's
    front) from a head at ``head`` (T, 2), within the eyes' reach."""
    rel = np.asarray(target, np.float64) - np.asarray(head, np.float64)
    yaw = np.clip(rel[:, 0], -EYE_YAW_LIMIT, EYE_YAW_LIMIT)
    pitch = np.clip(rel[:, 1], -EYE_DOWN_LIMIT, EYE_UP_LIMIT)
    one = np.stack([yaw, pitch], axis=1)
    return np.repeat(one[:, None, :], 2, axis=1).astype(np.float32)


# -- blinks -------------------------------------------------------------------------------

#: Mean seconds between spontaneous blinks (a gamma renewal, shape 3); the least between two.
BLINK_INTERVAL, BLINK_GAP = 8.0, 0.9
#: Chance of a blink at the start of a pause (or line end), and at a gaze shift of 15+ degrees.
PAUSE_BLINK, SHIFT_BLINK = 0.5, 0.25
#: A blink's lid weights, frame by frame (closing, closed, opening).
BLINK_SHAPE = (0.7, 1.0, 0.45, 0.1)


def blink_frames(n_frames: int, rng: np.random.Generator, pauses=(), shifts=(), stressed=()) -> list[int]:
    """The first frames of the blinks over ``n_frames``: event blinks at ``pauses`` and
    ``shifts`` (seconds) with their chances, then spontaneous ones between them, at least
    :data:`BLINK_GAP` apart; none whose closed frames (lid at 0.4 or more) overlap a
    ``stressed`` interval (seconds): it moves to the nearest free frame within 0.4 s or is
    dropped."""
    gap = int(math.ceil(BLINK_GAP * FPS))
    heavy = [k for k, v in enumerate(BLINK_SHAPE) if v >= 0.4]
    blocked = np.zeros(n_frames + len(BLINK_SHAPE), bool)
    for a, b in stressed:
        f0, f1 = int(math.floor(a * FPS)), int(math.ceil(b * FPS))
        for k in heavy:  # a blink starting at f has its heavy frame f + k inside [f0, f1)
            blocked[max(0, f0 - k) : max(0, f1 - k)] = True
    chosen: list[int] = []

    def free(f: int) -> bool:
        return 0 <= f < n_frames and not blocked[f] and all(abs(f - c) >= gap for c in chosen)

    def place(f: int) -> None:
        for d in [0] + [s * k for k in range(1, 7) for s in (-1, 1)]:
            if free(f + d):
                chosen.append(f + d)
                return

    events = [(t, PAUSE_BLINK) for t in pauses] + [(t, SHIFT_BLINK) for t in shifts]
    for t, chance in sorted(events):
        if rng.random() < chance:
            place(int(math.floor(t * FPS)))
    t = rng.uniform(0.5, BLINK_INTERVAL)
    while t * FPS < n_frames:
        place(int(math.floor(t * FPS)))
        t += max(BLINK_GAP, rng.gamma(3.0, BLINK_INTERVAL / 3.0))
    return sorted(chosen)


def blink_weights(n_frames: int, starts) -> np.ndarray:
    """(n_frames,) lid weights of blinks starting at ``starts``."""
    out = np.zeros(n_frames, np.float32)
    for f in starts:
        for k, v in enumerate(BLINK_SHAPE):
            if f + k < n_frames:
                out[f + k] = max(out[f + k], v)
    return out


# -- a speaker's face over the performance ------------------------------------------------


def _stopwords():
    from model.teacher import STOPWORDS  # lazy: the teacher loads the gesture library

    return STOPWORDS


def _segments_of(u) -> list:
    return phoneme_segments(u.phonemes) if u.phonemes else letter_segments(u.words)


def speaker_face(plan, speaker, poses: np.ndarray, seed: int = 0) -> FaceTrack:
    """The face of ``speaker`` over ``plan``'s whole performance (``plan.n_frames`` frames),
    with its body's ``poses`` (for the head the eyes turn from): its own lines' mouth, brows
    and expressions, blinks and gaze everywhere. Deterministic for a plan, poses and seed."""
    n = plan.n_frames
    speakers = plan.speakers
    me = speakers.index(speaker)
    rng = np.random.default_rng([seed, me, 0xFACE])
    stop = _stopwords()
    weights = np.zeros((n, N_BLENDSHAPES), np.float32)
    own = [u for u in plan.utterances if u.speaker == speaker]
    segments, stressed, pauses, face_controls = [], [], [], []
    raised = np.zeros((n, N_BLENDSHAPES), np.float32)
    for u in own:
        cancel.check()
        at = u.start
        segs = _segments_of(u)
        segments += [(c, a + at, b + at, s) for c, a, b, s in segs]
        stressed += [(p.start + at, p.end + at) for p in u.phonemes if p.stress == 2]
        lo, hi = u.start_frame, u.start_frame + u.n_frames
        part = brows(u.words, u.text, u.n_frames, stop)
        raised[lo:hi] = np.maximum(raised[lo:hi], part[: hi - lo])
        for w0, w1 in zip(u.words, u.words[1:]):
            if w1.start - w0.end >= PHRASE_GAP:
                pauses.append(at + w0.end)
        if u.words:
            pauses.append(at + u.words[-1].end)
        face_controls += [(c.name, c.start_frame + lo, c.end_frame + lo) for c in u.controls if c.kind == "face"]
    m, marks = mouth(segments, n)
    weights += m
    weights += expressions(face_controls, n)
    weights[:, _BROWS] = 1.0 - (1.0 - weights[:, _BROWS]) * (1.0 - raised[:, _BROWS])  # a raise on an expression's brows
    _close_lips(weights, marks["closed"])
    target, shifts = _gaze_targets(plan, speaker, rng, stop)
    gaze = eyes_for(target, head_angles(poses))
    blinks = blink_weights(n, blink_frames(n, rng, pauses, shifts, stressed))
    down = np.clip(-gaze[:, 0, 1] / EYE_DOWN_LIMIT, 0, 1) * 0.25  # lids follow the eyes down
    for name in ("eyeBlinkLeft", "eyeBlinkRight"):
        weights[:, _J[name]] = np.maximum(weights[:, _J[name]] + down, blinks)
    weights = np.clip(weights, 0.0, 1.0)
    set_eye_looks(weights, gaze)
    return FaceTrack(weights, gaze)


def _gaze_targets(plan, speaker, rng: np.random.Generator, stop) -> tuple[np.ndarray, list[float]]:
    """(n, 2) where ``speaker`` aims its eyes (yaw, pitch from its body's front) frame by frame,
    and the times (seconds) of shifts of 15 degrees or more. See the module's docstring."""
    n = plan.n_frames
    speakers = plan.speakers
    me = speakers.index(speaker)
    count = len(speakers)
    seat = {s: seat_yaw(count, me, k) for k, s in enumerate(speakers)}
    audience = count < 2
    target = np.zeros((n, 2), np.float64)
    utterances = plan.utterances
    addressees = _addressees([u.speaker for u in utterances])
    # listening: at whoever started last (between lines the last speaker, until the next
    # line's motion starts); after its own line, at the one it spoke to
    if not audience:
        for i in sorted(range(len(utterances)), key=lambda i: utterances[i].start_frame):
            u = utterances[i]
            who = u.speaker if u.speaker != speaker else addressees[i]
            target[max(0, u.start_frame) :, 0] = seat.get(who, 0.0)
    # glances away while listening
    t = rng.exponential(GLANCE_INTERVAL)
    while t * FPS < n:
        f0 = int(t * FPS)
        f1 = min(n, f0 + int(round(rng.uniform(*GLANCE_LENGTH) * FPS)))
        side = rng.choice([-1.0, 1.0])
        target[f0:f1, 0] += side * rng.uniform(8.0, 15.0)
        target[f0:f1, 1] -= rng.uniform(4.0, 10.0)
        t += (f1 - f0) / FPS + rng.exponential(GLANCE_INTERVAL)
    # speaking: at the addressee, away at phrase starts, where a look mark says
    for i, u in enumerate(utterances):
        if u.speaker != speaker:
            continue
        addressee = addressees[i]
        listeners = [s for s in speakers if s != speaker]
        lo, hi = u.start_frame, min(n, u.start_frame + u.n_frames)
        base = seat.get(addressee, 0.0) if addressee is not None else 0.0
        target[lo:hi] = (base, 0.0)
        words = u.words
        after = _after_words(u.text, words)
        for p, (first, last) in enumerate(phrases(words, after) if words else []):
            a = u.start + words[first].start
            b = u.start + words[last].end
            f0, f1 = max(lo, int(math.floor(a * FPS))), min(hi, int(math.ceil(b * FPS)))
            yaw = base
            if len(listeners) > 1 and rng.random() < OTHER_LISTENER:
                yaw = seat[listeners[int(rng.integers(len(listeners)))]]
            target[f0:f1] = (yaw, 0.0)
            if rng.random() < (AVERT_FIRST if p == 0 else AVERT_PHRASE):
                length = min(rng.uniform(0.5, 1.3), 0.6 * (b - a) + 0.2)
                g0 = max(lo, int(math.floor((a - 0.2) * FPS)))
                g1 = min(hi, g0 + max(1, int(round(length * FPS))))
                side = rng.choice([-1.0, 1.0])
                up = rng.random() < 0.5
                target[g0:g1] = (yaw + side * rng.uniform(10.0, 20.0),
                                 rng.uniform(6.0, 12.0) if up else -rng.uniform(8.0, 14.0))
        for c in u.controls:
            if c.kind != "look":
                continue
            if c.name in LOOK_DIRECTIONS:
                aim = LOOK_DIRECTIONS[c.name]
            elif c.name in seat and c.name != speaker:
                aim = (seat[c.name], 0.0)
            else:
                continue
            g0 = max(0, lo + c.start_frame - int(round(LOOK_LEAD * FPS)))
            g1 = min(n, max(lo + c.end_frame, g0 + int(round(LOOK_MIN * FPS))))
            target[g0:g1] = aim
    step = np.hypot(*(np.diff(target, axis=0).T)) if n > 1 else np.zeros(0)
    shifts = [(f + 1) / FPS for f in np.flatnonzero(step >= 15.0)]
    return target, shifts


def _addressees(speakers: list) -> list:
    """Whom each line speaks to, given the lines' ``speakers`` in order: the next line's other
    speaker, else the previous one's (None: nobody else speaks). Linear: one pass each way."""
    n = len(speakers)
    nxt, prev = [None] * n, [None] * n
    for i in range(n - 2, -1, -1):  # the first other speaker after line i
        nxt[i] = speakers[i + 1] if speakers[i + 1] != speakers[i] else nxt[i + 1]
    for i in range(1, n):  # ... and before it
        prev[i] = speakers[i - 1] if speakers[i - 1] != speakers[i] else prev[i - 1]
    return [a if a is not None else b for a, b in zip(nxt, prev)]
