"""The ``matching`` engine: motion matching over a database of the training corpus's takes.

The network regresses its teacher and averages away the per-take holds and strokes (model card,
"Known limits"). This engine does not regress: it *retrieves*. The database
(``model/weights/matching_db.npz``, built by ``python -m model.training.matching_db``; a user's
own, of their BVH takes, by ``sgt train --engine matching``, :attr:`Options.database`) holds
the training takes' motion (poses, 15 fps) with their per-frame speech features (the same audio
and word features the network reads, :mod:`model.features`, reduced by a PCA) and each frame's
style (SGToolkit Eq. 4-6). Generation walks the utterance in segments of :data:`SEGMENT`
frames; for each it picks the database frame whose

- **speech** over the segment and a little around it (:data:`CONTEXT_BEFORE`,
  :data:`CONTEXT_AFTER` frames) is nearest the utterance's (squared distance of the windows'
  PCA keys),
- **entry pose** (pose and velocity of the frame before it, in a pose PCA) is nearest the
  motion made so far,
- **style** is nearest the requested style where the script asks for one, else the style of the
  speaker's drawn take (:func:`draw_take`, the matching engine's "take's posture": one training
  take per speaker, so a speaker gestures alike in all its lines),
- and, where the segment holds a pose control, whose pose on that frame is nearest the request,

with a bonus for simply continuing the take it is already playing (:data:`CONTINUE_BONUS`),
except where that take falls silent while the line speaks on (:func:`continue_bonus`).
An utterance is matched from its own inputs alone (no pose of the lines around it): the
performance eases each line in from its speaker's track (:func:`model.performance.place`).
Segments join with a cross-fade of :data:`BLEND` frames from the old take's own continuation
into the new one, bone by bone, so no joint jumps. The first segment is drawn among the
:data:`FIRST_CHOICES` best by the seed; the rest is deterministic. Then the same
post-processing as the neural engine (:func:`model.postprocess.finish`: smoothing, the speed
correction, the pause hold, the exact pose-control blend).

numpy only: no torch import on this engine's path.
"""

from __future__ import annotations

import dataclasses
import stat
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from core import cancel
from core.controls import STYLE_NAMES
from core.npz import load_npz
from core.reading import InputFileError, loads_json
from core.skeleton import FPS, JOINT_INDEX, POSE_DIM, normalize_pose, positions_from_pose
from model import postprocess, take_posture
from model.features import AUDIO_DIM, level_db, speech_inputs, word_id

DEFAULT_DB = Path(__file__).with_name("weights") / "matching_db.npz"
FORMAT = "sgt-matching-db"
VERSION = 1

#: Frames per searched segment (0.8 s), and the speech context around it that the key covers.
SEGMENT = 12
CONTEXT_BEFORE = 2
CONTEXT_AFTER = 4
#: Frames over which a new segment cross-fades in from the old take's continuation.
BLEND = 4
#: Per-frame speech features: audio PCA components, then energy, spectral flux, word onset,
#: accent, speaking (:func:`frame_features`).
AUDIO_COMPONENTS = 4
#: Weights of the cost terms (the speech key is standardised per frame feature; the pose terms
#: are squared distances of unit bone directions).
W_SPEECH = 0.5
W_POSE = 4.0
W_VELOCITY = 40.0
W_STYLE = 8.0
W_TAKE_STYLE = 0.15
W_CONTROL = 8.0
#: Cost taken off the candidate that continues the playing take; less where the script requests
#: a style, so the search moves to takes of that style.
CONTINUE_BONUS = 10.0
CONTINUE_BONUS_STYLED = 2.0
#: No continue bonus for a take that falls silent (its next segment's share of frames with
#: speech below SILENT_TAKE) where the line speaks on without a break (at least SPEAKING_LINE
#: of the frames from SPEECH_RUN before the segment to its end): the bonus would carry the
#: take's rest on through the speech (on long unmarked lines a fifth of the segments played,
#: at a third of the teacher's stroke rate).
SILENT_TAKE = 0.1
SPEAKING_LINE = 0.9
SPEECH_RUN = 30
#: The first segment is drawn among this many best candidates.
FIRST_CHOICES = 16
#: Candidate segment starts are every STRIDE-th database frame (SEGMENT is a multiple, so a
#: take's own continuation is always a candidate).
STRIDE = 2


