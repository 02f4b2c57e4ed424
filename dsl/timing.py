"""Word timing for an utterance: real speech (espeak-ng or a recording) or a quick estimate.

The estimate needs no speech engine and is what ``sgt check`` uses by default and what the
editor uses on every keystroke; ``sgt compile`` and ``sgt say`` always use real speech.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from dsl.script import Utterance

_SENTENCE_END = re.compile(r"[.!?;:]")
LEAD_IN = 0.05  # seconds of silence before the first estimated word


class TimedWord(NamedTuple):
    word: str
    start: float  # seconds
    end: float


@dataclass
class Timing:
    words: list[TimedWord]
    duration: float
    source: str  # "estimate", "espeak-ng", "textgrid", "json", "pocketsphinx"
    audio_path: Path | None = None
    sample_rate: int | None = None


def estimate_timing(utt: Utterance) -> Timing:
    """A deterministic guess at word times from text length and the speaking rate."""
    per_word = 60.0 / max(1, utt.voice.rate)
    t = LEAD_IN
    words: list[TimedWord] = []
    pauses = {}
    for p in utt.pauses:
        pauses[p.word_index] = pauses.get(p.word_index, 0.0) + p.seconds
    text = utt.text
    ends = [w.start for w in utt.words[1:]] + [len(text)]
    for i, w in enumerate(utt.words):
        if pauses:
            t += pauses.get(i, 0.0)
        length = per_word * (0.45 + 0.11 * min(w.end - w.start, 14))
        words.append(TimedWord(w.text, t, t + length))
        t += length
        tail = text[w.end : ends[i]]
        if tail.isspace() or not tail:
            continue
        if _SENTENCE_END.search(tail):
            t += 0.25
        elif "," in tail:
            t += 0.12
    t += pauses.get(len(utt.words), 0.0)
    return Timing(words, max(t + LEAD_IN, 0.2), "estimate")


def speech_timing(utt: Utterance, cache_dir: Path | None = None) -> Timing:
    """Real timing: synthesize with espeak-ng, or read the utterance's recording.

    Raises :class:`dsl.speech.SpeechError` with a user-facing message on failure.
    """
    from dsl import speech

    pauses = [(p.offset, p.seconds) for p in utt.pauses]
    if utt.audio is not None:
        result = speech.load_recording(
            utt.audio.path, utt.text, utt.word_spans, pauses, timings_path=utt.audio.timings, cache_dir=cache_dir
        )
    else:
        v = utt.voice
        result = speech.synthesize(
            utt.text, utt.word_spans, pauses, voice=v.name, rate=v.rate, pitch=v.pitch, cache_dir=cache_dir
        )
    words = [TimedWord(w.text, float(w.start), float(w.end)) for w in result.words]
    return Timing(words, float(result.duration), result.source, Path(result.audio_path), result.sample_rate)
