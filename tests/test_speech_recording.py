"""Tests of dsl.speech recorded-speech loading: timings files, matching, alignment, pauses."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import soundfile as sf

from dsl.speech import SpeechError, _espeak, load_recording, synthesize

needs_espeak = pytest.mark.skipif(_espeak.find_library() is None, reason="libespeak-ng not installed")

TEXT = "Well, hello there my friend."
WORDS = [("Well", 0.10, 0.40), ("hello", 0.55, 0.90), ("there", 0.90, 1.20), ("my", 1.25, 1.40),
         ("friend", 1.40, 1.90)]


def spans_of(text: str) -> list[tuple[int, int]]:
    return [m.span() for m in re.finditer(r"[\w'’\-]+", text)]


def tone_wav(path, seconds=2.2, sr=16000, channels=1):
    t = np.arange(int(seconds * sr)) / sr
    x = 0.3 * np.sin(2 * np.pi * 220 * t)
    data = np.stack([x] * channels, axis=1) if channels > 1 else x
    sf.write(str(path), data, sr)
    return path


def long_textgrid(words, xmax=2.2, extra_tier=True):
    intervals = []
    t = 0.0
    for w, a, b in words:
        if a > t:
            intervals.append((t, a, ""))
        intervals.append((a, b, w))
        t = b
    intervals.append((t, xmax, "sil"))
    lines = ['File type = "ooTextFile"', 'Object class = "TextGrid"', "", "xmin = 0", f"xmax = {xmax}",
             "tiers? <exists>", f"size = {2 if extra_tier else 1}", "item []:"]
    tiers = []
    if extra_tier:
        tiers.append(("phones", [(0.0, xmax, "AH")]))
    tiers.append(("words", intervals))
    for i, (name, ivs) in enumerate(tiers, 1):
        lines += [f"    item [{i}]:", '        class = "IntervalTier"', f'        name = "{name}"',
                  "        xmin = 0", f"        xmax = {xmax}", f"        intervals: size = {len(ivs)}"]
        for j, (a, b, w) in enumerate(ivs, 1):
            lines += [f"        intervals [{j}]:", f"            xmin = {a}", f"            xmax = {b}",
                      f'            text = "{w}"']
    return "\n".join(lines) + "\n"


def short_textgrid(words, xmax=2.2):
    ivs = [(a, b, w) for w, a, b in words]
    out = ['File type = "ooTextFile"', 'Object class = "TextGrid"', "", "0", f"{xmax}", "<exists>", "1",
           '"IntervalTier"', '"Word"', "0", f"{xmax}", str(len(ivs) + 1), "0", str(ivs[0][0]), '""']
    for a, b, w in ivs:
        out += [str(a), str(b), f'"{w}"']
    return "\n".join(out) + "\n"


def test_textgrid_long_format(tmp_path):
    audio = tone_wav(tmp_path / "a.wav")
    tg = tmp_path / "a.TextGrid"
    tg.write_text(long_textgrid(WORDS), encoding="utf-8")
    s = load_recording(audio, TEXT, spans_of(TEXT), timings_path=tg, cache_dir=tmp_path / "c")
    assert s.source == "textgrid"
    assert [(w.word, w.start, w.end) for w in s.words] == WORDS
    assert s.audio_path == audio and s.sample_rate == 16000 and abs(s.duration - 2.2) < 1e-9


def test_textgrid_short_format_utf16_quotes(tmp_path):
    words = [("Say", 0.1, 0.3), ('"hi"', 0.3, 0.6), ("café", 0.6, 1.0)]
    text = 'Say "hi" café!'
    audio = tone_wav(tmp_path / "a.wav", seconds=1.2)
    tg = tmp_path / "a.TextGrid"
    content = short_textgrid([(w.replace('"', '""'), a, b) for w, a, b in words], xmax=1.2)
    tg.write_bytes(content.encode("utf-16"))  # Praat writes UTF-16 when the text is not ASCII
    s = load_recording(audio, text, spans_of(text), timings_path=tg, cache_dir=tmp_path / "c")
    assert [w.word for w in s.words] == ["Say", "hi", "café"]
    assert [w.start for w in s.words] == [0.1, 0.3, 0.6]


def test_json_timings_normalised_match(tmp_path):
    text = "Don’t STOP, believing!"
    audio = tone_wav(tmp_path / "a.wav")
    js = tmp_path / "t.json"
    js.write_text(json.dumps([{"word": "don't", "start": 0.1, "end": 0.4}, {"word": "sil", "start": 0.4, "end": 0.5},
                              {"word": "stop", "start": 0.5, "end": 0.8},
                              {"word": "Believing", "start": 0.8, "end": 1.5}]))
    s = load_recording(audio, text, spans_of(text), timings_path=js, cache_dir=tmp_path / "c")
    assert s.source == "json"
    assert [(w.start, w.end) for w in s.words] == [(0.1, 0.4), (0.5, 0.8), (0.8, 1.5)]


def test_mismatch_names_word_and_time(tmp_path):
    audio = tone_wav(tmp_path / "a.wav")
    tg = tmp_path / "a.TextGrid"
    bad = list(WORDS)
    bad[3] = ("your", 1.25, 1.40)
    tg.write_text(long_textgrid(bad), encoding="utf-8")
    with pytest.raises(SpeechError) as ei:
        load_recording(audio, TEXT, spans_of(TEXT), timings_path=tg, cache_dir=tmp_path / "c")
    e = ei.value
    assert e.word_index == 3 and e.time == 1.25
    assert "'my'" in e.message and "'your'" in e.message and "1.25" in e.message


def test_word_count_mismatch(tmp_path):
    audio = tone_wav(tmp_path / "a.wav")
    js = tmp_path / "t.json"
    js.write_text(json.dumps([{"word": w, "start": a, "end": b} for w, a, b in WORDS[:-1]]))
    with pytest.raises(SpeechError) as ei:
        load_recording(audio, TEXT, spans_of(TEXT), timings_path=js, cache_dir=tmp_path / "c")
    assert "4 words" in ei.value.message and "5" in ei.value.message and "'friend'" in ei.value.message
    assert ei.value.word_index == 4


@pytest.mark.parametrize("entry, fragment", [
    ({"word": "Well", "start": "x", "end": 0.4}, "'start' must be a number"),
    ({"word": "Well", "start": 0.5, "end": 0.4}, "before start"),
    ({"word": "Well"}, "no 'start'"),
])
def test_json_validation(tmp_path, entry, fragment):
    audio = tone_wav(tmp_path / "a.wav")
    js = tmp_path / "t.json"
    js.write_text(json.dumps([entry]))
    with pytest.raises(SpeechError) as ei:
        load_recording(audio, "Well", [(0, 4)], timings_path=js, cache_dir=tmp_path / "c")
    assert fragment in ei.value.message and "t.json" in ei.value.message and "entry 1" in ei.value.message


def test_decreasing_times_rejected(tmp_path):
    audio = tone_wav(tmp_path / "a.wav")
    js = tmp_path / "t.json"
    js.write_text(json.dumps([{"word": "a", "start": 0.5, "end": 0.6}, {"word": "b", "start": 0.2, "end": 0.3}]))
    with pytest.raises(SpeechError, match="entry 2"):
        load_recording(audio, "a b", [(0, 1), (2, 3)], timings_path=js, cache_dir=tmp_path / "c")


def test_unreadable_audio_names_file(tmp_path):
    bad = tmp_path / "broken.wav"
    bad.write_bytes(b"not audio at all")
    with pytest.raises(SpeechError, match="broken.wav"):
        load_recording(bad, "Well", [(0, 4)], cache_dir=tmp_path / "c")


def test_flac_stereo_and_pause(tmp_path):
    audio = tone_wav(tmp_path / "a.flac", channels=2, sr=22050)
    js = tmp_path / "t.json"
    js.write_text(json.dumps([{"word": w, "start": a, "end": b} for w, a, b in WORDS]))
    off = TEXT.index("my")
    s = load_recording(audio, TEXT, spans_of(TEXT), [(off, 0.5)], timings_path=js, cache_dir=tmp_path / "c")
    assert s.audio_path.suffix == ".wav" and s.audio_path.parent == tmp_path / "c"
    info = sf.info(str(s.audio_path))
    assert info.channels == 1 and info.samplerate == 22050
    assert abs(s.duration - 2.7) < 1e-3 and abs(info.duration - s.duration) < 1e-3
    for (w, a, b), got in zip(WORDS, s.words):
        shift = 0.5 if w in ("my", "friend") else 0.0
        assert abs(got.start - (a + shift)) < 1e-3
    x, _ = sf.read(str(s.audio_path))
    gap = x[int(1.26 * 22050): int(1.69 * 22050)]  # the cut lies in 1.20..1.25: 1.25..1.70 is silent
    assert np.abs(gap).max() < 1e-3


@needs_espeak
def test_pocketsphinx_alignment_on_synthesized_speech(tmp_path):
    text = "The quick brown fox jumps over the lazy dog near the river bank in 1999, don't you think?"
    spans = spans_of(text)
    ref = synthesize(text, spans, cache_dir=tmp_path / "syn")
    got = load_recording(ref.audio_path, text, spans, cache_dir=tmp_path / "c")
    assert got.source == "pocketsphinx" and len(got.words) == len(spans)
    err = np.array([abs(a.start - b.start) for a, b in zip(got.words, ref.words)])
    print(f"pocketsphinx mean start error {err.mean() * 1000:.1f} ms, max {err.max() * 1000:.1f} ms")
    assert err.mean() < 0.15
    assert err.max() < 0.3
    starts = [w.start for w in got.words]
    assert starts == sorted(starts)


@needs_espeak
def test_alignment_out_of_vocabulary_word(tmp_path):
    text = "Meet my friend Zorblax tomorrow."
    spans = spans_of(text)
    ref = synthesize(text, spans, cache_dir=tmp_path / "syn")
    got = load_recording(ref.audio_path, text, spans, cache_dir=tmp_path / "c")
    err = np.array([abs(a.start - b.start) for a, b in zip(got.words, ref.words)])
    assert err.mean() < 0.15, err


def test_alignment_failure_says_supply_timings(tmp_path):
    audio = tmp_path / "silence.wav"
    sf.write(str(audio), np.zeros(1600), 16000)  # 0.1 s: far too short for the words
    with pytest.raises(SpeechError, match="TextGrid"):
        load_recording(audio, "extraordinary circumstances everywhere today", spans_of(
            "extraordinary circumstances everywhere today"), cache_dir=tmp_path / "c")


SPOKEN = "Well, hello there my friend. How are you today?"


def spoken_recording(tmp_path, text=SPOKEN, pad=0.3):
    """``text`` spoken by espeak-ng, with ``pad`` s of room noise (60 dB under the speech)
    before and after it and under it, as a recording; and where the voice starts and ends in
    it (s), measured on the clean audio here."""
    s = synthesize(text, spans_of(text), cache_dir=tmp_path / "syn")
    x, sr = sf.read(str(s.audio_path))
    loud = np.flatnonzero(np.abs(x) > 10 ** (-40 / 20) * np.abs(x).max())
    p = np.zeros(int(pad * sr))
    y = np.concatenate([p, x, p])
    y = y + np.random.default_rng(0).normal(0, 1e-3 * np.abs(x).max(), len(y))
    path = tmp_path / "rec.wav"
    sf.write(str(path), y, sr)
    return path, pad + loud[0] / sr, pad + (loud[-1] + 1) / sr


@needs_espeak
def test_aligned_words_are_trimmed_to_the_voice(tmp_path):
    """Issue 10: the aligner started the first word ~40 ms before the voice and ended the last
    one after it (its 10 ms frames, and silence given to the words next to it)."""
    path, onset, offset = spoken_recording(tmp_path)
    got = load_recording(path, SPOKEN, spans_of(SPOKEN), cache_dir=tmp_path / "c")
    assert abs(got.words[0].start - onset) < 0.015, (got.words[0], onset)
    assert abs(got.words[-1].end - offset) < 0.015, (got.words[-1], offset)
    friend, how = got.words[4], got.words[5]
    assert how.start - friend.end > 0.1  # the pause between the sentences belongs to no word


@needs_espeak
@pytest.mark.parametrize("transcript, index, named", [
    ("Well, hello there my dear friend. How are you today?", 4, "'dear'"),  # a word the recording does not say
    ("Well, hello my friend. How are you today?", 2, "between 'hello' and 'my'"),  # the recording says 'there'
])
def test_a_transcript_that_does_not_match_the_recording_is_rejected(tmp_path, transcript, index, named):
    path, _, _ = spoken_recording(tmp_path)
    truth = synthesize(SPOKEN, spans_of(SPOKEN), cache_dir=tmp_path / "syn").words
    there = 0.3 + truth[2].start
    with pytest.raises(SpeechError) as ei:
        load_recording(path, transcript, spans_of(transcript), cache_dir=tmp_path / "c")
    e = ei.value
    assert e.kind == "mismatch" and e.word_index == index, e.message
    assert named in e.message and "rec.wav" in e.message and f"{e.time:.2f} s" in e.message
    if "between" in named:  # the time is where the unexpected speech starts
        assert abs(e.time - there) < 0.05, (e.time, there)
    else:  # between 'my' and 'friend'
        assert 0.3 + truth[3].start - 0.05 < e.time < 0.3 + truth[4].end
    # the verdict is cached with the alignment: the same error without the aligner
    from dsl.speech import align

    def boom(*a, **k):
        raise AssertionError("aligned again")

    import pytest as _pytest
    with _pytest.MonkeyPatch.context() as mp:
        mp.setattr(align, "align_words", boom)
        with pytest.raises(SpeechError) as again:
            load_recording(path, transcript, spans_of(transcript), cache_dir=tmp_path / "c")
    assert again.value.message == e.message and again.value.word_index == index


def test_poor_fits_flags_a_word_whose_phones_fit_far_worse_than_usual():
    """dsl.speech.align.poor_fits: each phone's score per frame, relative to the recording's
    median word, against the table of how that phone fits in correct transcripts; a word of
    at least POOR_FIT_PHONES phones is flagged when the mean of its phones' z, times the square
    root of their number (at most POOR_FIT_MAX_PHONES), is above POOR_FIT_Z, or when most of
    its phones last the aligner's shortest (squeezed in) and their mean z is above SQUEEZED_Z;
    shorter words never (their fit rests on a few frames)."""
    from dsl.speech import align

    table = align.phone_fit()

    def word(phones, spreads=0.0, frames=10, level=-20.0):
        # a phone scoring (median + spreads * spread) times the recording's level per frame
        return [(p, frames, int(round(level * frames * (table[p][0] + spreads * table[p][1])))) for p in phones]

    usual = [word(["HH", "AH", "L", "OW"]), word(["DH", "EH", "R"]), word(["M", "AY"]), word(["F", "R", "EH", "N", "D"]),
             word(["T", "AH", "D", "EY"])]
    assert align.poor_fits(usual) == []
    pocket, bask = ["P", "AA", "K", "AH", "T"], ["B", "AE", "S", "K"]

    def flagged(phones, spreads, frames=10):
        return [(k, squeezed) for k, _, squeezed in align.poor_fits(usual[:3] + [word(phones, spreads, frames)] + usual[4:])]

    assert flagged(pocket, 2.5) == [(3, False)]  # its mean z: 2.9, times sqrt(5): 6.4
    assert flagged(pocket, 1.5) == []  # 1.8 * sqrt(5) = 3.9
    assert flagged(["K", "AE", "T"], 2.3) == []  # 2.6 * sqrt(3) = 4.6: a short word's mean wanders more
    assert flagged(bask, 2.0, frames=align.SHORTEST_PHONE) == [(3, True)]  # squeezed in, 2.3 spreads worse
    assert flagged(bask, 2.0, frames=align.SHORTEST_PHONE + 1) == []  # room for it: 2.3 * sqrt(4) = 4.6
    assert flagged(bask, 1.5, frames=align.SHORTEST_PHONE) == []  # squeezed but fitting as usual words do (1.8)
    prudently = ["P", "R", "UW", "D", "AH", "N", "T", "L", "IY"]  # 9 phones, scaled as 6: a whole word a little off
    assert flagged(prudently, 1.5) == []  # 1.76 * sqrt(6) = 4.3 (sqrt(9): 5.3)
    assert flagged(prudently, 2.0) == [(3, False)]  # 2.3 * sqrt(6) = 5.7
    short = usual[:2] + [word(["AH", "T"], spreads=6.0)] + usual[3:]  # two phones: never judged
    assert align.poor_fits(short) == []
    assert align.poor_fits(None) == [] and align.poor_fits([None, None]) == []
