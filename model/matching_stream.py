"""The matching engine as a stream: frames decided with the network stream's lookahead.

:func:`model.matching.match` searches each segment of :data:`~model.matching.SEGMENT` frames
(0.8 s) with a key of the speech from 2 frames before it to 4 after it: 1.3 s past the
segment's start, more than the stream's :data:`~model.streaming.LOOKAHEAD_S` (0.467 s). The
stream keeps that lookahead and gives the search what is known when a segment starts:

- a segment is chosen when its first frame is decided, i.e. once the speech is known up to 7
  frames past it; its **speech term** is the mean squared distance over the known part of the
  window only (frames ``t - 2`` to ``t + 6`` of the 18 the offline key covers: the database's
  keys are a PCA of whole windows, so each candidate's known part is read back from its key;
  chosen by measurement over rescaling it or estimating the whole key from the known part,
  docs/serve.md);
- the **entry**, **style** and **continue-bonus** terms (no bonus for a take falling silent
  while the line speaks on, up to the segment's known frames: :func:`~model.matching.continue_bonus`), the first segment drawn among the best
  by the seed, the **cross-fade** of a new take from the old one's continuation and the in-engine
  **pause hold** are :func:`~model.matching.match`'s, frame by frame (a pause is known when its
  first frame is decided: the stream knows 0.467 s of silence, more than ``PAUSE_MIN_S``);
- the features of a frame (accents included) are computed over the known frames of the last
  :data:`HISTORY` frames (the offline engine normalises the accents over the whole utterance);
- the **re-timing of stroke ends onto accents** (:func:`~model.matching.snap_beats`) is
  **not** done: it moves frames by up to 4 frames towards an accent found with the whole
  utterance's loudness range, and the lookahead is spent on the speech key already;
- :func:`~model.postprocess.limit_velocity` runs causally (each frame limited from the one
  returned before), then the 1-euro filter causally (:func:`~model.postprocess.one_euro` with
  state, at the matching engine's cutoff, where the offline engine runs it forwards and
  backwards), then the network stream's pause hold (:class:`~model.streaming.StreamBase`); the
  speed correction (``follow_speed``) needs 0.7 s of look-ahead and is not applied, so a
  ``speed`` request is met by the search's style term alone.

Work per frame is bounded: one search (a product of the window key with every candidate's) per
segment, features of at most :data:`HISTORY` frames. numpy only: no torch on this path.
benchmarks/bench_serve.py measures the stream against :func:`~model.matching.match` on the same
words (docs/serve.md quotes it).
"""

from __future__ import annotations

import numpy as np

from core.skeleton import POSE_DIM
from model import postprocess
from model.features import word_features
from model.matching import (
    BLEND,
    CONTEXT_BEFORE,
    CONTINUE_BONUS,
    CONTINUE_BONUS_STYLED,
    FEATURE_WEIGHTS,
    ONE_EURO_MIN_CUTOFF,
    SEGMENT,
    SPEECH_RUN,
    W_SPEECH,
    W_STYLE,
    W_TAKE_STYLE,
    Database,
    continue_bonus,
    draw_take,
    entry_cost,
    entry_state,
    frame_features,
    held_frames,
    pick_candidate,
    segment_frames,
)
from model.streaming import LOOKAHEAD, STEP, StreamBase

#: Frames of the speech window known when a segment starts: ``CONTEXT_BEFORE`` before it, the
#: segment's first frame and the ``LOOKAHEAD`` after it.
KNOWN = CONTEXT_BEFORE + STEP + LOOKAHEAD
#: Frames of features computed for a search (the accents are normalised over them).
HISTORY = 45


