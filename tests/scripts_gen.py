"""Generated multi-speaker scripts for the parity of `sgt check`, `sgt edit` and `sgt lsp`
(tests/test_parity.py): 2 to 5 speakers, ``[look:NAME]`` at speakers of the script, at names it
lacks, at the speaker itself, at a speaker spelt in another case and at directions; ``<face:...>``
spans (some misspelt) and ``[face:...]`` written as a tag; ``@voice``, ``@rate`` and ``@pitch``
for speakers (some for no line's speaker, some in another case); speakers spelt in two cases;
pose controls close enough to overlap, pauses, interruptions (a negative ``@gap``), continuation
lines and the speaker-colon slip (``guide:[pose:nod] Yes.``). Deterministic for a seed."""

from __future__ import annotations

import random

NAMES = ["guide", "visitor", "ann", "bob", "cara", "knight", "merchant"]
STRANGERS = ["dave", "visiter", "gide", "nobody"]
DIRECTIONS = ["left", "right", "up", "down", "ahead"]
WORDS = ["hello", "there", "we", "have", "three", "new", "shops", "on", "the", "ground", "floor", "and", "a", "cinema",
         "upstairs", "so", "take", "lift", "behind", "you", "then", "turn", "left", "at", "fountain", "will", "see",
         "big", "blue", "sign"]
GESTURES = ["wave", "nod", "point_right", "open_arms", "beat_both", "shrug"]
FACES = ["smile", "sad", "surprised", "calm"]


def script(seed: int) -> str:
    """One script; about one in six has an error (a misspelt gesture or expression, a ``[face:...]`` tag)."""
    rng = random.Random(seed)
    speakers = rng.sample(NAMES, rng.randint(2, 5))
    variant = {s: s.capitalize() for s in speakers if rng.random() < 0.15}  # a speaker also spelt in another case
    erroneous = rng.random() < 0.17
    lines: list[str] = []
    if rng.random() < 0.5:
        lines.append("@voice en-us")
    for s in speakers:
        r = rng.random()
        if r < 0.25:
            lines.append(f"@voice {s}: en-gb")
        elif r < 0.35:
            lines.append(f"@rate {s}: {rng.choice([140, 160, 200])}")
        elif r < 0.4:
            lines.append(f"@pitch {s.capitalize()}: 60")  # the speaker in another case: a warning
    if rng.random() < 0.25:
        lines.append(f"@voice {rng.choice(STRANGERS)}: en-gb")  # for no line's speaker
    preset = "shy" if rng.random() < 0.3 else "happy"
    if preset == "shy":
        lines.append("@preset shy = space:-2 handedness:-1")
    if lines and rng.random() < 0.5:
        lines.append("")
    for n in range(rng.randint(3, 9)):
        who = rng.choice(speakers)
        if who in variant and rng.random() < 0.4:
            who = variant[who]
        if n and rng.random() < 0.15:
            lines.append(f"@gap -{rng.choice([200, 400, 900])}ms")
        lines += _utterance(rng, who, speakers + list(variant.values()), preset, erroneous and n == 1)
    return "\n".join(lines) + "\n"


def _utterance(rng: random.Random, who: str, speakers: list[str], preset: str, broken: bool) -> list[str]:
    words = rng.sample(WORDS, rng.randint(3, 12))
    pieces: list[str] = []
    for i, word in enumerate(words):
        r = rng.random()
        if r < 0.2:
            pieces.append(_look(rng, who, speakers))
        elif r < 0.3:
            pieces.append(f"[pose:{rng.choice(GESTURES)}{rng.choice(['', ' x2', ' x3'])}]")
        elif r < 0.33:
            pieces.append(f"[pause {rng.choice([200, 500])}ms]")
        elif r < 0.36:  # two strokes a word apart: the second is late (SGT401)
            pieces.append("[pose:open_arms] " + word + " [pose:point_right x2]")
            continue
        if r > 0.9 and i + 2 < len(words):  # an expression over the next words
            pieces.append(f"<face:{rng.choice(FACES)}>{word} {words[i + 1]}</face>" if rng.random() < 0.6 else
                          f"<{preset}>{word}</{preset}>")
            continue
        pieces.append(word)
    if broken:
        pieces.insert(rng.randrange(len(pieces) + 1), rng.choice(["[pose:wavee]", "[face:smile]", "<face:smiel>hi</face>"]))
    body = " ".join(pieces) + rng.choice([".", "!", "?"])
    r = rng.random()
    if r < 0.06:  # the speaker-colon slip, with a mark first or a word first
        return [f"{who}:{rng.choice(['[pose:nod]', '[look:left]', '<happy>', 'hello'])} {body}"]
    if r < 0.1:
        return [f"{body}"]  # no speaker
    if r < 0.2 and len(pieces) > 4:  # a continuation line
        cut = body.rfind(" ", 0, len(body) // 2)
        if cut > 0:
            return [f"{who}: {body[:cut]}", f"    {body[cut + 1:]}"]
    return [f"{who}: {body}"]


def _look(rng: random.Random, who: str, speakers: list[str]) -> str:
    r = rng.random()
    target = (rng.choice(speakers) if r < 0.45 else rng.choice(STRANGERS) if r < 0.6 else who if r < 0.67
              else rng.choice(speakers).upper() if r < 0.75 else rng.choice(DIRECTIONS))
    return f"[look:{target}{rng.choice(['', '', ' hold=1s'])}]"
