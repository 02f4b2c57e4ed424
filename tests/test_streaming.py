"""Streaming generation (model/streaming.py): frames decided with a fixed, stated lookahead."""

from __future__ import annotations

import numpy as np
import pytest

from core.skeleton import FPS, N_BONES
from core.words import TimedWord
from dsl import compile_text
from model import postprocess
from model.runtime import load_runner
from model.streaming import LOOKAHEAD_S, TAIL, StreamError, StreamGenerator

TEXT = "guide: Welcome to the mall! The shops are over there, and the food court is upstairs."


@pytest.fixture(scope="module")
def words():
    return list(compile_text(TEXT, timing="estimate").plan.utterances[0].words)


def test_one_euro_in_pieces_is_one_euro_whole():
    x = np.random.default_rng(0).normal(size=(61, 27))
    state: dict = {}
    pieces = [postprocess.one_euro(x[i : i + k], state=state) for i, k in zip(range(0, 61, 4), [4] * 16)]
    assert np.array_equal(np.concatenate(pieces), postprocess.one_euro(x))


def stream(words, pieces: int, seed: int = 2, **kw) -> tuple[np.ndarray, list[float]]:
    """Feed ``words`` in ``pieces`` groups; returns the poses and, per frame, how far past it
    the speech was known when it was emitted (seconds)."""
    gen = StreamGenerator(load_runner(None), seed=seed, **kw)
    out, lags = [], []
    for group in np.array_split(np.arange(len(words)), pieces):
        frames = gen.add_words([words[i] for i in group])
        lags += [gen.known - (sum(map(len, out)) + i) / FPS for i in range(len(frames))]
        out.append(frames)
    out.append(gen.finish())
    return np.concatenate(out), lags


def test_the_frames_do_not_depend_on_how_the_words_arrive(words):
    whole, _ = stream(words, 1)
    one_by_one, _ = stream(words, len(words))
    assert np.array_equal(whole, one_by_one)
    assert len(whole) == int(np.ceil((words[-1].end + TAIL) * FPS - 1e-6))
    bones = np.linalg.norm(whole.reshape(-1, N_BONES, 3), axis=-1)
    assert np.allclose(bones, 1.0, atol=1e-4)
    assert not np.array_equal(whole, stream(words, 1, seed=3)[0])  # another seed, another take
    assert not np.array_equal(whole, stream(words, 1, style={"speed": 2.5})[0])


def test_lookahead_is_the_stated_one_when_time_advances_frame_by_frame(words):
    """A TTS says each word (with its end) when it starts; time advances one frame at a time.
    Every frame needs the speech known exactly LOOKAHEAD_S past it: it is emitted by the first
    message after which that much is known, never before."""
    gen = StreamGenerator(load_runner(None), seed=0)
    pending = list(words)
    emitted = 0
    for k in range(1, int(words[-1].end * FPS) + 30):
        t = k / FPS
        before = gen.known
        starting = [w for w in pending if w.start <= t]
        pending = pending[len(starting):]
        frames = [gen.add_words(starting)] if starting else []
        frames.append(gen.known_until(t))
        for i in range(sum(map(len, frames))):
            frame_time = (emitted + i) / FPS
            assert before < frame_time + LOOKAHEAD_S - 1e-9 <= gen.known
        emitted += sum(map(len, frames))
    assert emitted > 40
    assert LOOKAHEAD_S <= 0.5


def test_bad_input_is_refused_with_a_reason(words):
    gen = StreamGenerator(load_runner(None))
    gen.add_words(words[:3])
    with pytest.raises(StreamError, match="before the previous word ends"):
        gen.add_words([words[1]])
    gen.known_until(words[3].start + 0.5)
    with pytest.raises(StreamError, match="known up to"):
        gen.add_words([words[3]])
    with pytest.raises(StreamError, match="unknown style"):
        StreamGenerator(load_runner(None), style={"sped": 1.0})
    with pytest.raises(StreamError, match="from -3"):
        StreamGenerator(load_runner(None), style={"speed": 9})
    with pytest.raises(StreamError, match="0 <= start <= end"):
        gen.add_words([TimedWord("x", 9.0, 8.0)])
    gen.finish()
    with pytest.raises(StreamError, match="ended"):
        gen.known_until(99)
