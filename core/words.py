"""The one timed-word type: a spoken word and when it is spoken.

Every package uses :class:`TimedWord`: speech timing (espeak-ng, recordings), the compiled
plan, the engines' inputs, motion files, renders and the editor. In files a timed word is
``{"word": str, "start": seconds, "end": seconds}`` (:meth:`TimedWord.to_dict` /
:meth:`TimedWord.from_dict`); nowhere else is another shape accepted.
"""

from __future__ import annotations

from typing import NamedTuple


class TimedWord(NamedTuple):
    """``word`` spoken from ``start`` to ``end`` seconds (on whatever clock the owner states)."""

    word: str
    start: float
    end: float

    def shifted(self, seconds: float) -> "TimedWord":
        return TimedWord(self.word, self.start + seconds, self.end + seconds)

    def to_dict(self, digits: int = 3) -> dict:
        return {"word": self.word, "start": round(self.start, digits), "end": round(self.end, digits)}

    @classmethod
    def from_dict(cls, d: dict) -> "TimedWord":
        """Raises ValueError (or TypeError/KeyError, both turned into ValueError) on a bad entry."""
        try:
            return cls(str(d["word"]), float(d["start"]), float(d["end"]))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"a word needs 'word', 'start' and 'end', got {d!r}") from exc


def shift_words(words, seconds: float) -> list[TimedWord]:
    """``words`` ``seconds`` later (a new list)."""
    new = tuple.__new__  # TimedWord(...) without the NamedTuple call overhead (long scripts)
    return [new(TimedWord, (w[0], w[1] + seconds, w[2] + seconds)) for w in words]