class _Partial:
    """The database's speech keys as the stream compares them: the first ``KNOWN`` frames of each
    candidate's window, read back from its key (``key_mean + key_basis @ key``), compared with
    the stream's known frames. ``lin`` (K, M) and ``quad`` (M,) make the squared distance
    ``|a|^2 - 2 a B k + k' B'B k`` one product per search."""

    def __init__(self, db: Database) -> None:
        width = KNOWN * len(db.feat_mean)
        self.mean = db.key_mean[:width]
        self.basis = db.key_basis[:width]  # (width, K)
        keys = db.speech_keys.astype(np.float32)
        self.quad = ((keys @ (self.basis.T @ self.basis)) * keys).sum(1)
        self.width = width


_PARTIAL: dict[int, tuple[Database, _Partial]] = {}


def _partial(db: Database) -> _Partial:
    """The :class:`_Partial` of ``db``, kept for the last two databases (a service's streams share it)."""
    got = _PARTIAL.get(id(db))
    if got is None or got[0] is not db:
        while len(_PARTIAL) >= 2:
            _PARTIAL.pop(next(iter(_PARTIAL)))
        got = _PARTIAL[id(db)] = (db, _Partial(db))
    return got[1]


class MatchingStreamGenerator(StreamBase):
    """The matching engine's stream over the database ``db`` (:func:`model.matching.load`), with the
    interface of :class:`model.streaming.StreamGenerator`: :meth:`add_words`, :meth:`add_audio`,
    :meth:`known_until`, :meth:`finish` each return the frames they decide, (n, 27) poses.
    ``take_style``: follow the style of a database take drawn with the seed where the client
    asks for none (as ``sgt generate --engine matching`` does; its ``--no-take-posture``)."""

    def __init__(self, db: Database, *, seed: int = 0, style: dict[str, float] | None = None, smoothing: bool = True,
                 take_style: bool = True) -> None:
        super().__init__(style=style, smoothing=smoothing)
        self.db = db
        self.partial = _partial(db)
        self.rng = np.random.default_rng((0x4D42, int(seed)))
        # the style term of match (model.matching._style_targets), the same for every segment
        on = self.style_mask > 0
        target = np.where(on, self.style, 0.0).astype(np.float32)
        weight = np.where(on, W_STYLE, 0.0).astype(np.float32)
        if take_style:
            take = draw_take(db, seed)
            target[~on], weight[~on] = db.take_style[take][~on], W_TAKE_STYLE
        self.style_cost = (weight @ db.cand_style_sq_t - (2.0 * weight * target) @ db.cand_style_t).astype(np.float32)
        self.bonus = CONTINUE_BONUS_STYLED if W_STYLE > 0 and (weight >= W_STYLE).any() else CONTINUE_BONUS
        # the search's state, as in match
        self.segments = 0  # segments chosen so far
        self.seg: np.ndarray | None = None  # the playing segment's frames (cross-fade applied)
        self.seg_start = 0  # the frame where it started
        self.seg_frame = 0  # its first frame in the database
        self.pick = -1  # its candidate
        self.pos: int | None = None  # the database frame the playing take continues with
        self.holding = False  # in a pause: the pose it paused in is held
        self.anchor: np.ndarray | None = None
        self.hold_pos: int | None = None
        self.hold_i = 0
        self.recent = np.zeros((0, POSE_DIM), np.float32)  # the last two decided frames before smoothing
        self.last_limited: np.ndarray | None = None  # the last frame limit_velocity returned

    def _step(self, limit: int, final: bool = False) -> np.ndarray:
        f = self.done
        span = self._pause_span(f, final)
        self.spans.append(span)  # the pause hold of _calm_pauses reads it when the frame is returned
        self.done += 1
        frame = self._held() if span is not None else self._played(f)
        self.recent = np.concatenate([self.recent[-1:], frame[None]])
        return frame[None]

    def _held(self) -> np.ndarray:
        """A frame inside a pause: the pose the speaker paused in, with match's share of the playing
        take's continuation."""
        db = self.db
        if not self.holding:
            self.holding, self.hold_i = True, 0
            self.anchor = self.recent[-1]
            self.hold_pos = None if self.seg is None else self.seg_frame + (self.done - 1 - self.seg_start)
            self.seg = None
        i, self.hold_i = self.hold_i, self.hold_i + 1
        if self.hold_pos is None:
            return self.anchor.copy()
        return held_frames(db, self.hold_pos, self.anchor, i).astype(np.float32)

    def _played(self, f: int) -> np.ndarray:
        if self.seg is None or f - self.seg_start >= SEGMENT:
            self._choose(f)
        return self.seg[f - self.seg_start]

    def _choose(self, t: int) -> None:
        """Search the segment that starts at frame ``t`` (match's search, with the speech window
        cut to what is known)."""
        db = self.db
        cur, pos, tail, prev = -1, None, None, None
        if self.holding:  # after a pause: from the pose held, as match does
            prev = entry_state(db, self.recent[-2] if len(self.recent) > 1 else self.recent[-1], self.recent[-1])
            tail = np.repeat(self.recent[-1:], BLEND, axis=0)
            self.holding = False
        elif self.seg is not None:  # the playing segment has played all of its frames
            j = self.seg_frame
            cur, pos = self.pick, j + SEGMENT
            prev = entry_state(db, db.poses[j + SEGMENT - 2], db.poses[j + SEGMENT - 1])
        cost = self._speech_cost(t)
        cost += self.style_cost
        if prev is not None:
            cost += entry_cost(db, prev)
        nxt = -1 if cur < 0 else int(db.next_cand[cur])
        first = self.segments == 0 and tail is None  # the first segment: one of the best few, by the seed
        run = max(0, t - SPEECH_RUN)  # the speech run before the segment and its known frames
        ids, _ = word_features(self._recent_words(run), t + STEP + LOOKAHEAD - run)
        bonus = continue_bonus(db, nxt, float((ids > 0).mean()), self.bonus)
        pick = pick_candidate(cost, nxt, bonus, self.rng if first else None)
        j = int(db.cands[pick])
        source = tail if tail is not None else (db.poses[pos : pos + BLEND] if pos is not None else None)
        seg = segment_frames(db, j, SEGMENT, source if pick != nxt else None)  # cross-faded from what the motion continues with
        self.seg, self.seg_start, self.seg_frame, self.pick = seg.astype(np.float32), t, j, pick
        self.segments += 1

    def _speech_cost(self, t: int) -> np.ndarray:
        """(M,) W_SPEECH times the mean squared distance of the known speech window of a segment at
        ``t`` (frames ``t - CONTEXT_BEFORE`` to ``t + LOOKAHEAD``) to each candidate's."""
        db, part = self.db, self.partial
        s, e = max(0, t - HISTORY), t + STEP + LOOKAHEAD
        ids, onsets = word_features(self._recent_words(s), e - s)
        raw = frame_features(self._audio_features(s, e), ids, onsets, db.audio_mean, db.audio_basis)
        feats = (raw - db.feat_mean) / db.feat_std * FEATURE_WEIGHTS
        rows = np.clip(np.arange(t - CONTEXT_BEFORE, e), 0, None) - s  # the frames before 0 hold frame 0, as window_keys
        a = feats[rows].reshape(-1) - part.mean
        cost = (a @ part.basis).astype(np.float32) @ db.speech_keys_t
        cost *= -2.0
        cost += part.quad
        cost += float(a @ a)
        cost *= W_SPEECH / part.width
        return cost

    def _smooth(self, raw: np.ndarray) -> np.ndarray:
        """limit_velocity from the last frame it returned (no bone turns faster than the teacher's
        limit), then the causal 1-euro filter at the matching engine's cutoff."""
        x = raw if self.last_limited is None else np.concatenate([self.last_limited[None], raw])
        limited = postprocess.limit_velocity(x, postprocess.MAX_STEP_DEG).astype(np.float32)
        limited = limited if self.last_limited is None else limited[1:]
        self.last_limited = limited[-1].copy()
        if not self.smoothing:
            return limited
        return postprocess.one_euro(limited, min_cutoff=ONE_EURO_MIN_CUTOFF, state=self.filter_state)
