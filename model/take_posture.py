"""The take's posture and drift: how a speaker holds the body when the script asks for nothing in particular.

Takes differ in ways no word or sound reveals: one speaker keeps the hands low and close,
another holds them high and wide, one favours one arm. A network trained to regress
its data averages those takes out and makes the same middle-of-the-road posture every time,
whatever its noise vector says (model card, "What we compared"). So weights carry the postures
of their training takes (:class:`Takes`, measured by :func:`model.training.takes.measure_takes`:
each training take's mean pose minus the mean pose the network itself makes on that take's
speech), and generation draws one training take per speaker (:func:`draw`) and adds its
posture to every bone direction of the network's output before post-processing
(:func:`with_posture`). The posture gives way, eased over :data:`POSTURE_RAMP` frames, wherever
the script requests a pose (the network's own pose following stays as it was; the exact blend
comes after) or a space or handedness style (a posture would move them off the request).

A take's hold also wanders: every few seconds the speaker settles into a slightly different
hold, at moments that no word or sound reveals either, so the network averages that out too.
Weights therefore also carry each training take's *drift* (:attr:`Takes.drifts`): its
reference motion minus the network's output on its speech, both low-passed (a Gaussian of
:data:`DRIFT_SIGMA` frames, slower than a gesture stroke), less the posture, each bone's
offset at most :data:`DRIFT_LIMIT`, sampled every :data:`DRIFT_STEP` frames. The drawn take's drift is added along with its posture, from a
start frame the utterance chooses (:func:`drift_start`), mirrored back and forth when the
speech outlasts the take; its clock stands still in the pauses the engine holds
(:func:`drift_clock`), and it also gives way to a requested slower speed (:func:`drift_weight`).

Chosen by measurement on the val split over three training seeds (model card, "The take's
posture"): the posture cut FGD without controls to less than half and left jerk, speed
histograms and beat alignment as they were; the drift (model card, "The take's drift") cut it
by a further third or more for a rise of the Hellinger distance (0.151 to 0.162 on the test
split). Drawing the take's space and handedness style as well, fed to the
network as style controls, lowered the Hellinger distance a little but made the motion
smoother and less aligned with the speech (on the test split, below shuffled audio in two
seeds): not taken.
"""

from __future__ import annotations

import base64
import zlib
from dataclasses import dataclass

import numpy as np

from core.controls import STYLE_INDEX
from core.skeleton import POSE_DIM, normalize_pose
from model.postprocess import pause_frames, smoothstep

#: At most this many takes are kept in a weights file (a random subset of larger datasets).
MAX_TAKES = 1024
#: Largest posture offset per number: a bone direction moves by less than one unit.
POSTURE_LIMIT = 1.0
#: Frames over which the posture eases out before a pose control or a space/handedness request.
POSTURE_RAMP = 6
#: Style requests the posture gives way to (it would move them).
YIELDS_TO_STYLES = ("space", "handedness")
#: The drift's low-pass (a Gaussian's sigma, frames) and the frames between its stored samples
#: (chosen on the val split, model card "The take's drift").
DRIFT_SIGMA = 8.0
DRIFT_STEP = 5
#: Largest drift offset of one bone direction (about 11 degrees): the drift carries the hold's
#: wandering, not whole gestures the network left out (chosen on the val split, model card).
DRIFT_LIMIT = 0.2
#: First entry of every draw's random key, so a draw never shares a stream with other users of the seed.
_STREAM = 0x7A4E


class TakesError(ValueError):
    """A weights file's takes that are not what :meth:`Takes.from_dict` expects."""


@dataclass(frozen=True)
class Takes:
    """The training takes a weights file carries: ``postures`` (n, 27), offsets of the bone
    directions, and optionally ``drifts``, one (k_i, 27) array per take, the slow offsets around
    the posture sampled every :data:`DRIFT_STEP` frames (None: weights recorded before drifts)."""

    postures: np.ndarray
    drifts: tuple | None = None

    def __len__(self) -> int:
        return len(self.postures)

    def as_dict(self) -> dict:
        """What a weights file stores (postures rounded to 0.0001; drifts as float16 in base64,
        with each take's sample count)."""
        out = {"postures": np.round(self.postures, 4).tolist()}
        if self.drifts is not None:
            flat = np.concatenate([np.asarray(d, np.float16).reshape(-1, POSE_DIM) for d in self.drifts])
            out["drift"] = {"step": DRIFT_STEP, "sigma": DRIFT_SIGMA, "lengths": [len(d) for d in self.drifts],
                            "float16": base64.b64encode(flat.astype("<f2").tobytes()).decode("ascii")}
        return out

    @classmethod
    def from_dict(cls, blob) -> Takes:
        """Read :meth:`as_dict`'s form; raises :class:`TakesError` for anything else."""
        try:
            postures = np.asarray(blob["postures"], np.float32)
        except (TypeError, KeyError, ValueError, IndexError):
            raise TakesError("takes must be a dict with a 'postures' list of lists of numbers") from None
        if postures.ndim != 2 or postures.shape[1] != POSE_DIM:
            raise TakesError(f"takes must hold postures of {POSE_DIM} numbers each")
        _check_values(postures, "postures")
        drift = blob.get("drift")
        return cls(postures, None if drift is None else _read_drifts(drift, len(postures)))


