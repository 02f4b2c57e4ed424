"""Tests of dsl.speech synthesis (espeak-ng through ctypes)."""

from __future__ import annotations

import re
import subprocess
import sys
import time
import wave
from pathlib import Path

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
    sr, raw, events = _espeak.run_synth("café naïve world", "gmw/en-US", 175, 50)
    assert sr == 22050 and len(raw) > 0
    assert [e.char_index for e in events][:3] == [0, 5, 11]


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
