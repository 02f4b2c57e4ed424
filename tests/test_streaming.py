"""Streaming generation (model/streaming.py): frames decided with a fixed, stated lookahead."""

from __future__ import annotations

import numpy as np
import pytest
from streams import assert_each_frame_waits_for_its_lookahead

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
    emitted = assert_each_frame_waits_for_its_lookahead(StreamGenerator(load_runner(None), seed=0), words)
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


# -- audio ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def speech():
    """Real speech (espeak-ng) of TEXT at the model's rate, with its word timings."""
    from dsl.speech.audio import read_wav, resample_poly
    from model.features import SAMPLE_RATE

    plan = compile_text(TEXT).plan
    u = plan.utterances[0]
    data, rate = read_wav(u.audio_path)
    audio = resample_poly(data[:, 0], SAMPLE_RATE, rate).astype(np.float32)
    shift = u.audio_offset or 0.0  # word times on the audio's clock
    return audio, [TimedWord(w.word, w.start - shift, w.end - shift) for w in u.words]


def stream_audio(audio, words, chunks, seed=1):
    """Feed the audio in ``chunks`` random pieces, each with the words that start in it."""
    from model.features import SAMPLE_RATE

    gen = StreamGenerator(load_runner(None), seed=seed)
    gen.add_audio(np.zeros(0, np.float32))  # audio from the start: no frame is decided without it
    cuts = np.sort(np.random.default_rng(chunks).choice(np.arange(1, len(audio)), chunks - 1, replace=False))
    out, pending = [], list(words)
    for piece_end, piece in zip([*cuts, len(audio)], np.split(audio, cuts)):
        t = piece_end / SAMPLE_RATE
        starting = [w for w in pending if w.start < t]
        pending = pending[len(starting):]
        if starting:
            out.append(gen.add_words(starting))
        out.append(gen.add_audio(piece))
        out.append(gen.known_until(t))
        assert sum(map(len, out)) <= int(t * FPS)  # never ahead of the audio
    out.append(gen.finish())
    return np.concatenate(out), gen


def test_audio_chunks_give_the_same_frames_however_they_are_cut(speech):
    audio, words = speech
    one, gen = stream_audio(audio, words, 1)
    many, _ = stream_audio(audio, words, 37)
    assert np.array_equal(one, many)
    # the features are the offline features of the whole audio (the utterance is shorter than
    # the level window, so the speech level is the same)
    from model.features import audio_features

    n = len(gen.powers)
    assert np.allclose(gen._audio_features(0, n), audio_features(audio, n), atol=1e-6)
    # and the audio is used: the words alone give other motion
    words_only, _ = stream(words, 1, seed=1)
    assert not np.allclose(one[: len(words_only)], words_only[: len(one)], atol=1e-3)


def test_with_audio_a_frame_waits_for_the_audio_after_it(speech):
    """Words known far ahead do not decide a frame: it waits for LOOKAHEAD_S of audio after it."""
    from model.features import HOP

    audio, words = speech
    gen = StreamGenerator(load_runner(None))
    assert len(gen.add_audio(np.zeros(0, np.float32))) == 0
    assert len(gen.add_words(words)) == 0  # every word known, no audio yet: nothing decided
    emitted = 0
    for k in range(1, 40):
        emitted += len(gen.add_audio(audio[(k - 1) * HOP : k * HOP]))
        # the audio is known up to k / FPS s; frame f is decided once it is known LOOKAHEAD_S past f / FPS
        assert emitted == max(0, k - round(LOOKAHEAD_S * FPS) + 1)
    with pytest.raises(StreamError, match="not numbers"):
        gen.add_audio(np.array([np.nan], np.float32))


def test_the_stream_holds_a_take_posture_that_gives_way_to_the_clients_space_and_handedness(words):
    """model/take_posture.py in the stream, as offline."""
    runner = load_runner(None)
    assert runner.takes is not None

    class Plain:  # the same network without takes
        noise_dim, takes = runner.noise_dim, None
        run_window = staticmethod(runner.run_window)

    def run(r, seed, **kw):
        gen = StreamGenerator(r, seed=seed, **kw)
        return np.concatenate([gen.add_words(words), gen.finish()])

    for seed in (2, 5):
        with_take, without = run(runner, seed), run(Plain, seed)
        assert np.abs(with_take.mean(0) - without.mean(0)).max() > 0.05  # the posture moves the take
        assert np.allclose(np.linalg.norm(with_take.reshape(-1, N_BONES, 3), axis=-1), 1.0, atol=1e-4)
        for style in ({"space": 1.0}, {"handedness": -0.5}):  # asked for: the network alone
            assert np.array_equal(run(runner, seed, style=style), run(Plain, seed, style=style))
        assert not np.array_equal(run(runner, seed, style={"speed": 1.0}), run(Plain, seed, style={"speed": 1.0}))