def limit_bones(offsets: np.ndarray, limit: float = DRIFT_LIMIT) -> np.ndarray:
    """(T, 27) offsets with each bone's 3-vector shortened to at most ``limit`` (direction kept)."""
    bones = np.asarray(offsets, np.float64).reshape(len(offsets), -1, 3)
    norm = np.linalg.norm(bones, axis=-1, keepdims=True)
    return (bones * np.minimum(1.0, limit / np.maximum(norm, 1e-12))).reshape(np.shape(offsets))


def _check_values(a: np.ndarray, what: str) -> None:
    if not np.isfinite(a).all():
        raise TakesError(f"take {what} hold values that are not numbers")
    if np.abs(a).max(initial=0) > POSTURE_LIMIT:
        raise TakesError(f"take {what} must lie within ±{POSTURE_LIMIT:g}")


def _read_drifts(blob, n_takes: int) -> tuple:
    try:
        lengths = [int(k) for k in blob["lengths"]]
        step = int(blob["step"])
        raw = base64.b64decode(blob["float16"].encode("ascii"), validate=True)
    except (TypeError, KeyError, ValueError, AttributeError):
        raise TakesError("take drifts must be a dict with 'step', 'lengths' and 'float16' (base64)") from None
    if step != DRIFT_STEP:
        raise TakesError(f"take drifts are sampled every {step} frames; this sgt reads every {DRIFT_STEP}")
    if len(lengths) != n_takes or min(lengths, default=1) < 1 or len(raw) != 2 * POSE_DIM * sum(lengths):
        raise TakesError("take drifts do not match their takes (one non-empty drift per take)")
    flat = np.frombuffer(raw, "<f2").astype(np.float32).reshape(-1, POSE_DIM)
    _check_values(flat, "drifts")
    return tuple(np.split(flat, np.cumsum(lengths)[:-1]))


@dataclass(frozen=True)
class Take:
    """One drawn training take: its ``posture`` (27,) and ``drift`` (k, 27) samples or None."""

    posture: np.ndarray
    drift: np.ndarray | None = None

    def drift_at(self, frames) -> np.ndarray:
        """(n, 27) drift at the drift clock's ``frames`` (:func:`drift_clock`): interpolated
        between the samples, mirrored back and forth past the take's end; zeros without a drift."""
        t = np.asarray(frames, np.float64)
        if self.drift is None or not len(t):
            return np.zeros((len(t), POSE_DIM), np.float32)
        span = (len(self.drift) - 1) * DRIFT_STEP  # frames the samples cover
        t = np.abs((t + span) % (2 * span) - span) if span > 0 else np.zeros_like(t)  # mirror: 0 .. span .. 0 ..
        pos = t / DRIFT_STEP
        i = np.minimum(np.floor(pos).astype(np.int64), len(self.drift) - 1)
        j = np.minimum(i + 1, len(self.drift) - 1)
        f = (pos - i)[:, None]
        return ((1.0 - f) * self.drift[i] + f * self.drift[j]).astype(np.float32)


def speaker_key(base_seed: int, speaker: str | None) -> tuple[int, int]:
    """The draw key of a speaker in a performance: the same for all its utterances, stable when
    other speakers' lines are added or removed (None: the unnamed speaker)."""
    return (int(base_seed), zlib.crc32((speaker or "").encode("utf-8", "surrogatepass")))


def draw(takes: Takes | None, key) -> Take | None:
    """One training :class:`Take` drawn with the random key ``key`` (an int or a tuple of
    ints); None when there are no takes."""
    if takes is None or not len(takes):
        return None
    key = tuple(key) if isinstance(key, (tuple, list)) else (int(key),)
    i = int(np.random.default_rng((_STREAM, *key)).integers(len(takes)))
    return Take(takes.postures[i], None if takes.drifts is None else takes.drifts[i])


