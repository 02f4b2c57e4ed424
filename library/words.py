"""Words that call for a gesture: the table the rules engine triggers library gestures with,
and that ``sgt suggest`` / ``--auto-gestures`` place gestures by (``library/words.toml``).

:func:`load_word_rules` reads the built-in table, then a ``words.toml`` in each gesture folder
given (a user's folders: an entry there replaces the built-in entries for the same words), and
checks every entry (unknown keys and wrong types are errors with the file and the entry's
number). :meth:`WordRules.triggers` is the rules engine's table (word -> gestures, in the
table's order, a later entry replacing an earlier one for a word); :meth:`WordRules.for_word`
the entries a suggestion may come from, in order.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

BUILTIN_WORDS = Path(__file__).resolve().parent / "words.toml"
WORDS_FILE = "words.toml"

_KEYS = {"words", "gestures", "kind", "suggest", "teacher", "after", "not_after", "not_before", "question"}


class WordRulesError(ValueError):
    """A words table that cannot be used (one line for users, with the file)."""


@dataclass(frozen=True)
class WordRule:
    """One entry: ``words`` call for ``gestures`` (a ``kind`` of reference); ``suggest`` is the
    gesture a suggestion places (None: never), when the word before is in ``after`` (if given)
    and not in ``not_after``, the word after is not in ``not_before``, and (``question``) the
    sentence ends with "?"; ``teacher``: the rules engine uses it."""

    words: tuple[str, ...]
    gestures: tuple[str, ...]
    kind: str
    suggest: str | None
    teacher: bool = True
    after: frozenset[str] | None = None
    not_after: frozenset[str] = frozenset()
    not_before: frozenset[str] = frozenset()
    question: bool = False
    source: str = "built-in"

    def fits(self, before: str | None, after: str | None, in_question: bool) -> bool:
        """Whether the context (the words before and after, lower case; None at an edge) fits."""
        if self.after is not None and before not in self.after:
            return False
        if before in self.not_after or after in self.not_before:
            return False
        return in_question or not self.question


@dataclass
class WordRules:
    rules: list[WordRule] = field(default_factory=list)

    def triggers(self) -> dict[str, tuple[str, ...]]:
        """The rules engine's table: word -> candidate gestures."""
        out: dict[str, tuple[str, ...]] = {}
        for r in self.rules:
            if r.teacher:
                for w in r.words:
                    out[w] = r.gestures
        return out

    def for_word(self, word: str) -> list[WordRule]:
        """The entries that may suggest a gesture on ``word`` (lower case), in order."""
        return [r for r in self._by_word().get(word, ()) if r.suggest is not None]

    def _by_word(self) -> dict[str, list[WordRule]]:
        index = getattr(self, "_index", None)
        if index is None:
            index = {}
            for r in self.rules:
                for w in r.words:
                    index.setdefault(w, []).append(r)
            self._index = index
        return index


def load_word_rules(folders=()) -> WordRules:
    """The built-in table, then each folder's ``words.toml`` (missing ones are skipped); raises
    :class:`WordRulesError` for a table that cannot be used."""
    rules = _read(BUILTIN_WORDS, "built-in")
    for folder in folders:
        path = Path(folder) / WORDS_FILE
        if path.is_file():
            extra = _read(path, str(path))
            replaced = {w for r in extra for w in r.words}
            rules = [r for r in rules if not set(r.words) & replaced] + extra
    return WordRules(rules)


def _read(path: Path, source: str) -> list[WordRule]:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise WordRulesError(f"{path}: cannot read it ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise WordRulesError(f"{path}: TOML syntax error: {exc}") from None
    entries = data.get("words", [])
    unknown_top = set(data) - {"words"}
    if unknown_top or not isinstance(entries, list):
        raise WordRulesError(f"{path}: expected only [[words]] entries (found {', '.join(sorted(unknown_top)) or 'words'})")
    return [_rule(e, path, n + 1, source) for n, e in enumerate(entries)]


def _rule(e, path: Path, n: int, source: str) -> WordRule:
    where = f"{path}: [[words]] entry {n}"
    if not isinstance(e, dict):
        raise WordRulesError(f"{where}: not a table")
    unknown = set(e) - _KEYS
    if unknown:
        raise WordRulesError(f"{where}: unknown key {', '.join(sorted(unknown))} (keys: {', '.join(sorted(_KEYS))})")
    words, gestures = e.get("words"), e.get("gestures")
    if not isinstance(words, str) or not words.split():
        raise WordRulesError(f"{where}: 'words' must be a string of space-separated words")
    if not isinstance(gestures, list) or not gestures or not all(isinstance(g, str) for g in gestures):
        raise WordRulesError(f"{where}: 'gestures' must be a list of gesture names")
    suggest = e.get("suggest", gestures[0])
    if suggest is True:
        suggest = gestures[0]
    if suggest is not False and not isinstance(suggest, str):
        raise WordRulesError(f"{where}: 'suggest' must be a gesture name or false")

    def words_of(key: str) -> frozenset[str] | None:
        v = e.get(key)
        if v is None:
            return None
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise WordRulesError(f"{where}: '{key}' must be a list of words")
        return frozenset(x.lower() for x in v)

    for key in ("teacher", "question"):
        if key in e and not isinstance(e[key], bool):
            raise WordRulesError(f"{where}: '{key}' must be true or false")
    return WordRule(tuple(w.lower() for w in words.split()), tuple(gestures), str(e.get("kind", "")),
                    None if suggest is False else suggest, bool(e.get("teacher", True)), words_of("after"),
                    words_of("not_after") or frozenset(), words_of("not_before") or frozenset(),
                    bool(e.get("question", False)), source)
