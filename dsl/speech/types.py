"""Plain data types shared by the speech modules (cheap to import)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from core.words import TimedWord


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


class SpeechError(Exception):
    """A user-facing speech problem (bad voice, unreadable file, timing mismatch...).

    ``message`` is meant to be shown as is, without a traceback. ``word_index`` (index into the
    word spans) and ``time`` (seconds into the audio) locate the problem when known. ``kind``
    says what it is about, so that a diagnostic can point at the right place: "voice" (an
    unknown voice), "audio" (the recording cannot be read), "timings" (the timings file is
    malformed), "mismatch" (the timings do not fit the transcript or the recording), "crash" (the
    process synthesizing died), "engine" (anything else: the engine or the aligner failed). ``file`` is the file it is about;
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
