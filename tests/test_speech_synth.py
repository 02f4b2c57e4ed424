"""Tests of dsl.speech synthesis (espeak-ng through ctypes)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import wave
from pathlib import Path

import numpy as np
import pytest

from dsl import speech
from dsl.speech import Speech, SpeechError, _espeak, synthesize

pytestmark = pytest.mark.skipif(_espeak.find_library() is None, reason="libespeak-ng not installed")

FRAME = 1 / 15  # core.skeleton.FPS


def spans_of(text: str) -> list[tuple[int, int]]:
    return [m.span() for m in re.finditer(r"[\w'\-]+", text)]


def check_invariants(s: Speech, text: str, spans) -> None:
    assert len(s.words) == len(spans)
    assert [w.word for w in s.words] == [text[a:b] for a, b in spans]
    prev = 0.0
    for w in s.words:
        assert 0.0 <= w.start <= w.end <= s.duration + 1e-9
        assert w.start >= prev
        prev = w.start
    with wave.open(str(s.audio_path)) as wf:
        assert wf.getnchannels() == 1 and wf.getsampwidth() == 2
        assert wf.getframerate() == s.sample_rate
        assert abs(wf.getnframes() / s.sample_rate - s.duration) < 1e-6


def test_sentence_times_increase_and_fit(tmp_path):
    text = "The quick brown fox jumps over the lazy dog."
    spans = spans_of(text)
    s = synthesize(text, spans, cache_dir=tmp_path)
    check_invariants(s, text, spans)
    assert s.source == "espeak-ng" and s.sample_rate == 22050
    starts = [w.start for w in s.words]
    assert all(b > a for a, b in zip(starts, starts[1:])), starts  # every word gets its own time
    assert starts[0] <= 0.05  # lead-in
    assert 1.5 < s.duration < 4.0
    assert s.words[-1].end < s.duration  # trailing silence kept, not counted as speech


def test_merged_words_numbers_contractions(tmp_path):
    text = "She sat in the garden in 1999, and I don't know why."
    spans = spans_of(text)
    s = synthesize(text, spans, cache_dir=tmp_path)
    check_invariants(s, text, spans)
    w = {x.word: x for x in s.words}
    starts = [x.start for x in s.words]
    assert all(b > a for a, b in zip(starts, starts[1:])), starts
    # "1999" is read as several engine words: it must take a long time, and "and" comes after
    assert w["1999"].end - w["1999"].start > 0.6
    assert w["don't"].end - w["don't"].start > 0.1


def test_non_ascii_positions(tmp_path):
    text = "Un café naïve, très «bien» déjà vu & <ok>."
    spans = spans_of(text)
    s = synthesize(text, spans, cache_dir=tmp_path)
    check_invariants(s, text, spans)
    starts = [x.start for x in s.words]
    assert all(b > a for a, b in zip(starts, starts[1:])), starts


def test_event_positions_are_characters():
    # "é" is two UTF-8 bytes; if positions were bytes, the second word would be off by one
    sr, raw, events, phonemes = _espeak.run_synth("café naïve world", "gmw/en-US", 175, 50)
    assert sr == 22050 and len(raw) > 0
    assert [e.char_index for e in events][:3] == [0, 5, 11]
    assert sorted({p.char_index for p in phonemes if p.name}) == [0, 5, 11]  # each phoneme names its word's start


def test_pause_lengthens_and_shifts(tmp_path):
    text = "I think, that we should go now."
    spans = spans_of(text)
    base = synthesize(text, spans, cache_dir=tmp_path)
    off = text.index("that")
    p = synthesize(text, spans, [(off, 0.7)], cache_dir=tmp_path)
    check_invariants(p, text, spans)
    assert abs((p.duration - base.duration) - 0.7) < FRAME
    for a, b in zip(base.words, p.words):
        if a.word in ("I", "think"):
            assert abs(a.start - b.start) < 1e-3
        else:
            assert abs((b.start - a.start) - 0.7) < FRAME
    # the word before the pause ends before the silence, not at the next word
    think = p.words[1]
    assert p.words[2].start - think.end >= 0.7


def test_leading_and_trailing_pause(tmp_path):
    text = "Hello there."
    spans = spans_of(text)
    base = synthesize(text, spans, cache_dir=tmp_path)
    p = synthesize(text, spans, [(0, 0.5), (len(text), 0.25)], cache_dir=tmp_path)
    assert abs(p.duration - base.duration - 0.75) < 1e-3
    assert abs(p.words[0].start - base.words[0].start - 0.5) < 1e-3


def test_deterministic_across_processes(tmp_path):
    text = "Determinism matters: same input, same bytes."
    spans = spans_of(text)
    a = synthesize(text, spans, cache_dir=tmp_path / "a")
    b = synthesize(text, spans, cache_dir=tmp_path / "b")
    assert a.audio_path.read_bytes() == b.audio_path.read_bytes()
    assert a.words == b.words and a.duration == b.duration
    # and in a fresh interpreter (the engine keeps state between calls in one process)
    code = (
        "import sys, re; from pathlib import Path; from dsl.speech import synthesize;"
        f"t={text!r}; s=synthesize(t,[m.span() for m in re.finditer(r\"[\\w'\\-]+\",t)],cache_dir=Path(sys.argv[1]));"
        "print(repr([(w.start,w.end) for w in s.words]))"
    )
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "c")], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == repr([(w.start, w.end) for w in a.words])
    assert (tmp_path / "c" / a.audio_path.name).read_bytes() == a.audio_path.read_bytes()


def test_parameters_change_result(tmp_path):
    text = "Speak faster please."
    spans = spans_of(text)
    slow = synthesize(text, spans, rate=120, cache_dir=tmp_path)
    fast = synthesize(text, spans, rate=300, cache_dir=tmp_path)
    assert fast.duration < slow.duration * 0.75
    assert fast.audio_path != slow.audio_path


def test_cache_hit_skips_engine(tmp_path, monkeypatch):
    text = "Cache me if you can."
    spans = spans_of(text)
    first = synthesize(text, spans, [(6, 0.3)], cache_dir=tmp_path)

    def boom(*a, **k):
        raise AssertionError("engine called on a cache hit")

    monkeypatch.setattr(_espeak, "run_synth", boom)
    monkeypatch.setattr(_espeak, "engine", boom)
    t = time.perf_counter()
    second = synthesize(text, spans, [(6, 0.3)], cache_dir=tmp_path)
    assert time.perf_counter() - t < 0.05
    assert second == first
    # a different input is a miss and does reach the engine
    with pytest.raises(AssertionError, match="engine called"):
        synthesize(text, spans, [(6, 0.4)], cache_dir=tmp_path)


def test_a_short_cached_wav_is_a_miss_and_is_made_again(tmp_path):
    """Speech cache entries are written without fsync (a crash of the machine can leave a WAV
    short while its JSON survives): the JSON records the WAV's size, and a WAV of another size
    is a miss, synthesized again, never read as speech."""
    text = "Cache me if you can."
    spans = spans_of(text)
    first = synthesize(text, spans, cache_dir=tmp_path)
    wav = Path(first.audio_path)
    whole = wav.read_bytes()
    wav.write_bytes(whole[: len(whole) // 2])
    again = synthesize(text, spans, cache_dir=tmp_path)
    assert again == first and wav.read_bytes() == whole


def test_default_cache_dir_env(monkeypatch, tmp_path):
    """SGT_CACHE_DIR, else XDG_CACHE_HOME (absolute only, as the XDG spec says), else ~/.cache."""
    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "x"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert speech.default_cache_dir() == tmp_path / "x" / "speech"
    monkeypatch.delenv("SGT_CACHE_DIR")
    assert speech.default_cache_dir() == tmp_path / "xdg" / "sgt" / "speech"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/dir")
    assert speech.default_cache_dir().parts[-3:] == (".cache", "sgt", "speech")
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert speech.default_cache_dir() == Path.home() / ".cache" / "sgt" / "speech"


def test_unknown_voice_suggests(tmp_path):
    assert "en-us" in speech.list_voices()
    with pytest.raises(SpeechError) as ei:
        synthesize("Hi there.", [(0, 2), (3, 8)], voice="en-uss", cache_dir=tmp_path)
    assert "en-us" in ei.value.message and "did you mean" in ei.value.message
    s = synthesize("Hi there.", [(0, 2), (3, 8)], voice="en-us+f3", cache_dir=tmp_path)
    assert len(s.words) == 2


def test_bad_arguments(tmp_path):
    with pytest.raises(SpeechError):
        synthesize("Hi", [(0, 5)], cache_dir=tmp_path)
    with pytest.raises(SpeechError):
        synthesize("Hi", [(0, 2)], rate=20, cache_dir=tmp_path)
    with pytest.raises(SpeechError):
        synthesize("Hi", [(0, 2)], [(1, -1.0)], cache_dir=tmp_path)


def test_missing_library_message(monkeypatch):
    monkeypatch.setattr(_espeak, "LIBRARY_NAME", "libespeak-ng-does-not-exist.so.9")
    monkeypatch.setattr(_espeak, "_engine", None)
    with pytest.raises(_espeak.EngineError) as ei:
        _espeak.engine()
    assert "apt-get install espeak-ng" in ei.value.message


def test_import_is_cheap():
    """Importing the package loads neither the espeak-ng library nor soundfile or pocketsphinx."""
    code = ("import sys, dsl.speech; maps = open('/proc/self/maps').read(); "
            "print('espeak' in maps, 'soundfile' in sys.modules, 'pocketsphinx' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False", "False"]
    loaded = subprocess.run([sys.executable, "-c", "from dsl.speech import _espeak; _espeak.engine(); "
                             "print('espeak' in open('/proc/self/maps').read())"], capture_output=True, text=True)
    assert loaded.stdout.split() == ["True"], loaded.stderr  # the check above can see a loaded library


def _offsets(x, sr, t0, t1):
    """End (s) of the last 10 ms window in [t0, t1] above -40 dB of the loudest one: where the
    audio of a word spoken from t0 on, before t1, ends (computed here, not with dsl.speech.audio)."""
    win, hop = int(0.01 * sr), int(0.0025 * sr)
    frames = np.lib.stride_tricks.sliding_window_view(np.asarray(x, float), win)[::hop]
    db = 10 * np.log10(np.maximum((frames * frames).mean(axis=1), 1e-20))
    db -= db.max()
    first, last = int(np.ceil(t0 * sr / hop)), int((t1 * sr - win) // hop)
    loud = np.flatnonzero(db[first:last + 1] > -40)
    return None if len(loud) == 0 else ((first + loud[-1]) * hop + win) / sr


def _samples(s):
    with wave.open(str(s.audio_path)) as wf:
        return np.frombuffer(wf.readframes(wf.getnframes()), "<i2").astype(float)


@pytest.mark.parametrize("rate", [80, 160, 300])
def test_a_word_ends_where_its_audio_ends(tmp_path, rate):
    """Issue 10: 'friend' ended at the next sentence's first word (338 ms late at @rate 160)."""
    text = "Well, hello there my friend. How are you today?"
    spans = spans_of(text)
    s = synthesize(text, spans, rate=rate, cache_dir=tmp_path)
    x = _samples(s)
    errors = []
    for k, w in enumerate(s.words):
        t1 = s.words[k + 1].start if k + 1 < len(s.words) else s.duration
        off = _offsets(x, s.sample_rate, w.start, t1)
        if off is not None:
            errors.append(abs(w.end - off))
    assert np.median(errors) < 0.04 and max(errors) < 1 / 15, errors
    friend, how = s.words[4], s.words[5]
    assert how.start - friend.end > 0.05  # the sentence break is silence, not part of 'friend'


