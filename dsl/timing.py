"""Word timing for an utterance: real speech (espeak-ng or a recording) or a quick estimate.

The estimate needs no speech engine and is what ``sgt check`` uses by default and what the
editor uses on every keystroke; ``sgt compile`` and ``sgt say`` always use real speech.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from core.words import TimedWord, shift_words
from dsl import speech
from dsl.script import Utterance
from dsl.speech.synth import LEAD_IN  # the estimate starts its first word where real speech does

_SENTENCE_END = re.compile(r"[.!?;:]")
_timed_word = tuple.__new__  # TimedWord(word, start, end) without the NamedTuple call overhead

@dataclass
class Timing:
    words: list[TimedWord]
    duration: float
    source: str  # "estimate", "espeak-ng", "textgrid", "json", "pocketsphinx"
    audio_path: Path | None = None
    sample_rate: int | None = None
    #: The phonemes on the same clock (:class:`dsl.speech.types.TimedPhoneme`); none for an estimate.
    phonemes: list = field(default_factory=list)

    def shifted(self, lead: float) -> Timing:
        """The same timing ``lead`` seconds later."""
        return Timing(shift_words(self.words, lead), self.duration + lead, self.source, self.audio_path, self.sample_rate,
                      [p.shifted(lead) for p in self.phonemes])


def estimate_timing(utt: Utterance) -> Timing:
    """A deterministic guess at word times from text length and the speaking rate."""
    per_word = 60.0 / max(1, utt.voice.rate)
    t = LEAD_IN
    words: list[TimedWord] = []
    append = words.append
    pauses = {}
    for p in utt.pauses:
        pauses[p.word_index] = pauses.get(p.word_index, 0.0) + p.seconds
    text = utt.text
    spoken = utt.words
    following = [w.start for w in spoken]  # following[i + 1]: where the gap after word i ends
    following.append(len(text))
    sentence_end = _SENTENCE_END.search
    i = 0
    for w in spoken:
        if pauses:
            t += pauses.get(i, 0.0)
        i += 1
        end = w.end
        n = end - w.start
        length = per_word * (0.45 + 0.11 * (n if n < 14 else 14))
        append(_timed_word(TimedWord, (w.text, t, t + length)))
        t += length
        tail = text[end : following[i]]
        if not tail or tail.isspace():
            continue
        if sentence_end(tail):
            t += 0.25
        elif "," in tail:
            t += 0.12
    t += pauses.get(len(spoken), 0.0)
    return Timing(words, max(t + LEAD_IN, 0.2), "estimate")


def speech_timing(utt: Utterance, cache_dir: Path | None = None) -> Timing:
    """Real timing: synthesize with espeak-ng, or read the utterance's recording.

    Raises :class:`dsl.speech.SpeechError` with a user-facing message on failure.
    """
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
    phonemes = list(result.phonemes)
    if utt.audio is not None:  # a recording: the dictionary's phonemes of its aligned words
        phonemes = speech.synth.phonemes_of_words(result.words, utt.voice.name)
    return Timing(list(result.words), float(result.duration), result.source, Path(result.audio_path), result.sample_rate,
                  phonemes)