def drift_clock(n: int, start: int = 0, words=None) -> np.ndarray:
    """(n,) the drift's frame for each of ``n`` frames: from ``start`` on, standing still inside
    the pauses between ``words`` (:func:`model.postprocess.pause_frames`), where the engine holds
    the pose, so a pause ends where the drift was when it began."""
    return clock_of(~pause_frames(words or [], n), start)


def clock_of(moving, start: int = 0) -> np.ndarray:
    """(n,) the drift's frame for frames whose ``moving`` (n,) bool says whether the clock runs
    into the next one: ``start`` on the first, one more after each moving frame (the stream
    passes the pause spans it found itself)."""
    moving = np.asarray(moving, bool)
    return start + np.concatenate([[0], np.cumsum(moving)[:-1]]).astype(np.int64) if len(moving) else np.zeros(0, np.int64)


def drift_start(words) -> int:
    """The frame of the drawn take's drift an utterance starts from: fixed by its words, so a
    speaker's lines do not all start alike and an utterance keeps its motion when other lines
    change."""
    text = " ".join(getattr(w, "word", str(w)) for w in words or ())
    return zlib.crc32(text.encode("utf-8", "surrogatepass")) % 100_003


def posture_weight(arrays) -> np.ndarray:
    """(T,) share of the posture per frame for the script's controls ``arrays``: 0 on frames
    that request a pose, space or handedness, easing up to 1 over :data:`POSTURE_RAMP` frames
    away from them."""
    return _give_way(_requested(arrays))


def drift_weight(arrays) -> np.ndarray:
    """(T,) share of the drift per frame: as :func:`posture_weight`, and it also gives way
    where a slower speed is requested (a drift would add motion to it; a faster request keeps
    it and the engine's speed correction meets the request)."""
    return _give_way(_requested(arrays) | asks_slower(arrays.style, arrays.style_mask))


def asks_slower(style, style_mask) -> np.ndarray:
    """(T,) bool: frames of style requests ``style``/``style_mask`` (T, 3) that ask for a slower
    speed, where the drift gives way."""
    k = STYLE_INDEX["speed"]
    return (np.asarray(style_mask)[:, k] > 0.5) & (np.asarray(style)[:, k] < 0)


def _requested(arrays) -> np.ndarray:
    """(T,) bool: frames that request a pose or one of :data:`YIELDS_TO_STYLES`."""
    held = np.asarray(arrays.pose_mask) > 0.5
    for name in YIELDS_TO_STYLES:
        held = held | (np.asarray(arrays.style_mask)[:, STYLE_INDEX[name]] > 0.5)
    return held


def _give_way(held: np.ndarray) -> np.ndarray:
    """0 on the ``held`` frames, easing up to 1 over :data:`POSTURE_RAMP` frames away from them."""
    n = len(held)
    if not held.any():
        return np.ones(n, np.float32)
    at = np.flatnonzero(held)
    k = np.clip(np.searchsorted(at, np.arange(n)), 0, len(at) - 1)
    dist = np.minimum(np.abs(np.arange(n) - at[k]), np.abs(np.arange(n) - at[np.maximum(k - 1, 0)]))
    return smoothstep(dist / (POSTURE_RAMP + 1)).astype(np.float32)


def with_posture(poses: np.ndarray, take: Take | None, weight=None, frames=None, drift_weight=None) -> np.ndarray:
    """Poses (T, 27) moved by the drawn ``take``: its posture times ``weight`` and its drift
    at the drift clock's ``frames`` (default 0 .. T-1, :func:`drift_clock`) times
    ``drift_weight`` (both (T,), default 1; see :func:`posture_weight`, :func:`drift_weight`;
    the drift's weight defaults to ``weight``), bones renormalised. Frames where both weights
    are 0 keep their values, and ``poses`` itself comes back when ``take`` is None or nothing
    is to move."""
    n = len(poses)
    w = np.ones(n, np.float32) if weight is None else np.asarray(weight, np.float32)
    wd = w if drift_weight is None else np.asarray(drift_weight, np.float32)
    has_drift = take is not None and take.drift is not None
    if take is None or not (np.any(w) or (has_drift and np.any(wd))):
        return poses
    offsets = w[:, None] * take.posture[None]
    on = w > 0
    if has_drift:
        offsets = offsets + wd[:, None] * take.drift_at(np.arange(n) if frames is None else frames)
        on = on | (wd > 0)
    out = np.array(poses, np.float32)
    out[on] = normalize_pose(out[on] + offsets[on])
    return out


def take_key(inputs, seed: int):
    """The key a take is drawn with (:func:`draw`): the speaker's within a performance
    (``inputs.take_key``), else the engine's seed."""
    key = getattr(inputs, "take_key", None)
    return seed if key is None else key
