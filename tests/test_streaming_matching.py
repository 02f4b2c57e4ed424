"""The matching engine as a stream (model/matching_stream.py): the network stream's lookahead,
deterministic takes, styles, held pauses, no jumps at joins, near the offline matching motion;
and `sgt serve --database` reaching it over a real WebSocket."""

from __future__ import annotations

import json

import numpy as np
import pytest
from streams import assert_each_frame_waits_for_its_lookahead

from core.controls import ControlArrays
from core.skeleton import FPS, JOINT_INDEX, N_BONES, positions_from_pose
from core.words import TimedWord
from dsl import compile_text
from model import matching, postprocess
from model.features import silence_features, word_features
from model.matching_stream import MatchingStreamGenerator
from model.streaming import LOOKAHEAD_S, TAIL, StreamError
from sgt_tui.serve.stream import StreamSession

TEXTS = ["Welcome to the mall! The shops are over there, and the food court is upstairs.",
         "Good morning everyone, thank you for coming. Today we talk about the weather and the trains.",
         "Follow me please, the meeting room is just around the corner on the left."]


@pytest.fixture(scope="module")
def db():
    return matching.load()


@pytest.fixture(scope="module")
def sentences():
    return [list(compile_text(f"guide: {t}", timing="estimate").plan.utterances[0].words) for t in TEXTS]


def run(db, words, seed=0, pieces=1, **kw) -> np.ndarray:
    gen = MatchingStreamGenerator(db, seed=seed, **kw)
    groups = np.array_split(np.arange(len(words)), pieces)
    return np.concatenate([gen.add_words([words[i] for i in g]) for g in groups] + [gen.finish()])


def offline(db, words, seed, n) -> np.ndarray:
    """The offline matching engine on the same words (no audio), its take drawn with ``seed``."""
    ids, onsets = word_features(words, n)
    arrays = ControlArrays.empty(n)
    raw = matching.match(db, silence_features(n), ids, onsets, arrays, seed, matching.draw_take(db, seed), None,
                         postprocess.pause_frames(words, n))
    return matching.finish(raw, arrays, words=words)


def mean_angle(a, b) -> float:
    a, b = a.reshape(-1, N_BONES, 3), b.reshape(-1, N_BONES, 3)
    return float(np.degrees(np.arccos(np.clip((a * b).sum(-1), -1, 1))).mean())


def wrist_speed(poses) -> np.ndarray:
    """(T - 1,) mean speed of the two wrists, m/s."""
    x = positions_from_pose(poses)[:, [JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]]]
    return np.linalg.norm(np.diff(x, axis=0), axis=-1).mean(-1) * FPS


def test_each_frame_is_decided_at_the_first_moment_its_lookahead_is_known(db, sentences):
    """As tests/test_streaming.py for the network: a TTS says each word when it starts, time
    advances a frame at a time; each frame comes with the first message after which the speech
    is known LOOKAHEAD_S past it, never before."""
    emitted = assert_each_frame_waits_for_its_lookahead(MatchingStreamGenerator(db, seed=0), sentences[0])
    assert emitted > 40


def test_with_audio_a_frame_waits_for_the_audio_after_it(db, sentences):
    """Words known far ahead decide nothing: a frame waits for LOOKAHEAD_S of audio after it."""
    from model.features import HOP  # lazy: only this test feeds audio

    audio = np.random.default_rng(0).normal(0, 0.1, HOP * 40).astype(np.float32)
    gen = MatchingStreamGenerator(db)
    assert len(gen.add_audio(np.zeros(0, np.float32))) == 0
    assert len(gen.add_words(sentences[0])) == 0
    emitted = 0
    for k in range(1, 40):
        emitted += len(gen.add_audio(audio[(k - 1) * HOP : k * HOP]))
        assert emitted == max(0, k - round(LOOKAHEAD_S * FPS) + 1)


