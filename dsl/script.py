"""The parsed form of a script: what the analyser produces and the compiler consumes."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from core.diagnostics import Diagnostic


class Span(NamedTuple):
    """A place in the source file (1-based line and column) and its length in characters."""

    line: int
    col: int
    length: int = 1


@dataclass
class WordToken:
    text: str
    start: int  # character offsets in Utterance.text
    end: int
    where: Span


@dataclass
class PoseMark:
    name: str
    speed: int
    flip: bool
    hold: float  # seconds
    offset: int  # character offset in Utterance.text
    where: Span
    word_index: int | None  # anchored to this word's onset ...
    after_word: int | None = None  # ... or, with no word after it, to the end of this one

    @property
    def options(self) -> dict:
        opts: dict = {"speed": self.speed, "flip": self.flip}
        if self.hold:
            opts["hold"] = self.hold
        return opts


@dataclass
class StyleSpan:
    name: str  # the first name in the tag: a style element, a preset or ``face``
    values: dict[str, float]  # requested values, inner spans already applied
    offset: int
    end_offset: int  # where it closes (end of utterance when left open)
    where: Span
    first_word: int | None = None
    last_word: int | None = None  # inclusive; None when the span holds no word
    #: The facial expression the span asks for itself (``face:NAME``, else a built-in preset's,
    #: :data:`core.face.PRESET_EXPRESSIONS`); None: the outer span's face goes on.
    face: str | None = None
    #: Whether the span sets a style element or a preset itself (a ``<face:...>`` alone does not).
    styled: bool = True


@dataclass
class LookMark:
    """``[look:TARGET]``: where the eyes look from the next word on (a speaker's name or one of
    :data:`core.face.LOOK_DIRECTIONS`), until the end of its clause or for ``hold`` seconds."""

    target: str
    hold: float  # seconds; 0: to the end of the clause
    offset: int  # character offset in Utterance.text
    where: Span
    word_index: int | None  # from this word's onset ...
    after_word: int | None = None  # ... or, with no word after it, from the end of this one
    target_where: Span | None = None  # the target's name in the tag


@dataclass
class Pause:
    seconds: float
    offset: int
    where: Span
    word_index: int  # the pause comes before this word (== number of words at the end)


@dataclass
class AudioRef:
    path: Path
    timings: Path | None
    where: Span  # the audio file's name in the directive
    timings_where: Span | None = None  # the value of ``timings=``


@dataclass
class Voice:
    name: str = "en-us"
    rate: int = 165
    pitch: int = 50


@dataclass
class Utterance:
    index: int
    speaker: str | None
    line: int
    text: str  # spoken text; offsets of words, marks and pauses refer to it
    words: list[WordToken] = field(default_factory=list)
    poses: list[PoseMark] = field(default_factory=list)
    looks: list[LookMark] = field(default_factory=list)
    styles: list[StyleSpan] = field(default_factory=list)
    pauses: list[Pause] = field(default_factory=list)
    voice: Voice = field(default_factory=Voice)
    audio: AudioRef | None = None
    gap: float | None = None  # seconds of silence before this line (``@gap`` just before it); None: the header's
    gap_where: Span | None = None  # the value of that ``@gap`` (negative: this line interrupts)

    display: str = ""  # the text as a reader sees it: no tags, whitespace collapsed

    @property
    def word_spans(self) -> list[tuple[int, int]]:
        return [(w.start, w.end) for w in self.words]


#: Seconds of silence between one line's speech and the next one's, unless ``@gap`` says otherwise.
DEFAULT_GAP = 0.5
#: The longest ``@gap``, seconds.
MAX_GAP = 30.0


@dataclass
class Header:
    voice: Voice = field(default_factory=Voice)
    gap: float = DEFAULT_GAP  # ``@gap`` in the header
    speaker_overrides: dict[str, dict] = field(default_factory=dict)  # speaker -> {name, rate, pitch}
    seed: int = 0
    library_dirs: list[Path] = field(default_factory=list)
    library_where: dict[Path, Span] = field(default_factory=dict)
    presets: dict[str, dict[str, float]] = field(default_factory=dict)
    voice_where: dict[str, Span] = field(default_factory=dict)  # speaker ("" = default) -> directive
    #: Every speaker a per-speaker directive names: (name, where the name is, directive), in order.
    speaker_refs: list[tuple[str, Span, str]] = field(default_factory=list)
    #: Where each setting was last given ("seed", "voice:SPEAKER", "preset:NAME", ...), for
    #: the duplicate rule's note.
    settings_where: dict[str, Span] = field(default_factory=dict)
    #: Presets whose definition has errors: already reported, so their uses are not.
    broken_presets: set[str] = field(default_factory=set)

    def voice_for(self, speaker: str | None) -> Voice:
        over = self.speaker_overrides.get(speaker or "", {})
        return Voice(over.get("name", self.voice.name), over.get("rate", self.voice.rate), over.get("pitch", self.voice.pitch))


@dataclass
class Script:
    path: str
    source: str
    header: Header
    utterances: list[Utterance]
    diagnostics: list[Diagnostic]

    def missing_utterance(self, requested) -> int | None:
        """The first of ``requested`` (utterance indices, 0-based) the script does not have; None
        when it has them all (:func:`core.counting.no_utterance` says so)."""
        known = {u.index for u in self.utterances}
        return next((n for n in requested or () if n not in known), None)
