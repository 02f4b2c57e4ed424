"""English words' parts of speech, base forms and senses, from WordNet 3.0's database files
(Debian's ``wordnet-base``: ``/usr/share/wordnet``; another copy through ``WNSEARCHDIR``).

What suggestions ask of it (:mod:`dsl.sense`): which parts of speech a word can be and how often
each was seen in the tagged corpus WordNet counted (``index.*``), its base forms (WordNet's
*morphy*: the exception lists ``*.exc`` then the suffix rules), its senses in order of frequency,
and a sense's lexicographer file (``noun.artifact``, ``noun.time``, ...) and pointers (synonyms
share a sense; ``&`` links similar adjectives). The files are sorted by word, so a look-up is a
binary search over a memory map: nothing is read whole, the first look-up costs a few
milliseconds, and the database takes 28 MB on disk.

:func:`find_lexicon` returns None where no database is installed: suggestions then use the words
table alone (``sgt suggest --explain`` says so).
"""

from __future__ import annotations

import mmap
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

#: Where a WordNet database is looked for, after ``$WNSEARCHDIR``.
PLACES = ("/usr/share/wordnet", "/usr/local/share/wordnet", "/usr/local/WordNet-3.0/dict", "/opt/homebrew/share/wordnet")
POS = ("n", "v", "a", "r")
_FILES = {"n": "noun", "v": "verb", "a": "adj", "r": "adv"}
#: WordNet's lexicographer files, by number (``lexnames``).
LEXNAMES = (
    "adj.all", "adj.pert", "adv.all", "noun.Tops", "noun.act", "noun.animal", "noun.artifact", "noun.attribute",
    "noun.body", "noun.cognition", "noun.communication", "noun.event", "noun.feeling", "noun.food", "noun.group",
    "noun.location", "noun.motive", "noun.object", "noun.person", "noun.phenomenon", "noun.plant", "noun.possession",
    "noun.process", "noun.quantity", "noun.relation", "noun.shape", "noun.state", "noun.substance", "noun.time",
    "verb.body", "verb.change", "verb.cognition", "verb.communication", "verb.competition", "verb.consumption",
    "verb.contact", "verb.creation", "verb.emotion", "verb.motion", "verb.perception", "verb.possession",
    "verb.social", "verb.stative", "verb.weather", "adj.ppl")
_RULES = {
    "n": (("s", ""), ("ses", "s"), ("xes", "x"), ("zes", "z"), ("ches", "ch"), ("shes", "sh"), ("men", "man"), ("ies", "y")),
    "v": (("s", ""), ("ies", "y"), ("es", "e"), ("es", ""), ("ed", "e"), ("ed", ""), ("ing", "e"), ("ing", "")),
    "a": (("er", ""), ("est", ""), ("er", "e"), ("est", "e")),
    "r": (),
}
_LONGEST = 80  # no WordNet lemma is longer; a longer word is not looked up


@dataclass(frozen=True)
class Entry:
    """A word as one part of speech: its senses (synset offsets, most frequent first) and how
    many of them were seen in the tagged corpus (``tagged``: 0 for a rare use)."""

    lemma: str
    pos: str
    senses: tuple[int, ...]
    tagged: int


@dataclass(frozen=True)
class Synset:
    offset: int
    pos: str
    lexname: str
    words: tuple[str, ...]
    pointers: tuple[tuple[str, int, str], ...]  # (symbol, offset, pos)
    gloss: str


