"""Scores `sgt suggest` on tests/data/suggest_labels.txt (its format is described there).

:func:`evaluate` returns the counts: of the calls (words that call for a gesture), how many got
an acceptable gesture (``hit``), a gesture that is not (``wrong``) or none (``missed``); and of
the suggestions, how many landed on a word that calls for none (``spurious``).
"""

from __future__ import annotations

import re
from pathlib import Path

DATA = Path(__file__).resolve().parent / "data"
LABELS = DATA / "suggest_labels.txt"
#: The fresh set, split once: tune on DEV only; TEST gives the figures.
DEV = DATA / "suggest_dev.txt"
TEST = DATA / "suggest_test.txt"
#: A second development set, labelled before the suggester ran on it: a rule tuned on DEV is checked here too.
VAL = DATA / "suggest_val.txt"
_CLEAN = re.compile(r"[^a-z0-9']+")


def read_labels(path: Path = LABELS) -> list[tuple[str, list[list[tuple[str, int, set[str]]]]]]:
    """(sentence, calls): each call a list of alternatives (word, occurrence, acceptable gestures)."""
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        text, _, labels = line.partition(" ||")
        calls = []
        for call in filter(None, (c.strip() for c in labels.split(";"))):
            alts = []
            for alt in call.split(" / "):
                word, _, gestures = alt.partition(":")
                word, _, nth = word.strip().partition("@")
                alts.append((word.lower(), int(nth or 1), set(gestures.split())))
            calls.append(alts)
        out.append((text.strip(), calls))
    return out


def evaluate(labels=None) -> dict:
    from dsl.parser import analyse
    from dsl.suggest import suggest
    from library import load_library
    from library.words import load_word_rules

    labels = read_labels() if labels is None else labels
    lib, rules = load_library(use_config=False), load_word_rules()
    counts = {"sentences": len(labels), "calls": 0, "hit": 0, "wrong": 0, "missed": 0, "suggestions": 0, "spurious": 0}
    mistakes = []
    for text, calls in labels:
        script = analyse(f"s: {text}\n", "labels.sgt")
        (u,) = script.utterances
        words = [_CLEAN.sub("", w.text.lower()) for w in u.words]

        def key(i, words=words):
            return (words[i], words[: i + 1].count(words[i]))

        got = {key(i): s for s in suggest(script, lib, rules)
               for i, w in enumerate(u.words) if w.where.col == s.col}
        counts["suggestions"] += len(got)
        covered = set()
        for alts in calls:
            counts["calls"] += 1
            keys = [(w, n) for w, n, _ in alts]
            covered.update(keys)
            found = [(k, got[k]) for k in keys if k in got]
            if any(s.gesture in acc for (w, n, acc) in alts for k, s in found if k == (w, n)):
                counts["hit"] += 1
            elif found:
                counts["wrong"] += 1
                mistakes.append(f"wrong: {text} -> {found[0][1].gesture} on {found[0][0][0]}")
            else:
                counts["missed"] += 1
                mistakes.append(f"missed: {text} ({alts[0][0]})")
        for k, s in got.items():
            if k not in covered:
                counts["spurious"] += 1
                mistakes.append(f"spurious: {text} -> {s.gesture} on {k[0]}")
    counts["mistakes"] = mistakes
    return counts


def report(c: dict) -> str:
    calls, sugg = max(1, c["calls"]), max(1, c["suggestions"])
    return (f"{c['sentences']} sentences, {c['calls']} words that call for a gesture: {c['hit']} got an acceptable "
            f"one ({c['hit'] / calls:.1%}), {c['wrong']} a wrong one ({c['wrong'] / calls:.1%}), {c['missed']} none; "
            f"{c['suggestions']} suggestions, {c['spurious']} on words that call for none ({c['spurious'] / sugg:.1%})")
