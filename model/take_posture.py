"""The take's posture: how a speaker holds the body when the script asks for nothing in particular.

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

Chosen by measurement on the val split over three training seeds (model card, "The take's
posture"): it cut FGD without controls to less than half and left jerk, speed histograms and
beat alignment as they were. Drawing the take's space and handedness style as well, fed to the
network as style controls, lowered the Hellinger distance a little but made the motion
smoother and less aligned with the speech (on the test split, below shuffled audio in two
seeds): not taken.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from core.controls import STYLE_INDEX
from core.skeleton import POSE_DIM, normalize_pose
from model.postprocess import smoothstep

#: At most this many takes are kept in a weights file (a random subset of larger datasets).
MAX_TAKES = 1024
#: Largest posture offset per number: a bone direction moves by less than one unit.
POSTURE_LIMIT = 1.0
#: Frames over which the posture eases out before a pose control or a space/handedness request.
POSTURE_RAMP = 6
#: Style requests the posture gives way to (it would move them).
YIELDS_TO_STYLES = ("space", "handedness")
#: First entry of every draw's random key, so a draw never shares a stream with other users of the seed.
_STREAM = 0x7A4E


class TakesError(ValueError):
    """A weights file's takes that are not what :meth:`Takes.from_dict` expects."""


@dataclass(frozen=True)
class Takes:
    """The training takes a weights file carries: ``postures`` (n, 27), offsets of the bone directions."""

    postures: np.ndarray

    def __len__(self) -> int:
        return len(self.postures)

    def as_dict(self) -> dict:
        """What a weights file stores (numbers rounded to 0.0001)."""
        return {"postures": np.round(self.postures, 4).tolist()}

    @classmethod
    def from_dict(cls, blob) -> Takes:
        """Read :meth:`as_dict`'s form; raises :class:`TakesError` for anything else."""
        try:
            postures = np.asarray(blob["postures"], np.float32)
        except (TypeError, KeyError, ValueError, IndexError):
            raise TakesError("takes must be a dict with a 'postures' list of lists of numbers") from None
        if postures.ndim != 2 or postures.shape[1] != POSE_DIM:
            raise TakesError(f"takes must hold postures of {POSE_DIM} numbers each")
        if not np.isfinite(postures).all():
            raise TakesError("takes hold values that are not numbers")
        if np.abs(postures).max(initial=0) > POSTURE_LIMIT:
            raise TakesError(f"take postures must lie within ±{POSTURE_LIMIT:g}")
        return cls(postures)


def speaker_key(base_seed: int, speaker: str | None) -> tuple[int, int]:
    """The draw key of a speaker in a performance: the same for all its utterances, stable when
    other speakers' lines are added or removed (None: the unnamed speaker)."""
    return (int(base_seed), zlib.crc32((speaker or "").encode("utf-8", "surrogatepass")))


def draw(takes: Takes | None, key) -> np.ndarray | None:
    """One training take's posture (27,) drawn with the random key ``key`` (an int or a tuple
    of ints); None when there are no takes."""
    if takes is None or not len(takes):
        return None
    key = tuple(key) if isinstance(key, (tuple, list)) else (int(key),)
    return takes.postures[int(np.random.default_rng((_STREAM, *key)).integers(len(takes)))]


def posture_weight(arrays) -> np.ndarray:
    """(T,) share of the posture per frame for the script's controls ``arrays``: 0 on frames
    that request a pose, space or handedness, easing up to 1 over :data:`POSTURE_RAMP` frames
    away from them."""
    held = np.asarray(arrays.pose_mask) > 0.5
    for name in YIELDS_TO_STYLES:
        held = held | (np.asarray(arrays.style_mask)[:, STYLE_INDEX[name]] > 0.5)
    n = len(held)
    if not held.any():
        return np.ones(n, np.float32)
    at = np.flatnonzero(held)
    k = np.clip(np.searchsorted(at, np.arange(n)), 0, len(at) - 1)
    dist = np.minimum(np.abs(np.arange(n) - at[k]), np.abs(np.arange(n) - at[np.maximum(k - 1, 0)]))
    return smoothstep(dist / (POSTURE_RAMP + 1)).astype(np.float32)


def with_posture(poses: np.ndarray, posture: np.ndarray | None, weight=None) -> np.ndarray:
    """Poses (T, 27) moved by ``posture`` (27,) times ``weight`` ((T,), default 1: see
    :func:`posture_weight`), bones renormalised; frames of weight 0 keep their values, and
    ``poses`` itself comes back when ``posture`` is None or the weight is 0 everywhere."""
    if posture is None or (weight is not None and not np.any(weight)):
        return poses
    if weight is None:
        return normalize_pose(np.asarray(poses, np.float32) + posture)
    w = np.asarray(weight, np.float32)
    out = np.array(poses, np.float32)
    on = w > 0
    out[on] = normalize_pose(out[on] + w[on, None] * posture)
    return out