def test_a_frame_does_not_depend_on_words_after_its_lookahead(db, sentences):
    """The search reads only the speech known when a frame is decided: two streams whose words
    differ only after time T agree on every frame decided before T is known, and are the same
    however the words arrive (whole, one by one) and for the same seed."""
    for words in sentences:
        a = run(db, words, seed=3)
        for cut in range(3, len(words)):
            T = words[cut].start
            other = words[:cut] + [TimedWord("banana", w.start + 0.6, w.end + 0.6) for w in words[cut:]]  # a pause at T
            b = run(db, other, seed=3)
            decided = int(np.floor(T * FPS + 1e-6)) - round(LOOKAHEAD_S * FPS) + 1  # frames decided with speech known to T
            assert np.array_equal(a[:decided], b[:decided]) and not np.array_equal(a, b)
    words = sentences[1]
    a = run(db, words, seed=3)
    assert np.array_equal(a, run(db, words, seed=3, pieces=len(words)))  # however the words arrive
    assert np.array_equal(a, run(db, words, seed=3))  # deterministic for a seed
    assert not np.array_equal(a, run(db, words, seed=4))  # another seed, another take
    assert len(a) == int(np.ceil((words[-1].end + TAIL) * FPS - 1e-6))
    assert np.allclose(np.linalg.norm(a.reshape(-1, N_BONES, 3), axis=-1), 1.0, atol=1e-4)


def test_a_speed_style_moves_the_wrists_the_right_way(db, sentences):
    def speed(style):
        return np.mean([wrist_speed(run(db, w, seed=s, style=style)).mean() for w in sentences for s in (0, 1)])

    slow, plain, fast = speed({"speed": -2.0}), speed(None), speed({"speed": 2.0})
    assert slow < 0.5 * plain and fast > 1.5 * plain  # measured: 0.005, 0.17, 0.46 m/s


def test_pauses_are_held(db):
    words = [TimedWord(w, 0.2 + 0.32 * i, 0.2 + 0.32 * i + 0.28) for i, w in enumerate(["so", "here", "we", "are", "today"])]
    words += [TimedWord(w, 4.0 + 0.32 * i, 4.0 + 0.32 * i + 0.28) for i, w in enumerate(["and", "now", "we", "go", "on"])]
    words += [TimedWord(w, 7.5 + 0.32 * i, 7.5 + 0.32 * i + 0.28) for i, w in enumerate(["to", "the", "end", "of", "it"])]
    quiet = postprocess.pause_frames(words, int(words[-1].end * FPS))[1:]
    speaking = ~postprocess.pause_frames(words, len(quiet) + 1)[1:]
    speaking[: int(words[0].start * FPS)] = False
    ratios = []
    for seed in range(4):
        v = wrist_speed(run(db, words, seed=seed))[: len(quiet)]
        ratios.append(v[quiet].mean() / v[speaking].mean())
    assert quiet.sum() > 60 and max(ratios) < 0.2  # measured: at most 0.03


def test_no_bone_jumps_at_segment_joins(db, sentences):
    """The entry cost (pose and velocity), the cross-fade and the causal velocity limit: no bone
    turns faster than the teacher's limit, smoothed or not (without the three: 52-61 degrees a
    frame at joins)."""
    worst = 0.0
    for words in sentences:
        for seed in (0, 1, 2):
            for smoothing in (True, False):
                d = run(db, words, seed=seed, smoothing=smoothing).reshape(-1, N_BONES, 3)
                worst = max(worst, float(np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(-1), -1, 1))).max()))
    assert worst < postprocess.MAX_STEP_DEG  # measured: 22.0 (the limit itself: the takes' own strokes reach it)


def test_the_stream_is_near_the_offline_matching_motion(db, sentences):
    """Mean angle per bone against the offline engine on the same words and seed; another seed's
    offline take is about twice as far (benchmarks/bench_serve.py measures more sentences)."""
    near, far = [], []
    for words in sentences:
        for seed in (0, 1, 2):
            s = run(db, words, seed=seed)
            near.append(mean_angle(s, offline(db, words, seed, len(s))))
            far.append(mean_angle(offline(db, words, seed + 10, len(s)), offline(db, words, seed, len(s))))
    assert np.mean(near) < 10.0 and np.mean(near) < 0.75 * np.mean(far)  # measured: 7.9 and 14.0 degrees


