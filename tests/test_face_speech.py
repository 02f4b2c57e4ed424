"""Phoneme timing for the face (issue 25): espeak-ng's phoneme events carried through the
speech result, its cache and the plan; a recording's phonemes from espeak-ng's dictionary."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from dsl.compiler import compile_text
from dsl.speech import _espeak, synthesize
from dsl.speech.synth import is_vowel, phonemes_of_words
from dsl.speech.types import TimedPhoneme

pytestmark = pytest.mark.skipif(_espeak.find_library() is None, reason="libespeak-ng not installed")


def spans_of(text: str) -> list[tuple[int, int]]:
    return [m.span() for m in re.finditer(r"[\w'\-]+", text)]


def test_phoneme_events_are_the_engines_to_the_sample(tmp_path):
    text = "Maybe a bubble will pop, but not today."
    s = synthesize(text, spans_of(text), cache_dir=tmp_path)
    sr, _, _, events = _espeak.run_synth(text, "gmw/en-US", 175, 50)
    named = [e for e in events if e.name]
    assert [p.phoneme for p in s.phonemes] == [e.name for e in named]
    # the same times, but for the lead-in's shift: within one sample of each other
    rel_p = np.array([p.start for p in s.phonemes]) - s.phonemes[0].start
    rel_e = np.array([e.sample for e in named]) / sr - named[0].sample / sr
    assert np.abs(rel_p - rel_e).max() < 1.5 / sr
    # in order, each where the next starts (or a pause), inside the audio and its words
    for a, b in zip(s.phonemes, s.phonemes[1:]):
        assert a.start <= a.end <= b.start + 1e-9
    assert s.words[0].start - 0.05 <= s.phonemes[0].start and s.phonemes[-1].end <= s.duration
    stressed = [p for p in s.phonemes if p.stress]
    assert stressed and all(is_vowel(p.phoneme) for p in stressed)
    assert {p.phoneme for p in s.phonemes} >= {"m", "b", "p"}


def test_a_pause_moves_the_phonemes_after_it(tmp_path):
    text = "I think that we should go now."
    spans = spans_of(text)
    base = synthesize(text, spans, cache_dir=tmp_path)
    paused = synthesize(text, spans, [(text.index("that"), 0.7)], cache_dir=tmp_path)
    that = paused.words[2].start
    before = [p for p in paused.phonemes if p.start < that]
    after = [p for p in paused.phonemes if p.start >= that]
    assert before and after and after[0].start - before[-1].end >= 0.69  # no phoneme in the silence
    assert before[-1].end <= paused.words[1].end + 0.02  # "think" ends before the pause
    # the phonemes after it are the same ones, all moved by one shift (to a frame): the pause
    # plus espeak-ng's lengthening of the word before a phrase break ("think", about 0.1 s)
    tail = [p for p in base.phonemes if p.start >= base.words[2].start]
    assert [p.phoneme for p in tail] == [p.phoneme for p in after]
    shifts = np.array([b.start - a.start for a, b in zip(tail, after)])
    assert 0.7 - 1e-3 <= shifts.min() and shifts.max() - shifts.min() < 1 / 15
    assert shifts.mean() - 0.7 == pytest.approx(paused.words[1].end - base.words[1].end, abs=1 / 15)


def test_the_cache_keeps_the_phonemes(tmp_path, monkeypatch):
    text = "Keep my phonemes, please."
    first = synthesize(text, spans_of(text), cache_dir=tmp_path)

    def boom(*a, **k):
        raise AssertionError("engine called on a cache hit")

    monkeypatch.setattr(_espeak, "run_synth", boom)
    again = synthesize(text, spans_of(text), cache_dir=tmp_path)
    assert again == first and again.phonemes == first.phonemes and first.phonemes


def test_the_plan_carries_the_phonemes_on_the_utterance_clock(tmp_path):
    result = compile_text("guide: [pose:wave] Hello, maybe a bubble?\n", cache_dir=tmp_path)
    u = result.plan.utterances[0]
    assert u.lead_in > 0 and u.phonemes
    # the lead-in is added to the phonemes as to the words
    assert u.phonemes[0].start >= u.lead_in and abs(u.phonemes[0].start - u.words[0].start) < 0.05
    entry = json.loads(result.plan.to_json())["utterances"][0]["phonemes"]
    assert entry[0] == ["h", round(u.phonemes[0].start, 3), round(u.phonemes[0].end, 3)]
    assert any(name.startswith("\u02c8") for name, _, _ in entry)  # the stress mark on the stressed vowel
    estimate = compile_text("guide: Hello.\n", timing="estimate").plan.utterances[0]
    assert estimate.phonemes == [] and json.loads(compile_text("guide: Hello.\n", timing="estimate").plan.to_json())[
        "utterances"][0]["phonemes"] == []


def test_a_recordings_phonemes_come_from_the_dictionary_over_its_words(tmp_path):
    text = "Bring me the blue box."
    spoken = synthesize(text, spans_of(text), cache_dir=tmp_path / "cache")
    (tmp_path / "rec.wav").write_bytes(spoken.audio_path.read_bytes())
    (tmp_path / "rec.json").write_text(json.dumps([w._asdict() for w in spoken.words]))
    script = tmp_path / "s.sgt"
    result = compile_text(f"@audio rec.wav timings=rec.json\nguide: {text}\n", path=script, cache_dir=tmp_path / "cache")
    assert result.ok, [d.message for d in result.diagnostics]
    u = result.plan.utterances[0]
    for w in u.words:
        mine = [p for p in u.phonemes if w.start - 1e-9 <= p.start < w.end]
        assert mine and abs(mine[0].start - w.start) < 1e-9 and abs(mine[-1].end - w.end) < 1e-9, w
    assert [p.phoneme for p in u.phonemes][:3] == ["b", "ɹ", "ɪ"]
    assert sum(p.stress == 2 for p in u.phonemes) >= 3  # bring, blue, box


def test_phonemes_of_words_spread_vowels_longer_and_never_raise():
    from core.words import TimedWord

    got = phonemes_of_words([TimedWord("map", 1.0, 1.4)], "en-us")
    assert [p.phoneme for p in got] == ["m", "æ", "p"] and got[1].stress == 2
    assert got[0].start == 1.0 and abs(got[-1].end - 1.4) < 1e-9
    assert got[1].end - got[1].start > 2 * (got[0].end - got[0].start)  # a stressed vowel: 3 shares to 1
    assert phonemes_of_words([TimedWord("map", 1.0, 1.4)], "no-such-voice") == []


def test_a_recordings_words_reach_espeak_in_a_worker_not_in_this_process(monkeypatch):
    """A transcript's words are script text: translated in the worker that synthesizes (a crash
    there is an error, not the death of `sgt serve`), never by this process's engine."""
    from core.words import TimedWord

    def in_process(*_):
        raise AssertionError("text_to_phonemes ran in this process")

    monkeypatch.setattr(_espeak._Engine, "text_to_phonemes", in_process)
    got = phonemes_of_words([TimedWord("bubble", 0.0, 0.5)], "en-us")
    assert [p.phoneme for p in got][:2] == ["b", "ʌ"]
    monkeypatch.setattr(_espeak, "_ask", lambda *a: _espeak._answer(_espeak.EngineError("crash", "killed"), b""))
    assert phonemes_of_words([TimedWord("bubble", 0.0, 0.5)], "en-us") == []  # a dead worker: no phonemes


def test_timed_phoneme_lists_write_the_stress_mark():
    assert TimedPhoneme("oʊ", 0.12345, 0.5, 2).to_list() == ["\u02c8oʊ", 0.123, 0.5]
    assert TimedPhoneme("ə", 0, 1, 1).to_list() == ["\u02ccə", 0, 1]
    assert TimedPhoneme("h", 0, 1).shifted(0.5) == TimedPhoneme("h", 0.5, 1.5)
