"""Gestures chosen from the words: where the author left no mark, the words that call for a
gesture get one (``sgt suggest``, ``sgt generate --auto-gestures``).

The table is :mod:`library.words` (``library/words.toml``, extensible by the user's gesture
folders): counting ("first", "two"), deixis ("I", "you", "here", "there", "left", "up",
"behind"), negation, size, greetings and farewells, questions, contrast, emphasis, change, each
with the context it needs (the word before and after, a question). :func:`suggest` goes through
each utterance of an analysed script:

- a word gets the first entry of the table for it whose context fits and whose gesture the
  library has;
- no suggestion within two words of a mark the author wrote, nor within two words of another
  suggestion (counting words excepted: "one, two, three" may chain, each a finger more);
- at most one mark per three words of the utterance, the author's included (a counting word
  next to a counting word already chosen is free: a list counts on): when more words call for
  one, the kinds of :data:`PRIORITY` come first (counting, then directions, ...), then the
  earlier word.

:func:`apply_suggestions` inserts them into the text (``[pose:NAME] `` before the word, nothing
else changed), so an author reviews them as a diff.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: Which kinds of reference win when a line has more words that call for a gesture than it has
#: room for (earlier first).
PRIORITY = ("counting", "direction", "question", "negation", "greeting", "farewell", "size", "change", "contrast",
            "command", "deixis", "emphasis", "uncertainty", "totality", "affirmation", "evaluation", "invitation",
            "union", "calming", "celebration", "politeness", "exchange", "cognition")
#: The fewest words between two marks (counting words excepted).
SPACING = 3
#: At most one mark per this many words of an utterance.
WORDS_PER_MARK = 3

_CLEAN = re.compile(r"[^a-z0-9']+")


@dataclass(frozen=True)
class Suggestion:
    """A gesture for the word at ``line``:``col`` (1-based, the script's own lines) of
    utterance ``utterance`` (0-based), because of the table's entry of ``kind``."""

    utterance: int
    line: int
    col: int
    gesture: str
    word: str
    kind: str

    def to_dict(self) -> dict:
        return {"utterance": self.utterance, "line": self.line, "col": self.col, "gesture": self.gesture,
                "word": self.word, "kind": self.kind}


def _norm(text: str) -> str:
    return _CLEAN.sub("", text.lower().replace("\u2019", "'"))


def suggest(script, library, rules) -> list[Suggestion]:
    """Suggestions for every utterance of an analysed ``script`` (:func:`dsl.parser.analyse`),
    with gestures from ``library`` only, by ``rules`` (:class:`library.words.WordRules`)."""
    out: list[Suggestion] = []
    rank = {k: n for n, k in enumerate(PRIORITY)}
    for u in script.utterances:
        words = [_norm(w.text) for w in u.words]
        n = len(words)
        if not n:
            continue
        marked = {m.word_index if m.word_index is not None else m.after_word for m in u.poses}
        marked.discard(None)
        candidates = []
        for i, w in enumerate(words):
            if any(abs(i - j) < SPACING for j in marked):
                continue
            before = words[i - 1] if i > 0 else None
            after = words[i + 1] if i + 1 < n else None
            question = _ends_sentence_with(u.text, u.words[i].end) == "?"
            for rule in rules.for_word(w):
                if rule.suggest in library and rule.fits(before, after, question):
                    candidates.append((rank.get(rule.kind, len(PRIORITY)), i, rule))
                    break
        room = max(0, n // WORDS_PER_MARK - len(marked)) if n >= WORDS_PER_MARK else (0 if marked else 1)
        chosen: list[tuple[int, object]] = []
        used = 0
        for _, i, rule in sorted(candidates, key=lambda c: (c[0], c[1])):
            counting = rule.kind == "counting"
            chained = counting and any(r.kind == "counting" and abs(i - j) < SPACING for j, r in chosen)
            if used >= room and not chained:
                continue
            if any(abs(i - j) < SPACING and not (counting and r.kind == "counting") for j, r in chosen):
                continue
            chosen.append((i, rule))
            used += not chained
        for i, rule in sorted(chosen, key=lambda c: c[0]):
            where = u.words[i].where
            out.append(Suggestion(u.index, where.line, where.col, rule.suggest, u.words[i].text, rule.kind))
    return out


def _ends_sentence_with(text: str, offset: int) -> str | None:
    """The punctuation that ends the sentence holding ``offset`` in ``text`` (., ? or !), or
    None when the utterance ends first."""
    m = re.compile(r"[.?!]").search(text, offset)
    return m.group(0) if m else None


def apply_suggestions(source: str, suggestions) -> str:
    """``source`` with ``[pose:NAME] `` inserted before each suggested word; every other
    character kept (line ends too)."""
    lines = source.splitlines(keepends=True)
    by_line: dict[int, list[Suggestion]] = {}
    for s in suggestions:
        by_line.setdefault(s.line, []).append(s)
    for line, found in by_line.items():
        text = lines[line - 1]
        for s in sorted(found, key=lambda s: s.col, reverse=True):
            at = s.col - 1
            text = text[:at] + f"[pose:{s.gesture}] " + text[at:]
        lines[line - 1] = text
    return "".join(lines)