def test_the_stream_holds_pauses_as_the_offline_engine_does(monkeypatch):
    """model/postprocess.calm_pauses in the stream: the same hold on the same frames, whether the
    words come at once or one by one; after the last word it holds on to the end."""
    from model import streaming

    words = [TimedWord("so", 0.2, 0.5), TimedWord("here", 0.55, 0.9), TimedWord("we", 2.9, 3.1),
             TimedWord("go", 3.2, 3.6), TimedWord("now", 3.7, 4.0), TimedWord("again", 5.1, 5.6)]

    def run(pieces):
        gen = StreamGenerator(load_runner(None), seed=4)
        groups = np.array_split(np.arange(len(words)), pieces)
        out = [gen.add_words([(words[i].word, words[i].start, words[i].end) for i in group]) for group in groups]
        return np.concatenate(out + [gen.finish()])

    held = run(1)
    assert np.array_equal(held, run(len(words)))  # the hold does not depend on how the words arrive
    monkeypatch.setattr(streaming, "hold_pose", lambda poses, target, weight: poses)
    unheld = run(1)
    offline = postprocess.calm_pauses(unheld, words)  # pauses 0.9-2.9 s and 4.0-5.1 s
    last = int(np.floor(words[-1].end * FPS)) + 1
    assert np.array_equal(held[:last], offline[:last])
    quiet = postprocess.pause_frames(words, len(unheld))
    assert quiet.sum() > 40 and not np.array_equal(held[quiet], unheld[quiet])
    # after the last word the stream does not know that no word follows: it holds on, towards
    # the pose it paused in (the offline engine, knowing the speech has ended, does not)
    assert np.array_equal(offline[last:], unheld[last:]) and not np.array_equal(held[last:], unheld[last:])
    paused_in = unheld[last - 1]
    assert np.abs(held[-1] - paused_in).sum() < 0.6 * np.abs(unheld[-1] - paused_in).sum()


def test_the_stream_adds_the_takes_drift_on_its_own_clock_and_drops_it_for_a_slower_speed():
    """The drawn take's drift in the stream: frame f gets the drift at clock f while no pause
    intervenes (a constant network makes it visible), none when the client asks for a slower
    speed; a faster speed keeps it."""
    from core.skeleton import REST_POSE, normalize_pose
    from model import take_posture

    rng = np.random.default_rng(3)
    takes = take_posture.Takes(rng.uniform(-0.05, 0.05, (3, 27)).astype(np.float32),
                               tuple(rng.uniform(-0.15, 0.15, (12, 27)).astype(np.float32) for _ in range(3)))

    class Constant:  # the network holds the rest pose whatever it hears
        noise_dim = 16

        def __init__(self, with_takes):
            self.takes = takes if with_takes else None

        def run_window(self, audio, ids, onsets, pose, pose_mask, style, style_mask, z):
            return np.repeat(np.asarray(REST_POSE, np.float32)[None], len(audio), 0)

    words = [(w, 0.3 * i, 0.3 * i + 0.28) for i, w in enumerate("one two three four five six seven eight".split())]

    def run(with_takes=True, **kw):
        gen = StreamGenerator(Constant(with_takes), seed=5, smoothing=False, **kw)
        return np.concatenate([gen.add_words(words), gen.finish()])

    out = run()
    take = take_posture.draw(takes, 5)
    n = int(round(words[-1][2] * FPS))  # up to the last word: no pause yet
    want = normalize_pose(np.asarray(REST_POSE, np.float32) + take.posture + take.drift_at(np.arange(n)))
    assert np.allclose(out[:n], want, atol=1e-5)
    assert np.abs(np.diff(out[:n], axis=0)).max() > 1e-3  # it moves
    slow = run(style={"speed": -1.0})
    assert np.allclose(slow[:n], normalize_pose(np.asarray(REST_POSE, np.float32) + take.posture), atol=1e-5)
    assert np.allclose(run(style={"speed": 1.0})[:n], want, atol=1e-5)


def test_the_streams_drift_stands_still_after_the_last_word_once_it_finishes(monkeypatch):
    """After the last word the stream holds (docs/serve.md); its drift clock stands still too."""
    from model import take_posture

    seen = []
    original = take_posture.with_posture

    def spy(poses, take, weight=None, frames=None, drift_weight=None):
        seen.append(np.asarray(frames).copy())
        return original(poses, take, weight, frames, drift_weight)

    monkeypatch.setattr(take_posture, "with_posture", spy)
    gen = StreamGenerator(load_runner(None), seed=1)
    gen.add_words([("one", 0.1, 0.4), ("two", 0.5, 0.8)])
    gen.finish()
    clock = np.concatenate(seen)
    last = int(np.floor(0.8 * FPS)) + 1  # the first frame after the last word
    assert len(clock) > last + 5 and np.all(np.diff(clock[:last]) == 1)
    assert np.all(clock[last:] == clock[last])  # still while the stream holds its tail