def test_a_pause_inside_a_clause_goes_between_words(tmp_path):
    """Issue 10: a mid-clause [pause] cut into the word before it, whose end played after the silence."""
    text = "I think that we should go now."
    spans = spans_of(text)
    s = synthesize(text, spans, [(text.index("that"), 0.5)], cache_dir=tmp_path)
    check_invariants(s, text, spans)
    x, sr = _samples(s), s.sample_rate
    that = s.words[2]
    zeros = np.flatnonzero(x[: int(that.start * sr)] == 0)
    runs = np.split(zeros, np.flatnonzero(np.diff(zeros) > 1) + 1)
    silence = max(runs, key=len)
    assert len(silence) >= int(0.5 * sr) - 1
    assert s.words[1].end <= silence[0] / sr + 0.005  # 'think' is over before the silence (5 ms frames)
    after = x[silence[-1] + 1: int(that.start * sr)]  # between the silence and 'that'
    loudest = np.sqrt(np.max(np.lib.stride_tricks.sliding_window_view(x * x, int(0.01 * sr)).mean(axis=1)))
    assert len(after) == 0 or np.sqrt((after * after).mean()) < loudest * 0.01, len(after) / sr
    # the words before the pause are those of the clause alone, to the end of 'think'
    alone = synthesize("I think,", spans_of("I think,"), cache_dir=tmp_path)
    y = _samples(alone)
    end = int(s.words[1].end * sr)
    assert np.array_equal(x[:end], y[:end])


