"""Word timing for an utterance: real speech (espeak-ng or a recording) or a quick estimate.

The estimate needs no speech engine and is what ``sgt check`` uses by default and what the
editor uses on every keystroke; ``sgt compile`` and ``sgt say`` always use real speech.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from dsl.script import Utterance

_SENTENCE_END = ".!?;:"
LEAD_IN = 0.05  # seconds of silence before the first estimated word


@dataclass(frozen=True)
class TimedWord:
    word: str
    start: float
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
    for i, w in enumerate(utt.words):
        t += pauses.get(i, 0.0)
        length = per_word * (0.45 + 0.55 * min(len(w.text), 14) / 5.0)
        words.append(TimedWord(w.text, t, t + length))
        t += length
        tail = utt.text[w.end : utt.words[i + 1].start] if i + 1 < len(utt.words) else utt.text[w.end :]
        if any(c in _SENTENCE_END for c in tail):
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
