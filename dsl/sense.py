"""What a word means where it stands, before a gesture is chosen for it (:mod:`dsl.suggest`).

A gesture table maps words to gestures, but a word is spelt the same in all its senses: "right"
is a direction in "on your right" and a judgement in "the right answer"; "one" counts in "one
ticket" and does not in "one of them", "one moment" or "from one to twelve"; "back" is a place
in "the back door" and a return in "I'll be right back". This module reads an utterance's words
(:func:`read`) and says, for each, what it means here (:class:`Reading`): the table word it
stands for (``key``: the word itself, its base form, or the word of its sense: "went up" said of
prices stands for "rise"), or that it calls for no gesture here, and why.

How it reads, by the project's own rules over WordNet (no statistical tagger: docs/library.md,
"The lexical resource", says why and what it costs):

- **parts of speech** from a closed-class lexicon (determiners, pronouns, prepositions,
  auxiliaries, conjunctions, numbers) and, for the open classes, WordNet's parts of speech with
  their corpus counts (:mod:`library.lexicon`), chosen by the words around (after a determiner
  a noun or an adjective, after "to" or a modal a verb, after a copula an adjective, a clause's
  first word an imperative); base forms by WordNet's morphy ("dropped" -> drop, "better" -> good);
- **clauses** split at punctuation and conjunctions, with whether they are questions, conditions
  ("if you press...") and what negation covers ("not a big effect": the negation, not the size,
  carries the gesture);
- **senses** of the words that need one, by their role: directions (left, right, back, up,
  down, here, there), numbers and ordinals (a count, an item of a list, a place in a row, a
  range, a pronoun, a unit of time), negation and its idioms ("no problem", "don't worry"),
  pronouns (the speaker, the addressee against a generic "you"), and the idioms that turn a word
  to another sense ("one moment" asks to wait, "that's right" agrees).

With no WordNet installed the open classes are guessed from suffixes alone and words outside
the table find no neighbour; the closed-class rules still hold.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

# -- the closed classes ----------------------------------------------------------------------

DET = frozenset(["the", "a", "an", "this", "that", "these", "those", "my", "your", "his", "her", "its", "our", "their", "some", "any", "no", "every", "each", "all", "both", "another", "either", "neither", "which", "what", "whose", "such"])
POSSESSIVE = frozenset(["my", "your", "his", "her", "its", "our", "their"])
SUBJECT = frozenset(["i", "you", "he", "she", "it", "we", "they"])
PRON = frozenset(["i", "me", "you", "he", "him", "she", "her", "it", "we", "us", "they", "them", "myself", "yourself", "himself", "herself", "itself", "ourselves", "themselves", "mine", "yours", "ours", "theirs", "hers", "someone", "somebody", "anyone", "anybody", "everyone", "everybody", "nobody", "something", "anything", "everything", "nothing", "none"])
CONTRACTED = {"i'm": "i", "i've": "i", "i'll": "i", "i'd": "i", "you're": "you", "you've": "you", "you'll": "you",
              "you'd": "you", "we're": "we", "we've": "we", "we'll": "we", "we'd": "we", "they're": "they",
              "they'll": "they", "it's": "it", "that's": "that", "there's": "there", "here's": "here",
              "let's": "us", "he's": "he", "she's": "she", "what's": "what", "who's": "who", "where's": "where"}
COPULA = frozenset(["am", "is", "are", "was", "were", "be", "been", "being", "'s", "'re", "seems", "seem", "seemed", "looks", "look", "looked", "feel", "feels", "felt", "got", "get", "gets", "become", "becomes", "became", "stays", "stay", "remain", "remains", "sounds", "sound"])
MODAL = frozenset(["will", "would", "shall", "should", "can", "could", "may", "might", "must", "'ll", "'d", "cannot"])
AUX = frozenset(["am", "is", "are", "was", "were", "be", "been", "being", "have", "has", "had", "do", "does", "did"]) | MODAL
NEGATIVE_AUX = frozenset(["isn't", "aren't", "wasn't", "weren't", "don't", "doesn't", "didn't", "won't", "wouldn't", "can't", "cannot", "couldn't", "shouldn't", "haven't", "hasn't", "hadn't", "mustn't", "ain't"])
ADP = frozenset(["in", "on", "at", "to", "from", "by", "with", "about", "into", "onto", "over", "under", "above", "below", "behind", "beside", "between", "through", "across", "around", "along", "against", "among", "after", "before", "during", "for", "of", "off", "out", "up", "down", "near", "past", "since", "until", "till", "toward", "towards", "within", "without", "upon", "inside", "outside", "beyond", "via", "like"])
CONJ = frozenset(["and", "or", "but", "nor", "so", "yet"])
SCONJ = frozenset(["if", "when", "while", "because", "although", "though", "unless", "whenever", "whereas", "once", "as", "whether"])
CONDITION = frozenset(["if", "when", "whenever", "once", "unless"])
WH = frozenset(["what", "where", "why", "how", "who", "which", "when", "whom", "whose"])
INTJ = frozenset(["hello", "hi", "hey", "bye", "goodbye", "yes", "yeah", "no", "oh", "oops", "wow", "shh", "please", "ok", "okay", "alright", "thanks", "farewell", "hooray", "yay", "welcome", "greetings"])
#: Adverbs that are only adverbs here (WordNet also has "still" as a verb, "just" as an adjective).
ADVERBS = frozenset(["still", "just", "also", "even", "only", "already", "always", "never", "often", "really", "very", "quite", "too", "then", "now", "soon", "again", "almost", "ever", "yet", "so", "suddenly", "finally"])
NUMBERS = {"zero": 0, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
           "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "twenty": 20, "thirty": 30, "forty": 40, "fifty": 50,
           "sixty": 60, "hundred": 100, "thousand": 1000, "million": 10 ** 6, "billion": 10 ** 9}
ORDINALS = {"first": 1, "second": 2, "third": 3, "fourth": 4, "fifth": 5, "firstly": 1, "secondly": 2, "thirdly": 3,
            "last": 0, "next": 0}
NEGATORS = frozenset(["no", "not", "never", "nothing", "nobody", "none", "neither", "nor", "cannot", "nowhere"]) | NEGATIVE_AUX
#: Verbs after which "left", "right", "up", ... are a way to go.
HANDING = frozenset(("give", "hand", "pass", "bring"))
MOTION = frozenset(["turn", "turns", "turned", "turning", "go", "goes", "going", "went", "gone", "keep", "keeps", "kept", "bear", "head", "heads", "move", "moves", "moved", "look", "looks", "looked", "looking", "step", "veer", "swing", "lean", "leaning", "walk", "walks", "walked", "climb", "climbed", "climbs", "point", "points", "pointed", "glance", "glanced", "drive", "stay", "stays"])
#: Nouns a direction word can be the side of ("the left hand", "the right door").
SPATIAL = frozenset(["side", "hand", "wing", "door", "doors", "window", "windows", "wall", "walls", "exit", "entrance", "corner", "lane", "aisle", "bank", "corridor", "hallway", "staircase", "stairs", "lift", "elevator", "tower", "column", "row", "shelf", "drawer", "pocket", "seat", "screen", "panel", "button", "path", "road", "street", "fork", "turn", "edge", "margin", "flank", "field", "hemisphere", "half", "picture", "figure", "image", "photo", "page"])
#: Adjectives of size: with a noun or after a copula they are a size whatever the word before.
SIZE_WORDS = frozenset(["big", "huge", "large", "enormous", "giant", "gigantic", "massive", "vast", "immense", "tall", "small", "tiny", "little", "minuscule"])
#: Nouns an ordinal counts as an item of a list ("the second step") rather than a place in a row.
LIST_ITEMS = frozenset(["step", "steps", "stage", "stages", "phase", "point", "points", "thing", "things", "reason", "reasons", "option", "options", "rule", "rules", "question", "questions", "part", "lesson", "idea", "ideas", "problem", "problems", "example", "examples", "way", "method", "principle", "factor", "sign", "tip", "task", "goal", "choice", "feature", "advantage", "benefit", "item", "bag", "rule"])
#: The kinds of noun (WordNet's lexicographer files) an ordinal counts off as items ("the second
#: guest", "the first cause", "the third chapter"); before the others (things, places, times,
#: amounts: "the second staircase", "the first day", "the second half") it is a place in a row.
COUNTED = frozenset(["noun.person", "noun.event", "noun.feeling", "noun.cognition", "noun.communication", "noun.motive"])
#: Nouns a quantity is ("prices went up": a rise, not a place above).
QUANTITY = frozenset(["price", "prices", "fee", "fees", "cost", "costs", "rate", "rates", "number", "numbers", "sales", "profit", "profits", "temperature", "temperatures", "speed", "level", "levels", "value", "values", "balance", "bill", "bills", "rent", "tax", "taxes", "score", "scores", "population", "demand", "supply", "income", "salary", "wages", "count", "total", "amount", "share", "shares", "stock", "stocks", "unemployment", "inflation", "pressure", "volume"])
#: Words of the closed classes: never the noun an adjective stands before ("the giant was ...").
CLOSED = AUX | NEGATIVE_AUX | PRON | DET | CONJ | SCONJ | frozenset(CONTRACTED)
_CLEAN = re.compile(r"[^a-z0-9']+")
_BREAK = re.compile(r"[,;:.?!()\u2014\u2013]|--| - ")


def norm(text: str) -> str:
    """A word as the table has it: lower case, letters, digits and apostrophes."""
    return _CLEAN.sub("", text.lower().replace("\u2019", "'"))


@dataclass
class Token:
    """One word of an utterance, read: ``tag`` a coarse part of speech (NOUN VERB ADJ ADV NUM ORD
    PRON DET ADP CONJ SCONJ AUX NEG WH INTJ PART), ``lemma`` its base form; ``clause`` and
    ``sentence`` count from 0; ``pause`` the punctuation right after it ("" for none)."""

    text: str
    word: str
    tag: str = ""
    lemma: str = ""
    clause: int = 0
    sentence: int = 0
    question: bool = False
    condition: bool = False
    negated: int | None = None  # the index of the negator whose scope holds this word
    pause: str = ""
    start: bool = False  # the first word of its clause
    poses: tuple[str, ...] = ()  # WordNet's parts of speech for it, most used first


@dataclass(frozen=True)
class Reading:
    """What word ``index`` means here: ``key`` the table word it is looked up as (None: no
    gesture here), ``sense`` in words (for ``--explain``), ``strict``: the key comes from a
    sense rule (the table entry's word contexts, written for the word itself, are not applied);
    ``kinds``: the table kinds the sense allows (empty: any)."""

    index: int
    key: str | None
    sense: str
    strict: bool = False
    kinds: frozenset[str] = field(default_factory=frozenset)


# -- reading: parts of speech, clauses, negation ----------------------------------------------------


def read(words: list[str], text: str, ends: list[int], lexicon=None) -> list[Token]:
    """The tokens of an utterance: its words as written (``words``), its text and where each
    word ends in it (``ends``)."""
    toks = [Token(w, norm(w)) for w in words]
    for i, t in enumerate(toks):
        after = text[ends[i]: (ends[i + 1] - len(words[i + 1])) if i + 1 < len(toks) else len(text)]
        t.pause = "".join(ch for ch in after if not ch.isspace())
    _clauses(toks)
    for i, t in enumerate(toks):
        t.poses = _poses(t.word, lexicon)
    for i, t in enumerate(toks):
        t.tag = _tag(toks, i)
        t.lemma = _lemma(t, lexicon)
    _negation(toks)
    return toks


def _clauses(toks: list[Token]) -> None:
    clause = sentence = 0
    start = True
    for t in toks:
        if t.word in CONJ | SCONJ and not start and t.word not in ("so", "as", "once"):
            clause += 1
            start = True
        t.clause, t.sentence, t.start = clause, sentence, start
        start = False
        if _BREAK.search(t.pause):
            clause += 1
            start = True
            if any(ch in t.pause for ch in ".?!"):
                sentence += 1
    # a sentence's question mark and a clause's condition
    by_sentence: dict[int, list[Token]] = {}
    for t in toks:
        by_sentence.setdefault(t.sentence, []).append(t)
    for ts in by_sentence.values():
        q = "?" in ts[-1].pause
        for t in ts:
            t.question = q
    by_clause: dict[int, list[Token]] = {}
    for t in toks:
        by_clause.setdefault(t.clause, []).append(t)
    for ts in by_clause.values():
        cond = ts[0].word in CONDITION and len(ts) > 1 and (ts[1].word in SUBJECT | DET or ts[1].word in CONTRACTED)
        for t in ts:
            t.condition = cond


def _poses(word: str, lexicon) -> tuple[str, ...]:
    if lexicon is None or not word or not word[0].isalpha():
        return ()
    scored = []
    for pos in ("n", "v", "a", "r"):
        forms = lexicon.base_forms(word, pos)
        if forms:
            e = lexicon.entry(forms[0], pos)
            exact = forms[0] == word
            scored.append((-(e.tagged * (1 if exact else 0.5) + (1 if exact else 0)), pos))
    return tuple(p for _, p in sorted(scored))


def _tag(toks: list[Token], i: int) -> str:
    t = toks[i]
    w = t.word
    prev = toks[i - 1] if i > 0 and toks[i - 1].clause == t.clause else None
    nxt = toks[i + 1] if i + 1 < len(toks) else None
    if w in NUMBERS or w.isdigit():
        return "NUM"
    if w in ORDINALS:
        return "ORD"
    if w in NEGATORS:
        return "NEG"
    if w in ADVERBS:
        return "ADV"
    if w in CONTRACTED:
        return "PRON"
    if w in WH:
        return "WH"
    if w in ("to",):
        return "PART" if nxt is not None and "v" in nxt.poses[:1] and nxt.word not in DET else "ADP"
    if w in AUX:
        return "AUX"
    if w in DET and w not in ("that", "no"):
        if w in ("this", "these", "those", "all", "both", "each") and (nxt is None or nxt.word in ADP | AUX or t.pause):
            return "PRON"
        return "DET"
    if w == "that":
        return "DET" if nxt is not None and nxt.poses[:1] == ("n",) else "PRON"
    if w in PRON:
        return "PRON"
    if w in CONJ:
        return "CONJ"
    if w in SCONJ and w not in ("once", "as"):
        return "SCONJ"
    if w in ("up", "down", "out", "off", "back", "away", "over", "around", "in", "on") and (
            nxt is None or t.pause or nxt.word in ADP | CONJ | {"and", "again"} or nxt.tag == "ADV"):
        return "ADV" if w not in ("in", "on") else "ADP"
    if w in ADP:
        return "ADP"
    if w in INTJ and (t.pause or nxt is None or i == 0):
        return "INTJ"
    poses = t.poses
    if not poses:
        if w.endswith("ly"):
            return "ADV"
        if w.endswith(("ing", "ed")):
            return "VERB"
        return "NOUN"
    pw = prev.word if prev is not None else None
    pt = prev.tag if prev is not None else None
    can = set(poses)
    if pt in ("DET", "ADJ", "NUM", "ORD") or (pw in POSSESSIVE):
        if "a" in can and nxt is not None and ("n" in nxt.poses or nxt.word.endswith("s")) and nxt.tag != "ADP" and (
                nxt.word not in CLOSED):
            return "ADJ"
        if "a" in can and pt == "ADJ" and nxt is not None and nxt.word in CLOSED:
            return "ADJ"  # "much better this year"
        if "n" in can:
            return "NOUN"
        if "a" in can:
            return "ADJ"
    if pw in ("have", "has", "had", "having", "'ve") and "v" in can and w.endswith(("ed", "en", "wn", "ne", "ht", "t")):
        return "VERB"
    if "v" in can and (pt == "PART" or pw in MODAL or pw in NEGATIVE_AUX | {"let's", "please", "do", "did", "does"}):
        return "VERB"
    if pw in COPULA and "a" in can:
        return "ADJ"
    if pt == "PRON" and pw in SUBJECT | set(CONTRACTED) | {"nobody", "everyone", "someone"} and "v" in can:
        return "VERB"
    if prev is None and "v" in can and (nxt is None or nxt.word in DET | PRON | ADP | {"me", "us", "it"} or t.pause):
        return "VERB"  # a clause's first word: an imperative
    if w.endswith("ly") and "r" in can:
        return "ADV"
    if w.endswith("ed") and "v" in can and pt in ("NOUN", "PRON"):
        return "VERB"
    return {"n": "NOUN", "v": "VERB", "a": "ADJ", "r": "ADV"}[poses[0]]


def _lemma(t: Token, lexicon) -> str:
    w = CONTRACTED.get(t.word, t.word)
    pos = {"NOUN": "n", "VERB": "v", "ADJ": "a", "ADV": "r"}.get(t.tag)
    if lexicon is None or pos is None:
        return w
    forms = lexicon.base_forms(w, pos)
    if pos == "a" and len(forms) > 1 and forms[0] == w and w in lexicon.exceptions("a"):
        return forms[1]  # "better" -> good, "worse" -> bad: the comparative's base
    return forms[0] if forms else w


def _negation(toks: list[Token]) -> None:
    """Each word after a negator, up to its clause's end, is in its scope."""
    for i, t in enumerate(toks):
        if t.tag == "NEG" and not _idiom_negation(toks, i):
            for j in range(i + 1, len(toks)):
                if toks[j].clause != t.clause or toks[j].word in ("but",):
                    break
                if toks[j].negated is None:
                    toks[j].negated = i


def _idiom_negation(toks: list[Token], i: int) -> str | None:
    """Why the negator at ``i`` negates nothing a gesture shows ("no problem", "not only",
    "why not", "isn't it?"), or None."""
    w = toks[i].word
    nxt = toks[i + 1].word if i + 1 < len(toks) else None
    prev = toks[i - 1].word if i > 0 else None
    if w == "no" and nxt in ("problem", "worries", "doubt", "matter", "longer", "wonder", "rush", "hurry"):
        return f"'no {nxt}' is an idiom"
    if w == "not" and nxt in ("only", "just", "yet", "to"):
        return f"'not {nxt}' negates no statement"
    if w == "not" and prev in ("why", "perhaps", "maybe", "probably", "or", "if"):
        return f"'{prev} not' negates no statement"
    if w in NEGATIVE_AUX and nxt in SUBJECT and toks[i].clause != toks[i - 1].clause if i else False:
        return "a question tag"
    if w == "never" and nxt == "mind":
        return "'never mind' is an idiom"
    if w == "never" and prev == "you" and nxt == "know":
        return "'you never know' is an idiom"
    return None


# -- senses ---------------------------------------------------------------------------------------


def _prev(toks, i, n=1):
    return toks[i - n] if i - n >= 0 else None


def _next(toks, i, n=1):
    return toks[i + n] if i + n < len(toks) else None


def _w(t) -> str | None:
    return t.word if t is not None else None


def _noun_after(toks, i) -> Token | None:
    """The noun that the word at ``i`` modifies (the next word, past adjectives), if any."""
    for j in range(i + 1, min(len(toks), i + 4)):
        t = toks[j]
        if t.tag == "NOUN" or (t.tag == "ADJ" and t.word.endswith("s") and "n" in t.poses):
            return t
        if t.tag not in ("ADJ", "ADV") or toks[j - 1].pause:
            return None
    return None


def _lexname(lexicon, word: str, pos: str = "n") -> str:
    if lexicon is None:
        return ""
    forms = lexicon.base_forms(word, pos)
    if not forms:
        return ""
    e = lexicon.entry(forms[0], pos)
    return lexicon.synset(e.senses[0], pos).lexname if e and e.senses else ""


def _is_time(lexicon, word: str) -> bool:
    return word in ("moment", "second", "minute", "hour", "day", "time", "while") or _lexname(lexicon, word) == "noun.time"


def reading(toks: list[Token], i: int, lexicon=None) -> Reading:
    """What word ``i`` of ``toks`` means here (:class:`Reading`)."""
    t = toks[i]
    w = t.word
    if t.tag == "NEG":
        why = _idiom_negation(toks, i)
        if why is not None:
            return _no(i, why)
        first = next((j for j in range(i) if toks[j].tag == "NEG" and toks[j].sentence == t.sentence
                      and _idiom_negation(toks, j) is None), None)
        if first is not None:
            return _no(i, f"the sentence's negation is already on '{toks[first].word}'")
    for rule in _RULES:
        r = rule(toks, i, lexicon)
        if r is not None:
            return r
    if t.negated is not None and t.tag in ("ADJ", "ADV", "VERB", "NOUN") and w not in ("everything", "all"):
        neg = toks[t.negated].word
        return Reading(i, None, f"under the negation '{neg}': the negation carries the gesture",
                       kinds=frozenset())
    return Reading(i, t.lemma or w, _describe(t))


def _describe(t: Token) -> str:
    name = {"NOUN": "a noun", "VERB": "a verb", "ADJ": "an adjective", "ADV": "an adverb", "NUM": "a number",
            "ORD": "an ordinal", "PRON": "a pronoun", "DET": "a determiner", "ADP": "a preposition",
            "CONJ": "a conjunction", "SCONJ": "a conjunction", "AUX": "an auxiliary", "NEG": "a negation",
            "WH": "a question word", "INTJ": "an interjection", "PART": "a particle"}.get(t.tag, "a word")
    base = f" (base form '{t.lemma}')" if t.lemma and t.lemma != CONTRACTED.get(t.word, t.word) else ""
    return f"'{t.word}' as {name}{base}"


def _no(i, why) -> Reading:
    return Reading(i, None, why)


def _as(i, key, why, *kinds) -> Reading:
    return Reading(i, key, why, True, frozenset(kinds))


# Each rule: (toks, i, lexicon) -> Reading or None (the next rule decides).

def _idioms(toks, i, lex):
    t = toks[i]
    w = t.word
    p, n = _w(_prev(toks, i)), _w(_next(toks, i))
    pp = _w(_prev(toks, i, 2))
    # waiting: "one moment", "just a second", "hold on", "please hold"
    if w in ("one", "a") and n in ("moment", "second", "sec", "minute") and not (_next(toks, i, 2) and _next(toks, i, 2).tag == "NOUN"):
        return _as(i, "wait", f"'{w} {n}' asks the listener to wait", "command") if w == "one" else None
    if w in ("second", "moment", "minute", "sec") and p in ("a", "one") and pp in ("just", "wait", None) and t.start is False:
        if p == "one":
            return _no(i, f"'one {w}': the wait is on 'one'")
        return _as(i, "wait", f"'{p} {w}' asks the listener to wait", "command")
    if w == "hold" and (n == "on" or p == "please" or t.pause) and t.tag != "NOUN":
        return _as(i, "wait", f"'{w}{' on' if n == 'on' else ''}' asks the listener to wait", "command")
    if w == "there's" and n not in ("the", "my", "your", "our", "his", "her", "their", "that"):
        return _no(i, f"'there's {n or ''}'".rstrip() + ": 'there' introduces, it points nowhere")
    if w == "thank" and n == "you":
        return None
    if w == "you" and p in ("thank", "see", "mind"):
        return _no(i, f"'{p} you' is a formula, not a pointing")
    if w in ("worry", "worries") and p in ("don't", "no"):
        return _as(i, "calm", f"'{p} {w}' calms", "calming")
    if w in ("don't", "no") and n in ("worry", "worries"):
        return _no(i, f"'{w} {n}': the calming is on '{n}'")
    if w in ("know", "idea", "sure") and p in ("don't", "not", "no", "dunno", "didn't", "doesn't"):
        return _as(i, "maybe", f"'{p} {w}': not knowing", "uncertainty")
    if w in ("don't", "not", "no", "didn't") and n in ("know", "sure", "idea"):
        return _no(i, f"'{w} {n}': the shrug is on '{n}'")
    if w == "not" and n == "bad":
        return _as(i, "so-so", "'not bad': fair, praise held back", "evaluation")
    if w == "bad" and p == "not":
        return _no(i, "'not bad': the gesture is on 'not'")
    if w == "did" and p == "we" and n == "it":
        return _as(i, "hooray", "'we did it': a victory", "celebration")
    if w == "done" and p == "well":
        return _as(i, "good", "'well done': praise", "evaluation")
    if w in ("right", "correct") and p in ("that's", "you're", "exactly", "quite", "absolutely", "all") and p != "all":
        return _as(i, "yes", f"'{p} {w}': agreeing", "affirmation")
    if w == "right" and p not in MOTION and (p == "all" or (i == 0 and t.pause) or n in ("now", "away", "here", "there", "back", "after",
                                                                          "before", "behind", "next", "then", "in",
                                                                          "at", "on", "under", "above", "below", "ahead")):
        if p == "all":
            return _no(i, "'all right' agrees, no direction")
        if i == 0 and t.pause:
            return _no(i, f"'{w}' opening a sentence is a discourse marker")
        return _no(i, f"'right {n}': 'right' is 'exactly' here")
    if w == "nice" and n == "to":
        return _no(i, "'nice to meet': the handshake is on 'meet'")
    if w == "meet" and n == "you" and p == "to":
        return _as(i, "handshake", "'to meet you': a greeting with the hand", "greeting")
    if w in ("good",) and n in ("morning", "afternoon", "evening", "night", "luck", "bye"):
        return _no(i, f"'good {n}' is a formula")
    if w == "how" and n in ("can", "may") and _w(_next(toks, i, 2)) in ("i", "we") and _w(_next(toks, i, 3)) == "help":
        return _no(i, "'how can I help' is a service formula")
    if w in ("deal",) and (t.pause and i == 0):
        return _as(i, "handshake", "'deal!': an agreement sealed", "greeting")
    if w == "oops":
        return _as(i, "oops", "'oops': a slip", "evaluation")
    return None


def _directions(toks, i, lex):
    t = toks[i]
    w = t.word
    if w not in ("left", "right", "back", "up", "down", "ahead", "behind", "past", "top", "bottom", "here", "there",
                 "around", "round"):
        return None
    p, n = _prev(toks, i), _next(toks, i)
    pw, nw = _w(p), _w(n)
    if w in ("left", "right"):
        if pw in ("on", "to", "the", "your", "my", "his", "her", "their", "our", "far") and (
                n is None or t.pause or nw in ADP | CONJ | {"and", "is", "are", "was"} or nw in SPATIAL):
            return _as(i, w, f"'{w}' as a direction (a side: '{pw} {w}')", "direction")
        if pw in MOTION or (p is not None and p.lemma in MOTION) or pw in ("then", "and") and _w(_prev(toks, i, 2)) in MOTION | {"left", "right"}:
            return _as(i, w, f"'{w}' as a direction (a way to go: '{pw} {w}')", "direction")
        if nw in SPATIAL:
            return _as(i, w, f"'{w}' as a direction (the {w} {nw})", "direction")
        if w == "right" and (pw in COPULA or pw in ("be",)) and (n is None or t.pause or n.tag != "NOUN"):
            return _as(i, "yes", "'right' after a copula: correct", "affirmation")
        if w == "left" and t.tag in ("VERB",) or pw in SUBJECT | set(CONTRACTED) | {"have", "has", "had", "is", "are",
                                                                                      "nothing", "nobody", "anything"}:
            return _no(i, "'left' as a verb (went away, remains)")
        if n is not None and n.tag == "NOUN":
            return _no(i, f"'{w} {nw}': {'correct, fitting' if w == 'right' else 'a side that is not a place'}")
        return _no(i, f"'{w}' is no direction here")
    if w == "back":
        pl = p.lemma if p is not None else None
        if pw in ("then",) or nw in ("then", "in", "when") and (i == 0 or pw in ("way", "years", "long")):
            return _as(i, "ago", "'back then': the past, behind", "time")
        if pw in ("the", "its", "his", "her", "my", "your", "their") and nw == "of":
            return _as(i, "behind", "'the back of': a place behind", "direction")
        if pw == "the" and (n is None or t.pause or nw in SPATIAL | {"door", "row", "room", "yard", "wall", "seat", "garden", "office"}):
            return _as(i, "behind", "'the back': a place behind", "direction")
        if pw == "the" and n is not None and n.tag == "NOUN":
            return _as(i, "behind", f"'the back {nw}': a place behind", "direction")
        if pl in ("come", "be", "go", "get", "call", "give", "bring", "write", "plug", "put", "look", "walk", "turn",
                  "pay", "send", "hold", "stand", "step", "fight", "run", "head", "want", "take") or pw in (
                "right", "it", "them", "me", "you", "her", "him", "way", "all") or pw in SUBJECT:
            if pl in ("stand", "step") and i + 1 < len(toks) and (t.pause or n is None):
                return _as(i, "stop", f"'{pw} back': keep away", "command")
            return _no(i, f"'{pw} back': a return, no place")
        if p is not None and p.tag in ("VERB",):
            return _no(i, f"'{pw} back': a return, no place")
        if pw in POSSESSIVE | {"its"}:
            return _no(i, "'back' as a body part or side")
        return None
    if w in ("up", "down"):
        pl = p.lemma if p is not None else None
        if pw == "upside" or (w == "down" and pl in ("calm", "slow", "settle", "quiet", "sit", "shut", "break", "burn",
                                                      "broke", "burned", "write", "note", "track", "turn", "let")):
            if pl in ("calm", "slow", "settle", "quiet"):
                return None
            return _no(i, f"'{pw} {w}': a phrasal verb, no direction")
        if w == "down" and pw in ("voice", "volume") or (pw in ("it",) and _w(_prev(toks, i, 2)) == "keep"):
            return _as(i, "calm", "'keep it down': quieter", "calming")
        if pl in ("go", "went", "gone", "come", "be", "move", "shoot", "jump", "creep", "crept") or pw in ("went", "gone", "goes", "going", "gone"):
            subject = [x for x in toks[max(0, i - 6): i] if x.clause == t.clause and x.tag == "NOUN"]
            if subject and (subject[-1].word in QUANTITY or _lexname(lex, subject[-1].word) in ("noun.quantity", "noun.possession", "noun.attribute")):
                key = "rise" if w == "up" else "fall"
                return _as(i, key, f"'{pw} {w}' said of '{subject[-1].word}': a quantity {'rising' if w == 'up' else 'falling'}", "change")
            if pl in ("go", "went", "gone") and not subject and i > 0 and toks[i - 1].start:
                return _as(i, w, f"'{pw} {w}' as a direction", "direction")
            return _as(i, w, f"'{pw} {w}' as a direction", "direction") if pl in ("go", "move", "crept", "creep") and nw in DET | {"there", "the", "in", "to", "at", "from"} else None
        if pl in ("look", "point", "climb", "climbed"):
            return _as(i, w, f"'{pw} {w}': a direction", "direction")
        if (i == 0 or t.start or pw in ("far", "way", "right", "up", "down", "over", "deep")) and (
                nw in ("there", "here", "in", "at", "on", "the", "to") or pw in ("far",)):
            return _as(i, w, f"'{w} {nw}': a place {'above' if w == 'up' else 'below'}", "direction")
        if nw in ("there", "here") or pw in ("lies", "live", "lives", "sits") or (
                pw in COPULA and nw in ("in", "on", "at", "above", "by", "near", "among")):
            return _as(i, w, f"'{w}' as a place", "direction")
        return None
    if w in ("ahead",):
        return _as(i, "ahead", "'ahead': in front", "direction")
    if w == "past":
        if pw == "the" or pw == "in":
            return _as(i, "ago", "'the past': behind, back then", "time")
        return _no(i, "'past' as a preposition or adjective")
    if w in ("top", "bottom"):
        if pw == "the" and nw in ("of", None) or pw in ("at", "on") or t.pause:
            return _as(i, "upstairs" if w == "top" else "downstairs", f"'the {w}': a place {'above' if w == 'top' else 'below'}",
                       "direction")
        return _no(i, f"'{w}' is no place here")
    if w in ("around", "round"):
        if n is not None and (n.tag == "NUM" or nw in ("noon", "midnight")):
            return _no(i, f"'{w} {nw}': about, roughly")
        if pw in ("gather", "come", "all", "turn", "go", "way", "and", "sit", "dance", "danced", "skated", "walk", "fly"):
            return _as(i, "circle", f"'{pw} {w}': in a ring", "shape")
        if n is None or t.pause or nw in ("it", "them", "the", "him", "her") and p is not None and p.tag == "VERB":
            return _as(i, "circle", f"'{w}': all round", "shape")
        return None
    if w == "there":
        if n is not None and not t.pause and n.tag == "VERB" and pw not in ("over", "up", "down", "out", "right", "in"):
            return _no(i, f"'there {nw}': 'there' introduces, it points nowhere")
        if pw in ("over", "up", "down", "out", "right") or (pw in MOTION and (n is None or t.pause)):
            return _as(i, "there", f"'{pw} there': a place pointed at", "deixis")
        if t.tag == "ADV" and (n is None or t.pause) and p is not None and p.tag in ("VERB", "NOUN"):
            return None
        return None
    if w == "here":
        if pw in ("over", "in", "right", "from", "up", "down") or t.start and i == 0:
            return _as(i, "here", f"'{pw or ''} here': this place".replace("' here", "here"), "deixis")
        return None
    if w == "behind":
        if nw in ("you", "me", "us", "the", "them", "him", "her", "this", "that") or n is None or t.pause:
            return _as(i, "behind", "'behind': a place at the back", "direction")
        return None
    return None


def _counting(toks, i, lex):
    t = toks[i]
    w = t.word
    if w not in NUMBERS and w not in ORDINALS and w not in ("once", "twice", "both", "pair", "couple", "thousands",
                                                            "millions", "billions"):
        return None
    p, n = _prev(toks, i), _next(toks, i)
    pw, nw = _w(p), _w(n)
    value = NUMBERS.get(w) or ORDINALS.get(w)
    # a list said aloud: "one, two, three"
    neighbours = [x for x in (p, n) if x is not None and x.word in NUMBERS and (x is p and p.pause or x is n and t.pause)]
    if w in NUMBERS and neighbours:
        return _as(i, w, f"'{w}' counting aloud (a list of numbers)", "counting")
    if w in ("once", "twice"):
        if w == "once" and n is not None and not t.pause and (n.tag == "VERB" or n.word.endswith("ed") and "v" in n.poses):
            return _no(i, f"'once {nw}': formerly, not a count")
        if w == "once" and (pw in ("at", "all") or nw in ("upon", "again", "more") or (n is not None and (
                n.word in SUBJECT or n.word in CONTRACTED or n.word in POSSESSIVE or n.word in ("the", "this", "that")))):
            return _no(i, f"'{w}' as 'when' or an idiom, not a count")
        return _as(i, w, f"'{w}': how many times", "counting")
    if w == "both":
        if n is not None and n.tag in ("NOUN", "ADJ") or pw in ("of",) or nw == "of" or nw in DET - {"no"}:
            return _as(i, w, f"'both {nw}': two of them", "counting")
        return _no(i, "'both' without a noun to count")
    if w in ("pair", "couple"):
        return None
    if w in ("last", "next"):
        return None
    if w in ORDINALS:
        if t.start and (t.pause or n is None or (n.tag in ("PRON", "VERB", "DET") and not _is_time(lex, nw or ""))):
            return _as(i, w, f"'{w}' opening a clause: an item of a list", "counting")
        if w in ("second",) and (pw in ("a", "one", "every", "per", "each") or nw in ("later", "ago")):
            return _no(i, "'second' as a unit of time")
        noun = _noun_after(toks, i)
        if pw in ("the", "my", "your", "our", "its", "their", "his", "her", "in") and noun is not None:
            after = _next(toks, toks.index(noun))
            if noun.word in LIST_ITEMS or noun.lemma in LIST_ITEMS or (
                    _lexname(lex, noun.lemma or noun.word) in COUNTED and not (after is not None and after.word == "of")):
                return _as(i, w, f"'{w} {noun.word}': an item of a list", "counting")
            return _no(i, f"'{w} {noun.word}': a place in a row or a time, not an item counted off")
        if nw == "of" and pw == "the":
            return _no(i, f"'the {w} of': a place in a row")
        if pw in ("the",) and (n is None or t.pause or (n is not None and n.tag in ("AUX", "VERB"))):
            return _no(i, f"'the {w}': one in a row")
        return _no(i, f"'{w}' as a rank, not a count")
    # cardinal numbers
    if w in ("thousand", "million", "billion") and pw == "a" or w in ("thousands", "millions", "billions") and nw == "of":
        return _as(i, "huge", f"'{w}': a great many", "size")
    if value is None or value > 5:
        return _no(i, f"'{w}': no hand counts it") if value else None
    if pw in ("from", "between") or nw in ("to", "and", "or") and _w(_next(toks, i, 2)) in NUMBERS or (pw in ("to",) and _prev(toks, i, 2) is not None and _prev(toks, i, 2).tag == "NUM"):
        if nw == "or":
            return _as(i, w, f"'{w} or ...': a rough count", "counting")
        return _no(i, f"'{w}' as an end of a range, not a count")
    if nw == "of" and (_w(_next(toks, i, 2)) in ("the", "us", "them", "you", "these", "those", "my", "our", "your", "its", "their", "her", "his")):
        if w == "one":
            return _no(i, "'one of': picking one out, not counting")
        if _w(_next(toks, i, 2)) in ("us", "them", "you") and pw == "the":
            return _no(i, f"'the {w} of {_w(_next(toks, i, 2))}': a group, not a count")
    if w == "one":
        if pw in DET | {"no", "the", "any", "every", "this", "that", "which", "each", "new", "lovely", "red", "big",
                        "small", "chosen", "little", "old", "good", "only", "another"} or (p is not None and p.tag == "ADJ"):
            if pw == "only" and n is not None and n.tag == "NOUN":
                return _as(i, w, f"'only one {nw}': a count", "counting")
            return _no(i, f"'{pw} one': a pronoun, not a count")
        if nw in ("by", "another", "more", "way", "day", "time", "thing", "hand", "side", "night", "morning", "after",
                  "point", "stage", "moment"):
            return _no(i, f"'one {nw}': an idiom, not a count")
        if n is not None and _is_time(lex, nw) and n.tag == "NOUN":
            return _no(i, f"'one {nw}': a time, not a count")
        if n is not None and n.tag in ("NOUN", "ADJ"):
            return _as(i, w, f"'one {nw}': a count", "counting")
        return _no(i, "'one' as a pronoun")
    if pw in ("the", "these", "those", "its", "our", "your", "their", "my") and n is not None and n.tag in ("NOUN", "ADJ"):
        return _no(i, f"'{pw} {w} {nw}': a group already known, not counted off")
    if p is not None and p.tag == "NOUN" and p.word not in QUANTITY and not p.start and not p.word.endswith("'s"):
        return _no(i, f"'{pw} {w}': a name or a number, not a count")
    if p is not None and p.tag == "NOUN" and p.start:
        return _no(i, f"'{pw} {w}': a name, not a count")
    if n is not None and (n.tag in ("NOUN", "ADJ") or n.word.endswith("s")):
        return _as(i, w, f"'{w} {nw}': a number of things", "counting")
    if pw in ("any", "all", "these", "those", "the") or nw in ("of",):
        return _as(i, w, f"'{w}': a count", "counting")
    return _no(i, f"'{w}' without anything to count")


def _pronouns(toks, i, lex):
    t = toks[i]
    w = t.word
    base = CONTRACTED.get(w, w)
    if base not in ("i", "me", "my", "mine", "myself", "you", "your", "yours", "yourself", "we", "us", "our", "ours",
                    "ourselves"):
        return None
    p, n = _prev(toks, i), _next(toks, i)
    pw, nw = _w(p), _w(n)
    if base in ("you", "your", "yours", "yourself"):
        if t.condition:
            return _no(i, f"'{w}' in a condition ('{toks[_clause_start(toks, i)].word} ...'): a generic 'you'")
        if pw in ("thank", "see", "mind", "to", "for", "with", "of") and w == "you" and (n is None or t.pause):
            return _no(i, f"'{pw} you': the listener is not pointed at")
        if base == "your":
            return _no(i, "'your' as a possessive: no pointing")
        if t.question:
            return _no(i, f"'{w}' in a question: the question carries the gesture")
        if sum(1 for x in toks if CONTRACTED.get(x.word, x.word) in ("you", "your")) > 1 and any(x.condition for x in toks):
            return _no(i, f"'{w}' in a general statement: a generic 'you'")
        if nw in MODAL | {"can", "can't", "need", "have", "get", "will", "never", "might", "would", "should", "must",
                          "may", "were", "had"} and base == "you" and w == "you":
            return _no(i, f"'you {nw}': instructions or a generic 'you', no pointing")
        if base == "yours" and pw == "not":
            return _as(i, w, f"'not {w}': the listener, in contrast", "deixis")
        if w == "you're" and n is not None and (n.tag in ("ADJ", "DET", "VERB", "ADV") or nw in ("the", "a", "free")):
            return _as(i, w, f"'{w}': the listener, spoken about", "deixis")
        if w == "you" and i == 0 or (w == "you" and n is not None and n.lemma in ("look", "seem")):
            return _as(i, w, "'you': the listener, spoken about", "deixis")
        if w == "you" and p is not None and p.tag == "VERB" and p.lemma in ("value", "love", "trust", "need", "thank", "miss", "like"):
            return _as(i, w, f"'{pw} you': the listener", "deixis")
        return _no(i, f"'{w}': no stress on the listener")
    if base in ("we", "us", "our", "ours", "ourselves"):
        if t.question or t.condition:
            return _no(i, f"'{w}' in a {'question' if t.question else 'condition'}")
        if pw in ("let", "with", "to", "of", "at", "for") and w != "ours":
            return _no(i, f"'{pw} {w}': no stress on the group")
        group = _as(i, "we", f"'{w}': the speaker's group", "deixis")
        if base in ("us",) and pw in ("join", "follow", "with", "is", "safe", "help"):
            return group
        if base in ("our", "ours") and not (p is not None and p.tag in ("DET", "ADJ")):
            return group
        if base == "we" and (t.start or i == 0 or (p is not None and p.tag in ("ADV", "INTJ", "NOUN"))) and not any(
                x.word in ("the", "way") for x in toks[max(0, i - 2): i]):
            return group
        return _no(i, f"'{w}' in a subordinate phrase: no stress on the group")
    # the speaker
    if t.question:
        return _no(i, f"'{w}' in a question")
    if base in ("i",):
        nxt_lemma = n.lemma if n is not None else None
        if nw in ("think", "guess", "mean", "suppose", "believe", "see", "hear", "know", "understand", "can", "could",
                  "hope", "feel", "wonder", "agree", "just", "don't", "didn't", "can't", "am", "was", "'m") or nxt_lemma in (
                "think", "believe", "understand", "hear", "see", "hope"):
            return _no(i, f"'{w} {nw}': a hedge or a routine 'I', no stress on the speaker")
        if w in ("i'll", "i'd") or nw in ("will", "shall", "want", "need", "never", "promise", "swear", "myself") or (
                w == "i'm" and n is not None and n.text[:1].isupper()):
            return _as(i, "i", f"'{w} {nw}': the speaker, stressed", "deixis")
        return _no(i, f"'{w} {nw}': a routine 'I', no stress on the speaker")
    if base in ("me", "myself"):
        if p is not None and p.tag == "VERB" and p.lemma in HANDING and not t.question:
            return _as(i, "me", f"'{pw} {w}': asking to be given", "deixis")
        if pw in ("let", "show", "tell", "follow", "give", "excuse", "help", "hear", "with", "to", "for", "disagree") and not (
                pw == "let" and nw in ("show", "tell", "take", "introduce")):
            if pw == "to" and (n is None or t.pause):
                return _as(i, "me", f"'to {w}': the speaker", "deixis")
            return _no(i, f"'{pw} me': no stress on the speaker")
        return _as(i, "me", f"'{w}': the speaker", "deixis")
    if base in ("my", "mine"):
        if p is not None and p.tag == "VERB" and not t.start and p.lemma not in ("steal", "stole"):
            return _no(i, f"'{w}' as a possessive after a verb: no stress on the speaker")
        if t.start and nw not in ("heart",):
            return _no(i, f"'{w}' opening a clause: a routine possessive")
        return _as(i, "my", f"'{w}': the speaker's own", "deixis")
    return None


def _clause_start(toks, i) -> int:
    j = i
    while j > 0 and toks[j - 1].clause == toks[i].clause:
        j -= 1
    return j


def _roles(toks, i, lex):
    """Words whose gesture depends on their part of speech or role."""
    t = toks[i]
    w, lemma = t.word, t.lemma
    p, n = _prev(toks, i), _next(toks, i)
    pw, nw = _w(p), _w(n)
    if lemma in ("believe", "guess", "suppose", "reckon", "expect", "feel", "think", "wonder") and (
            pw in SUBJECT or pw in MODAL or pw in ("do", "don't", "you", "i")) and not (
            lemma in ("think", "wonder") and (nw in ("about", "of", "hard", "carefully", "twice", "over") or
                                              nw == "it" and _w(_next(toks, i, 2)) == "over")):
        return _no(i, f"'{pw} {w}': a hedge, not thinking shown")
    if lemma in ("think", "wonder", "ponder", "consider"):
        if pw in ("let", "me", "to", "must", "need", "should") or t.start and (t.pause or nw in ("about", "of", "it", "carefully", "hard")) or nw in ("about", "of", "it", "hard", "carefully", "twice", "over"):
            return _as(i, "ponder", f"'{w}' as thinking it over", "cognition")
        if pw in SUBJECT or pw in ("you", "do", "don't"):
            return _no(i, f"'{pw} {w}': a hedge, not thinking shown")
        return None
    if lemma in ("remember", "recall"):
        if pw in ("i",) and n is not None:
            return _as(i, "remember", f"'{w}': recalling the past", "cognition")
        if pw in ("to",):
            return _as(i, "remember", f"'to {w}': keep it in mind", "cognition")
        return None
    if lemma in ("stop", "wait", "halt") and t.tag == "NOUN":
        return _no(i, f"'{w}' as a noun (a place, a pause): nobody is asked to stop")
    if lemma == "stop" and w != "stop":
        return _no(i, f"'{w}' tells of stopping, it does not ask for it")
    if lemma == "meet" and not (t.start or pw in ("please", "let's", "and")):
        return _no(i, f"'{w}' tells of a meeting, no coming together shown")
    if lemma == "understand" and pw not in ("i", "we", "totally", "completely", "fully"):
        return _no(i, f"'{pw} {w}': no agreement shown")
    if w in ("waiting", "waited") and (pw in COPULA or pw in ("be", "been", "keep", "kept")) and w != "wait":
        return _no(i, f"'{pw} {w}': telling of waiting, not asking for it")
    if w in ("floor", "floors") and p is not None and (p.tag == "ORD" or pw in ("ground", "top", "upper", "lower", "main")):
        return _no(i, f"'{pw} {w}': a storey, not a place below")
    if w in ("floor", "ground", "sky", "ceiling", "floors") and not any(
            x.word in ("at", "on", "to", "onto", "into", "from", "toward", "towards", "under", "up", "down", "off")
            for x in toks[max(0, i - 3): i] if x.clause == t.clause):
        return _no(i, f"'{w}' named, not pointed at (no 'on the', 'to the' before it)")
    if w == "well" and nw == "done":
        return _no(i, "'well done': the praise is on 'done'")
    if t.tag == "ADJ" and lemma in SIZE_WORDS and (n is not None and n.tag == "NOUN" or pw in COPULA or t.start):
        return _as(i, lemma, f"'{w}' as a size{f' (of {nw})' if n is not None and n.tag == 'NOUN' else ''}", "size")
    if w == "little" and nw == "one":
        return _no(i, "'little one': a way of calling someone")
    if w == "little" and pw == "a" and (n is None or n.tag != "NOUN" or nw in ("bit", "more", "less", "while")):
        return _no(i, "'a little': a degree, not a size")
    if w in ("bit",) and pw in ("a",):
        return _no(i, "'a bit': a degree, not a size")
    if w in ("short",) and (n is None or n.tag != "NOUN"):
        return _no(i, "'short' of time or length of talk")
    if w == "giant" and t.tag == "NOUN" and pw not in ("a", "an"):
        return _no(i, "'the giant': a character named, its size already shown")
    if w == "key":
        if n is not None and n.tag == "NOUN" and pw in ("the", "a", "is", "key", "one"):
            return _as(i, "important", f"'key {nw}': what matters most", "emphasis")
        return _no(i, "'key' as a thing, not a stress")
    if lemma in ("join",):
        if nw in ("us", "me", "them"):
            return _as(i, "come", f"'{w} {nw}': an invitation", "invitation")
        if pw in ("for", "thanks", "thank") or (p is not None and p.tag == "ADP"):
            return _no(i, f"'{pw} {w}': no invitation")
        return _as(i, "unite", f"'{w}': coming together", "union")
    if lemma in ("follow", "come") and (pw in SUBJECT - {"you"} or pw in ("always", "often", "never", "usually")):
        return _no(i, f"'{pw} {w}' tells, it does not invite")
    if lemma in ("follow", "come"):
        if nw in ("me", "us", "here", "with", "in", "along", "on", "closer", "inside") or (w == "come" and (n is None or t.pause)):
            if nw in ("back", "from", "true", "out", "up", "down"):
                return _no(i, f"'{w} {nw}' is no invitation")
            if w in ("followed", "came", "comes", "follows", "coming", "following"):
                return _no(i, f"'{w}' tells, it does not invite")
            return None
        return _no(i, f"'{w}' tells, it does not invite")
    if lemma in ("take",):
        if nw in ("this", "these", "it", "my", "one") and (t.start or pw in ("please", "here")):
            return _as(i, "offer", f"'{w} {nw}': handing it over", "exchange")
        return _no(i, f"'{w}' as taking, not offering")
    if lemma in HANDING and nw in ("me", "us") and t.tag == "VERB":
        return _no(i, f"'{w} {nw}': the asking is on '{nw}'")
    if lemma in ("give", "offer", "share") and t.tag == "VERB":
        if nw in ("up", "back", "in", "away", "way") or (nw in ("it", "them") and _w(_next(toks, i, 2)) in ("back", "up", "away")):
            return _no(i, f"'{w} {nw}': no offering")
        return _as(i, "offer", f"'{w}': offering", "exchange")
    if lemma in ("easy",) and not (pw == "it" and _w(_prev(toks, i, 2)) == "take" or t.start or pw in ("go",)):
        return _no(i, "'easy' as 'not hard', no calming")
    if lemma in ("slowly", "gently") and p is not None and p.tag == "VERB" and p.lemma in ("read", "say", "speak", "explain"):
        return None
    if w == "always" and p is not None and p.tag in ("NOUN", "PRON") or (w == "always" and nw in ("said", "says", "told")):
        return _no(i, "'always' as a habit, no whole shown")
    if w == "all" and (nw in ("night", "day", "week", "year", "morning", "evening", "the", "at", "right", "set", "over",
                              "along", "alone", "ready", "this", "that", "i", "we", "you", "in")
                       or pw in ("at", "not", "that's", "is", "after", "once") or (pw in ("you", "them", "us", "we", "they", "it") and nw not in ("together",) and not t.pause and n is not None)):
        if nw == "the" and _w(_next(toks, i, 2)) not in ("way", "time", "same"):
            return _as(i, "all", f"'all the {_w(_next(toks, i, 2))}': the whole of them", "totality")
        if pw in ("them", "they") and nw in ("lived", "together") or (pw == "you" and t.pause):
            return None
        return _no(i, f"'{pw or ''} all {nw or ''}'".replace("' all", "'all").replace(" '", "'") + ": an idiom, no whole")
    if w == "must":
        return _no(i, "'must' as a modal: an obligation or a guess, the stress falls on what follows")
    if w in ("every", "each", "all") and n is not None and n.tag == "NOUN" and _is_time(lex, nw):
        return _no(i, f"'{w} {nw}': how often, not the whole of anything")
    if w in ("every", "everything", "everyone", "everybody", "whole", "entire") and t.condition:
        return _no(i, f"'{w}' in a condition")
    if w in ("lost",) and t.tag == "VERB" and nw == "everything":
        return _no(i, "'lost everything': the whole is on 'everything'")
    if w in ("fall", "drop", "rise") and t.tag == "NOUN" and pw not in ("a", "the", "sharp", "steep"):
        return _no(i, f"'{w}' as a noun (a season, a drop of)")
    if w in ("well",) and p is not None and p.tag == "VERB" and p.lemma in ("fight", "do", "play", "sing", "work", "write", "cook", "fought", "did"):
        return _as(i, "good", f"'{pw} well': praise", "evaluation")
    if w in ("sure",) and i > 0 and p is not None and pw not in ("not",) and not t.start:
        return _no(i, "'sure' inside a sentence: no agreement shown")
    if w in ("wrong",) and n is not None and n.tag == "NOUN":
        return _as(i, "oops", f"'wrong {nw}': a slip", "evaluation")
    if w in ("questions",) and not t.question and pw not in ("any",):
        return _no(i, "'questions' in a statement")
    if w in ("great",) and (t.start or pw in COPULA or (n is not None and n.tag != "NOUN") or (n is not None and nw in (
            "job", "idea", "question", "news", "work", "day", "time", "choice", "answer", "team", "fun"))):
        return _as(i, "good", f"'{w}' as praise, not size", "evaluation")
    if lemma in ("cheer",) and t.tag == "VERB":
        return _as(i, "hooray", f"'{w}': cheering", "celebration")
    if w in ("future",) and pw in ("the",):
        return _as(i, "future", "'the future': ahead in time", "time")
    if w in ("choice", "compare", "choose") and (w != "choose" or nw == "between"):
        return _as(i, "weigh", f"'{w}': weighing options", "contrast")
    if w == "why" and t.question:
        return None
    return None


_RULES = (_idioms, _directions, _counting, _pronouns, _roles)