FORK_CASES = [("Tower market bread coins sword shield lantern.", "en-us", 175, 50),
              ("café naïve world", "gmw/en-US", 200, 60), ("Hello there, friend! How are you?", "en-us+m3", 150, 40)]


def _fresh(text, voice, rate, pitch):
    request = json.dumps({"text": text, "voice": voice, "rate": rate, "pitch": pitch}).encode("utf-8")
    return _espeak._parse_answer(_espeak._run_fresh(request, 60), "")


def test_the_fork_server_answers_as_a_fresh_process_would():
    """Each synthesis by a child of the fork server is the same bits as the first synthesis of
    a new process, however many came before it (the engine keeps state between syntheses in
    one process: a server that synthesized itself would drift)."""
    for case in FORK_CASES + FORK_CASES:
        assert _espeak.run_synth(*case) == _fresh(*case)
    server = _espeak._fork_server()
    assert server is not None and server.proc.poll() is None and server is _espeak._fork_server()
    with pytest.raises(_espeak.EngineError) as ei:
        _espeak.run_synth("x", "no-such-voice", 175, 50)
    assert ei.value.kind == "voice" and server.proc.poll() is None


def test_a_dead_or_busy_fork_server_is_not_a_failure():
    case = FORK_CASES[0]
    server = _espeak._fork_server()
    os.kill(server.proc.pid, signal.SIGKILL)
    server.proc.wait()
    assert _espeak.run_synth(*case) == _fresh(*case)  # a new server
    assert _espeak._fork_server() is not server and _espeak._fork_server().proc.poll() is None
    busy = _espeak._fork_server()
    with busy.lock:  # another thread's request: this one goes to a process of its own
        assert _espeak.run_synth(*case) == _fresh(*case)