def test_bad_input_is_refused_with_a_reason(db, sentences):
    words = sentences[0]
    gen = MatchingStreamGenerator(db)
    gen.add_words(words[:3])
    with pytest.raises(StreamError, match="before the previous word ends"):
        gen.add_words([words[1]])
    with pytest.raises(StreamError, match="unknown style"):
        MatchingStreamGenerator(db, style={"sped": 1.0})
    gen.finish()
    with pytest.raises(StreamError, match="ended"):
        gen.known_until(99)


def test_a_database_that_cannot_be_read_is_an_error_message_and_the_stream_goes_on(tmp_path, caplog):
    session = StreamSession(None, None, database=str(tmp_path / "none.npz"))
    [reply] = session.handle({"type": "start", "engine": "matching"})
    assert reply["type"] == "error" and "cannot run" in reply["message"]
    # the server's path is for its log, not for the client
    assert "none.npz" not in reply["message"] and "none.npz" in caplog.text
    [reply] = session.handle({"type": "start", "engine": "matching", "seed": 1.5})
    assert reply["type"] == "error" and "seed" in reply["message"]
    session.database = None  # the shipped one
    [ready] = session.handle({"type": "start", "engine": "matching"})
    assert ready["type"] == "ready" and ready["engine"] == "matching"


def test_sgt_serve_database_reaches_the_matching_stream(db, sentences, tmp_path):
    """A real `sgt serve --database` process on loopback: a stream with "engine": "matching" gets
    the frames of that database's stream (not the shipped one's), an unknown engine is an error
    message and the stream goes on."""
    import importlib.util  # lazy: the benchmark's Server helper, as tests/test_serve_process.py loads it
    from pathlib import Path  # lazy: only this test names files

    from websockets.sync.client import connect  # lazy: only this test is a WebSocket client

    root = Path(__file__).resolve().parent.parent
    spec = importlib.util.spec_from_file_location("bench_serve", root / "benchmarks" / "bench_serve.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    # another database: the shipped one with its takes' frames in reverse order
    with np.load(matching.DEFAULT_DB) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["poses"] = arrays["poses"][::-1].copy()
    arrays["frame_style"] = arrays["frame_style"][::-1].copy()
    mine = tmp_path / "mine.npz"
    np.savez(mine, **arrays)
    words = sentences[0]
    with bench.Server("--database", str(mine)) as server, connect(f"ws://127.0.0.1:{server.port}/v1/stream") as ws:
        ws.send(json.dumps({"type": "start", "engine": "matching-ish"}))
        assert "engine" in json.loads(ws.recv())["message"]
        ws.send(json.dumps({"type": "start", "engine": "matching", "seed": 5}))
        ready = json.loads(ws.recv())
        assert ready["engine"] == "matching" and ready["lookahead_s"] == pytest.approx(LOOKAHEAD_S, abs=1e-4)
        ws.send(json.dumps({"type": "words", "words": [w.to_dict(6) for w in words]}))
        ws.send(json.dumps({"type": "end"}))
        frames = []
        while (m := json.loads(ws.recv()))["type"] != "done":
            assert m["type"] == "frames"
            frames.append(np.array(m["poses"]))
    got = np.concatenate(frames)
    words6 = [TimedWord(w.word, round(w.start, 6), round(w.end, 6)) for w in words]
    want = run(matching.load(mine), words6, seed=5)
    assert got.shape == want.shape and np.allclose(got, want, atol=1e-4)
    assert not np.allclose(got, run(db, words6, seed=5), atol=1e-2)  # not the shipped database's


def test_the_matching_stream_runs_without_torch():
    """numpy only on the matching stream's path (torch would cost 1.2-1.7 s of a service's start)."""
    import subprocess  # lazy: only this test starts a process
    import sys  # lazy: the same interpreter
    from pathlib import Path  # lazy: the repository root

    code = ("import sys\n"
            "from model import matching\n"
            "from model.matching_stream import MatchingStreamGenerator\n"
            "g = MatchingStreamGenerator(matching.load(), seed=1)\n"
            "assert len(g.add_words([('hello', 0.1, 0.5), ('there', 0.6, 1.0)])) + len(g.finish()) > 10\n"
            "print('torch' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).resolve().parent.parent, capture_output=True,
                         text=True, timeout=120, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
