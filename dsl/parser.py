"""Parse and check a script: source text -> :class:`~dsl.script.Script` plus diagnostics.

This is the static half of the front end (no speech, no timing); it is fast enough to run on
every keystroke. Checks that need the outside world (voices, recordings) and timing (pose
controls that overlap) live in the compiler, which every command and the editor share.

Every problem is reported with a rule of :mod:`core.rules`, and each root cause once: a
syntax error blanks the bad tag and the body is scanned again; a mismatched closing tag
closes the span it names (or nothing) without a second error; a preset whose definition
failed is not reported again where it is used.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from pathlib import Path

from core import rules
from core.controls import STYLE_NAMES
from core.diagnostics import Diagnostic, Fix, Related, TextEdit, sort_key
from core.face import EXPRESSIONS, PRESET_EXPRESSIONS
from core.reading import read_bytes
from dsl.directives import DirectiveContext, apply_directive
from dsl.durations import parse_duration
from dsl.lines import Statement, decode_source, split_lines, split_statements, utf16_order
from dsl.presets import BUILTIN_PRESETS
from dsl.scan import scan_items
from dsl.script import (
    Header,
    LookMark,
    Pause,
    PoseMark,
    Script,
    Span,
    StyleSpan,
    Utterance,
    WordToken,
)
from dsl.speakers import look_targets, speaker_diagnostics
from dsl.styles import parse_style_value

#: A spoken word: letters or digits, with inner apostrophes or hyphens ("don't", "left-hand").
WORD_RE = re.compile(r"[^\W_]+(?:['\u2019\-][^\W_]+)*")
ESCAPABLE = "[]<>\\#:"
TAG_KINDS = ("pose", "pause", "look")
POSE_OPTIONS = ("x1", "x2", "x3", "flip", "hold")
MAX_PAUSE = 10.0
MAX_HOLD = 10.0
_MAX_RECOVERIES = 50
_new_span = tuple.__new__  # Span(line, col, length) without the NamedTuple call overhead
_TAG_HINT = ("tags look like [pose:point_right x2 flip hold=500ms], [look:left] or [pause 300ms]; "
             "write '\\[' for a literal '['")
_STYLE_HINT = "style tags look like <speed:-1 space:+0.5> ... </> or <happy>; write '\\<' for a literal '<'"
#: Characters that hide in a script (see rules BIDI_CONTROL, INVISIBLE_CHARACTER, NUL_CHARACTER).
_SUSPICIOUS_RE = re.compile("[\x00\u200b\u200e\u200f\u2060\ufeff\u202a-\u202e\u2066-\u2069]+")
#: What follows ``hold`` when its '=' is missing (``hold 300ms``, ``hold 2``).
_HOLD_VALUE_RE = re.compile(r"(?:\d+(?:\.\d*)?|\.\d+)(?:ms|s)?")
_BIDI = frozenset("\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


class _Analyser:
    def __init__(self, path: str, gesture_names, base_dir: Path, skipped_gesture=None) -> None:
        self.file = path
        self._names_source = gesture_names
        self.gesture_names: set[str] | None = None
        self.skipped_gesture = skipped_gesture  # name -> Related (why its spec was skipped) or None
        self.base_dir = base_dir
        self.diags: list[Diagnostic] = []

    # -- diagnostics -------------------------------------------------------------------
    def report(self, stmt: Statement, offset: int, length: int, rule: rules.Rule, **kw) -> None:
        line, col = stmt.position(offset)
        self.diags.append(rule.at(self.file, line, col, length, **kw))

    def guess(self, stmt: Statement, offset: int, length: int, word: str, choices, fmt: str = "{}") -> dict:
        """``hint`` and ``fixes`` keywords for a misspelt ``word`` at ``offset`` (no hint when
        nothing is close, so the rule's default hint stays)."""
        line, col = stmt.position(offset)
        hint, fixes = rules.did_you_mean(word, choices, line, col, length, fmt)
        return {"fixes": fixes, **({"hint": hint} if hint else {})}

    def replace(self, stmt: Statement, offset: int, length: int, text: str, title: str) -> Fix:
        line, col = stmt.position(offset)
        return Fix(title, (TextEdit(line, col, length, text),))

    def related(self, where: Span, message: str) -> Related:
        return Related(message, self.file, where.line, where.col, where.length)

    def span(self, stmt: Statement, offset: int, length: int) -> Span:
        line, col = stmt.position(offset)
        return Span(line, col, max(1, length))

    # -- syntax ------------------------------------------------------------------------
    def parse_body(self, stmt: Statement) -> tuple[list[tuple] | None, str]:
        """Scan the utterance body; at a syntax error report it, blank the bad part and scan
        again (:func:`dsl.scan.scan_items` stops exactly where the grammar fails).

        Returns the body's items (see :mod:`dsl.scan`), None when it could not be repaired, and
        the body as read (bad parts blanked)."""
        body = stmt.text[stmt.body_offset :]
        items, stop = scan_items(body)
        if stop is None:
            return items, body
        chars = list(body)
        for _ in range(_MAX_RECOVERIES):
            lo, hi = self._syntax_error(stmt, body, stop)
            for i in range(lo, hi):
                if chars[i] != "\n":
                    chars[i] = " "
            body = "".join(chars)
            items, stop = scan_items(body)
            if stop is None:
                return items, body
        return None, body

    def _syntax_error(self, stmt: Statement, body: str, pos: int) -> tuple[int, int]:
        """Report the syntax error at body offset ``pos``; return the range to blank out."""
        at = stmt.body_offset + pos
        ch = body[pos]
        if ch in "[<":
            closer = "]" if ch == "[" else ">"
            what = "tag" if ch == "[" else "style tag"
            close = _find_closer(body, pos, closer)
            if close is None:
                self.report(stmt, at, 1, rules.UNCLOSED, char=ch, what=what, closer=closer,
                            fixes=(self.replace(stmt, at, 1, "\\" + ch, f"escape the '{ch}' to speak it"),))
                nxt = [j for j in (body.find(c, pos + 1) for c in "[<\n") if j >= 0]
                return pos, min(nxt) if nxt else len(body)
            inner = body[pos : close + 1]
            if ch == "[" and re.match(r"\[\s*pose\s*:\s*\]", inner):
                self.report(stmt, at, len(inner), rules.MISSING_NAME)
            elif ch == "[" and re.match(r"\[\s*look\s*:\s*\]", inner):
                self.report(stmt, at, len(inner), rules.MISSING_LOOK_TARGET)
            else:
                kind = "closing tag" if inner.startswith("</") else what
                self.report(stmt, at, len(inner), rules.BAD_TAG, what=kind, text=repr(inner),
                            hint=_TAG_HINT if ch == "[" else _STYLE_HINT)
            return pos, close + 1
        if ch in "]>":
            self.report(stmt, at, 1, rules.STRAY_CLOSER, char=ch, what="bracket" if ch == "]" else "angle bracket",
                        fixes=(self.replace(stmt, at, 1, "\\" + ch, f"escape the '{ch}' to speak it"),))
        elif ch == "\\":  # an escape takes any next character: this one ends the body
            self.report(stmt, at, 1, rules.TRAILING_BACKSLASH,
                        fixes=(self.replace(stmt, at, 1, "\\\\", "write a literal backslash"),))
        else:
            self.report(stmt, at, 1, rules.SYNTAX, char=ch)
        return pos, pos + 1

    # -- statements --------------------------------------------------------------------
    def run(self, source: str) -> tuple[Header, list[Utterance]]:
        statements, layout = split_statements(source, self.file)
        self.diags.extend(layout)
        # (an ASCII text can only hold NUL of them: two fast scans instead of the regex)
        if "\x00" in source or (not source.isascii() and _SUSPICIOUS_RE.search(source)):
            self._suspicious_characters(source)
        header = Header()
        ctx = DirectiveContext(self.file, self.base_dir, header, set(STYLE_NAMES) | set(BUILTIN_PRESETS) | {"face"})
        utterances: list[Utterance] = []
        first_utterance: Span | None = None
        audio_line = 0
        for stmt in statements:
            if stmt.kind == "directive":
                had = ctx.pending_audio
                apply_directive(ctx, stmt.text, stmt.line, first_utterance)
                if ctx.pending_audio is not had:
                    audio_line = stmt.line
                continue
            if first_utterance is None:  # the header is complete: now the gesture names are known
                self._resolve_names(header)
                first_utterance = Span(stmt.line, 1, max(1, len(stmt.text.split("\n", 1)[0])))
            before = len(self.diags)
            utt = self.utterance(stmt, len(utterances), header)
            if not utt.words and not any(d.is_error for d in self.diags[before:]):
                self._silent(stmt)
            utt.voice = header.voice_for(utt.speaker)
            utt.audio, ctx.pending_audio = ctx.pending_audio, None
            if ctx.pending_gap is not None:
                (utt.gap, utt.gap_where), ctx.pending_gap = ctx.pending_gap, None
            utterances.append(utt)
        if ctx.pending_audio is not None:
            self.diags.append(rules.DANGLING_AUDIO.at(self.file, audio_line, 1, 6))
        if ctx.pending_gap is not None:
            self.diags.append(rules.DANGLING_GAP.at(self.file, ctx.pending_gap[1].line, 1, 4))
        self.diags.extend(ctx.diagnostics)
        if utterances:
            self.diags.extend(speaker_diagnostics(self.file, header, [
                (u.speaker, Span(u.line, 1, len(u.speaker))) for u in utterances if u.speaker]))
            self.diags.extend(look_targets(self.file, utterances))
        return header, utterances

    def _silent(self, stmt: Statement) -> None:
        """Warn about an utterance with no words (and no error), with a fix that blanks its lines."""
        edits = tuple(TextEdit(line, col, len(piece), "")
                      for piece, line, col in zip(stmt.text.split("\n"), stmt._lines, stmt._cols) if piece)
        line, col = stmt.position(0)
        first = stmt.text.split("\n", 1)[0]
        who = f"'{stmt.speaker}'" if stmt.speaker else "it"
        self.diags.append(rules.SILENT_UTTERANCE.at(self.file, line, col, len(first), who=who,
                                                    fixes=(Fix("remove the line", edits),)))

    def _resolve_names(self, header: Header) -> None:
        names = self._names_source(header) if callable(self._names_source) else self._names_source
        self.gesture_names = set(names) if names is not None else None

    def _suspicious_characters(self, source: str) -> None:
        """Warn about NUL bytes, bidi controls and invisible characters, once per run per line."""
        for number, text in enumerate(split_lines(source), start=1):
            for m in _SUSPICIOUS_RE.finditer(text):
                run = m.group()
                col = m.start() + 1
                nul = run.count("\x00")
                bidi = [c for c in run if c in _BIDI]
                other = [c for c in run if c != "\x00" and c not in _BIDI]
                if number == 1 and m.start() == 0 and other and other[0] == "\ufeff":
                    other = other[1:]  # a byte-order mark at the start of the file is fine
                if nul:
                    self.diags.append(rules.NUL_CHARACTER.at(self.file, number, col, len(run), count=nul, s="s" if nul != 1 else "",
                                                             fixes=(Fix("remove them", (TextEdit(number, col, len(run), run.replace("\x00", "")),)),)))
                if bidi:
                    self.diags.append(rules.BIDI_CONTROL.at(self.file, number, col, len(run), chars=_codepoints(bidi),
                                                            fixes=(Fix("remove it", (TextEdit(number, col, len(run), "".join(c for c in run if c not in _BIDI)),)),)))
                if other:
                    self.diags.append(rules.INVISIBLE_CHARACTER.at(self.file, number, col, len(run), chars=_codepoints(other),
                                                                   fixes=(Fix("remove it", (TextEdit(number, col, len(run), "".join(c for c in run if c == "\x00" or c in _BIDI)),)),)))

    def utterance(self, stmt: Statement, index: int, header: Header) -> Utterance:
        items, body = self.parse_body(stmt)
        base = stmt.body_offset
        utt = Utterance(index=index, speaker=stmt.speaker, line=stmt.line, text="")
        marks: list[tuple] = []  # tags and style tags, in source order
        if items is None:
            spoken = shown = [body]
        else:  # tags and escape marks are blanked in the spoken text and left out of the display
            spoken, shown = [], []
            run_start = None  # where the current run of adjacent marks starts in the body
            for n, item in enumerate(items):
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
                        self.report(stmt, base + item[1], 2, rules.BAD_ESCAPE, char=ch,
                                    fixes=(self.replace(stmt, base + item[1], 2, ch, "remove the backslash"),))
                else:
                    spoken.append(" " * (item[2] - item[1]))
                    marks.append(item)
                    run_start = item[1] if run_start is None else run_start
                    nxt = items[n + 1] if n + 1 < len(items) else None
                    if nxt is None or nxt[0] in ("text", "escape"):  # the run of marks ends here
                        if _between_letters(body, run_start, item[2]):
                            shown.append(" ")  # the speech splits the word here: so does the display
                            self._mark_in_word(stmt, body, run_start, item[2])
                        run_start = None
        # line breaks of continuation lines are spaces (an escaped one is already blanked)
        utt.text = text = " " * base + "".join(spoken).replace("\n", " ")
        utt.display = " ".join("".join(shown).split())
        if items is not None:
            utt.words = self._words(stmt, text)
        self._marks(stmt, utt, marks, header, base)
        return utt

    def _mark_in_word(self, stmt: Statement, body: str, start: int, end: int) -> None:
        """Warn about marks (body[start:end]) written inside a word, with a fix that moves them."""
        left = start
        while left > 0 and (body[left - 1].isalnum() or body[left - 1] in "'\u2019-"):
            left -= 1
        right = end
        while right < len(body) and (body[right].isalnum() or body[right] in "'\u2019-"):
            right += 1
        mark = body[start:end]
        closing = mark.startswith("</")
        what = ("closing tag" if closing else "style tag" if mark.startswith("<") else "pause" if re.match(r"\[\s*pause", mark)
                else "look mark" if re.match(r"\[\s*look", mark) else "pose control" if mark.startswith("[") else "tag")
        first, second = body[left:start], body[end:right]
        base = stmt.body_offset
        fixes: tuple = ()
        (l0, c0), (l1, _) = stmt.position(base + left), stmt.position(base + right)
        if "\n" not in body[left:right] and l0 == l1:
            _, cm = stmt.position(base + start)
            if closing:  # a closing tag moves after the word, anything else before it
                _, cw = stmt.position(base + right)
            else:
                cw = c0
            fixes = (Fix(f"move the {what} {'after' if closing else 'before'} the word",
                         (TextEdit(l0, cw, 0, mark), TextEdit(l0, cm, len(mark), ""))),)
        self.report(stmt, base + start, end - start, rules.MARK_IN_WORD, what=what, word=first + second,
                    parts=f"'{first}' and '{second}'", fixes=fixes)

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
                span = self._style_open(stmt, offset, length, payload, presets, header.broken_presets, stack, base)
                if span is not None:
                    utt.styles.append(span)
                else:  # keep the stack in step so its closing tag is not reported again
                    first = payload[0][0]
                    span = StyleSpan(first, dict(stack[-1].values) if stack else {}, offset, -1, self.span(stmt, offset, length))
                stack.append(span)
            else:  # style_close
                self._style_close(stmt, offset, length, payload, stack)
        for span in stack:  # left open: lasts to the end of the utterance
            span.end_offset = len(utt.text)
        self._resolve_styles(stmt, utt)

    def _style_close(self, stmt: Statement, offset: int, length: int, names: list[str], stack: list[StyleSpan]) -> None:
        text = stmt.text[offset : offset + length]
        if not stack:
            self.report(stmt, offset, length, rules.UNMATCHED_CLOSE, text=text,
                        fixes=(self.replace(stmt, offset, length, "", "remove it"),))
            return
        top = stack[-1]
        if names and names[0] != top.name:
            self.report(stmt, offset, length, rules.MISMATCHED_CLOSE, text=text, top=top.name,
                        related=(self.related(top.where, f"the innermost open span, <{top.name}...>, opens here"),),
                        fixes=(self.replace(stmt, offset, length, f"</{top.name}>", f"close <{top.name}...> here"),
                               self.replace(stmt, offset, length, "</>", "close the innermost span here")))
            # Crossed spans (<a><b>..</a>..</b>): close the span it names and keep the inner
            # ones open, so their own closing tags still match. A name no open span has
            # closes nothing. Either way the problem is reported once.
            for i in range(len(stack) - 1, -1, -1):
                if stack[i].name == names[0]:
                    stack.pop(i).end_offset = offset
                    break
            return
        stack.pop().end_offset = offset

    def _tag(self, stmt, utt: Utterance, offset: int, length: int, payload, starts: list[int], base: int) -> None:
        names, args = payload  # NAMEs as (text, start); args as (key, value|None, start, end)
        kind, kpos = names[0]
        kpos += base
        if kind not in TAG_KINDS:
            self.report(stmt, kpos, len(kind), rules.UNKNOWN_TAG, kind=kind, **self.guess(stmt, kpos, len(kind), kind, TAG_KINDS))
            return
        if kind == "pause":
            self._pause(stmt, utt, offset, length, names, args, starts, base)
            return
        if kind == "look":
            self._look(stmt, utt, offset, length, names, args, starts, base)
            return
        if len(names) < 2:
            self.report(stmt, offset, length, rules.MISSING_NAME)
            return
        name, npos = names[1]
        npos += base
        ok = True
        if self.gesture_names is not None and name not in self.gesture_names:
            why = self.skipped_gesture(name) if self.skipped_gesture else None
            self.report(stmt, npos, len(name), rules.UNKNOWN_GESTURE, name=name, related=(why,) if why else (),
                        **self.guess(stmt, npos, len(name), name, sorted(self.gesture_names)))
            ok = False
        speed, flip, hold = 1, False, 0.0
        seen: dict[str, tuple[int, int]] = {}
        args = list(args)
        while args:
            key, value, a0, a1 = args.pop(0)
            apos, alen = base + a0, a1 - a0
            group = "speed" if key in ("x1", "x2", "x3") else key
            if group in seen and key in POSE_OPTIONS:
                what = "the speed (x1, x2, x3)" if group == "speed" else f"pose option '{key}'"
                line, col = stmt.position(seen[group][0])
                self.report(stmt, apos, alen, rules.DUPLICATE, what=what,
                            related=(Related("the earlier one, overridden", self.file, line, col, seen[group][1]),),
                            fixes=(Fix("remove the earlier one", (TextEdit(line, col, seen[group][1], ""),)),)
                            if line == stmt.position(apos)[0] else ())
            seen[group] = (apos, alen)
            if key == "hold" and value is None and args and args[0][1] is None and _HOLD_VALUE_RE.fullmatch(args[0][0]):
                self._hold_form(stmt, apos, base + args[0][3] - apos, args.pop(0)[0])
                ok = False
            elif key in ("x1", "x2", "x3") and value is None:
                speed = int(key[1])
            elif key == "flip" and value is None:
                flip = True
            elif key == "hold":
                seconds = self._hold_seconds(stmt, apos, alen, value)
                if seconds is None:
                    ok = False
                else:
                    hold = seconds
            elif key in ("x1", "x2", "x3", "flip"):
                self.report(stmt, apos, alen, rules.OPTION_VALUE, key=key,
                            fixes=(self.replace(stmt, apos, alen, key, f"write just '{key}'"),))
                ok = False
            else:
                self.report(stmt, apos, alen, rules.UNKNOWN_OPTION, key=key, **self.guess(stmt, apos, len(key), key, POSE_OPTIONS))
                ok = False
        if not utt.words and not starts:
            self.report(stmt, offset, length, rules.EMPTY_UTTERANCE)
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

    def _hold_seconds(self, stmt, apos: int, alen: int, value: str | None) -> float | None:
        """The seconds of a ``hold=DURATION`` option (a pose control's or a look mark's), or None
        after reporting a bad or out-of-range duration."""
        seconds = parse_duration(value) if value is not None else None
        if seconds is None:
            self._bad_duration(stmt, apos, alen, "hold", value)
            return None
        if not 0 < seconds <= MAX_HOLD:
            self.report(stmt, apos, alen, rules.OUT_OF_RANGE, what="hold", value=value,
                        allowed=f"more than 0 and at most {MAX_HOLD:g}s")
            return None
        return seconds

    def _look(self, stmt, utt: Utterance, offset: int, length: int, names, args, starts: list[int], base: int) -> None:
        """``[look:TARGET hold=DURATION]``: a :class:`~dsl.script.LookMark` anchored like a pose
        control (the next word, else the end of the last one). Whether TARGET is a speaker is
        known once every line is read (:func:`dsl.speakers.look_targets`)."""
        if len(names) < 2:
            self.report(stmt, offset, length, rules.MISSING_LOOK_TARGET)
            return
        target, tpos = names[1]
        tpos += base
        hold, ok, seen = 0.0, True, None
        args = list(args)
        while args:
            key, value, a0, a1 = args.pop(0)
            apos, alen = base + a0, a1 - a0
            if key == "hold" and value is None and args and args[0][1] is None and _HOLD_VALUE_RE.fullmatch(args[0][0]):
                self._hold_form(stmt, apos, base + args[0][3] - apos, args.pop(0)[0])
                ok = False
                continue
            if key != "hold" or value is None:
                space = stmt.text[apos - 1] in " \t"
                self.report(stmt, apos, alen, rules.LOOK_OPTION, key=stmt.text[apos : apos + alen],
                            fixes=(self.replace(stmt, apos - space, alen + space, "", "remove it"),))
                ok = False
                continue
            if seen is not None:
                line, col = stmt.position(seen[0])
                self.report(stmt, apos, alen, rules.DUPLICATE, what="option 'hold'",
                            related=(Related("the earlier one, overridden", self.file, line, col, seen[1]),),
                            fixes=(Fix("remove the earlier one", (TextEdit(line, col, seen[1], ""),)),)
                            if line == stmt.position(apos)[0] else ())
            seen = (apos, alen)
            seconds = self._hold_seconds(stmt, apos, alen, value)
            if seconds is None:
                ok = False
            else:
                hold = seconds
        if not ok or not starts:  # (no words: the eyes have no word to follow; silent-utterance says so)
            return
        mark = LookMark(target, hold, offset, self.span(stmt, offset, length), None,
                        target_where=self.span(stmt, tpos, len(target)))
        following = bisect_right(starts, offset)
        if following < len(starts):
            mark.word_index = following
        else:
            mark.after_word = len(starts) - 1
        utt.looks.append(mark)

    def _hold_form(self, stmt, offset: int, length: int, value: str) -> None:
        """``hold 300ms`` (a space for the '='): one error, fixed by ``hold=300ms``; a bare
        number gets both units."""
        texts = [f"hold={value}"] if value.endswith("s") else [f"hold={value}ms", f"hold={value}s"]
        (l0, _), (l1, _) = stmt.position(offset), stmt.position(offset + length - 1)
        fixes = tuple(self.replace(stmt, offset, length, t, f"write {t}") for t in texts) if l0 == l1 else ()
        self.report(stmt, offset, length, rules.HOLD_FORM, value=value, hint="write " + " or ".join(texts), fixes=fixes)

    def _bad_duration(self, stmt, offset: int, length: int, what: str, text: str | None) -> None:
        """A duration without a unit gets fixes that add one; a missing one says so."""
        text = text or ""
        kw: dict = {}
        if re.fullmatch(r"\d+(?:\.\d*)?|\.\d+", text):
            start = offset + length - len(text)
            kw = {"hint": f"add a unit: {text}ms or {text}s",
                  "fixes": (self.replace(stmt, start, len(text), text + "ms", f"write {text}ms"),
                            self.replace(stmt, start, len(text), text + "s", f"write {text}s"))}
        self.report(stmt, offset, length, rules.BAD_DURATION, what=what, given=f", not '{text}'" if text else "", **kw)

    def _pause(self, stmt, utt, offset, length, names, args, starts, base) -> None:
        if len(names) > 1 or len(args) != 1 or args[0][1] is not None:
            self.report(stmt, offset, length, rules.BAD_PAUSE)
            return
        text = args[0][0]
        seconds = parse_duration(text)
        apos = base + args[0][2]
        if seconds is None:
            self._bad_duration(stmt, apos, len(text), "a pause", text)
            return
        if not 0 < seconds <= MAX_PAUSE:
            self.report(stmt, apos, len(text), rules.OUT_OF_RANGE, what="pause", value=text,
                        allowed=f"more than 0 and at most {MAX_PAUSE:g}s")
            return
        index = bisect_right(starts, offset)
        utt.pauses.append(Pause(seconds, offset, self.span(stmt, offset, length), index))

    def _style_open(self, stmt, offset, length, items, presets, broken, stack, base) -> StyleSpan | None:
        values: dict[str, float] = {}
        first_name = None
        ok = True
        styled = False  # a style element or a preset of its own
        face = preset_face = None  # its own expression (face:NAME), a built-in preset's
        seen: dict[str, tuple[int, int]] = {}
        for name, value, i0, i1 in items:
            ipos, ilen = base + i0, i1 - i0
            first_name = first_name or name
            if name in seen:
                line, col = stmt.position(seen[name][0])
                self.report(stmt, ipos, ilen, rules.DUPLICATE, what=f"style item '{name}'",
                            related=(Related("the earlier one, overridden", self.file, line, col, seen[name][1]),),
                            fixes=(Fix("remove the earlier one", (TextEdit(line, col, seen[name][1], ""),)),)
                            if line == stmt.position(ipos)[0] else ())
            seen[name] = (ipos, ilen)
            if name == "face":
                if value in EXPRESSIONS:
                    face = value
                    continue
                kw = self.guess(stmt, ipos + ilen - len(value), len(value), value, list(EXPRESSIONS)) if value else {}
                self.report(stmt, ipos, ilen, rules.UNKNOWN_FACE, given=f", not '{value}'" if value else "",
                            names=", ".join(EXPRESSIONS), **kw)
                ok = False
                continue
            if name in presets:
                if value is not None:
                    self.report(stmt, ipos, ilen, rules.PRESET_VALUE, name=name,
                                fixes=(self.replace(stmt, ipos, ilen, name, f"write <{name}>"),))
                    ok = False
                    continue
                values.update(presets[name])
                styled = True
                preset_face = PRESET_EXPRESSIONS.get(name, preset_face)
                continue
            if name in broken:  # its definition is already reported: its uses are not
                ok = False
                continue
            result = parse_style_value(name, value)
            if isinstance(result, tuple):
                rule, fields = result
                kw: dict = {}
                if rule is rules.UNKNOWN_STYLE:
                    fields = {**fields, "what": "style or preset"}
                    kw = self.guess(stmt, ipos, len(name), name, list(STYLE_NAMES) + sorted(presets))
                self.report(stmt, ipos, ilen, rule, **fields, **kw)
                ok = False
                continue
            values[name] = result
            styled = True
        face = face or preset_face
        if not ok and not values and face is None:
            return None
        inherited = dict(stack[-1].values) if stack else {}
        inherited.update(values)
        return StyleSpan(first_name or "style", inherited, offset, -1, self.span(stmt, offset, length), face=face,
                         styled=styled or not face)

    def _resolve_styles(self, stmt: Statement, utt: Utterance) -> None:
        for span in utt.styles:
            inside = [i for i, w in enumerate(utt.words) if w.start >= span.offset and w.end <= span.end_offset]
            if inside:
                span.first_word, span.last_word = inside[0], inside[-1]
            elif utt.words:  # (no words at all: silent-utterance, or an error, says so once)
                self.report(stmt, span.offset, span.where.length, rules.EMPTY_SPAN)


def _between_letters(body: str, start: int, end: int) -> bool:
    """Whether body[start:end] (a run of marks) has a letter or digit right before and after it."""
    return 0 < start and end < len(body) and body[start - 1].isalnum() and body[end].isalnum()


def _codepoints(chars) -> str:
    names = {"\u200b": "ZERO WIDTH SPACE", "\u2060": "WORD JOINER", "\ufeff": "BYTE ORDER MARK",
             "\u200e": "LEFT-TO-RIGHT MARK", "\u200f": "RIGHT-TO-LEFT MARK", "\u202a": "LEFT-TO-RIGHT EMBEDDING",
             "\u202b": "RIGHT-TO-LEFT EMBEDDING", "\u202c": "POP DIRECTIONAL FORMATTING",
             "\u202d": "LEFT-TO-RIGHT OVERRIDE", "\u202e": "RIGHT-TO-LEFT OVERRIDE", "\u2066": "LEFT-TO-RIGHT ISOLATE",
             "\u2067": "RIGHT-TO-LEFT ISOLATE", "\u2068": "FIRST STRONG ISOLATE", "\u2069": "POP DIRECTIONAL ISOLATE"}
    unique = list(dict.fromkeys(chars))
    return ", ".join(f"U+{ord(c):04X} ({names.get(c, 'invisible')})" for c in unique)


def _find_closer(body: str, start: int, closer: str) -> int | None:
    """The ``closer`` that ends the tag opened at ``start``, unless another tag or the line
    ends first."""
    for i in range(start + 1, len(body)):
        c = body[i]
        if c == closer:
            return i
        if c in "[<\n":
            return None
    return None


def analyse(source: str, path: str = "<string>", gesture_names=None, base_dir: Path | None = None,
            skipped_gesture=None) -> Script:
    """Parse and statically check ``source``.

    ``gesture_names`` is the set of known gestures, a callable ``header -> names`` called once
    the header is read (so ``@library`` folders count), or None to skip gesture-name checks.
    ``skipped_gesture(name)`` may return a :class:`~core.diagnostics.Related` note saying why a
    gesture of that name is missing (its spec file was skipped), for the unknown-gesture error.
    """
    base = base_dir if base_dir is not None else (Path(path).parent if path != "<string>" else Path.cwd())
    a = _Analyser(path, gesture_names, base, skipped_gesture)
    header, utterances = a.run(source)
    diags = sorted(a.diags, key=sort_key)
    return Script(path, source, header, utterances, diags)


def read_source(path: Path) -> tuple[str, list[Diagnostic]]:
    """Read a script file as UTF-8; undecodable bytes become a diagnostic, not an exception.

    A UTF-16 file is not decoded at all (it would be garbage): the text is empty and the one
    diagnostic says so. Raises ``OSError`` when the file cannot be read, and
    :class:`core.reading.InputFileError` (an ``OSError``) for a FIFO, a device or a file over
    the size limit of scripts (never read)."""
    data = read_bytes(path, "script")
    order = utf16_order(data)
    if order is not None:
        return "", [rules.UTF16.at(str(path), 0, 0, order=order)]
    text, bad = decode_source(data)
    diags = []
    if bad is not None:
        body = data[3:] if data.startswith(b"\xef\xbb\xbf") else data
        line = body[:bad].count(b"\n") + 1
        start = body.rfind(b"\n", 0, bad) + 1
        col = len(body[start:bad].decode("utf-8", errors="replace")) + 1  # characters, not bytes
        diags.append(rules.ENCODING.at(str(path), line, col, 1))
    return text, diags
