"""Gestures chosen from the words: where the author left no mark, the words that call for a
gesture get one (``sgt suggest``, ``sgt generate --auto-gestures``, the editor's f6).

Three steps for each utterance of an analysed script (:func:`suggest`):

1. **Sense before gesture** (:mod:`dsl.sense`): each word is read for its part of speech and
   role, and says what it stands for here: the table word it is looked up as (itself, its base
   form, or the word of its sense: "one moment" stands for "wait", "went up" said of prices for
   "rise"), or no gesture ("the right answer", "one of them", "I'll be right back", a "you" in
   "if you press ...", an adjective under a negation).
2. **The table, then meaning beyond it**: the word gets the first entry of the table
   (:mod:`library.words`, the user's to extend) for it whose context fits and whose gesture the
   library has; a word the table does not have, an adjective, verb or adverb, gets the gesture of
   a table word it shares a sense with in WordNet (:class:`Neighbours`: "enormous" finds "big",
   "awful" finds "bad"), counting only the word's commonest senses (:data:`TEXT_SENSES`) and
   the table word's (:data:`SEED_SENSES`), thresholds measured on the development half of
   tests/data/suggest_dev.txt. Where the table has the word, the table decides.
3. **Restraint**: no suggestion within two words of any mark the author wrote, nor of the same
   meaning as an author's mark in the same sentence or within :data:`SAME_MEANING` words of it
   (the same gesture, or gestures one table entry lists together); none next to another
   suggestion (counting words excepted: "one, two, three" chains), none within two words of one
   of the same meaning ("Hello, and welcome": one greeting); at most one mark per
   :data:`WORDS_PER_MARK` words of the utterance, the author's included; pointing at a person
   (:data:`SOFT`), which the same word calls for in one sentence and not the next, keeps wider
   bounds (:data:`SPACING_SOFT`, :data:`WORDS_PER_SOFT`); when more words call for one, the
   kinds of :data:`PRIORITY` come first, then the earlier word; a count in a sentence that joins
   things together yields to the joining ("two teams as one, together").

Each :class:`Suggestion` says which word called it, what that word means there and where its
gesture came from (``sgt suggest --explain``). :func:`apply_suggestions` inserts them into the
text (``[pose:NAME] `` before the word, nothing else changed), so an author reviews them as a diff.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from dsl import sense
from library.lexicon import find_lexicon

#: Which kinds of reference win when a line has more words that call for a gesture than it has
#: room for (earlier first).
PRIORITY = ("counting", "direction", "negation", "question", "greeting", "farewell", "size", "evaluation", "change",
            "union", "separation", "shape", "time", "command", "celebration", "politeness", "calming",
            "uncertainty", "cognition", "affirmation", "exchange", "invitation", "contrast", "emphasis", "totality",
            "deixis")
#: The fewest words between two marks (counting words excepted), and at most one mark per this
#: many words of an utterance, the author's included: a gesture the words call for (a count, a
#: direction, a size, a negation, ...) takes a stroke of the hands, two words apart suffice.
SPACING = 2
WORDS_PER_MARK = 2
#: Pointing at a person ("we", "I", "you") is the optional kind: the same word calls for it in one
#: sentence and not the next, so it keeps the wider bounds (this many words apart, one per this
#: many words) and yields to the gestures the words call for.
SOFT = frozenset({"deixis"})
SPACING_SOFT = 3
WORDS_PER_SOFT = 3
#: No suggestion of the same meaning as an author's mark within this many words of it (nor in its sentence).
SAME_MEANING = 8
#: A word outside the table reaches a table word's gesture through one of its commonest senses
#: (this many), shared with one of the table word's commonest senses (this many), or an adjective
#: similar to it. Measured on the development half (scripts/suggest_check.py --sweep).
TEXT_SENSES = 1
SEED_SENSES = 2
#: The kinds whose words reach their gesture through WordNet neighbours (pointing, counting,
#: greetings, questions and politeness are closed lists: a neighbour of "left" or "two" is not a
#: direction or a count, one of "proud" is "arrogant"; emphasis too: the neighbours of
#: "important" are "main", "key", "central", words that classify and stress nothing), and the
#: parts of speech that do. An adjective similar to a table adjective counts only through the
#: table word's commonest sense ("bad" as poor, not as "severe" or "intense").
OPEN_KINDS = {"size": "a", "evaluation": "a", "change": "v", "union": "vr", "separation": "vr", "shape": "n",
              "calming": "vr", "celebration": "vn", "uncertainty": "r", "cognition": "v", "time": "r"}
OPEN_POS = ("a", "v", "r", "n")
_WN_POS = {"ADJ": "a", "VERB": "v", "ADV": "r", "NOUN": "n"}
_CLEAN = re.compile(r"[^a-z0-9']+")


@dataclass(frozen=True)
class Suggestion:
    """A gesture for the word at ``line``:``col`` (1-based, the script's own lines) of
    utterance ``utterance`` (0-based), because of the table's entry of ``kind``; ``sense`` says
    what the word means there and ``via`` where the gesture came from."""

    utterance: int
    line: int
    col: int
    gesture: str
    word: str
    kind: str
    sense: str = ""
    via: str = ""

    def to_dict(self) -> dict:
        return {"utterance": self.utterance, "line": self.line, "col": self.col, "gesture": self.gesture,
                "word": self.word, "kind": self.kind, "sense": self.sense, "via": self.via}

    def explain(self) -> str:
        """One line: where, the gesture, the word that called it, its sense and the gesture's source."""
        return f"{self.line}:{self.col}: {self.gesture} on '{self.word}': {self.sense}; {self.via}"


class Neighbours:
    """Table words by their WordNet senses: a word outside the table finds the table word it
    shares one of its commonest senses with (or, for an adjective, one similar to it)."""

    def __init__(self, rules, lexicon) -> None:
        self.lexicon = lexicon
        self.seeds: dict[tuple[str, int], tuple[int, str]] = {}
        for rule in rules.rules:
            if rule.suggest is None or rule.kind not in OPEN_KINDS:
                continue
            for word in rule.words:
                for pos in OPEN_KINDS[rule.kind]:
                    entry = lexicon.entry(word, pos)
                    if entry is None:
                        continue
                    for rank, offset in enumerate(entry.senses[:SEED_SENSES]):
                        self._add(pos, offset, rank, word)
                        if pos == "a" and rank == 0:
                            for symbol, other, opos in lexicon.synset(offset, pos).pointers:
                                if symbol == "&":
                                    self._add(opos, other, rank + 1, word)

    def _add(self, pos: str, offset: int, rank: int, word: str) -> None:
        old = self.seeds.get((pos, offset))
        if old is None or rank < old[0]:
            self.seeds[(pos, offset)] = (rank, word)

    def near(self, lemma: str, pos: str) -> str | None:
        """The table word that ``lemma`` (a base form, part of speech ``pos``) stands close to, or None."""
        entry = self.lexicon.entry(lemma, pos)
        if entry is None:
            return None
        for offset in entry.senses[:TEXT_SENSES]:
            hit = self.seeds.get((pos, offset))
            synset = self.lexicon.synset(offset, pos) if hit is None and pos in ("v", "a") else None
            if synset is not None and (pos == "a" or synset.lexname == "verb.motion"):
                # a satellite of a table adjective; a way of moving that is a kind of a table verb
                # ("plummet" is a kind of "drop"; "fix" is a kind of "improve" but no motion)
                link = "@" if pos == "v" else "&"
                hit = next((self.seeds[(p, o)] for symbol, o, p in synset.pointers
                            if symbol == link and (p, o) in self.seeds), None)
            if hit is not None:
                return hit[1]
        return None


_NEIGHBOURS: dict[tuple, Neighbours] = {}


def neighbours(rules, lexicon) -> Neighbours | None:
    """The :class:`Neighbours` of ``rules`` (kept while the same table is in use)."""
    if lexicon is None:
        return None
    key = (id(rules), len(rules.rules), str(lexicon.folder), TEXT_SENSES, SEED_SENSES)
    found = _NEIGHBOURS.get(key)
    if found is None or found.lexicon is not lexicon:
        _NEIGHBOURS.clear()
        found = _NEIGHBOURS[key] = Neighbours(rules, lexicon)
    return found


def _norm(text: str) -> str:
    return _CLEAN.sub("", text.lower().replace("\u2019", "'"))


def _meanings(rules) -> dict[str, frozenset[str]]:
    """Gesture -> the gestures of the same meaning (itself, and those a table entry lists with it,
    directions, pointing and counts apart: each of those is its own meaning)."""
    out: dict[str, set[str]] = {}
    for r in rules.rules:
        group = set(r.gestures) | ({r.suggest} if r.suggest else set())
        for g in group:
            out.setdefault(g, {g})
            if r.kind not in ("direction", "deixis", "counting"):
                out[g] |= group
    return {g: frozenset(s) for g, s in out.items()}


def _candidate(tok, reading, rules, library, near, question: bool, before, after):
    """(gesture, kind, via) for a word's reading, or None."""
    if reading.key is None:
        return None
    keys = [reading.key]
    if not reading.strict and tok.word != reading.key:
        keys.insert(0, tok.word)  # the table speaks for the word as written first ("grew" has its entry)
    for key in keys:
        entries = rules.for_word(key)
        if not entries:
            continue
        fitting = [r for r in entries if r.suggest in library and (reading.strict or r.fits(before, after, question))]
        if reading.kinds:
            fitting = [r for r in fitting if r.kind in reading.kinds] or fitting
        if fitting:
            r = fitting[0]
            where = "the built-in table" if r.source == "built-in" else r.source
            return r.suggest, r.kind, f"'{key}' in {where} ({r.kind})"
        return None  # the table speaks for this word: its contexts say no
    pos = _WN_POS.get(tok.tag)
    if near is None or pos not in OPEN_POS:
        return None
    seed = near.near(reading.key, pos)
    if seed is None:
        return None
    for r in rules.for_word(seed):
        if r.suggest in library and r.kind in OPEN_KINDS:
            return r.suggest, r.kind, f"WordNet: '{reading.key}' shares a sense with the table's '{seed}' ({r.kind})"
    return None


def suggest(script, library, rules, lexicon=...) -> list[Suggestion]:
    """Suggestions for every utterance of an analysed ``script`` (:func:`dsl.parser.analyse`),
    with gestures from ``library`` only, by ``rules`` (:class:`library.words.WordRules`) and the
    WordNet ``lexicon`` (:func:`library.lexicon.find_lexicon` when not given; None: the table alone)."""
    if lexicon is ...:
        lexicon = find_lexicon()
    near = neighbours(rules, lexicon)
    meanings = _meanings(rules)
    out: list[Suggestion] = []
    rank = {k: n for n, k in enumerate(PRIORITY)}
    for u in script.utterances:
        words = [w.text for w in u.words]
        n = len(words)
        if not n:
            continue
        toks = sense.read(words, u.text, [w.end for w in u.words], lexicon)
        marks = [(m.word_index if m.word_index is not None else m.after_word, m.name) for m in u.poses]
        marks = [(j, name) for j, name in marks if j is not None]
        marked = {j for j, _ in marks}
        candidates = []
        for i, tok in enumerate(toks):
            if any(abs(i - j) < SPACING_SOFT for j in marked):
                continue
            reading = sense.reading(toks, i, lexicon)
            before = toks[i - 1].word if i > 0 else None
            after = toks[i + 1].word if i + 1 < n else None
            found = _candidate(tok, reading, rules, library, near, tok.question, before, after)
            if found is None:
                continue
            gesture, kind, via = found
            same = meanings.get(gesture, frozenset({gesture}))
            if any(name in same and (abs(i - j) <= SAME_MEANING or toks[min(j, n - 1)].sentence == tok.sentence)
                   for j, name in marks):
                continue
            candidates.append((rank.get(kind, len(PRIORITY)), i, gesture, kind, reading.sense, via))
        joined = {toks[c[1]].sentence for c in candidates if c[3] == "union"}
        # "the two teams work together": the number counts the parties joined, the joining is the gesture
        candidates = [c for c in candidates if not (c[3] == "counting" and toks[c[1]].sentence in joined)]
        chosen: list[tuple] = []
        for c in sorted(candidates, key=lambda c: (c[0], c[1])):
            _, i, gesture, kind, _, _ = c
            counting = kind == "counting"
            soft = kind in SOFT
            per, gap = (WORDS_PER_SOFT, SPACING_SOFT) if soft else (WORDS_PER_MARK, SPACING)
            chained = counting and any(o[3] == "counting" and abs(i - o[1]) < gap for o in chosen)
            used = len(marked) + sum(1 for o in chosen if not o[6])
            room = max(1, n // per) if not marked else n // per
            if used >= room and not chained:
                continue
            if any(abs(i - o[1]) < max(gap, SPACING_SOFT if o[3] in SOFT else SPACING) and not (counting and o[3] == "counting")
                   for o in chosen):
                continue
            same = meanings.get(gesture, frozenset({gesture}))
            if not counting and any(o[2] in same and abs(i - o[1]) < SPACING_SOFT for o in chosen):
                continue  # "Hello, and welcome": one greeting is enough
            chosen.append((*c, chained))
        for _, i, gesture, kind, meaning, via, _ in sorted(chosen, key=lambda c: c[1]):
            where = u.words[i].where
            out.append(Suggestion(u.index, where.line, where.col, gesture, u.words[i].text, kind, meaning, via))
    return out


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
