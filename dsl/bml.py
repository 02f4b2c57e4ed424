"""BML (the Behavior Markup Language of Greta, SmartBody and AsapRealizer): written from a
compiled script, and read back into one.

Writing (:func:`write_bml`): per utterance one ``<bml>`` block, in order, inside one
``<sgt:performance>`` root: the speech's text with a ``<sync id="tmN"/>`` where a mark stands,
``<gesture>`` (its stroke on the mark's sync point, start and end in seconds from the block's
start), ``<gaze>`` and ``<faceLexeme>``. Gesture lexemes follow Greta's gestuary convention
``CLASS=name`` (:func:`lexeme`); expressions and gaze directions are in :data:`FACE_LEXEMES`
and :data:`GAZE_DIRECTIONS`. sgt's own options (x2, flip, hold=) are attributes in the
:data:`SGT_NS` namespace, which realizers leave alone.

Reading (:func:`bml_script`): BML 1.0 (``<sync>`` in ``<text>``) and Greta's form (``<tm>``
in ``<speech>``); a behaviour's place is the sync point its ``stroke`` (else ``start``) refers
to. Whatever cannot become a mark is a :class:`~dsl.markup.Problem` with its line and column.
:func:`check_bml` holds the blocks sgt writes to the rules it states (docs/formats.md#bml-and-ssml).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from itertools import pairwise
from xml.sax.saxutils import escape as xml_escape
from xml.sax.saxutils import quoteattr

from core.counting import plural
from core.face import LOOK_DIRECTIONS
from core.skeleton import FPS
from dsl.markup import MarkMap, Problem, Utterance, script_text
from dsl.xmlread import Element, parse_xml

BML_NS = "http://www.bml-initiative.org/bml/bml-1.0"
#: sgt's own attributes and root element.
SGT_NS = "urn:sgt:bml"

#: Gesture classes of Greta's gestuary (``CLASS=name``), taken from a gesture's first tag that is one.
GESTURE_CLASSES = ("deictic", "beat", "iconic", "metaphoric", "emblem", "adaptor", "posture")
#: sgt expression -> faceLexeme lexeme (one to one: Greta's emotion names; smile and calm as BML 1.0 core lexemes).
FACE_LEXEMES = {"smile": "RAISE_MOUTH_CORNERS", "happy": "joy", "sad": "sadness", "angry": "anger",
                "surprised": "surprise", "afraid": "fear", "disgusted": "disgust", "calm": "relief",
                "neutral": "neutral"}
#: BML 1.0 core faceLexemes read as the nearest expression (besides :data:`FACE_LEXEMES`' own).
FACE_CORE = {"LOWER_MOUTH_CORNERS": "sad", "RAISE_BROWS": "surprised", "WIDEN_EYES": "surprised",
             "LOWER_BROWS": "angry", "OBLIQUE_BROWS": "sad"}
#: Gaze directions: sgt direction -> BML offsetDirection (the angle from core.face.LOOK_DIRECTIONS).
GAZE_DIRECTIONS = {"left": "LEFT", "right": "RIGHT", "up": "UP", "down": "DOWN"}
#: The gaze target of a direction (and of ``ahead``): the audience in front of the character.
AUDIENCE = "audience"
#: BML 1.0 core head lexemes -> sgt gestures.
HEAD_LEXEMES = {"NOD": "nod", "SHAKE": "head_shake"}


def lexeme(name: str, tags) -> str:
    """A gesture's lexeme: ``CLASS=name`` with the class from its tags (``deictic=point_right``),
    ``gesture=name`` for a gesture with no such tag."""
    cls = next((t for t in tags if t in GESTURE_CLASSES), "gesture")
    return f"{cls}={name}"


# ---------------------------------------------------------------------------------------------
# Writing


def write_bml(script, plan, library) -> str:
    """The BML document of a compiled script (``script``: :class:`dsl.script.Script`, ``plan``
    its :class:`dsl.plan.Plan`), and what it leaves out (lines for the user)."""
    plans = {p.index: p for p in plan.utterances}
    blocks, left_out = [], {"style span": 0, "pause": 0}
    for utt in script.utterances:
        p = plans.get(utt.index)
        if p is None:
            continue
        blocks.append(_block(utt, p, library, left_out))
    doc = (f'<?xml version="1.0" encoding="UTF-8"?>\n<sgt:performance xmlns:sgt="{SGT_NS}" xmlns="{BML_NS}"'
           f' source={quoteattr(str(plan.source))}>\n' + "".join(blocks) + "</sgt:performance>\n")
    notes = [f"{plural(n, what)} (BML has no element for {'it' if n == 1 else 'them'})" for what, n in left_out.items() if n]
    broken = check_bml(parse_xml(doc))
    if broken:  # a bug of this writer, never the script's
        raise RuntimeError(f"sgt wrote BML that breaks its own rules: line {broken[0].line}: {broken[0].message}")
    return doc, notes


def _block(utt, p, library, left_out) -> str:
    sid = f"s{utt.index}"
    # Where each sync point stands in the text (character offsets of utt.text), in order.
    offsets = sorted({m.offset for m in utt.poses} | {m.offset for m in utt.looks}
                     | {o for s in utt.styles if s.face is not None for o in (s.offset, s.end_offset)})
    sync = {o: f"tm{i + 1}" for i, o in enumerate(offsets)}
    text, at = [], 0
    for o in offsets:
        text.append(xml_escape(utt.text[at:o]))
        text.append(f'<sync id="{sync[o]}"/>')
        at = o
    text.append(xml_escape(utt.text[at:]))
    spoken = _BEFORE_PUNCTUATION.sub("", " ".join("".join(text).split()))
    controls = {(c.kind, c.line, c.col): c for c in p.controls}
    start = f' start="{_t(p.lead_in)}"' if p.lead_in else ""
    who = f" characterId={quoteattr(utt.speaker)}" if utt.speaker is not None else ""
    out = [f'  <bml id="u{utt.index}"{who} composition="APPEND" sgt:start="{_t(p.start)}" sgt:line="{utt.line}">\n',
           f'    <speech id="{sid}"{start}><text>{spoken}</text></speech>\n']
    for n, m in enumerate(utt.poses):
        c = controls.get(("pose", m.where.line, m.where.col))
        gesture = library.get(m.name)
        lex = lexeme(m.name, gesture.tags if gesture is not None else ())
        anchor = f"{sid}:{sync[m.offset]}"
        if c is not None and c.stroke_frame is not None:
            timing = f'start="{_t(c.start_frame / FPS)}" stroke="{anchor}" end="{_t(c.end_frame / FPS)}"'
        else:
            timing = f'start="{anchor}"' + (f' end="{_t(c.end_frame / FPS)}"' if c is not None else "")
        extra = f' sgt:speed="{m.speed}"' if m.speed != 1 else ""
        extra += ' sgt:flip="true"' if m.flip else ""
        extra += f' sgt:hold="{m.hold:g}"' if m.hold else ""
        out.append(f'    <gesture id="g{n + 1}" lexeme={quoteattr(lex)} {timing}{extra}/>\n')
    for n, m in enumerate(utt.looks):
        c = controls.get(("look", m.where.line, m.where.col))
        if m.target in GAZE_DIRECTIONS:
            target = (f'target="{AUDIENCE}" offsetDirection="{GAZE_DIRECTIONS[m.target]}"'
                      f' offsetAngle="{abs(LOOK_DIRECTIONS[m.target][0] or LOOK_DIRECTIONS[m.target][1]):g}"')
        else:
            target = f"target={quoteattr(AUDIENCE if m.target == 'ahead' else m.target)}"
        end = f' end="{_t(c.end_frame / FPS)}"' if c is not None else ""
        hold = f' sgt:hold="{m.hold:g}"' if m.hold else ""
        out.append(f'    <gaze id="z{n + 1}" {target} influence="EYES" start="{sid}:{sync[m.offset]}"{end}{hold}/>\n')
    faces = [s for s in utt.styles if s.face is not None]
    for n, s in enumerate(faces):
        out.append(f'    <faceLexeme id="f{n + 1}" lexeme="{FACE_LEXEMES[s.face]}" start="{sid}:{sync[s.offset]}"'
                   f' end="{sid}:{sync[s.end_offset]}"/>\n')
    left_out["style span"] += sum(1 for s in utt.styles if s.styled)
    left_out["pause"] += len(utt.pauses)
    out.append("  </bml>\n")
    return "".join(out)


#: Spaces a removed tag left before punctuation.
_BEFORE_PUNCTUATION = re.compile(r"\s+(?=[,.;:!?])")


def _t(seconds: float) -> str:
    return f"{seconds:.3f}"


# ---------------------------------------------------------------------------------------------
# Reading and the rules


#: A sync reference: ``speechId:syncId``, with an optional offset in seconds (``s0:tm1+0.2``).
_REF = re.compile(r"\s*([\w.\-]+)\s*:\s*([\w.\-]+)\s*(?:([+-])\s*(\d+(?:\.\d*)?))?\s*")
#: What a behaviour's place is read from, first found first.
_ANCHORS = ("stroke", "start")
#: Behaviours sgt reads; any other element of a block is reported.
_BEHAVIOURS = ("speech", "gesture", "head", "gaze", "faceLexeme")


@dataclass
class _Speech:
    id: str
    element: Element
    parts: list  # text and ("sync", id) in order
    syncs: set


def bml_script(root: Element, file: str, marks: MarkMap, library, speaker: str = "agent") -> tuple[str, list[Problem]]:
    """The script of a BML document (one ``<bml>`` block or any root holding them) and the
    problems: each behaviour that cannot become a mark, each sync reference that names no
    sync point, each element sgt does not read."""
    problems: list[Problem] = []
    blocks = [root] if root.tag == "bml" else [b for b in root.elements() if b.tag == "bml"]
    if not blocks:
        return "", [Problem(file, root.line, root.col, f"<{root.tag}> holds no <bml> block: nothing to import")]
    for e in root.elements():
        if root.tag != "bml" and e.tag != "bml":
            problems.append(Problem(file, e.line, e.col, f"<{e.tag}> is not a <bml> block: not imported"))
    utterances = []
    for block in blocks:
        utterances += _read_block(block, file, marks, library, problems)
    text, found = script_text(utterances, speaker)
    return text, problems + found


def check_bml(root: Element) -> list[Problem]:
    """The rules every block sgt writes keeps (Greta's BML parser's, and BML 1.0's): each
    ``<bml>`` has an ``id``; each behaviour an ``id`` unique in its block; a gesture and a
    faceLexeme a ``lexeme``, a gaze a ``target`` and ``influence``; every sync reference names
    the block's speech and a sync point in its text; a time is a number of seconds, at least 0;
    a gesture's start, stroke and end come in that order."""
    out: list[Problem] = []
    for block in [root] if root.tag == "bml" else root.elements():
        if "id" not in block.attrs:
            out.append(Problem("", block.line, block.col, "<bml> without an id"))
        speeches = {s.id: s for s in _speeches(block, "")}
        seen: set[str] = set()
        for e in block.elements():
            bid = e.attrs.get("id")
            if not bid or bid in seen:
                out.append(Problem("", e.line, e.col, f"<{e.tag}> without an id, or with one used before"))
            seen.add(bid or "")
            need = {"gesture": ("lexeme",), "faceLexeme": ("lexeme",), "gaze": ("target", "influence")}.get(e.tag, ())
            out += [Problem("", e.line, e.col, f"<{e.tag}> without {a}") for a in need if a not in e.attrs]
            times = []  # (attribute, comparable position): seconds, or (speech, sync order)
            for name in ("start", "stroke", "end"):
                if name not in e.attrs:
                    continue
                value = e.attrs[name]
                ref = _REF.fullmatch(value)
                if ref:
                    s = speeches.get(ref.group(1))
                    if s is None or ref.group(2) not in s.syncs:
                        out.append(Problem("", e.line, e.col, f"{name}='{value}' names no sync point of this block's speech"))
                        continue
                    times.append((name, ("sync", _sync_order(s, ref.group(2)))))
                    continue
                try:
                    t = float(value)
                except ValueError:
                    t = -1.0
                if not t >= 0:
                    out.append(Problem("", e.line, e.col, f"{name}='{value}' is neither a sync reference nor seconds"))
                    continue
                times.append((name, ("seconds", t)))
            for (a, ta), (b, tb) in pairwise(times):
                if ta[0] == tb[0] and ta[1] > tb[1]:
                    out.append(Problem("", e.line, e.col, f"<{e.tag}> {a} comes after its {b}"))
    return out


def _sync_order(speech: _Speech, sync_id: str) -> int:
    return [p[1] for p in speech.parts if isinstance(p, tuple)].index(sync_id)


def _speeches(block: Element, file: str, problems: list[Problem] | None = None) -> list[_Speech]:
    out = []
    for e in block.elements():
        if e.tag != "speech":
            continue
        parts: list = []
        _speech_parts(e, parts, file, problems)
        out.append(_Speech(e.attrs.get("id", ""), e, parts, {p[1] for p in parts if isinstance(p, tuple)}))
    return out


def _speech_parts(e: Element, parts: list, file: str, problems) -> None:
    for c in e.children:
        if isinstance(c, str):
            parts.append(c)
        elif c.tag in ("sync", "tm") and "id" in c.attrs:
            parts.append(("sync", c.attrs["id"]))
        elif c.tag == "text":
            _speech_parts(c, parts, file, problems)
        elif c.tag == "description":  # a realizer's own description of the same speech
            continue
        elif problems is not None:
            problems.append(Problem(file, c.line, c.col, f"<{c.tag}> in the speech is not read (its text is): "
                                                         "sgt reads <text>, <sync> and <tm>"))
            _speech_parts(c, parts, file, problems)


def _read_block(block: Element, file: str, marks: MarkMap, library, problems: list[Problem]) -> list[Utterance]:
    speeches = _speeches(block, file, problems)
    if not speeches:
        problems.append(Problem(file, block.line, block.col, "a <bml> block without <speech>: sgt scripts are speech "
                                                             "with marks; add the speech"))
        return []
    by_id = {s.id: s for s in speeches}
    at: dict[str, dict[str, list[str]]] = {s.id: {} for s in speeches}  # speech -> sync -> marks before it
    closes: dict[str, dict[str, list[str]]] = {s.id: {} for s in speeches}
    for e in block.elements():
        if e.tag == "speech":
            continue
        if e.tag not in _BEHAVIOURS:
            problems.append(Problem(file, e.line, e.col, f"<{e.tag}> is not imported: sgt reads "
                                                         "<gesture>, <head>, <gaze> and <faceLexeme>"))
            continue
        mark = _mark_of(e, file, marks, library, problems)
        if mark is None:
            continue
        keys = ("start",) if e.tag == "faceLexeme" else _ANCHORS
        place = _place(e, keys, by_id, file, problems)
        if place is None:
            continue
        if e.tag == "faceLexeme":
            end = _place(e, ("end",), by_id, file, problems, own=place[0])
            if end is None:
                continue
            closes[place[0]].setdefault(end[1], []).append("</face>")
        at[place[0]].setdefault(place[1], []).append(mark)
    out = []
    for s in speeches:
        pieces = []
        for part in s.parts:
            if isinstance(part, str):
                pieces.append(("text", part))
            else:
                pieces += [("mark", m) for m in closes[s.id].get(part[1], [])]
                pieces += [("mark", m) for m in at[s.id].get(part[1], [])]
        speaker = block.attrs.get("characterId") or block.attrs.get("character")
        out.append(Utterance(speaker, pieces, file, s.element.line, s.element.col))
    return out


def _mark_of(e: Element, file: str, marks: MarkMap, library, problems: list[Problem]) -> str | None:
    """The sgt mark a behaviour becomes (``[pose:...]``, ``[look:...]``, ``<face:...>``), or
    None with a problem."""
    def sgt(name):
        return e.attrs.get(f"{{{SGT_NS}}}{name}")

    if e.tag in ("gesture", "head"):
        lex = e.attrs.get("lexeme", "")
        mapped = marks.get(lex)
        if mapped is None:
            name = lex.split("=", 1)[1] if "=" in lex else lex
            if e.tag == "head" and lex.upper() in HEAD_LEXEMES:
                name = HEAD_LEXEMES[lex.upper()]
            if name not in library:
                problems.append(Problem(file, e.line, e.col, f"<{e.tag}> lexeme '{lex}' names no sgt gesture "
                                                             f"(sgt library list shows them): map it with --map FILE"))
                return None
            opts = ""
            if sgt("speed") in ("2", "3"):
                opts += f" x{sgt('speed')}"
            if sgt("flip") == "true":
                opts += " flip"
            if sgt("hold"):
                opts += f" hold={_seconds(sgt('hold'))}"
            mapped = f"pose:{name}{opts}"
        return f"[{mapped}]"
    if e.tag == "gaze":
        direction = e.attrs.get("offsetDirection", "").upper()
        names = {v: k for k, v in GAZE_DIRECTIONS.items()}
        target = e.attrs.get("target", "")
        if direction:
            if direction not in names:
                problems.append(Problem(file, e.line, e.col, f"<gaze> offsetDirection '{direction}' is not one sgt "
                                                             "looks in (LEFT, RIGHT, UP, DOWN)"))
                return None
            target = names[direction]
        elif target == AUDIENCE:
            target = "ahead"
        elif not re.fullmatch(r"[^\s\[\]<>:\\#]+", target):
            problems.append(Problem(file, e.line, e.col, f"<gaze> target '{target}' is no speaker name sgt can write"))
            return None
        return f"[look:{target}" + (f" hold={_seconds(sgt('hold'))}" if sgt("hold") else "") + "]"
    lex = e.attrs.get("lexeme", "")
    faces = {v: k for k, v in FACE_LEXEMES.items()} | FACE_CORE
    if lex not in faces:
        problems.append(Problem(file, e.line, e.col, f"<faceLexeme> lexeme '{lex}' is no sgt expression: sgt reads "
                                                     + ", ".join(sorted(faces))))
        return None
    return f"<face:{faces[lex]}>"


def _seconds(value: str) -> str:
    try:
        return f"{round(float(value) * 1000)}ms"
    except ValueError:
        return value  # (the script's check reports it at its place)


def _place(e: Element, keys, by_id: dict[str, _Speech], file: str, problems: list[Problem],
           own: str | None = None) -> tuple[str, str] | None:
    """(speech id, sync id) that ``e``'s first attribute of ``keys`` refers to, or None with a problem."""
    for key in keys:
        value = e.attrs.get(key)
        if value is None:
            continue
        ref = _REF.fullmatch(value)
        if ref is None:
            problems.append(Problem(file, e.line, e.col, f"<{e.tag}> {key}='{value}' is no sync point: sgt places "
                                                         "behaviours at words; refer to a <sync> of the speech"))
            return None
        s = by_id.get(ref.group(1))
        if s is None or ref.group(2) not in s.syncs or (own is not None and s.id != own):
            problems.append(Problem(file, e.line, e.col, f"<{e.tag}> {key}='{value}' names no sync point of this "
                                                         "block's speech"))
            return None
        if ref.group(3):
            problems.append(Problem(file, e.line, e.col, f"<{e.tag}> {key}='{value}': the offset "
                                                         f"{ref.group(3)}{ref.group(4)} s is not kept (sgt places it at the sync point)",
                                    warning=True))
        return s.id, ref.group(2)
    problems.append(Problem(file, e.line, e.col, f"<{e.tag}> has no {' or '.join(keys)}: sgt places behaviours at "
                                                 "words; refer to a <sync> of the speech"))
    return None