def options_from(options) -> "Options":
    """The matching :class:`Options` for the options a command gives (a :class:`model.neural.Options`
    or None): its smoothing, blend, ramp, take posture and database carry over."""
    if options is None or isinstance(options, Options):
        return options or Options()
    return Options(smoothing=getattr(options, "smoothing", Options.smoothing), blend=getattr(options, "blend", True),
                   ramp=getattr(options, "ramp", 6), take_posture=getattr(options, "take_posture", True),
                   database=getattr(options, "database", None))


class DatabaseError(ValueError):
    """A matching database file that is missing, damaged or of another format."""


@dataclass(frozen=True)
class Options:
    smoothing: str = "one_euro"  # as the neural engine (model.postprocess.SMOOTHERS)
    blend: bool = True  # exact pose-control blend and the speed correction
    ramp: int = 6
    database: str | None = None  # path; None = the shipped database
    take_posture: bool = True  # draw a take per speaker whose style the free frames follow


@dataclass
class Database:
    """The loaded database (see the module docstring); arrays are float32 unless said."""

    poses: np.ndarray  # (N, 27) all frames of all takes, one after the other
    clip_starts: np.ndarray  # (n_clips + 1,) int64 offsets
    frame_style: np.ndarray  # (N, 3) normalised style per frame
    take_style: np.ndarray  # (n_clips, 3) each take's mean style over its speaking frames
    audio_mean: np.ndarray  # (AUDIO_DIM,)
    audio_basis: np.ndarray  # (AUDIO_DIM, AUDIO_COMPONENTS)
    feat_mean: np.ndarray  # (F,)
    feat_std: np.ndarray  # (F,)
    key_mean: np.ndarray  # (W * F,)
    key_basis: np.ndarray  # (W * F, K) the window keys' PCA
    pose_mean: np.ndarray  # (27,)
    pose_basis: np.ndarray  # (27, P)
    cands: np.ndarray  # (M,) int64 candidate segment starts (global frames)
    speech_keys: np.ndarray  # (M, K)
    meta: dict

    # derived at load
    entry: np.ndarray = dataclasses.field(default=None)  # (M, 2P) weighted entry pose and velocity
    entry_sq: np.ndarray = dataclasses.field(default=None)  # (M,)
    speech_sq: np.ndarray = dataclasses.field(default=None)  # (M,)
    cand_style: np.ndarray = dataclasses.field(default=None)  # (M, 3)
    cand_clip: np.ndarray = dataclasses.field(default=None)  # (M,)
    next_cand: np.ndarray = dataclasses.field(default=None)  # (M,) the candidate continuing it, -1 none
    pose_pca: np.ndarray = dataclasses.field(default=None)  # (N, P)
    speech_keys_dim: int = 1  # numbers in a speech window (the key's length before its PCA)
    speech_keys_t: np.ndarray = dataclasses.field(default=None)  # (K, M)
    cand_style_t: np.ndarray = dataclasses.field(default=None)  # (3, M)
    cand_style_sq_t: np.ndarray = dataclasses.field(default=None)  # (3, M)
    cand_speaking: np.ndarray = dataclasses.field(default=None)  # (M,) share of the segment's frames with speech

    def finalise(self) -> "Database":
        self.speech_keys_dim = len(self.key_mean)
        self.pose_pca = ((self.poses - self.pose_mean) @ self.pose_basis).astype(np.float32)
        c = self.cands
        vel = self.pose_pca[c - 1] - self.pose_pca[c - 2]
        self.entry = np.concatenate([np.sqrt(W_POSE) * self.pose_pca[c - 1], np.sqrt(W_VELOCITY) * vel], 1).astype(np.float32)
        self.speech_keys_t = np.ascontiguousarray(self.speech_keys.T)
        self.entry_sq = (self.entry**2).sum(1)
        self.speech_sq = (self.speech_keys**2).sum(1)
        self.cand_style = self.frame_style[c + SEGMENT // 2]
        self.cand_style_t = np.ascontiguousarray(self.cand_style.T)
        self.cand_style_sq_t = np.ascontiguousarray((self.cand_style**2).T)
        self.cand_clip = np.searchsorted(self.clip_starts, c, side="right") - 1
        where = np.full(len(self.poses) + SEGMENT, -1, np.int64)
        where[c] = np.arange(len(c))
        nxt = where[c + SEGMENT]
        self.next_cand = np.where(self.cand_clip[np.maximum(nxt, 0)] == self.cand_clip, nxt, -1)
        self.cand_speaking = candidate_speaking(self)
        return self


def candidate_speaking(db: Database) -> np.ndarray:
    """(M,) each candidate segment's share of frames with speech, read back from its speech key
    (the key's PCA undone on the speaking feature of the segment's own frames)."""
    n_feat = len(db.feat_mean)
    rows = (CONTEXT_BEFORE + np.arange(SEGMENT)) * n_feat + n_feat - 1
    key = db.speech_keys @ db.key_basis[rows].T + db.key_mean[rows]
    return (key / FEATURE_WEIGHTS[-1] * db.feat_std[-1] + db.feat_mean[-1]).mean(1).astype(np.float32)


def candidate_starts(clip_starts: np.ndarray) -> np.ndarray:
    """Global frames where a segment may start: two frames into a take (an entry velocity), the
    segment and its blend into the next inside the take, on the :data:`STRIDE` grid of the take."""
    out = []
    for a, b in zip(clip_starts[:-1], clip_starts[1:]):
        first = a + 2
        last = b - SEGMENT - BLEND  # inclusive
        if last >= first:
            out.append(np.arange(first, last + 1, STRIDE))
    return np.concatenate(out).astype(np.int64) if out else np.zeros(0, np.int64)


def frame_features(audio: np.ndarray, ids: np.ndarray, onsets: np.ndarray, audio_mean: np.ndarray,
                   audio_basis: np.ndarray) -> np.ndarray:
    """(T, F) unstandardised per-frame speech features: the audio's PCA components, its energy,
    the spectral flux (mean positive rise of the mel bands), the word-onset flag, the accents
    (:func:`accents`, smoothed over a frame or two) and speaking."""
    a = np.asarray(audio, np.float32)
    pcs = (a - audio_mean) @ audio_basis
    flux = np.maximum(np.diff(a[:, :-1], axis=0, prepend=a[:1, :-1]), 0.0).mean(1)
    speaking = (np.asarray(ids) > 0).astype(np.float32)
    acc = np.convolve(accents(a[:, -1], ids, onsets), ACCENT_KERNEL, mode="same")
    return np.concatenate([pcs, a[:, -1:], flux[:, None], np.asarray(onsets, np.float32)[:, None], acc[:, None],
                           speaking[:, None]], 1).astype(np.float32)


#: Per-feature weights after standardisation (audio PCs, energy, flux, onset, accent, speaking).
FEATURE_WEIGHTS = np.array([1.0] * AUDIO_COMPONENTS + [1.0, 1.0, 1.0, 3.0, 1.5], np.float32)
#: The accents are spread over neighbouring frames, so a near miss still matches partly.
ACCENT_KERNEL = np.array([0.25, 0.6, 1.0, 0.6, 0.25], np.float32)
#: The teacher's accent mix (model.teacher.ACCENT_MIX): loudness, then onset strength.
ACCENT_MIX = (0.6, 0.4)
#: Accents of function words weigh this much of a content word's (as the teacher's do).
FUNCTION_WORD_ACCENT = 0.45


@lru_cache(maxsize=1)
def _function_word_ids() -> frozenset:
    from model.teacher import STOPWORDS  # lazy: the teacher's module loads the gesture library's code

    return frozenset(word_id(w) for w in STOPWORDS)


def accents(energy: np.ndarray, ids: np.ndarray, onsets: np.ndarray) -> np.ndarray:
    """(T,) the accent of every word on its frame, as the teacher places its beats: per word,
    the frame of its first half where the accent strength (the teacher's mix of the frame's
    loudness, scaled to the utterance's range, and its rise) is largest, valued at that
    strength (times :data:`FUNCTION_WORD_ACCENT` for a function word); 0 elsewhere."""
    e = np.asarray(energy, np.float64)
    n = len(e)
    out = np.zeros(n, np.float32)
    starts = np.flatnonzero(np.asarray(onsets) > 0)
    if n == 0 or not len(starts):
        return out
    s = (e - e.min()) / max(1e-6, e.max() - e.min())
    rise = np.maximum(np.diff(e, prepend=e[:1]), 0.0)
    f = np.clip(rise / max(1e-6, np.percentile(rise, 99)), 0.0, 1.0)
    strength = np.clip(ACCENT_MIX[0] * s + ACCENT_MIX[1] * f, 0.0, 1.0)
    ids = np.asarray(ids)
    changes = np.flatnonzero(np.diff(ids) != 0) + 1
    function_ids = _function_word_ids()
    for a in starts:
        k = np.searchsorted(changes, a, side="right")
        b = int(changes[k]) if k < len(changes) else n
        b = max(a + 1, b)
        seg = strength[a : max(a + 1, a + (b - a + 1) // 2 + 1)]
        i = int(np.argmax(seg))
        out[a + i] = max(out[a + i], seg[i] * (FUNCTION_WORD_ACCENT if int(ids[a]) in function_ids else 1.0))
    return out


def window_keys(feats: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(len(starts), W * F): the standardised features of frames ``start - CONTEXT_BEFORE`` to
    ``start + SEGMENT + CONTEXT_AFTER``, edges held beyond the ends of ``feats``."""
    offsets = np.arange(-CONTEXT_BEFORE, SEGMENT + CONTEXT_AFTER)
    idx = np.clip(np.asarray(starts)[:, None] + offsets[None], 0, len(feats) - 1)
    return feats[idx].reshape(len(starts), -1)


def load(path=None) -> Database:
    """The database at ``path`` (default: the shipped one), cached per path and file version (a
    database rebuilt in place is read again by a running service or editor)."""
    p = Path(path) if path else DEFAULT_DB
    try:
        st = p.stat()
    except OSError:
        st = None
    if st is None or stat.S_ISDIR(st.st_mode):  # (a FIFO or a device: refused by name in _load, unread)
        raise DatabaseError(f"no matching database at {p}: build it with {_rebuild(p)}")
    return _load(str(p), st.st_mtime_ns, st.st_size)


def _rebuild(p: Path) -> str:
    """The command that builds the database at ``p``: the shipped one from the corpus, a user's
    with ``sgt train``."""
    if p.resolve() == DEFAULT_DB.resolve():
        return "python -m model.training.matching_db --corpus data/corpus"
    return f"sgt train --engine matching --data DIR -o {p.parent} (or --corpus DIR; it writes matching_db.npz there)"


@lru_cache(maxsize=2)
def _load(path: str, _mtime_ns: int, _size: int) -> Database:
    p = Path(path)
    try:
        z = load_npz(p, "matching database")  # sizes checked before anything is inflated (zip bombs)
        meta = loads_json(str(z["meta"]))
        if not isinstance(meta, dict) or meta.get("format") != FORMAT or meta.get("version") != VERSION:
            raise DatabaseError(f"{p} is not a version-{VERSION} {FORMAT} file: rebuild it with {_rebuild(p)}")
        f32 = {k: z[k].astype(np.float32) for k in ("frame_style", "take_style", "audio_mean", "audio_basis",
                                                     "feat_mean", "feat_std", "key_mean", "key_basis",
                                                     "pose_mean", "pose_basis", "speech_keys")}
        poses = normalize_pose(z.pop("poses").astype(np.float32) / 32767.0).astype(np.float32)
        clip_starts = z["clip_starts"].astype(np.int64)
    except DatabaseError:
        raise
    except InputFileError as exc:
        raise DatabaseError(f"{p}: {exc.reason}; give a matching database built with {_rebuild(p)}") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:  # NpzError (damaged, foreign, a zip bomb), JSON, a missing array
        raise DatabaseError(f"{p} is not a readable matching database ({exc}): rebuild it with {_rebuild(p)}") from None
    if poses.ndim != 2 or poses.shape[1] != POSE_DIM or meta.get("segment") != SEGMENT or meta.get("stride") != STRIDE \
            or meta.get("blend") != BLEND or f32["audio_mean"].shape != (AUDIO_DIM,):
        raise DatabaseError(f"{p} was built with other settings: rebuild it with {_rebuild(p)}")
    try:
        if len(clip_starts) < 2 or clip_starts[0] != 0 or clip_starts[-1] != len(poses) or (np.diff(clip_starts) < 0).any():
            raise ValueError("its takes' offsets do not fit its frames")
        cands = candidate_starts(clip_starts)
        if len(f32["speech_keys"]) != len(cands) or len(f32["frame_style"]) != len(poses):
            raise ValueError("its arrays do not fit together")
        return Database(poses=poses, clip_starts=clip_starts, cands=cands, meta=meta, **f32).finalise()
    except (ValueError, IndexError) as exc:
        raise DatabaseError(f"{p} is not a readable matching database ({exc}): rebuild it with {_rebuild(p)}") from None


def draw_take(db: Database, key) -> int:
    """The index of the database take drawn with the random key ``key`` (an int or a tuple of ints)."""
    key = tuple(key) if isinstance(key, (tuple, list)) else (int(key),)
    return int(np.random.default_rng((0x4D41, *key)).integers(len(db.clip_starts) - 1))


def schedule(n: int, pauses=None) -> list[tuple[int, int, bool]]:
    """The pieces of an utterance of ``n`` frames: ``(start, length, held)``, segments of
    :data:`SEGMENT` frames (shorter where a pause cuts them) and the ``pauses`` (n,) bool runs,
    where the engine holds the pose (none at frame 0)."""
    held = np.zeros(n, bool) if pauses is None else np.asarray(pauses, bool)[:n].copy()
    held[:1] = False
    pieces, t = [], 0
    while t < n:
        if held[t]:
            b = t + int(np.argmin(held[t:])) if not held[t:].all() else n
            pieces.append((t, b - t, True))
            t = b
            continue
        ahead = np.flatnonzero(held[t : t + SEGMENT])
        length = int(ahead[0]) if len(ahead) else min(SEGMENT, n - t)
        pieces.append((t, length, False))
        t += length
    return pieces



def entry_state(db: Database, a, b) -> np.ndarray:
    """(pose, velocity) in the pose PCA of two consecutive poses: where a segment is entered from."""
    pa, pb = (np.stack([a, b]).astype(np.float32) - db.pose_mean) @ db.pose_basis
    return np.concatenate([pb, pb - pa])


def entry_cost(db: Database, prev: np.ndarray) -> np.ndarray:
    """(M,) each candidate's entry cost from the state ``prev`` (:func:`entry_state`), less the
    part that is the same for every candidate: pose (weight W_POSE) and velocity (W_VELOCITY)."""
    p = db.pose_basis.shape[1]
    w = np.concatenate([np.full(p, np.sqrt(W_POSE)), np.full(p, np.sqrt(W_VELOCITY))]).astype(np.float32)
    cost = db.entry @ (w * prev).astype(np.float32)
    cost *= -2.0
    cost += db.entry_sq
    return cost


def pick_candidate(cost: np.ndarray, nxt: int, bonus: float, rng=None) -> int:
    """The candidate a segment plays: with ``rng`` (the first segment), one of the
    :data:`FIRST_CHOICES` best drawn by it; else the best, or the playing take's continuation
    ``nxt`` (-1: none) when it is within ``bonus`` of the best."""
    if rng is not None:
        k = min(FIRST_CHOICES, len(cost))  # (a small user database may have fewer candidates)
        best = np.argpartition(cost, k - 1)[:k]
        best = best[np.argsort(cost[best], kind="stable")]
        return int(best[rng.integers(len(best))])
    pick = int(np.argmin(cost))
    if nxt >= 0 and pick != nxt and cost[nxt] - bonus <= cost[pick]:
        pick = nxt
    return pick


def continue_bonus(db: Database, nxt: int, speaking: float, bonus: float) -> float:
    """The bonus of continuing the playing take with candidate ``nxt`` where the line speaks on
    a ``speaking`` share of the frames from :data:`SPEECH_RUN` before the segment to its end:
    ``bonus``, or 0 where the take falls silent while the line speaks on (:data:`SILENT_TAKE`,
    :data:`SPEAKING_LINE`)."""
    if nxt >= 0 and speaking >= SPEAKING_LINE and db.cand_speaking[nxt] < SILENT_TAKE:
        return 0.0
    return bonus


def segment_frames(db: Database, j: int, length: int, source=None) -> np.ndarray:
    """The database's frames ``j`` on, ``length`` and :data:`BLEND` more; cross-faded over
    the first BLEND from ``source`` (what the motion continues with) when one is given."""
    seg = db.poses[j : j + length + BLEND]
    if source is not None:
        fade = postprocess.smoothstep(np.arange(1, BLEND + 1) / (BLEND + 1)).astype(np.float32)[:, None]
        seg = seg.copy()
        seg[:BLEND] = normalize_pose((1 - fade) * source + fade * seg[:BLEND])
    return seg


def held_frames(db: Database, pos: int, anchor: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Frames of a pause: the pose the speaker paused in (``anchor``), :data:`postprocess.PAUSE_HOLD`
    of it, and the rest the playing take's continuation from database frame ``pos`` (+ ``offsets``,
    held at its take's last frame)."""
    end = db.clip_starts[np.searchsorted(db.clip_starts, pos, side="right")]
    cont = db.poses[np.minimum(pos + np.asarray(offsets), end - 1)]
    keep = 1.0 - postprocess.PAUSE_HOLD
    return normalize_pose(keep * cont + (1.0 - keep) * anchor)


def match(db: Database, audio, ids, onsets, arrays, seed: int, take: int | None = None,
          start_pose: np.ndarray | None = None, pauses: np.ndarray | None = None) -> np.ndarray:
    """The matched motion (T, 27) before post-processing. ``take``: the drawn take whose style
    the free frames follow (None: none); ``start_pose`` (k, 27): the poses the motion starts
    from (the speaker's track), for the first entry cost; ``pauses`` (T,) bool: frames where the
    speaker pauses (:func:`model.postprocess.pause_frames`): the pose it paused in is held there
    (:data:`model.postprocess.PAUSE_HOLD` of it; the rest the playing take's continuation) and the
    search resumes from it, so the motion never rushes back from where the take went meanwhile."""
    n = arrays.n_frames
    raw_feats = frame_features(audio, ids, onsets, db.audio_mean, db.audio_basis)
    acc_frames = accents(np.asarray(audio, np.float32)[:, -1], ids, onsets)
    feats = (raw_feats - db.feat_mean) / db.feat_std * FEATURE_WEIGHTS
    pieces = schedule(n, pauses)
    starts = np.array([t for t, _, held in pieces if not held], np.int64)
    q = ((window_keys(feats, starts) - db.key_mean) @ db.key_basis).astype(np.float32)
    # per segment and candidate, what does not depend on the motion made so far: the speech
    # (mean squared distance per window number; + |q|^2 left out, the same for every candidate)
    # and the style (sum over dimensions of weight * (style - target)^2, expanded)
    static = q @ db.speech_keys_t
    static *= -2.0 * W_SPEECH / db.speech_keys_dim
    static += (W_SPEECH / db.speech_keys_dim) * db.speech_sq
    target, weight = _style_targets(db, arrays, starts, take)
    if weight.any():
        static += weight @ db.cand_style_sq_t
        static -= (2.0 * weight * target) @ db.cand_style_t
    styled = (weight >= W_STYLE).any(1) if W_STYLE > 0 else np.zeros(len(starts), bool)
    pose_mask = np.asarray(arrays.pose_mask) > 0.5
    speaking = np.asarray(ids)[:n] > 0
    rng = np.random.default_rng((0x4D42, int(seed)))
    out = np.zeros((n + SEGMENT + BLEND, POSE_DIM), np.float32)

    cur = None  # the playing candidate, when the last piece played all of its segment
    pos = None  # the database frame the playing take continues with
    tail = None  # (BLEND, 27): what the motion continues with when it is not the playing take
    prev = None  # (pose, velocity) in the pose PCA where the next segment starts
    if start_pose is not None and len(start_pose):
        sp = np.asarray(start_pose, np.float32)
        prev = entry_state(db, sp[-2] if len(sp) > 1 else sp[-1], sp[-1])
    s = 0
    for t, length, held in pieces:
        cancel.check()
        if held:  # hold the pose the speaker paused in, with a share of the take's continuation
            anchor = out[t - 1]
            if pos is not None:
                out[t : t + length] = held_frames(db, pos, anchor, np.arange(length))
            else:
                out[t : t + length] = anchor
            before = out[t + length - 2] if length > 1 else anchor
            prev = entry_state(db, before, out[t + length - 1])
            tail = np.repeat(out[t + length - 1 : t + length], BLEND, axis=0)
            cur = pos = None
            continue
        cost = static[s]
        if prev is not None:
            cost = entry_cost(db, prev)
            cost += static[s]
        ctl = np.flatnonzero(pose_mask[t : t + length])
        if len(ctl):  # a pose control in the segment: its pose in the candidate near the request
            k = int(ctl[0])
            want = (np.asarray(arrays.pose[t + k], np.float32) - db.pose_mean) @ db.pose_basis
            d = db.pose_pca[db.cands + k] - want
            cost = cost + W_CONTROL * (d * d).sum(1)
        nxt = -1 if cur is None else int(db.next_cand[cur])
        first = s == 0 and tail is None  # the first segment: one of the best few, by the seed
        bonus = continue_bonus(db, nxt, float(speaking[max(0, t - SPEECH_RUN) : t + length].mean()),
                               CONTINUE_BONUS_STYLED if styled[s] else CONTINUE_BONUS)
        pick = pick_candidate(cost, nxt, bonus, rng if first else None)
        j = int(db.cands[pick])
        source = tail if tail is not None else (db.poses[pos : pos + BLEND] if pos is not None else None)
        seg = segment_frames(db, j, length, source if pick != nxt else None)  # cross-faded from what the motion continues with
        out[t : t + len(seg)] = seg
        cur = pick if length == SEGMENT else None
        pos, tail = j + length, None
        prev = entry_state(db, db.poses[j + length - 2], db.poses[j + length - 1]) if length > 1 else \
            entry_state(db, out[t - 1] if t > 0 else db.poses[j], db.poses[j])
        s += 1
    out = out[:n].copy()
    if SNAP_FRAMES > 0:  # re-timed strokes turn no bone faster than the teacher's limit
        targets = np.union1d(np.flatnonzero(acc_frames >= ACCENT_MIN), syllable_onsets(audio))
        out = snap_beats(out, targets)
        out = postprocess.limit_velocity(out, postprocess.MAX_STEP_DEG).astype(np.float32)
    return out


#: :func:`snap_beats`: a stroke's end moves at most this many frames to an accent; accents
#: weaker than ACCENT_MIN are not targets; the wrists' stroke ends as sgt eval finds them.
SNAP_FRAMES = 4
ACCENT_MIN = 0.3
BEAT_DROP = 0.05
BEAT_LOOKBACK = 5
#: Slowest and fastest local playback rate the snapping may make between two stroke ends.
SNAP_RATE = (0.5, 2.0)


#: Snap targets also include the syllable onsets: peaks (the largest within 2 frames each side)
#: of the spectral flux of the log-mel bands at least this many dB high (0: accents only).
ONSET_RISE_DB = 6.0


def syllable_onsets(audio: np.ndarray) -> np.ndarray:
    """Frames where the voice rises: peaks of the mean positive rise of the log-mel bands (dB,
    the largest within 2 frames each side) at least :data:`ONSET_RISE_DB` high."""
    a = np.asarray(audio, np.float64)
    if ONSET_RISE_DB <= 0 or len(a) < 3:
        return np.zeros(0, np.int64)
    db = level_db(a[:, :-1])
    flux = np.concatenate([[0.0], np.maximum(np.diff(db, axis=0), 0.0).mean(1)])
    pad = np.concatenate([np.full(2, -np.inf), flux, np.full(2, -np.inf)])
    window = np.lib.stride_tricks.sliding_window_view(pad, 5)
    peaks = np.flatnonzero((window.argmax(1) == 2) & (flux >= ONSET_RISE_DB))
    return peaks.astype(np.int64)


def stroke_ends(poses: np.ndarray) -> np.ndarray:
    """Frames where a stroke of the wrists stops: local minima (the smallest within 2 frames each
    side) of the wrists' mean speed at least :data:`BEAT_DROP` m/s below the fastest of the
    :data:`BEAT_LOOKBACK` frames before (the motion beats of docs/metrics.md)."""
    x = positions_from_pose(np.asarray(poses, np.float32))[:, [JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]]]
    if len(x) < 7:
        return np.zeros(0, np.int64)
    speed = np.linalg.norm(x[2:] - x[:-2], axis=-1).mean(-1) / 2 * FPS
    pad = np.concatenate([np.full(2, np.inf), speed, np.full(2, np.inf)])
    window = np.lib.stride_tricks.sliding_window_view(pad, 5)
    minima = np.flatnonzero(window.argmin(1) == 2)
    keep = [t for t in minima if t > 0 and speed[max(0, t - BEAT_LOOKBACK):t].max() - speed[t] >= BEAT_DROP]
    return np.asarray(keep, np.int64) + 1


def snap_beats(poses: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """``poses`` locally re-timed so that each stroke end (:func:`stroke_ends`) within
    :data:`SNAP_FRAMES` of a target frame (an accent) lands on it: a monotone piecewise-linear
    time map through those pairs (the ends fixed, the local rate within :data:`SNAP_RATE`),
    poses interpolated between frames (bones renormalised)."""
    n = len(poses)
    ends = stroke_ends(poses)
    targets = np.asarray(targets, np.int64)
    if n < 3 or not len(ends) or not len(targets):
        return poses
    src, dst = [0.0], [0.0]
    for m in ends:
        a = int(targets[np.argmin(np.abs(targets - m))])
        if abs(a - m) > SNAP_FRAMES:
            continue
        if a <= dst[-1] or m <= src[-1] or a >= n - 1 or m >= n - 1:
            continue
        rate = (m - src[-1]) / (a - dst[-1])
        if not SNAP_RATE[0] <= rate <= SNAP_RATE[1]:
            continue
        src.append(float(m))
        dst.append(float(a))
    last = (n - 1 - src[-1]) / max(1e-9, n - 1 - dst[-1])
    while len(src) > 1 and not SNAP_RATE[0] <= last <= SNAP_RATE[1]:
        src.pop()
        dst.pop()
        last = (n - 1 - src[-1]) / max(1e-9, n - 1 - dst[-1])
    if len(src) == 1:
        return poses
    src.append(n - 1.0)
    dst.append(n - 1.0)
    at = np.interp(np.arange(n), dst, src)
    i = np.minimum(np.floor(at).astype(np.int64), n - 2)
    f = (at - i)[:, None].astype(np.float32)
    p = np.asarray(poses, np.float32)
    return normalize_pose((1 - f) * p[i] + f * p[i + 1]).astype(np.float32)


def _style_targets(db: Database, arrays, starts, take):
    """Per segment: the style target (S, 3) and each dimension's weight (S, 3): the requested
    style where the script asks (mean over the segment's requested frames), else the drawn take's."""
    sm = np.asarray(arrays.style_mask, np.float32)
    st = np.asarray(arrays.style, np.float32)
    target = np.zeros((len(starts), len(STYLE_NAMES)), np.float32)
    weight = np.zeros_like(target)
    for s, t in enumerate(starts):
        m = sm[t : t + SEGMENT]
        on = m.sum(0) > 0
        if on.any():
            target[s, on] = (st[t : t + SEGMENT] * m).sum(0)[on] / m.sum(0)[on]
            weight[s, on] = W_STYLE
        if take is not None:
            target[s, ~on] = db.take_style[take][~on]
            weight[s, ~on] = W_TAKE_STYLE
    return target, weight


#: The matching engine's 1-euro filter (forwards and backwards) has a higher minimum cutoff than
#: the neural engine's (model.postprocess.ZERO_PHASE_MIN_CUTOFF, 8 Hz): the matched takes are the
#: teacher's own motion, which needs only the joins smoothed (chosen on a tuning corpus, model card).
ONE_EURO_MIN_CUTOFF = 12.0


def finish(raw: np.ndarray, arrays, *, smoothing: str = "one_euro", blend: bool = True, ramp: int = 6,
           words=None) -> np.ndarray:
    """The post-processing of the neural engine (:func:`model.postprocess.finish`: smoothing, the
    speed correction, the pause hold with ``words``, the exact pose-control blend) on matched motion."""
    if smoothing == "one_euro":
        raw, smoothing = postprocess.one_euro_zero_phase(raw, min_cutoff=ONE_EURO_MIN_CUTOFF), "none"
    return postprocess.finish(raw, arrays.pose, arrays.pose_mask, smoothing=smoothing, blend=blend, ramp=ramp,
                              bones=arrays.bone_mask, words=words, style=arrays.style, style_mask=arrays.style_mask)


def generate(inputs, *, seed: int = 0, options: Options | None = None) -> np.ndarray:
    """Poses (T, 27) for one utterance (an :class:`~model.generate.EngineInputs`)."""
    opts = options if isinstance(options, Options) else Options()
    db = load(opts.database)
    n = inputs.n_frames
    audio, ids, onsets = speech_inputs(inputs, n)
    take = draw_take(db, take_posture.take_key(inputs, seed)) if opts.take_posture else None
    a = inputs.arrays
    raw = match(db, audio, ids, onsets, a, seed, take, pauses=postprocess.pause_frames(inputs.words, n))
    return finish(raw, a, smoothing=opts.smoothing, blend=opts.blend, ramp=opts.ramp, words=inputs.words)