class Lexicon:
    """A WordNet database folder, read lazily (memory maps, binary search)."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self._maps: dict[str, mmap.mmap] = {}
        self._exc: dict[str, dict[str, tuple[str, ...]]] = {}

    def _map(self, name: str) -> mmap.mmap:
        m = self._maps.get(name)
        if m is None:
            with open(self.folder / name, "rb") as f:
                m = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
            self._maps[name] = m
        return m

    def _line_at(self, m: mmap.mmap, pos: int) -> tuple[int, bytes]:
        start = m.rfind(b"\n", 0, pos) + 1
        end = m.find(b"\n", pos)
        return start, m[start: end if end >= 0 else len(m)]

    def _search(self, name: str, key: str) -> bytes | None:
        """The line of the sorted file ``name`` that starts with ``key`` and a space."""
        m = self._map(name)
        want = key.encode("utf-8")
        lo, hi = 0, len(m)
        while lo < hi:
            mid = (lo + hi) // 2
            start, line = self._line_at(m, mid)
            if line.startswith(b"  "):  # the licence at the top sorts before every word
                lo = start + len(line) + 1
                continue
            word = line.split(b" ", 1)[0]
            if word == want:
                return line
            if word < want:
                lo = start + len(line) + 1
            else:
                hi = start
        return None

    def entry(self, lemma: str, pos: str) -> Entry | None:
        """``lemma`` (a base form, lower case) as part of speech ``pos`` (n, v, a, r)."""
        return _entry(self, lemma, pos)

    def synset(self, offset: int, pos: str) -> Synset:
        return _synset(self, offset, pos)

    def base_forms(self, word: str, pos: str) -> tuple[str, ...]:
        """The base forms of ``word`` as ``pos`` that WordNet has (the word itself first when it is one)."""
        return _base_forms(self, word, pos)

    def exceptions(self, pos: str) -> dict[str, tuple[str, ...]]:
        table = self._exc.get(pos)
        if table is None:
            table = {}
            path = self.folder / f"{_FILES[pos]}.exc"
            if path.is_file():
                for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
                    parts = line.split()
                    if len(parts) >= 2:
                        table[parts[0]] = tuple(parts[1:])
            self._exc[pos] = table
        return table


def _key(word: str) -> str:
    return word.strip().lower().replace(" ", "_")


@lru_cache(maxsize=65536)
def _entry(lex: Lexicon, lemma: str, pos: str) -> Entry | None:
    key = _key(lemma)
    if not key or len(key) > _LONGEST:
        return None
    line = lex._search(f"index.{_FILES[pos]}", key)
    if line is None:
        return None
    f = line.decode("utf-8", "replace").split()
    n_senses, n_pointers = int(f[2]), int(f[3])
    rest = f[4 + n_pointers:]
    tagged = int(rest[1])
    senses = tuple(int(x) for x in rest[2: 2 + n_senses])
    return Entry(key, pos, senses, tagged)


@lru_cache(maxsize=65536)
def _synset(lex: Lexicon, offset: int, pos: str) -> Synset:
    m = lex._map(f"data.{_FILES[pos]}")
    end = m.find(b"\n", offset)
    f = m[offset: end if end >= 0 else len(m)].decode("utf-8", "replace")
    head, _, gloss = f.partition(" | ")
    p = head.split()
    lexname = LEXNAMES[int(p[1])] if int(p[1]) < len(LEXNAMES) else "?"
    n_words = int(p[3], 16)
    words = tuple(p[4 + 2 * i].lower().split("(")[0] for i in range(n_words))
    at = 4 + 2 * n_words
    n_ptr = int(p[at])
    pointers = tuple((p[at + 1 + 4 * i], int(p[at + 2 + 4 * i]), "a" if p[at + 3 + 4 * i] == "s" else p[at + 3 + 4 * i])
                     for i in range(n_ptr))
    return Synset(offset, pos, lexname, words, pointers, gloss.strip())


@lru_cache(maxsize=65536)
def _base_forms(lex: Lexicon, word: str, pos: str) -> tuple[str, ...]:
    word = _key(word)
    out: list[str] = []

    def add(form: str) -> None:
        if form and form not in out and _entry(lex, form, pos) is not None:
            out.append(form)

    add(word)
    for base in lex.exceptions(pos).get(word, ()):
        add(base)
    for suffix, ending in _RULES[pos]:
        if word.endswith(suffix) and len(word) > len(suffix) + 1:
            add(word[: len(word) - len(suffix)] + ending)
    return tuple(out)


def find_lexicon() -> Lexicon | None:
    """The installed WordNet database (``$WNSEARCHDIR`` first), or None."""
    return _find(os.environ.get("WNSEARCHDIR", ""))


@lru_cache(maxsize=4)
def _find(env: str) -> Lexicon | None:
    for place in (env, *PLACES) if env else PLACES:
        folder = Path(place)
        if all((folder / f"{kind}.{_FILES[p]}").is_file() for p in POS for kind in ("index", "data")):
            return Lexicon(folder)
    return None
