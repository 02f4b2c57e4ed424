"""Plain data types shared by the speech modules (cheap to import)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from core.words import TimedWord

#: IPA stress marks: primary, secondary (what :attr:`TimedPhoneme.stress` 2 and 1 write).
STRESS_MARK = {2: "\u02c8", 1: "\u02cc"}


class TimedPhoneme(NamedTuple):
    """One phoneme (IPA, as espeak-ng names it: ``h``, ``oʊ``, ``tʃ``) spoken from ``start`` to
    ``end`` seconds (on whatever clock the owner states); ``stress`` is 2 on a vowel with the
    word's primary stress, 1 on a secondary one, else 0. In files it is a list
    ``[name, start, end]`` with the stress as IPA's mark in front of the name (``"ˈoʊ"``)."""

    phoneme: str
    start: float
    end: float
    stress: int = 0

    def shifted(self, seconds: float) -> "TimedPhoneme":
        return TimedPhoneme(self.phoneme, self.start + seconds, self.end + seconds, self.stress)

    def to_list(self, digits: int = 3) -> list:
        return [STRESS_MARK.get(self.stress, "") + self.phoneme, round(self.start, digits), round(self.end, digits)]


@dataclass
class Speech:
    """Audio of an utterance plus one :class:`~core.words.TimedWord` per requested word span, in order.

    Invariants: ``0 <= start <= end <= duration`` for every word, and starts are non-decreasing.
    """

    audio_path: Path
    sample_rate: int
    duration: float
    words: list[TimedWord] = field(default_factory=list)
    source: str = ""
    #: The phonemes, in order, on the same clock as the words (espeak-ng's phoneme events for
    #: synthesized speech; each word's dictionary phonemes spread over its time for a recording).
    phonemes: list[TimedPhoneme] = field(default_factory=list)


class SpeechError(Exception):
    """A user-facing speech problem (bad voice, unreadable file, timing mismatch...).

    ``message`` is meant to be shown as is, without a traceback. ``word_index`` (index into the
    word spans) and ``time`` (seconds into the audio) locate the problem when known. ``kind``
    says what it is about, so that a diagnostic can point at the right place: "voice" (an
    unknown voice), "audio" (the recording cannot be read), "too-long" (the recording is longer
    than :mod:`core.limits` lets it be), "timings" (the timings file is
    malformed), "mismatch" (the timings do not fit the transcript or the recording), "crash" (the
    process synthesizing died), "not-installed" (a piper voice whose packages are missing), "engine" (anything else: the engine or the aligner failed). ``file`` is the file it is about;
    ``reason`` the message without the file's name (for a diagnostic that names it itself).
    """

    def __init__(self, message: str, word_index: int | None = None, time: float | None = None, *,
                 kind: str = "engine", file=None, reason: str | None = None):
        super().__init__(message)
        self.message = message
        self.word_index = word_index
        self.time = time
        self.kind = kind
        self.file = file
        self.reason = reason if reason is not None else message

    def __str__(self) -> str:
        return self.message
