"""What the language server answers about a place in a script: completion, hover, go to
definition, references and rename. Plain functions of a :class:`~sgt_tui.lsp.documents.Document`
(the analysis and the library are its analysis's) and a 0-based row and character column;
:mod:`sgt_tui.lsp.server` wires them to the protocol."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from lsprotocol import types as lsp
from pygls.uris import to_fs_path

from core.controls import STYLE_NAMES
from core.face import EXPRESSIONS, LOOK_DIRECTIONS
from core.reading import read_bytes
from dsl.directives import NAME_RE as PRESET_NAME_RE
from dsl.lines import SPEAKER_RE, strip_comment
from dsl.parser import POSE_OPTIONS
from dsl.presets import BUILTIN_PRESETS
from dsl.speech import SpeechError, list_voices
from dsl.speech.synth import list_variants
from library import BUILTIN_DIR
from library.spec import NAME_RE as GESTURE_NAME_RE
from library.spec import locate
from sgt_tui.editor.tokens import line_tokens
from sgt_tui.lsp import knowledge
from sgt_tui.lsp.documents import Document, units, uri_of
from sgt_tui.lsp.index import Occurrence, Workspace, line_occurrences, occurrences

DURATIONS = ("300ms", "500ms", "1s")
#: The longest name a rename gives (a speaker, a preset, a gesture).
MAX_NAME = 64


@dataclass(frozen=True)
class Target:
    """What is under the cursor: ``kind`` "gesture", "preset", "style", "speaker",
    "directive", "option", "tag" (a tag's kind: pose, pause) or "word" (``index``: its number
    in the utterance)."""

    kind: str
    name: str
    row: int
    col: int
    length: int
    index: int = -1


def target_at(doc: Document, row: int, col: int) -> Target | None:
    line = doc.line(row)
    if col > len(strip_comment(line)):
        return None
    for o in line_occurrences(row, line):
        if o.covers(row, col):
            kind = {"preset_def": "preset", "look": "speaker"}.get(o.kind, o.kind)
            return Target(kind, o.name, o.row, o.col, o.length)
    tok = line_tokens(line)
    if tok.directive is not None:
        a, b = tok.directive
        return Target("directive", line[a + 1 : b], row, a, b - a) if a <= col <= b else None
    for kind, s, e, payload in tok.items:
        if kind != "tag" or not s <= col < e:
            continue
        names, args = payload
        for key, _, a, b in args:
            if a <= col <= b:
                return Target("option", key, row, a, b - a)
        tag, at = names[0]
        if at <= col <= at + len(tag):
            return Target("tag", tag, row, at, len(tag))
    info = doc.analysis().utterance_at(row + 1)
    if info is not None:
        for i, (r, a, b) in enumerate(info.word_spans()):
            if r == row and a <= col <= b:
                return Target("word", line[a:b], row, a, b - a, i)
    return None


# -- completion -------------------------------------------------------------------------------

def _edit(doc: Document, row: int, start: int, end: int, text: str) -> lsp.TextEdit:
    return lsp.TextEdit(doc.range(row, start, end), text)


def _open_tag(before: str) -> tuple[str, int] | None:
    """The tag the cursor is in (``[`` or ``<`` and where it opens), reading escapes; None
    outside tags."""
    opened = None
    i = 0
    while i < len(before):
        c = before[i]
        if c == "\\":
            i += 2
            continue
        if c in "[<":
            opened = (c, i)
        elif c in "]>":
            opened = None
        i += 1
    return opened


def complete(doc: Document, row: int, col: int, workspace: Workspace) -> list[lsp.CompletionItem]:
    line = doc.line(row)
    before = line[:col]
    if strip_comment(before) != before:
        return []
    if before.startswith("@"):
        return _complete_directive(doc, row, before, workspace)
    opened = _open_tag(before)
    if opened is not None:
        char, at = opened
        inner = before[at + 1 :]
        return _complete_tag(doc, row, col, inner) if char == "[" else _complete_style(doc, row, col, line, at, inner)
    if before and before[0] in " \t":
        return []
    m = re.fullmatch(r"[^\W\d][\w\-]*|", before)
    if m is None:
        return []
    return [lsp.CompletionItem(f"{name}:", kind=lsp.CompletionItemKind.Variable, detail=detail,
                               text_edit=_edit(doc, row, 0, col, f"{name}: "), sort_text=f"{order:04d}")
            for order, (name, detail) in enumerate(_speakers(doc, workspace))]


def _speakers(doc: Document, workspace: Workspace | None) -> list[tuple[str, str]]:
    """Speakers of this script first (by lines), then the workspace's (with a workspace)."""
    here: dict[str, int] = {}
    for o in occurrences(doc.text):
        if o.kind == "speaker" and not doc.line(o.row).startswith("@"):  # its lines, not its directives
            here[o.name] = here.get(o.name, 0) + 1
    out = [(name, f"speaker in this script ({n} line{'s' if n != 1 else ''})")
           for name, n in sorted(here.items(), key=lambda kv: -kv[1])]
    if workspace is None:
        return out
    elsewhere = workspace.speakers()
    out += [(name, f"speaker in the workspace ({n} line{'s' if n != 1 else ''})")
            for name, n in sorted(elsewhere.items(), key=lambda kv: -kv[1]) if name not in here]
    return out


def _complete_directive(doc: Document, row: int, before: str, workspace: Workspace) -> list[lsp.CompletionItem]:
    m = re.fullmatch(r"@([\w\-]*)", before)
    if m:
        header = doc.analysis().utterances[0].line if doc.analysis().utterances else 1 << 30
        names = [n for n in knowledge.DIRECTIVES if row + 1 < header or n not in knowledge.HEADER_ONLY]
        return [lsp.CompletionItem(f"@{n}", kind=lsp.CompletionItemKind.Keyword, detail=knowledge.DIRECTIVES[n][0],
                                   documentation=knowledge.DIRECTIVES[n][1], filter_text=f"@{n}",
                                   text_edit=_edit(doc, row, 0, len(before), f"@{n} ")) for n in names]
    m = re.fullmatch(r"@(voice|rate|pitch)[ \t]+(?:(\S+?)[ \t]*:[ \t]*)?(\S*)", before)
    if not m:
        return []
    directive, speaker, partial = m.groups()
    start = len(before) - len(partial)
    items: list[lsp.CompletionItem] = []
    if directive == "voice":
        try:
            if "+" in partial:
                base, _, _ = partial.partition("+")
                cut = start + len(base) + 1
                items = [lsp.CompletionItem(f"{base}+{v}", kind=lsp.CompletionItemKind.EnumMember, detail="voice variant",
                                            filter_text=f"{base}+{v}", text_edit=_edit(doc, row, cut, len(before), v))
                         for v in list_variants()]
            else:
                items = [lsp.CompletionItem(v, kind=lsp.CompletionItemKind.EnumMember, detail="espeak-ng voice",
                                            text_edit=_edit(doc, row, start, len(before), v)) for v in list_voices()]
        except SpeechError:  # no speech engine: no voices to offer
            items = []
    if speaker is None and "+" not in partial:
        items += [lsp.CompletionItem(f"{name}:", kind=lsp.CompletionItemKind.Variable, detail=f"one speaker's {directive}",
                                     text_edit=_edit(doc, row, start, len(before), f"{name}: "))
                  for name, _ in _speakers(doc, workspace)]
    return items


def _complete_tag(doc: Document, row: int, col: int, inner: str) -> list[lsp.CompletionItem]:
    m = re.fullmatch(r"[ \t]*([\w\-]*)", inner)
    if m:
        start = col - len(m.group(1))
        return [lsp.CompletionItem(label, kind=lsp.CompletionItemKind.Keyword, documentation=knowledge.TAGS[kind],
                                   text_edit=_edit(doc, row, start, col, label))
                for kind, label in (("pose", "pose:"), ("look", "look:"), ("pause", "pause "))]
    m = re.fullmatch(r"[ \t]*look[ \t]*:[ \t]*([\w\-]*)", inner)
    if m:
        start = col - len(m.group(1))
        here = [(name, "speaker: look at them") for name, _ in _speakers(doc, None)]
        there = [(name, f"direction: yaw {yaw:+g}, pitch {pitch:+g} degrees") for name, (yaw, pitch) in LOOK_DIRECTIONS.items()]
        return [lsp.CompletionItem(name, kind=lsp.CompletionItemKind.EnumMember, detail=detail,
                                   text_edit=_edit(doc, row, start, col, name)) for name, detail in here + there]
    m = re.fullmatch(r"[ \t]*look[ \t]*:[ \t]*[\w\-]+[ \t]+([\w.=]*)", inner)
    if m:
        partial = m.group(1)
        start = col - len(partial)
        if partial.startswith("hold="):
            return _durations(doc, row, start + 5, col)
        return [lsp.CompletionItem("hold=", kind=lsp.CompletionItemKind.Property, documentation=knowledge.OPTIONS["hold"],
                                   text_edit=_edit(doc, row, start, col, "hold="))]
    m = re.fullmatch(r"[ \t]*pose[ \t]*:[ \t]*([\w\-]*)", inner)
    if m:
        start = col - len(m.group(1))
        library = doc.analysis().library
        return [lsp.CompletionItem(g.name, kind=lsp.CompletionItemKind.Function, detail=knowledge.gesture_detail(g),
                                   documentation=g.description, text_edit=_edit(doc, row, start, col, g.name),
                                   data={"gesture": g.name, "uri": doc.uri})
                for g in (library or ())]
    m = re.fullmatch(r"[ \t]*pose[ \t]*:[ \t]*[\w\-]+((?:[ \t]+[\w.+\-=]+)*)[ \t]+([\w.+\-=]*)", inner)
    if m:
        given = m.group(1).split()
        partial = m.group(2)
        start = col - len(partial)
        if partial.startswith("hold="):
            return _durations(doc, row, start + 5, col)
        have = {"speed" if g.split("=")[0] in ("x1", "x2", "x3") else g.split("=")[0] for g in given}
        items = []
        for key in POSE_OPTIONS:
            group = "speed" if key.startswith("x") else key
            if group in have:
                continue
            label = "hold=" if key == "hold" else key
            items.append(lsp.CompletionItem(label, kind=lsp.CompletionItemKind.Property, documentation=knowledge.OPTIONS[key],
                                            text_edit=_edit(doc, row, start, col, label)))
        return items
    m = re.fullmatch(r"[ \t]*pause[ \t]+([\w.]*)", inner)
    if m:
        return _durations(doc, row, col - len(m.group(1)), col)
    return []


def _durations(doc: Document, row: int, start: int, col: int) -> list[lsp.CompletionItem]:
    return [lsp.CompletionItem(d, kind=lsp.CompletionItemKind.Value, text_edit=_edit(doc, row, start, col, d)) for d in DURATIONS]


def _complete_style(doc: Document, row: int, col: int, line: str, at: int, inner: str) -> list[lsp.CompletionItem]:
    presets = _presets(doc)
    if inner.startswith("/"):
        partial = inner[1:].lstrip(" \t")
        if not re.fullmatch(r"[\w\-]*", partial):
            return []
        stack: list[str] = []
        for kind, _, _, payload in line_tokens(line[:at]).items:
            if kind == "style_open":
                stack.append(payload[0][0])
            elif kind == "style_close" and stack:
                stack.pop()
        names = list(reversed(stack)) or [*STYLE_NAMES, *presets]
        return [lsp.CompletionItem(f"{n}>", kind=lsp.CompletionItemKind.Keyword, filter_text=n,
                                   text_edit=_edit(doc, row, col - len(partial), col, f"{n}>")) for n in names]
    partial = re.split(r"[ \t]", inner)[-1]
    m = re.fullmatch(r"face:([\w\-]*)", partial)
    if m:
        start = col - len(m.group(1))
        return [lsp.CompletionItem(name, kind=lsp.CompletionItemKind.EnumMember, detail="facial expression",
                                   documentation=", ".join(f"{k} {v:g}" for k, v in shapes.items()) or "no expression (ends an outer one)",
                                   text_edit=_edit(doc, row, start, col, name)) for name, shapes in EXPRESSIONS.items()]
    if ":" in partial or not re.fullmatch(r"[\w\-]*", partial):
        return []
    start = col - len(partial)
    items = [lsp.CompletionItem(name, kind=lsp.CompletionItemKind.Property, detail="style element, -3..3",
                                documentation=f"{knowledge.STYLES[name]}; {knowledge.STYLE_RANGE}",
                                text_edit=_edit(doc, row, start, col, f"{name}:")) for name in STYLE_NAMES]
    items.append(lsp.CompletionItem("face", kind=lsp.CompletionItemKind.Property, detail="facial expression",
                                    documentation="<face:NAME>: " + ", ".join(EXPRESSIONS),
                                    text_edit=_edit(doc, row, start, col, "face:")))
    items += [lsp.CompletionItem(name, kind=lsp.CompletionItemKind.Constant,
                                 detail=("built-in preset: " if name in BUILTIN_PRESETS else "preset: ") + knowledge.preset_text(values),
                                 text_edit=_edit(doc, row, start, col, name)) for name, values in presets.items()]
    return items


def _presets(doc: Document) -> dict[str, dict[str, float]]:
    header = doc.analysis().header
    return {**BUILTIN_PRESETS, **(header.presets if header is not None else {})}


def resolve_gesture(doc: Document, item: lsp.CompletionItem) -> lsp.CompletionItem:
    """A gesture's completion item with its full documentation (figure included)."""
    library = doc.analysis().library
    g = library.get(item.data.get("gesture")) if library is not None and isinstance(item.data, dict) else None
    if g is not None:
        item.documentation = lsp.MarkupContent(lsp.MarkupKind.Markdown, knowledge.gesture_markdown(g))
    return item


# -- hover ------------------------------------------------------------------------------------

def hover(doc: Document, row: int, col: int, timing) -> lsp.Hover | None:
    t = target_at(doc, row, col)
    if t is None:
        return None
    text = _hover_text(doc, t, timing)
    if text is None:
        return None
    return lsp.Hover(lsp.MarkupContent(lsp.MarkupKind.Markdown, text), doc.range(t.row, t.col, t.col + t.length))


def _hover_text(doc: Document, t: Target, timing) -> str | None:
    analysis = doc.analysis()
    if t.kind == "gesture":
        g = analysis.library.get(t.name) if analysis.library is not None else None
        return knowledge.gesture_markdown(g) if g is not None else f"no gesture '{t.name}' in the library"
    if t.kind == "style":
        return f"**{t.name}** (style element): {knowledge.STYLES[t.name]}.\n\n{knowledge.STYLE_RANGE.capitalize()}."
    if t.kind == "preset":
        if t.name in BUILTIN_PRESETS:
            return f"**{t.name}** (built-in preset): `{knowledge.preset_text(BUILTIN_PRESETS[t.name])}`"
        header = analysis.header
        values = header.presets.get(t.name) if header is not None else None
        where = header.settings_where.get(f"preset:{t.name}") if header is not None else None
        if where is None:
            return f"no preset '{t.name}' in this script"
        line = doc.line(where.line - 1).strip()
        return f"**{t.name}** (preset of this script, line {where.line}): `{line}`" + (
            f"\n\n= `{knowledge.preset_text(values)}`" if values else "")
    if t.kind == "directive" and t.name in knowledge.DIRECTIVES:
        usage, meaning = knowledge.DIRECTIVES[t.name]
        return f"`{usage}`\n\n{meaning}"
    if t.kind == "option" and t.name in knowledge.OPTIONS:
        return f"**{t.name}**: {knowledge.OPTIONS[t.name]}"
    if t.kind == "tag" and t.name in knowledge.TAGS:
        return knowledge.TAGS[t.name]
    if t.kind == "speaker":
        header = analysis.header
        lines = sum(1 for u in analysis.utterances if u.speaker == t.name)
        if header is None:
            return f"**{t.name}**: {lines} line{'s' if lines != 1 else ''}"
        v = header.voice_for(t.name)
        return f"**{t.name}**: {lines} line{'s' if lines != 1 else ''} · voice {v.name}, rate {v.rate}, pitch {v.pitch}"
    if t.kind == "word":
        return _word_hover(doc, t, timing)
    return None


def _word_hover(doc: Document, t: Target, timing) -> str | None:
    info = doc.analysis().utterance_at(t.row + 1)
    plan, real = timing.plan_of(doc, info)
    if plan is None or t.index >= len(plan.words):
        return None
    w = plan.words[t.index]
    how = "speech timing" if real else "estimated from the text (preview the utterance for its real speech timing)"
    return (f"**{w.word}** (word {t.index + 1} of utterance {info.index + 1}): {w.start:.2f}-{w.end:.2f} s "
            f"from the utterance's first frame · {how}")


# -- definition, references, rename -----------------------------------------------------------

def definition(doc: Document, row: int, col: int) -> list[lsp.Location]:
    t = target_at(doc, row, col)
    if t is None:
        return []
    analysis = doc.analysis()
    if t.kind == "gesture":
        g = analysis.library.get(t.name) if analysis.library is not None else None
        if g is None:
            return []
        return [_spec_location(Path(g.path), doc.encoding)]
    if t.kind == "preset":
        if t.name in BUILTIN_PRESETS:
            n = knowledge.builtin_preset_line(t.name)
            return [lsp.Location(uri_of(knowledge.BUILTIN_PRESETS_FILE), lsp.Range(lsp.Position(n, 0), lsp.Position(n, 0)))]
        where = analysis.header.settings_where.get(f"preset:{t.name}") if analysis.header is not None else None
        return [lsp.Location(doc.uri, doc.span(where.line, where.col, where.length))] if where is not None else []
    if t.kind == "speaker":
        first = next((o for o in occurrences(doc.text) if o.kind == "speaker" and o.name == t.name), None)
        return [lsp.Location(doc.uri, doc.range(first.row, first.col, first.col + first.length))] if first else []
    return []


def _spec_text(path: Path) -> str:
    """A gesture spec's text, by the bounded reader ("" when it cannot be read)."""
    try:
        return read_bytes(path, "gesture spec").decode("utf-8", errors="replace")
    except OSError:
        return ""


def _spec_location(path: Path, encoding: str) -> lsp.Location:
    text = _spec_text(path)
    line, col, length = locate(text, "name")
    row = max(line - 1, 0)
    start = max(col - 1, 0)
    line_text = text.splitlines()[row] if line and text else ""
    rng = lsp.Range(lsp.Position(row, units(line_text[:start], encoding)), lsp.Position(row, units(line_text[: start + length], encoding)))
    return lsp.Location(uri_of(path), rng)


def _places(doc: Document, t: Target, docs, workspace: Workspace) -> dict[str, tuple[list[str], list[Occurrence]]]:
    """uri -> (the script's lines, the occurrences of the target's name there): this script for
    a preset, every script of the workspace (open ones as edited) for speakers and gestures."""
    kinds = {"preset": ("preset", "preset_def"), "speaker": ("speaker", "look"), "gesture": ("gesture",)}[t.kind]
    texts = {doc.uri: doc.text}
    if t.kind != "preset":
        for path in workspace.scripts():
            uri = uri_of(path)
            if uri in texts:
                continue
            open_doc = docs.get(uri)
            if open_doc is not None:
                texts[uri] = open_doc.text
            else:
                got = workspace.read(path)
                if got is not None:
                    texts[uri] = got[0]
    out = {}
    for uri, text in texts.items():
        found = [o for o in occurrences(text) if o.kind in kinds and o.name == t.name]
        if found:
            out[uri] = (text.split("\n"), found)
    return out


def _range_in(lines: list[str], o: Occurrence, encoding: str) -> lsp.Range:
    line = lines[o.row] if o.row < len(lines) else ""
    return lsp.Range(lsp.Position(o.row, units(line[: o.col], encoding)), lsp.Position(o.row, units(line[: o.col + o.length], encoding)))


def references(doc: Document, row: int, col: int, docs, workspace: Workspace, declaration: bool) -> list[lsp.Location]:
    t = target_at(doc, row, col)
    if t is None or t.kind not in ("preset", "speaker", "gesture"):
        return []
    out = [lsp.Location(uri, _range_in(lines, o, doc.encoding))
           for uri, (lines, found) in _places(doc, t, docs, workspace).items() for o in found
           if declaration or o.kind != "preset_def"]
    if t.kind == "gesture" and declaration:
        g = doc.analysis().library.get(t.name) if doc.analysis().library is not None else None
        if g is not None:
            out.append(_spec_location(Path(g.path), doc.encoding))
    return out


class RenameRefused(Exception):
    """Why the name under the cursor cannot be renamed (or not to that)."""


def prepare_rename(doc: Document, row: int, col: int) -> lsp.Range:
    t = _renamable(doc, row, col)
    return doc.range(t.row, t.col, t.col + t.length)


def _renamable(doc: Document, row: int, col: int) -> Target:
    t = target_at(doc, row, col)
    if t is None or t.kind not in ("preset", "speaker", "gesture"):
        raise RenameRefused("only speakers, presets of this script and user gestures can be renamed")
    if t.kind == "preset" and t.name in BUILTIN_PRESETS:
        raise RenameRefused(f"'{t.name}' is a built-in preset")
    if t.kind == "gesture":
        g = doc.analysis().library.get(t.name) if doc.analysis().library is not None else None
        if g is None:
            raise RenameRefused(f"no gesture '{t.name}' in the library")
        if Path(g.path).parent == BUILTIN_DIR:
            raise RenameRefused(f"'{t.name}' is a built-in gesture: copy it into a gesture folder of yours to rename it")
    return t


def _quoted(name: str) -> str:
    """A name for a message: quoted, at most 40 characters of it."""
    return f"'{name}'" if len(name) <= 40 else f"'{name[:37]}...' ({len(name)} characters)"


def _check_new_name(doc: Document, t: Target, new_name: str, places) -> None:
    """Refuse (:class:`RenameRefused`) a new name the language does not read as one, a long one,
    and one that is taken: renaming a speaker to another speaker of a script it edits merges
    the two (names that differ only in case too), a gesture to one of the library's shadows a
    built-in or replaces a gesture of yours, a preset to another of the script's merges them."""
    new = _quoted(new_name)
    if len(new_name) > MAX_NAME:
        raise RenameRefused(f"{new} is too long for a name: at most {MAX_NAME} characters")
    if new_name == t.name:
        raise RenameRefused(f"{new} is its name already")
    if t.kind == "speaker":
        if new_name != new_name.strip() or not SPEAKER_RE.fullmatch(f"{new_name}:"):
            raise RenameRefused(f"{new} is not a speaker name (one word: letters, digits, '_', '-', not starting with a digit)")
        if new_name in LOOK_DIRECTIONS:
            raise RenameRefused(f"{new} is a direction of [look:...]: a speaker of that name could not be looked at")
        for uri, (lines, _) in places.items():
            taken = {o.name for o in occurrences("\n".join(lines)) if o.kind == "speaker"} - {t.name}
            clash = next((name for name in taken if name.casefold() == new_name.casefold()), None)
            if clash is not None:
                where = "this script" if uri == doc.uri else to_fs_path(uri) or uri
                raise RenameRefused(f"{_quoted(clash)} is a speaker of {where} already: renaming would merge the two speakers")
    elif t.kind == "preset":
        if not PRESET_NAME_RE.match(new_name) or new_name in STYLE_NAMES or new_name in BUILTIN_PRESETS:
            raise RenameRefused(f"{new} cannot name a preset (lowercase letters, digits and '_', not a style element or built-in preset)")
        if any(o.kind == "preset_def" and o.name == new_name for o in occurrences(doc.text)):
            raise RenameRefused(f"{new} is a preset of this script already: renaming would merge the two presets")
    elif t.kind == "gesture":
        if not GESTURE_NAME_RE.match(new_name):
            raise RenameRefused(f"{new} cannot name a gesture (lowercase letters, digits and '_', starting with a letter)")
        library = doc.analysis().library
        other = library.get(new_name) if library is not None else None
        if other is not None:
            what = "a built-in gesture" if Path(other.path).parent == BUILTIN_DIR else f"a gesture of yours ({other.path})"
            raise RenameRefused(f"{new} is {what}: the renamed gesture would {'shadow' if 'built-in' in what else 'replace'} it")


def rename(doc: Document, row: int, col: int, new_name: str, docs, workspace: Workspace,
           resource_operations: bool) -> lsp.WorkspaceEdit:
    t = _renamable(doc, row, col)
    places = _places(doc, t, docs, workspace)
    _check_new_name(doc, t, new_name, places)
    edits = {uri: [lsp.TextEdit(_range_in(lines, o, doc.encoding), new_name) for o in found]
             for uri, (lines, found) in places.items()}
    if t.kind != "gesture":
        return lsp.WorkspaceEdit(changes=edits)
    if not resource_operations:
        raise RenameRefused("renaming a gesture renames its spec file, which this editor cannot do (workspace.workspaceEdit.resourceOperations)")
    g = doc.analysis().library.get(t.name)
    spec = Path(g.path)
    target = spec.with_name(f"{new_name}.toml")
    if target.exists():
        raise RenameRefused(f"{target} exists already")
    name_at = _spec_location(spec, doc.encoding)
    changes: list = [lsp.TextDocumentEdit(lsp.OptionalVersionedTextDocumentIdentifier(uri=uri_of(spec), version=None),
                                          [lsp.TextEdit(_spec_value_range(spec, name_at.range, doc.encoding), f'"{new_name}"')]),
                     lsp.RenameFile(old_uri=uri_of(spec), new_uri=uri_of(target))]
    for uri, uri_edits in edits.items():
        open_doc = docs.get(uri)
        changes.append(lsp.TextDocumentEdit(lsp.OptionalVersionedTextDocumentIdentifier(uri=uri, version=open_doc.version if open_doc else None),
                                            uri_edits))
    return lsp.WorkspaceEdit(document_changes=changes)


def _spec_value_range(spec: Path, key: lsp.Range, encoding: str) -> lsp.Range:
    """The range of the value of ``name = "..."`` on the key's line."""
    lines = _spec_text(spec).splitlines()
    line = lines[key.start.line] if key.start.line < len(lines) else ""
    m = re.match(r'(\s*name\s*=\s*)("[^"]*"|\'[^\']*\')', line)
    start, end = (m.start(2), m.end(2)) if m else (0, len(line))
    return lsp.Range(lsp.Position(key.start.line, units(line[:start], encoding)), lsp.Position(key.start.line, units(line[:end], encoding)))