def test_the_fork_server_ends_with_its_client():
    code = ("from dsl.speech import _espeak; _espeak.run_synth('hello', 'en-us', 175, 50); "
            "print(_espeak._fork_server().proc.pid, flush=True); import time; time.sleep(60)")
    client = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        pid = int(client.stdout.readline())
        os.kill(pid, 0)  # running
        client.kill()
        client.wait()
        for _ in range(100):
            if not _running(pid):
                break
            time.sleep(0.05)
        else:
            pytest.fail("the fork server outlived its killed client")
    finally:
        client.kill()
        client.stdout.close()


def _running(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, ended but not yet reaped by whoever adopted it, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


HOSTILE_VARIANTS = ["a" * 40, "../../../../../../etc/passwd", "/etc/passwd", "zz9", "m3/../../../../etc/passwd", "m3\x00"]


@pytest.mark.parametrize("variant", HOSTILE_VARIANTS)
def test_a_variant_is_an_installed_name_or_nothing_reaches_espeak(variant, capfd):
    """espeak-ng opens whatever file a variant names (and printed /etc/passwd line by line) and
    overflows a buffer on a long one (glibc aborted the process): the engine's own guard lets
    only installed voices and variants through, in this process, the fork server and a fresh one."""
    eng = _espeak.engine()
    identifier = next(v.identifier for v in eng.voices() if v.languages and v.languages[0] == "en-us")
    assert "m3" in eng.variants() and "f2" in eng.variants()
    assert eng.set_voice(f"{identifier}+m3")
    assert not eng.set_voice(f"{identifier}+{variant}")
    for ask in (_espeak.run_synth, lambda *a: _espeak._parse_answer(_espeak._run_fresh(json.dumps(dict(zip(
            ("text", "voice", "rate", "pitch"), a))).encode(), 60), "")):
        with pytest.raises(_espeak.EngineError) as ei:
            ask("hello", f"{identifier}+{variant}", 175, 50)
        assert ei.value.kind == "voice" and "root:" not in ei.value.message
    with pytest.raises(SpeechError) as ei:
        speech.synth.check_voice(f"en-us+{variant}")
    assert ei.value.kind == "voice" and "root:" not in ei.value.message
    assert "Bad voice attribute" not in capfd.readouterr().err


def test_variants_resolve_case_blind_and_long_names_are_refused(tmp_path):
    assert speech.synth.check_voice("en-us+M3").endswith("+m3")
    with pytest.raises(SpeechError, match="at most 64"):
        speech.synth.check_voice("en-us" + "x" * 100)
    with pytest.raises(SpeechError) as ei:
        speech.synth.check_voice("en-us+m33")
    assert ei.value.reason == "voice variant" and "'m3'" in ei.value.message
    assert "m3" in speech.synth.list_variants()


def test_a_synthesis_that_dies_is_a_crash_not_a_voice_problem(monkeypatch):
    """The fork server's child killed by a signal: EngineError kind "crash", which the compiler
    reports as SGT408 and the service answers with 500 (tests/test_serve_process.py)."""
    assert _espeak._died(signal.SIGKILL) == "espeak-ng was killed by SIGKILL"
    assert _espeak._died(signal.SIGABRT) == "espeak-ng was killed by SIGABRT"
    assert _espeak._died(3 << 8) == "espeak-ng exited with status 3"
    monkeypatch.setattr(_espeak, "_fork_server", lambda: None)  # a fresh process, killed by its own request
    monkeypatch.setattr(_espeak, "__file__", str(Path(__file__).parent / "no_such_worker.py"))
    with pytest.raises(_espeak.EngineError) as ei:
        _espeak.run_synth("hello", "gmw/en-US", 175, 50)
    assert ei.value.kind == "crash"
