"""What changed between two versions of a script, utterance by utterance (``sgt diff``).

A text diff of ``.sgt`` lines says that a line changed; a reviewer wants to know what the
character will do differently. :func:`diff_scripts` compiles both versions (estimated timing
by default: no speech engine; ``timing="speech"`` uses the cached or synthesized speech) and
compares their utterances:

- **Matching is by content**, not by line number: the utterances are aligned on (speaker,
  spoken words) with a longest-common-subsequence match (:mod:`difflib`), so a line inserted
  near the top does not make every later line "changed". Utterances left over on both sides
  are paired when their words are alike (a reworded line: ``changed``, with its text change),
  an utterance removed in one place and added with the same words in another is ``moved``,
  and the rest are ``added`` or ``removed``.
- **What changed in a matched utterance** (:class:`Change`, in this order): its text, its
  speaker, its voice (voice, rate, pitch), each pose control added, removed, moved to another
  word, or played otherwise (``x2``, ``flip``, ``hold=``), each style span added, removed,
  moved or with other values, each pause added, removed or longer/shorter, its ``@gap``, where
  it plays on the performance clock (a start that moved by a frame or more: ``retimed``, in
  seconds) and a length that changed.
- **What many utterances share is said once** (:func:`fold`): a header setting that changed
  (a speaker's ``@voice``/``@rate``/``@pitch``, the header's ``@gap`` and ``@seed``) is one
  :class:`HeaderChange`, and the lengths it changed go with it; a run of consecutive
  utterances that all start later or earlier because of an earlier change is one
  :class:`Shift`. Each utterance then lists only what else changed in it, and names the
  header changes and the shift that also apply to it; one with nothing else is ``affected``.
  A moved utterance keeps its own ``retimed`` (its new place, not an earlier change, moves it).
- An utterance with none of those is ``same`` (listed only with ``include_same``).

The result (:class:`ScriptDiff`) is plain data; :meth:`ScriptDiff.to_dict` is the JSON of
``sgt diff --format json`` (``"format": "sgt-diff"``; the schema is in docs/diff.md).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path

from core.skeleton import FPS

DIFF_FORMAT = "sgt-diff"
DIFF_VERSION = 2

#: Two left-over utterances whose words are at least this alike (difflib's ratio) are one
#: utterance reworded, not one removed and another added.
REWORDED = 0.5
#: Two shifts of a start this close (seconds) are the same shift.
SAME_SHIFT = 5e-4
#: The statuses of an utterance, in the order they are counted.
STATUSES = ("changed", "moved", "added", "removed", "affected", "same")


@dataclass(frozen=True)
class Change:
    """One difference of a matched utterance: ``kind`` (see :data:`KINDS`), what it is about
    (``what``: a gesture, a style, ``text``, ...), and the values before and after (``old``,
    ``new``: a word, a number, a text, None where there is none)."""

    kind: str
    what: str
    old: object = None
    new: object = None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "what": self.what, "old": self.old, "new": self.new}


#: The kinds of :class:`Change`, in the order they are listed.
KINDS = ("text", "speaker", "voice", "pose-added", "pose-removed", "pose-moved", "pose-options",
         "style-added", "style-removed", "style-moved", "style-values", "pause-added", "pause-removed",
         "pause-length", "gap", "retimed", "length")


@dataclass
class Side:
    """One version of an utterance: where it is and what it holds (for matching and showing)."""

    index: int
    line: int
    speaker: str | None
    text: str  # as a reader sees it: no tags
    words: tuple[str, ...]
    poses: list[tuple[str, dict, int | None, str]]  # (gesture, options, word index, word)
    styles: list[tuple[str, dict, int | None, int | None, str]]  # (name, values, first, last word, the words)
    pauses: list[tuple[float, int, str]]  # (seconds, before word, that word)
    voice: tuple[str, int, int]
    gap: float | None
    start: float | None  # seconds on the performance clock (None: the version did not compile)
    duration: float | None

    def key(self) -> tuple:
        return (self.speaker, tuple(w.lower() for w in self.words))

    def to_dict(self) -> dict:
        return {"index": self.index, "line": self.line, "speaker": self.speaker, "text": self.text,
                "start": None if self.start is None else round(self.start, 3),
                "duration": None if self.duration is None else round(self.duration, 3)}


@dataclass
class UtteranceDiff:
    """``status``: ``same``, ``changed``, ``moved`` (the same words elsewhere in the script,
    perhaps changed too), ``added``, ``removed`` or ``affected`` (nothing of its own changed:
    only a header change or a shift applies to it); ``old``/``new`` the two versions (one is
    None for added and removed); ``changes`` what changed in it alone; ``header`` and
    ``shift`` the indices of the :class:`HeaderChange` entries and the :class:`Shift` of
    :class:`ScriptDiff` that also apply to it."""

    status: str
    old: Side | None
    new: Side | None
    changes: list[Change] = field(default_factory=list)
    header: list[int] = field(default_factory=list)
    shift: int | None = None

    def to_dict(self) -> dict:
        return {"status": self.status, "old": self.old.to_dict() if self.old else None,
                "new": self.new.to_dict() if self.new else None, "changes": [c.to_dict() for c in self.changes],
                "header": list(self.header), "shift": self.shift}


@dataclass
class HeaderChange:
    """A header setting that changed, said once: ``kind`` ``voice`` (the voice, rate or pitch of
    ``speakers``: ``settings`` lists the directives that differ, ``old``/``new`` the whole
    voices), ``gap`` or ``seed`` (the header's); ``lines`` the new lines of the utterances it
    applies to (whose own changes leave it out), ``lengths`` (line, old, new seconds) of those
    whose length it alone changed."""

    kind: str
    speakers: list[str | None]
    settings: list[tuple[str, object, object]]  # (directive, old, new)
    old: object
    new: object
    lines: list[int] = field(default_factory=list)
    lengths: list[tuple[int, float, float]] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "speakers": list(self.speakers),
                "settings": [{"directive": d, "old": o, "new": n} for d, o, n in self.settings],
                "old": self.old, "new": self.new, "lines": list(self.lines),
                "lengths": [{"line": n, "old": round(o, 3), "new": round(b, 3)} for n, o, b in self.lengths]}


@dataclass
class Shift:
    """Consecutive utterances that start at another time because of a change before them:
    ``starts`` (new line, old start, new start) of each, by one amount or by amounts that
    drift where nothing listed in between explains it (a header's ``@rate`` or ``@gap``).
    ``to_end``: it runs to the new version's last utterance."""

    starts: list[tuple[int, float, float]] = field(default_factory=list)
    to_end: bool = False

    @property
    def lines(self) -> list[int]:
        return [n for n, _, _ in self.starts]

    @property
    def seconds(self) -> list[float]:
        """Each one's new start less its old one."""
        return [new - old for _, old, new in self.starts]

    @property
    def constant(self) -> bool:
        return max(self.seconds) - min(self.seconds) <= SAME_SHIFT

    def to_dict(self) -> dict:
        seconds = self.seconds
        return {"lines": self.lines, "to_end": self.to_end, "seconds": round(seconds[0], 3) if self.constant else None,
                "range": [round(min(seconds), 3), round(max(seconds), 3)],
                "starts": [{"line": n, "old": round(o, 3), "new": round(b, 3)} for n, o, b in self.starts]}


@dataclass
class ScriptDiff:
    """The utterances of two versions of one script, in the new version's order (removed ones
    where they were), what they share (``header``, ``shifts``: :func:`fold`), and the problems
    that kept either version from compiling (its timing is then unknown, and nothing is said
    about where utterances play)."""

    old_name: str
    new_name: str
    utterances: list[UtteranceDiff]
    timing: str
    problems: list[str] = field(default_factory=list)
    header: list[HeaderChange] = field(default_factory=list)
    shifts: list[Shift] = field(default_factory=list)

    @property
    def changed(self) -> list[UtteranceDiff]:
        return [u for u in self.utterances if u.status != "same"]

    def counts(self) -> dict[str, int]:
        out = dict.fromkeys(STATUSES, 0)
        for u in self.utterances:
            out[u.status] += 1
        return out

    def to_dict(self, include_same: bool = False) -> dict:
        return {"old": self.old_name, "new": self.new_name, "timing": self.timing, "counts": self.counts(),
                "problems": list(self.problems), "header": [h.to_dict() for h in self.header],
                "shifts": [s.to_dict() for s in self.shifts],
                "utterances": [u.to_dict() for u in self.utterances if include_same or u.status != "same"]}


def diff_scripts(old_text: str | None, new_text: str | None, *, old_name: str = "a.sgt", new_name: str = "b.sgt",
                 old_path: Path | str | None = None, new_path: Path | str | None = None,
                 timing: str = "estimate", library=None) -> ScriptDiff:
    """Compare two versions of a script (``None``: the file does not exist on that side: every
    utterance is added, or removed). ``*_path`` is where each version's relative ``@audio``
    and ``@library`` paths resolve from (default: the names); ``timing`` "estimate" (no speech
    engine) or "speech"."""
    problems: list[str] = []
    old, old_header = _sides(old_text, old_path or old_name, timing, library, problems, "old")
    new, new_header = _sides(new_text, new_path or new_name, timing, library, problems, "new")
    d = ScriptDiff(old_name, new_name, match(old, new), timing, problems)
    fold(d, old_header, new_header)
    return d


def _sides(text: str | None, path, timing: str, library, problems: list[str], which: str):
    """The utterances of one version, and its header (None: no such version)."""
    if text is None:
        return [], None
    from dsl.compiler import compile_file  # lazy: the compiler loads the library

    result = compile_file(Path(path), source=text, timing=timing, library=library)
    errors = [d for d in result.diagnostics if d.is_error]
    if errors:
        e = errors[0]
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        problems.append(f"the {which} version has errors, so where its lines play is unknown: "
                        f"{e.line}:{e.col}: {e.message}{more}")
    placed = {u.index: u for u in result.plan.utterances} if result.plan is not None and not errors else {}
    return [_side(u, placed.get(u.index)) for u in result.script.utterances], result.script.header


def _side(u, plan) -> Side:
    words = tuple(w.text for w in u.words)

    def word(i):
        return words[i] if i is not None and 0 <= i < len(words) else None

    poses = [(m.name, m.options, m.word_index, word(m.word_index if m.word_index is not None else m.after_word))
             for m in u.poses]
    styles = [(s.name, dict(s.values), s.first_word, s.last_word,
               " ".join(words[s.first_word : s.last_word + 1]) if s.first_word is not None and s.last_word is not None else "")
              for s in u.styles]
    pauses = [(p.seconds, p.word_index, word(p.word_index) or "(the end)") for p in u.pauses]
    return Side(u.index, u.line, u.speaker, u.display or " ".join(words), words, poses, styles, pauses,
                (u.voice.name, u.voice.rate, u.voice.pitch), u.gap,
                None if plan is None else plan.start + plan.audio_offset, None if plan is None else plan.duration)


# -- matching ----------------------------------------------------------------------------------


def match(old: list[Side], new: list[Side]) -> list[UtteranceDiff]:
    """Pair the utterances of two versions (see the module's docstring) and say what changed."""
    out: list[tuple[float, UtteranceDiff]] = []  # (where in the new order, the diff)
    sm = difflib.SequenceMatcher(a=[s.key() for s in old], b=[s.key() for s in new], autojunk=False)
    left_old: list[int] = []
    left_new: list[int] = []
    for tag, i1, i2, j1, j2 in sm.get_opcodes():
        if tag == "equal":
            for i, j in zip(range(i1, i2), range(j1, j2)):
                d = compare(old[i], new[j])
                out.append((j, UtteranceDiff("changed" if d else "same", old[i], new[j], d)))
        else:
            left_old += range(i1, i2)
            left_new += range(j1, j2)
    # the same words elsewhere: moved
    by_key: dict[tuple, list[int]] = {}
    for j in left_new:
        by_key.setdefault(new[j].key(), []).append(j)
    for i in list(left_old):
        js = by_key.get(old[i].key())
        if js:
            j = js.pop(0)
            left_old.remove(i)
            left_new.remove(j)
            out.append((j, UtteranceDiff("moved", old[i], new[j], compare(old[i], new[j]))))
    # reworded: the most alike pairs first, each side used once
    pairs = []
    for i in left_old:
        for j in left_new:
            if old[i].speaker == new[j].speaker or not old[i].words or not new[j].words:
                ratio = difflib.SequenceMatcher(a=[w.lower() for w in old[i].words],
                                                b=[w.lower() for w in new[j].words], autojunk=False).ratio()
                if ratio >= REWORDED:
                    pairs.append((-ratio, abs(i - j), i, j))
    for _, _, i, j in sorted(pairs):
        if i in left_old and j in left_new:
            left_old.remove(i)
            left_new.remove(j)
            out.append((j, UtteranceDiff("changed", old[i], new[j], compare(old[i], new[j]))))
    for j in left_new:
        out.append((j, UtteranceDiff("added", None, new[j], _contents(new[j], "added"))))
    for i in left_old:  # where it was: after the new utterance that follows its old neighbour
        out.append((_place_of_removed(i, old, new, out), UtteranceDiff("removed", old[i], None, _contents(old[i], "removed"))))
    return [d for _, d in sorted(out, key=lambda x: x[0])]


def _contents(side: Side, how: str) -> list[Change]:
    """The gestures, styles and pauses of an utterance added or removed whole, as changes."""
    out = []
    for c in side.poses:
        out.append(Change(f"pose-{how}", c[0], *((None, _where(c, "pose")) if how == "added" else (_where(c, "pose"), None))))
    for c in side.styles:
        out.append(Change(f"style-{how}", c[0], *((None, _where(c, "style")) if how == "added" else (_where(c, "style"), None))))
    return out


def _place_of_removed(i: int, old: list[Side], new: list[Side], placed) -> float:
    """A removed utterance's place in the new order: just after where its predecessor went."""
    for k in range(i - 1, -1, -1):
        for where, d in placed:
            if d.old is not None and d.new is not None and d.old.index == old[k].index:
                return where + 0.5
    return -0.5


# -- what many utterances share ---------------------------------------------------------------


def fold(d: ScriptDiff, old_header, new_header) -> None:
    """Say once what many utterances of ``d`` share (in place): header changes (from the
    utterances' voices, and the two headers' ``@gap`` and ``@seed`` when both are given),
    then the shifts of their starts; an utterance left with no change of its own is
    ``affected``. ``*_header``: the versions' headers (None: no such version)."""
    _fold_voices(d)
    if old_header is not None and new_header is not None:
        if old_header.gap != new_header.gap:
            d.header.append(HeaderChange("gap", [], [("@gap", old_header.gap, new_header.gap)], old_header.gap,
                                         new_header.gap))
        if old_header.seed != new_header.seed:
            d.header.append(HeaderChange("seed", [], [("@seed", old_header.seed, new_header.seed)], old_header.seed,
                                         new_header.seed))
    _fold_shifts(d)
    for u in d.utterances:
        if u.status == "changed" and not u.changes:
            u.status = "affected"


def _both(u: UtteranceDiff) -> bool:
    """Both versions, by the same speaker: what a header change applies to alike."""
    return u.old is not None and u.new is not None and u.old.speaker == u.new.speaker


def _fold_voices(d: ScriptDiff) -> None:
    """A speaker whose every utterance changed voice the same way: a header change, one for
    the speakers that changed alike; the length of an utterance that changed in nothing else
    goes with it."""
    seen: dict[str | None, set] = {}
    for u in d.utterances:
        if _both(u):
            seen.setdefault(u.new.speaker, set()).add((u.old.voice, u.new.voice))
    groups: dict[tuple, list[str | None]] = {}
    for speaker, pairs in seen.items():
        if len(pairs) == 1 and (pair := next(iter(pairs)))[0] != pair[1]:
            groups.setdefault(pair, []).append(speaker)
    for (old, new), speakers in groups.items():
        settings = [(name, a, b) for name, a, b in zip(("@voice", "@rate", "@pitch"), old, new, strict=True) if a != b]
        h = HeaderChange("voice", speakers, settings, _voice(old), _voice(new))
        index = len(d.header)
        d.header.append(h)
        for u in d.utterances:
            if not _both(u) or u.new.speaker not in speakers:
                continue
            u.header.append(index)
            h.lines.append(u.new.line)
            u.changes = [c for c in u.changes if c.kind != "voice"]
            length = next((c for c in u.changes if c.kind == "length"), None)
            if length is not None and all(c.kind in ("length", "retimed") for c in u.changes):
                u.changes.remove(length)
                h.lengths.append((u.new.line, u.old.duration, u.new.duration))


def _fold_shifts(d: ScriptDiff) -> None:
    """Consecutive ``changed`` utterances whose starts moved: one :class:`Shift` while they
    move by the same amount, or while nothing listed explains another amount (a change of the
    one before or of this one, such as its ``@gap``; a header change is not listed there); a
    moved, added, removed or unmoved utterance ends it."""
    run: Shift | None = None
    before = False  # the utterance before lists a change of its own
    for k, u in enumerate(d.utterances):
        retimed = next((c for c in u.changes if c.kind == "retimed"), None) if u.status == "changed" else None
        if retimed is None:
            run = None
            continue
        explained = before or any(c is not retimed for c in u.changes)
        if run is None or (explained and abs(u.new.start - u.old.start - run.seconds[-1]) > SAME_SHIFT):
            run = Shift()
            d.shifts.append(run)
        run.starts.append((u.new.line, u.old.start, u.new.start))
        run.to_end = all(v.new is None for v in d.utterances[k + 1:])
        u.shift = len(d.shifts) - 1
        u.changes.remove(retimed)
        before = bool(u.changes)


# -- what changed ------------------------------------------------------------------------------


def compare(a: Side, b: Side) -> list[Change]:
    """What changed from ``a`` to ``b`` (two versions of one utterance), in :data:`KINDS` order."""
    out: list[Change] = []
    if a.words != b.words or a.text != b.text:
        out.append(Change("text", "text", a.text, b.text))
    if a.speaker != b.speaker:
        out.append(Change("speaker", "speaker", a.speaker, b.speaker))
    if a.voice != b.voice:
        out.append(Change("voice", "voice", _voice(a.voice), _voice(b.voice)))
    out += _controls(a.poses, b.poses, "pose", a, b)
    out += _controls(a.styles, b.styles, "style", a, b)
    out += _pauses(a, b)
    if (a.gap or 0.0) != (b.gap or 0.0) and (a.gap is not None or b.gap is not None):
        out.append(Change("gap", "@gap", a.gap, b.gap))
    if a.start is not None and b.start is not None and abs(b.start - a.start) >= 1.0 / FPS - 1e-9:
        out.append(Change("retimed", "start", round(a.start, 3), round(b.start, 3)))
    if a.duration is not None and b.duration is not None and abs(b.duration - a.duration) >= 1.0 / FPS - 1e-9:
        out.append(Change("length", "length", round(a.duration, 3), round(b.duration, 3)))
    order = {k: n for n, k in enumerate(KINDS)}
    return sorted(out, key=lambda c: order[c.kind])


def _voice(v: tuple[str, int, int]) -> str:
    return f"{v[0]} rate {v[1]} pitch {v[2]}"


def _controls(olds, news, kind: str, a: Side, b: Side) -> list[Change]:
    """Pose or style controls matched by name (in order), then compared: added, removed, on
    another word, or with other options/values. A word is compared by its text and its place
    among the words (the n-th "the"), so rewording elsewhere in the line moves nothing."""
    out = []
    left = list(news)
    pairs = []
    for o in olds:
        same_name = [n for n in left if n[0] == o[0]]
        if not same_name:
            out.append(Change(f"{kind}-removed", o[0], _where(o, kind), None))
            continue
        # the one on the same word first, else the first
        n = next((n for n in same_name if _anchor(n, kind, b) == _anchor(o, kind, a)), same_name[0])
        left.remove(n)
        pairs.append((o, n))
    for o, n in pairs:
        if _anchor(o, kind, a) != _anchor(n, kind, b):
            out.append(Change(f"{kind}-moved", o[0], _where(o, kind), _where(n, kind)))
        if o[1] != n[1]:
            what = "options" if kind == "pose" else "values"
            out.append(Change(f"{kind}-{what}", o[0], _options(o[1], kind), _options(n[1], kind)))
    for n in left:
        out.append(Change(f"{kind}-added", n[0], None, _where(n, kind)))
    return out


def _anchor(c, kind: str, side: Side):
    """The words a control is on, as (text, which occurrence) pairs."""
    if kind == "pose":
        return _occurrence(side.words, c[2])
    return (_occurrence(side.words, c[2]), _occurrence(side.words, c[3]))


def _occurrence(words, i):
    if i is None or not 0 <= i < len(words):
        return None
    w = words[i].lower()
    return (w, sum(1 for x in words[:i] if x.lower() == w))


def _where(c, kind: str) -> str:
    if kind == "pose":
        return c[3] or "(no word)"
    return c[4] or "(no words)"


def _options(opts: dict, kind: str) -> str:
    if kind == "pose":
        parts = [f"x{opts.get('speed', 1)}"]
        if opts.get("flip"):
            parts.append("flip")
        if opts.get("hold"):
            parts.append(f"hold={opts['hold']:g}s")
        return " ".join(parts)
    return " ".join(f"{k}:{v:+g}" for k, v in sorted(opts.items()))


def _pauses(a: Side, b: Side) -> list[Change]:
    """Pauses matched by the word they come before (its text and occurrence)."""
    old = {_occurrence(a.words, p[1]) if p[1] < len(a.words) else ("(end)", 0): p for p in a.pauses}
    new = {_occurrence(b.words, p[1]) if p[1] < len(b.words) else ("(end)", 0): p for p in b.pauses}
    out = []
    for k, p in old.items():
        if k not in new:
            out.append(Change("pause-removed", "pause", f"{p[0]:g}s before {p[2]}", None))
        elif new[k][0] != p[0]:
            out.append(Change("pause-length", "pause", p[0], new[k][0]))
    for k, p in new.items():
        if k not in old:
            out.append(Change("pause-added", "pause", None, f"{p[0]:g}s before {p[2]}"))
    return out
