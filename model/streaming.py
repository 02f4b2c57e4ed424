"""Streaming generation: motion frames decided while the words are still arriving.

The offline engine (:mod:`model.neural`) runs the bidirectional network over 4 s windows, so a
frame depends on up to 3 s of speech after it. A running agent cannot wait for that. The stream
runs the same network and weights on a window that ends ``LOOKAHEAD`` frames after the frames it
decides: to decide frames ``[a, a + STEP)`` it runs the words of frames
``[a - CONTEXT, a + STEP + LOOKAHEAD)`` and keeps the outputs for ``[a, a + STEP)``. Frames then
go through the causal 1-euro filter of the offline engine (continued across calls, so exactly
the same filter). Settings chosen by measurement (docs/serve.md has the table): feeding the
decided frames back as seed poses made the motion about half as fast as the offline engine's
and twice as jerky at these window lengths; without seeds, one frame per call and 3 s of
context, the stream stays about 4 degrees per bone from the offline motion on average, with
1.2-1.3 times its speed and jerk (benchmarks/bench_serve.py prints these figures).

The algorithmic latency (lookahead) is therefore fixed and stated: a frame is emitted once the
words up to at most ``(STEP + LOOKAHEAD) / FPS`` seconds after it are known (:data:`LOOKAHEAD_S`,
0.47 s at 15 fps). One step is one network call on ``CONTEXT + STEP + LOOKAHEAD`` frames
(benchmarks/bench_serve.py measures it: about 1 ms in onnxruntime).

The network was trained on whole windows, so the stream's motion is not the offline motion:
benchmarks/bench_serve.py compares the two (docs/serve.md quotes it). Without audio the stream
follows the words, their onsets and the style, as the offline engine does with estimated timing.
With audio (:meth:`StreamGenerator.add_audio`, the speech as it is played) a frame also waits
for the audio up to its lookahead, and the network gets the audio features; their levels are
relative to the speech level of the last :data:`LEVEL_WINDOW_S` seconds of audio so far (the
offline engine uses the whole utterance's, which a stream does not have yet).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from core import cancel
from core.controls import STYLE_INDEX, STYLE_LIMIT, STYLE_NAMES
from core.skeleton import FPS, POSE_DIM
from core.words import TimedWord
from model import take_posture
from model.features import AUDIO_DIM, HOP, frame_powers, level_features, silence_features, speech_level, word_features
from model.postprocess import PAUSE_MIN_S, hold_pose, one_euro, pause_hold_weight

CONTEXT = 45  # frames of words before the decided ones (3 s)
STEP = 1  # frames decided per network call
LOOKAHEAD = 6  # frames of words after the decided ones
#: The longest a frame waits for words after it: the stated algorithmic latency, in seconds.
LOOKAHEAD_S = (STEP + LOOKAHEAD) / FPS
#: Motion after the last word when the stream ends (seconds): the speaker comes to rest.
TAIL = 0.5
#: The audio whose speech level the stream's audio features are relative to: the last this
#: many seconds (bounded work per frame however long the stream).
LEVEL_WINDOW_S = 30.0


class StreamError(ValueError):
    """Input the stream cannot take (words out of order, an unknown style, ...)."""


def parse_style(style: dict[str, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """(style, mask) (3,) float32 of a client's style request ``{"speed": 1.0, ...}``; raises
    :class:`StreamError` for an unknown name or a value out of range."""
    values = np.zeros(len(STYLE_NAMES), np.float32)
    mask = np.zeros(len(STYLE_NAMES), np.float32)
    for name, value in (style or {}).items():
        if name not in STYLE_INDEX:
            raise StreamError(f"unknown style '{name}': use {', '.join(STYLE_NAMES)}")
        if not isinstance(value, (int, float)) or not -STYLE_LIMIT <= value <= STYLE_LIMIT:
            raise StreamError(f"style {name} must be a number from -{STYLE_LIMIT} to {STYLE_LIMIT}")
        values[STYLE_INDEX[name]], mask[STYLE_INDEX[name]] = value, 1.0
    return values, mask


class StreamBase:
    """What every streaming engine shares: the words and audio as they arrive, when a frame may
    be decided (the speech known ``LOOKAHEAD_S`` past it), the pause spans and the offline
    engines' pause hold on the frames returned. An engine decides one frame per :meth:`_step`
    and smooths the frames it returns in :meth:`_smooth` (:class:`StreamGenerator`, the
    network; :class:`model.matching_stream.MatchingStreamGenerator`, the matching engine)."""

    def __init__(self, *, style: dict[str, float] | None = None, smoothing: bool = True) -> None:
        self.style, self.style_mask = parse_style(style)
        self.smoothing = smoothing
        self.filter_state: dict = {}
        self.emitted = 0  # frames returned so far
        self.spans: list = []  # the pause span (_pause_span) of each decided frame not yet returned
        self.last_filtered: np.ndarray | None = None  # the last returned frame before the pause hold
        self.hold_target: np.ndarray | None = None  # the pose the current pause holds (its frame before)
        self.words: list[TimedWord] = []
        self.word_ends: list[float] = []  # each word's end, for finding the recent words in O(log n)
        self.known = 0.0  # seconds of speech known
        self.done = 0  # frames decided
        self.finished = False
        self.audio: np.ndarray | None = None  # the speech not yet in ``powers`` (SAMPLE_RATE), once audio is sent
        self.audio_start = 0  # the sample of ``audio[0]``: a frame's first sample
        self.powers = np.zeros((0, AUDIO_DIM))  # frame_powers of the frames the audio so far covers

    @property
    def last_word_end(self) -> float:
        return self.words[-1].end if self.words else 0.0

    def add_words(self, words) -> np.ndarray:
        """Append timed words ((text, start, end) seconds on the stream's timeline, in order);
        the speech is then known up to the last one's end."""
        for word in words:
            text, start, end = word
            if not isinstance(text, str) or not text.strip():
                raise StreamError("a word must be non-empty text")
            if not (math.isfinite(start) and math.isfinite(end)) or start < 0 or end < start:
                raise StreamError(f"word '{text}' has times {start}..{end}: they must satisfy 0 <= start <= end")
            if start < self.last_word_end - 1e-6:
                raise StreamError(f"word '{text}' starts at {start:.3f} s, before the previous word ends "
                                  f"({self.last_word_end:.3f} s): send words in order")
            if start < self.known - 1e-6:
                raise StreamError(f"word '{text}' starts at {start:.3f} s, but the speech was said to be known up to "
                                  f"{self.known:.3f} s (silence after the last word): send words before saying so")
            self.words.append(TimedWord(text, float(start), float(end)))
            self.word_ends.append(float(end))
        return self.known_until(max(self.known, self.last_word_end))

    def add_audio(self, samples: np.ndarray) -> np.ndarray:
        """Append speech audio (float, SAMPLE_RATE, continuing the audio sent so far from time 0);
        from the first call on, frames also wait for the audio up to their lookahead. Returns
        the frames that can now be decided."""
        if self.finished:
            raise StreamError("the stream has ended")
        samples = np.asarray(samples, np.float32).reshape(-1)
        if not np.all(np.isfinite(samples)):
            raise StreamError("the audio holds values that are not numbers")
        self.audio = samples if self.audio is None else np.concatenate([self.audio, samples])
        whole = (self.audio_start + len(self.audio)) // HOP  # frames whose samples have all arrived
        if whole > len(self.powers):
            self._add_powers(whole)
            start = (len(self.powers) - 1) * HOP  # the first sample the next frame reads
            self.audio, self.audio_start = self.audio[start - self.audio_start :], start
        return self.known_until(self.known)

    def _add_powers(self, frames: int) -> None:
        first = len(self.powers)
        new = frame_powers(self.audio, first - self.audio_start // HOP, frames - first)
        self.powers = np.concatenate([self.powers, new])

    def _ready_frames(self) -> int:
        """Frames whose words (and audio, once audio is sent) are known."""
        known = int(math.floor(self.known * FPS + 1e-6))
        return known if self.audio is None else min(known, len(self.powers))

    def known_until(self, seconds: float) -> np.ndarray:
        """Say that the speech is known up to ``seconds`` (silence after the last word so far);
        returns the frames that can now be decided."""
        if self.finished:
            raise StreamError("the stream has ended")
        if not math.isfinite(seconds):
            raise StreamError("the time must be a finite number of seconds")
        self.known = max(self.known, float(seconds))
        out = []
        while self.done + STEP + LOOKAHEAD <= self._ready_frames():
            cancel.check()
            out.append(self._step(self.done + STEP + LOOKAHEAD))
        return self._emit(out)

    def finish(self) -> np.ndarray:
        """No more words: decide every frame up to ``TAIL`` seconds after the last word."""
        total = max(self.done, int(math.ceil((max(self.known, self.last_word_end) + TAIL) * FPS - 1e-6)))
        out = []
        while self.done < total:
            cancel.check()
            out.append(self._step(total, final=True))
        self.finished = True
        return self._emit(out)

    def _audio_features(self, s: int, e: int) -> np.ndarray:
        """Features of frames [s, e): silence without audio; with it, levels relative to the
        speech level of the last LEVEL_WINDOW_S seconds of audio up to frame e."""
        if self.audio is None:
            return silence_features(e - s)
        if e > len(self.powers):  # finishing: frames the audio only partly covers, or past its end
            self._add_powers(e)
        recent = self.powers[max(0, e - int(LEVEL_WINDOW_S * FPS)) : e]
        return level_features(self.powers[s:e], speech_level(recent)).astype(np.float32)

    def _emit(self, pieces: list[np.ndarray]) -> np.ndarray:
        if not pieces:
            return np.zeros((0, POSE_DIM), np.float32)
        return self._calm_pauses(self._smooth(np.concatenate(pieces)))

    def _step(self, limit: int, final: bool = False) -> np.ndarray:
        """Decide the next frames (at least one, none at or past ``limit``), appending each one's
        pause span to ``self.spans`` (``final``: no word follows, as :meth:`_pause_span`); returns
        their poses before :meth:`_smooth`."""
        raise NotImplementedError

    def _smooth(self, raw: np.ndarray) -> np.ndarray:
        """The causal 1-euro filter, continued across calls (``smoothing``)."""
        return one_euro(raw, state=self.filter_state) if self.smoothing else raw

    def _recent_words(self, s: int) -> list[TimedWord]:
        """The words that reach into frame ``s`` or later, on a clock that starts at frame ``s``."""
        t0 = s / FPS
        first = bisect.bisect_right(self.word_ends, t0 - 1.0 / FPS)  # ends never decrease (words in order)
        return [TimedWord(w.word, w.start - t0, w.end - t0) for w in self.words[first:]]

    def _calm_pauses(self, frames: np.ndarray) -> np.ndarray:
        """The offline engine's pause hold (:func:`model.postprocess.calm_pauses`) on frames about
        to be returned. It needs no more look-ahead than the stream has: a frame is decided only
        once the speech is known LOOKAHEAD_S (> PAUSE_MIN_S) past it, so whether it lies in a
        silence of at least PAUSE_MIN_S is known, and so is a pause end close enough to ease
        out before it; a pause whose next word is not known yet is held as if it went on.
        After the last word (:meth:`finish`) the hold continues to the end, where the offline
        engine, which knows no word follows, does not hold. Each frame's pause span is the one
        :meth:`_step` found when it decided the frame (``self.spans``)."""
        first = self.emitted
        self.emitted += len(frames)
        spans, self.spans = self.spans[: len(frames)], self.spans[len(frames):]  # decided with the frames
        target = np.empty_like(frames)
        weight = np.zeros(len(frames), np.float32)
        for i, span in enumerate(spans):
            if span is not None:
                a, b = span
                if first + i == a or self.hold_target is None:
                    self.hold_target = frames[i - 1] if i > 0 else self.last_filtered
                target[i] = self.hold_target
                weight[i] = pause_hold_weight(np.array([first + i - a]), b - a)[0]
        self.last_filtered = frames[-1].copy()
        return hold_pose(frames, target, weight)

    def _pause_span(self, f: int, final: bool) -> tuple[int, float] | None:
        """(first frame, end frame) of the pause frame ``f`` lies in (the end ``math.inf`` while
        no word after it is known and the stream has ended), as :func:`model.postprocess.pause_frames`
        spans it; None outside pauses."""
        words = self.words
        i = len(words) - 1
        while i >= 0 and math.floor(words[i].end * FPS) + 1 > f:
            i -= 1
        if i < 0:
            return None  # before the first word's end: never a pause
        end = words[i].end
        following = words[i + 1].start if i + 1 < len(words) else (math.inf if final else self.known)
        if following - end < PAUSE_MIN_S:
            return None
        stop = math.ceil(following * FPS) if math.isfinite(following) else math.inf
        return (math.floor(end * FPS) + 1, stop) if f < stop else None


class StreamGenerator(StreamBase):
    """The network's stream. Feed timed words (:meth:`add_words`) and say how far the speech is
    known (:meth:`known_until`); each call returns the frames it could decide, (n, 27) poses.
    :meth:`finish` returns the rest."""

    def __init__(self, runner, *, seed: int = 0, style: dict[str, float] | None = None, smoothing: bool = True) -> None:
        super().__init__(style=style, smoothing=smoothing)
        self.runner = runner
        self.z = np.random.default_rng(seed).standard_normal(runner.noise_dim).astype(np.float32)
        # the take's posture and drift (model.take_posture), unless the client asks for space or handedness
        asked = any(self.style_mask[STYLE_INDEX[n]] for n in take_posture.YIELDS_TO_STYLES)
        self.take = None if asked else take_posture.draw(getattr(runner, "takes", None), seed)
        if self.take is not None and take_posture.asks_slower(self.style[None], self.style_mask[None])[0]:
            self.take = take_posture.Take(self.take.posture)  # the drift gives way to a slower speed
        self.drift_frame = 0  # the drift's clock: it stands still in pauses (take_posture.drift_clock)

    def _step(self, limit: int, final: bool = False) -> np.ndarray:
        """Run the network for the next STEP frames (fewer at ``limit``); returns their raw poses
        with the take's posture and drift (``final``: no word follows, as :meth:`_pause_span`)."""
        a = self.done
        s = max(0, a - CONTEXT)
        e = min(a + STEP + LOOKAHEAD, max(limit, a + 1))
        n = e - s
        ids, onsets = word_features(self._recent_words(s), n)
        free = np.zeros((n, POSE_DIM), np.float32)
        y = self.runner.run_window(self._audio_features(s, e), ids, onsets, free, np.zeros(n, np.float32),
                                   np.repeat(self.style[None], n, 0), np.repeat(self.style_mask[None], n, 0), self.z)
        k = min(STEP, e - a)
        self.done += k
        spans = [self._pause_span(a + i, final) for i in range(k)]
        self.spans += spans  # the pause hold of _calm_pauses reads them when the frames are returned
        moving = [span is None for span in spans]
        frames = take_posture.clock_of(moving, self.drift_frame)  # as drift_clock: still in pauses
        self.drift_frame += sum(moving)
        return take_posture.with_posture(y[a - s : a - s + k], self.take, frames=frames)
