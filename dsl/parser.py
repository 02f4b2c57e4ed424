"""Parse and check a script: source text -> :class:`~dsl.script.Script` plus diagnostics.

This is the static half of the front end (no speech, no timing); it is fast enough to run on
every keystroke. Timing-dependent checks (overlapping pose controls) live in the compiler.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from pathlib import Path

from dsl.body import parse_items
from core.diagnostics import ERROR, WARNING, Diagnostic, did_you_mean, sort_key
from dsl.directives import DirectiveContext, apply_directive
from dsl.lines import Statement, decode_source, split_statements
from dsl.presets import BUILTIN_PRESETS
from dsl.scan import scan_body
from dsl.script import (
    Header,
    Pause,
    PoseMark,
    Script,
    Span,
    StyleSpan,
    Utterance,
    WordToken,
)
from dsl.styles import STYLE_ITEM_HELP, parse_style_value
from core.controls import STYLE_NAMES

#: A spoken word: letters or digits, with inner apostrophes or hyphens ("don't", "left-hand").
WORD_RE = re.compile(r"[^\W_]+(?:['\u2019\-][^\W_]+)*")
DURATION_RE = re.compile(r"(\d+(?:\.\d*)?|\.\d+)(ms|s)\Z")
ESCAPABLE = "[]<>\\#:"
TAG_KINDS = ("pose", "pause")
POSE_OPTIONS = ("x1", "x2", "x3", "flip", "hold")
MAX_PAUSE = 10.0
MAX_HOLD = 10.0
_MAX_RECOVERIES = 50
_new_span = tuple.__new__  # Span(line, col, length) without the NamedTuple call overhead


def parse_duration(text: str) -> float | None:
    """``300ms`` / ``1.2s`` -> seconds, or None when malformed."""
    m = DURATION_RE.match(text)
    if not m:
        return None
    value = float(m.group(1))
    return value / 1000.0 if m.group(2) == "ms" else value


class _Analyser:
    def __init__(self, path: str, gesture_names, base_dir: Path) -> None:
        self.file = path
        self._names_source = gesture_names
        self.gesture_names: set[str] | None = None
        self.base_dir = base_dir
        self.diags: list[Diagnostic] = []

    # -- diagnostics -------------------------------------------------------------------
    def report(self, stmt: Statement, offset: int, length: int, message: str, hint=None, code="", severity=ERROR, suggestions=()) -> None:
        line, col = stmt.position(offset)
        self.diags.append(Diagnostic(severity, message, self.file, line, col, max(1, length), hint, code, tuple(suggestions)))

    def span(self, stmt: Statement, offset: int, length: int) -> Span:
        line, col = stmt.position(offset)
        return Span(line, col, max(1, length))

    # -- syntax ------------------------------------------------------------------------
    def parse_body(self, stmt: Statement) -> tuple[list[tuple] | None, str]:
        """Parse the utterance body; on a syntax error report it, blank the bad tag and retry.

        Returns the body's items (see :mod:`dsl.scan`), None when it could not be repaired, and
        the body as parsed (bad tags blanked)."""
        body = stmt.text[stmt.body_offset :]
        items = scan_body(body)
        if items is not None:
            return items, body
        return self._recover(stmt, list(body))

    def _recover(self, stmt: Statement, body: list[str]) -> tuple[list[tuple] | None, str]:
        from lark.exceptions import UnexpectedInput

        base = stmt.body_offset
        for _ in range(_MAX_RECOVERIES):
            try:
                return parse_items("".join(body)), "".join(body)
            except UnexpectedInput as exc:
                lo, hi = self._syntax_error(stmt, "".join(body), exc, base)
                for i in range(lo, hi):
                    if body[i] != "\n":
                        body[i] = " "
        return None, "".join(body)

    def _syntax_error(self, stmt: Statement, body: str, exc, base: int) -> tuple[int, int]:
        """Report one syntax error; return the body range to blank out before retrying."""
        from lark.exceptions import UnexpectedToken

        pos = getattr(exc, "pos_in_stream", None)
        if isinstance(exc, UnexpectedToken) and exc.token is not None and exc.token.type != "$END":
            pos = exc.token.start_pos
        if pos is None or pos > len(body):
            pos = len(body)
        opener = _open_bracket(body, pos)
        if opener is None:
            ch = body[pos] if pos < len(body) else ""
            if ch in "]>":
                what = "bracket" if ch == "]" else "angle bracket"
                self.report(stmt, base + pos, 1, f"unexpected '{ch}' in speech", f"write '\\{ch}' for a literal {what}", "stray-closer")
            elif ch == "\\":
                self.report(stmt, base + pos, 1, "a '\\' at the end of a line escapes nothing", "write '\\\\' for a literal backslash", "bad-escape")
            else:
                self.report(stmt, base + pos, 1, f"unexpected '{ch}'", None, "syntax")
            return pos, min(len(body), pos + 1)
        o, kind = opener
        closer = "]" if kind == "[" else ">"
        close = _find_closer(body, o, closer)
        if close is None:
            name = "tag" if kind == "[" else "style tag"
            self.report(stmt, base + o, 1, f"unclosed '{kind}': this {name} has no '{closer}'", f"add '{closer}' to end the tag, or write '\\{kind}' for a literal '{kind}'", "unclosed")
            nxt = [j for j in (body.find(c, o + 1) for c in "[<\n") if j >= 0]
            return o, min(nxt) if nxt else len(body)
        inner = body[o : close + 1]
        self.report(stmt, base + o, close + 1 - o, _tag_syntax_message(inner, kind, pos - o), _tag_syntax_hint(kind), "bad-tag")
        return o, close + 1

    # -- statements --------------------------------------------------------------------
    def run(self, source: str) -> tuple[Header, list[Utterance]]:
        statements, layout = split_statements(source)
        for line, col, message in layout:
            self.diags.append(Diagnostic(ERROR, message, self.file, line, col, 1, "indent only the continuation lines of an utterance", "indent"))
        header = Header()
        ctx = DirectiveContext(self.file, self.base_dir, header, set(STYLE_NAMES) | set(BUILTIN_PRESETS))
        utterances: list[Utterance] = []
        seen_utterance = False
        audio_line = 0
        for stmt in statements:
            if stmt.kind == "directive":
                had = ctx.pending_audio
                apply_directive(ctx, stmt.text, stmt.line, seen_utterance)
                if ctx.pending_audio is not had:
                    audio_line = stmt.line
                continue
            if not seen_utterance:  # the header is complete: now the gesture names are known
                self._resolve_names(header)
            seen_utterance = True
            utt = self.utterance(stmt, len(utterances), header)
            utt.voice = header.voice_for(utt.speaker)
            utt.audio, ctx.pending_audio = ctx.pending_audio, None
            utterances.append(utt)
        if ctx.pending_audio is not None:
            self.diags.append(Diagnostic(ERROR, "'@audio' is not followed by an utterance", self.file, audio_line, 1, 6, "put '@audio' on the line before the utterance it belongs to", "dangling-audio"))
        self.diags.extend(ctx.diagnostics)
        return header, utterances

    def _resolve_names(self, header: Header) -> None:
        names = self._names_source(header) if callable(self._names_source) else self._names_source
        self.gesture_names = set(names) if names is not None else None

    def utterance(self, stmt: Statement, index: int, header: Header) -> Utterance:
        items, body = self.parse_body(stmt)
        base = stmt.body_offset
        utt = Utterance(index=index, speaker=stmt.speaker, line=stmt.line, text="")
        marks: list[tuple] = []  # tags and style tags, in source order
        if items is None:
            spoken = shown = [body]
        else:  # tags and escape marks are blanked in the spoken text and left out of the display
            spoken, shown = [], []
            for item in items:
                kind = item[0]
                if kind == "text":
                    spoken.append(item[3])
                    shown.append(item[3])
                elif kind == "escape":
                    ch = item[3][1]
                    if ch in ESCAPABLE:
                        spoken.append(" " + ch)
                        shown.append(ch)
                    else:
                        spoken.append("  ")
                        self.report(stmt, base + item[1], 2, f"unknown escape '\\{ch}'", "escapes are \\[ \\] \\< \\> \\\\ \\# \\:", "bad-escape")
                else:
                    spoken.append(" " * (item[2] - item[1]))
                    marks.append(item)
        # line breaks of continuation lines are spaces (an escaped one is already blanked)
        utt.text = text = " " * base + "".join(spoken).replace("\n", " ")
        utt.display = " ".join("".join(shown).split())
        if items is not None:
            utt.words = self._words(stmt, text)
        self._marks(stmt, utt, marks, header, base)
        return utt

    def _words(self, stmt: Statement, text: str) -> list[WordToken]:
        """The spoken words of ``text`` (an item never ends inside a word: tags and escapes are
        blanked, and an escaped character is never part of a word)."""
        words: list[WordToken] = []
        append = words.append
        origin = stmt.origin
        if origin is not None:  # one line: the column follows from the offset
            line, col0 = origin
            for m in WORD_RE.finditer(text):
                s, e = m.span()
                append(WordToken(m.group(), s, e, _new_span(Span, (line, col0 + s, e - s))))
        else:
            for m in WORD_RE.finditer(text):
                s, e = m.span()
                append(WordToken(m.group(), s, e, self.span(stmt, s, e - s)))
        return words

    def _marks(self, stmt: Statement, utt: Utterance, marks, header: Header, base: int) -> None:
        if not marks:
            return
        presets = {**BUILTIN_PRESETS, **header.presets}
        stack: list[StyleSpan] = []
        starts = [w.start for w in utt.words]
        for kind, start, end, payload in marks:
            offset, length = base + start, end - start
            if kind == "tag":
                self._tag(stmt, utt, offset, length, payload, starts, base)
            elif kind == "style_open":
                span = self._style_open(stmt, offset, length, payload, presets, stack, base)
                if span is not None:
                    utt.styles.append(span)
                else:  # keep the stack in step so its closing tag is not reported again
                    first = payload[0][0]
                    span = StyleSpan(first, dict(stack[-1].values) if stack else {}, {}, offset, -1, self.span(stmt, offset, length))
                stack.append(span)
            else:  # style_close
                names = payload
                if not stack:
                    self.report(stmt, offset, length, "closing tag with no open style span", "remove it, or open a span before it with <speed:...>", "unmatched-close")
                    continue
                top = stack[-1]
                if names and names[0] != top.name:
                    opened = [s.name for s in stack]
                    hint = f"the innermost open span is <{top.name}...> (line {top.where.line}, col {top.where.col}); close it with </{top.name}> or </>"
                    self.report(stmt, offset, length, f"mismatched closing tag </{names[0]}>", hint, "mismatched-close", suggestions=(f"</{top.name}>",))
                    if names[0] in opened:  # close up to the named span to resynchronise
                        while stack and stack[-1].name != names[0]:
                            stack.pop().end_offset = offset
                        if stack:
                            stack.pop().end_offset = offset
                    continue
                stack.pop().end_offset = offset
        for span in stack:  # left open: lasts to the end of the utterance
            span.end_offset = len(utt.text)
        self._resolve_styles(stmt, utt)

    def _tag(self, stmt, utt: Utterance, offset: int, length: int, payload, starts: list[int], base: int) -> None:
        names, args = payload  # NAMEs as (text, start); args as (key, value|None, start, end)
        kind, kpos = names[0]
        kpos += base
        if kind not in TAG_KINDS:
            hint, sugg = did_you_mean(kind, TAG_KINDS)
            self.report(stmt, kpos, len(kind), f"unknown tag '{kind}'", hint or "tags are [pose:NAME ...] and [pause DURATION]; write '\\[' for a literal '['", "unknown-tag", suggestions=sugg)
            return
        if kind == "pause":
            self._pause(stmt, utt, offset, length, names, args, starts, base)
            return
        if len(names) < 2:
            self.report(stmt, offset, length, "a pose control needs a gesture name: [pose:NAME]", "for example [pose:point_right]; 'sgt library list' shows the names", "missing-name")
            return
        name, npos = names[1]
        npos += base
        ok = True
        if self.gesture_names is not None and name not in self.gesture_names:
            hint, sugg = did_you_mean(name, sorted(self.gesture_names))
            self.report(stmt, npos, len(name), f"unknown gesture '{name}'", hint or "'sgt library list' shows the gestures", "unknown-gesture", suggestions=sugg)
            ok = False
        speed, flip, hold = 1, False, 0.0
        seen: dict[str, int] = {}
        for key, value, a0, a1 in args:
            apos, alen = base + a0, a1 - a0
            group = "speed" if key in ("x1", "x2", "x3") else key
            if group in seen:
                self.report(stmt, apos, alen, f"option '{key}' conflicts with an earlier '{group}' option", "give each option once", "duplicate-option")
                ok = False
                continue
            seen[group] = apos
            if key in ("x1", "x2", "x3") and value is None:
                speed = int(key[1])
            elif key == "flip" and value is None:
                flip = True
            elif key == "hold":
                seconds = parse_duration(value) if value is not None else None
                if seconds is None:
                    self.report(stmt, apos, alen, "hold needs a duration, e.g. hold=500ms or hold=1.5s", None, "bad-duration")
                    ok = False
                elif not 0 < seconds <= MAX_HOLD:
                    self.report(stmt, apos, alen, f"hold={value} is out of range", f"use more than 0 and at most {MAX_HOLD:g}s", "out-of-range")
                    ok = False
                else:
                    hold = seconds
            elif key in ("x1", "x2", "x3", "flip"):
                self.report(stmt, apos, alen, f"option '{key}' takes no value", f"write just '{key}'", "bad-option")
                ok = False
            else:
                hint, sugg = did_you_mean(key, POSE_OPTIONS)
                self.report(stmt, apos, alen, f"unknown pose option '{key}'", hint or "options are x1, x2, x3 (speed), flip (mirror) and hold=DURATION", "unknown-option", suggestions=sugg)
                ok = False
        if not utt.words and not starts:
            self.report(stmt, offset, length, "pose control on an utterance with no words", "a pose control is anchored to a word; add speech text", "empty-utterance")
            return
        if not ok:
            return
        mark = PoseMark(name, speed, flip, hold, offset, self.span(stmt, offset, length), None)
        following = bisect_right(starts, offset)  # the first word after the mark
        if following < len(starts):
            mark.word_index = following
        else:
            mark.after_word = len(starts) - 1
        utt.poses.append(mark)

    def _pause(self, stmt, utt, offset, length, names, args, starts, base) -> None:
        if len(names) > 1 or len(args) != 1 or args[0][1] is not None:
            self.report(stmt, offset, length, "a pause needs one duration: [pause 300ms] or [pause 1.2s]", None, "bad-pause")
            return
        text = args[0][0]
        seconds = parse_duration(text)
        apos = base + args[0][2]
        if seconds is None:
            hint = "add a unit: ms or s, e.g. [pause 300ms]" if re.fullmatch(r"[\d.]+", text) else "write it like 300ms or 1.2s"
            self.report(stmt, apos, len(text), f"bad pause duration '{text}'", hint, "bad-duration")
            return
        if not 0 < seconds <= MAX_PAUSE:
            self.report(stmt, apos, len(text), f"pause of {text} is out of range", f"use more than 0 and at most {MAX_PAUSE:g}s", "out-of-range")
            return
        index = bisect_right(starts, offset)
        utt.pauses.append(Pause(seconds, offset, self.span(stmt, offset, length), index))

    def _style_open(self, stmt, offset, length, items, presets, stack, base) -> StyleSpan | None:
        values: dict[str, float] = {}
        first_name = None
        ok = True
        for name, value, i0, i1 in items:
            ipos, ilen = base + i0, i1 - i0
            first_name = first_name or name
            if name in presets:
                if value is not None:
                    self.report(stmt, ipos, ilen, f"preset '{name}' takes no value", f"write <{name}>, or combine: <{name} speed:-1>", "bad-style")
                    ok = False
                    continue
                values.update(presets[name])
                continue
            result = parse_style_value(name, value)
            if isinstance(result, str):
                hint = STYLE_ITEM_HELP
                sugg: tuple = ()
                if name not in STYLE_NAMES:
                    h, sugg = did_you_mean(name, list(STYLE_NAMES) + sorted(presets))
                    hint = h or hint
                    result = f"unknown style or preset '{name}'"
                self.report(stmt, ipos, ilen, result, hint, "bad-style", suggestions=sugg)
                ok = False
                continue
            values[name] = result
        if not ok and not values:
            return None
        inherited = dict(stack[-1].values) if stack else {}
        inherited.update(values)
        return StyleSpan(first_name or "style", inherited, values, offset, -1, self.span(stmt, offset, length))

    def _resolve_styles(self, stmt: Statement, utt: Utterance) -> None:
        for span in utt.styles:
            inside = [i for i, w in enumerate(utt.words) if w.start >= span.offset and w.end <= span.end_offset]
            if inside:
                span.first_word, span.last_word = inside[0], inside[-1]
            else:
                self.report(stmt, span.offset, span.where.length, "style span holds no words", "put words between the opening and closing tags", "empty-span", severity=WARNING)


def _open_bracket(body: str, pos: int) -> tuple[int, str] | None:
    """The unclosed '[' or '<' (offset, char) that the error at ``pos`` lies in, if any."""
    found = None
    i = 0
    while i < min(pos, len(body)):
        c = body[i]
        if c == "\\":
            i += 2
            continue
        if c in "[<":
            found = (i, c)
        elif c in "]>":
            found = None
        i += 1
    if found is None and pos < len(body) and body[pos] in "[<":
        found = (pos, body[pos])
    return found


def _find_closer(body: str, start: int, closer: str) -> int | None:
    for i in range(start + 1, len(body)):
        c = body[i]
        if c == closer:
            return i
        if c in "[<\n" and c != closer:
            return None
    return None


def _tag_syntax_message(inner: str, kind: str, rel: int) -> str:
    if kind == "[":
        if re.match(r"\[\s*pose\s*:\s*\]", inner):
            return "a pose control needs a gesture name: [pose:NAME]"
        return f"malformed tag {inner!r}"
    if inner.startswith("</"):
        return f"malformed closing tag {inner!r}"
    if re.match(r"<\s*>", inner):
        return "empty style tag '<>'"
    return f"malformed style tag {inner!r}"


def _tag_syntax_hint(kind: str) -> str:
    if kind == "[":
        return "tags look like [pose:point_right x2 flip hold=500ms] or [pause 300ms]; write '\\[' for a literal '['"
    return "style tags look like <speed:-1 space:+0.5> ... </> or <happy>; write '\\<' for a literal '<'"


def analyse(source: str, path: str = "<string>", gesture_names=None, base_dir: Path | None = None) -> Script:
    """Parse and statically check ``source``.

    ``gesture_names`` is the set of known gestures, a callable ``header -> names`` called once
    the header is read (so ``@library`` folders count), or None to skip gesture-name checks.
    """
    base = base_dir if base_dir is not None else (Path(path).parent if path != "<string>" else Path.cwd())
    a = _Analyser(path, gesture_names, base)
    header, utterances = a.run(source)
    diags = sorted(a.diags, key=sort_key)
    return Script(path, source, header, utterances, diags)


def read_source(path: Path) -> tuple[str, list[Diagnostic]]:
    """Read a script file as UTF-8; undecodable bytes become a diagnostic, not an exception."""
    data = path.read_bytes()
    text, bad = decode_source(data)
    diags = []
    if bad is not None:
        line = data[:bad].count(b"\n") + 1
        col = bad - (data.rfind(b"\n", 0, bad) + 1) + 1
        diags.append(Diagnostic(ERROR, "the file is not valid UTF-8", str(path), line, col, 1, "save the file as UTF-8", "encoding"))
    return text, diags
