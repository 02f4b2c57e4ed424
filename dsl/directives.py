"""Header directives: ``@voice``, ``@rate``, ``@pitch``, ``@seed``, ``@library``, ``@preset``, ``@audio``.

::

    @voice en-us              # default voice for every speaker
    @voice robot: en-us+m3    # one speaker's voice
    @rate 150                 # words per minute (80..450); also per speaker
    @pitch 40                 # 0..100; also per speaker
    @seed 7                   # random seed of the generator
    @library ./gestures       # extra gesture folder, relative to the script
    @preset excited = speed:+2 space:+1.5
    @audio rec/line1.wav timings=rec/line1.TextGrid   # for the next utterance
    @gap 0.8s                 # silence between lines (header); before the next line (later)
    @gap -400ms               # (not in the header) the next line starts 0.4 s before the speech so far ends

All but ``@audio`` and ``@gap`` belong to the header, before the first utterance. A setting given twice
(the same directive for the same speaker, a preset of the same name, the same folder, two
``@audio`` for one utterance) is a warning and the last one wins (:data:`core.rules.DUPLICATE`).
"""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path

from core import rules
from core.controls import STYLE_NAMES
from core.diagnostics import Diagnostic, Related
from core.reading import kind_of, not_a_file
from core.seeds import SEED_MAX
from dsl.durations import parse_duration
from dsl.script import MAX_GAP, AudioRef, Header, Span
from dsl.speech.synth import PITCH_RANGE, RATE_RANGE
from dsl.styles import parse_style_value

DIRECTIVES = ("voice", "rate", "pitch", "seed", "library", "preset", "audio", "gap")
DIRECTIVE_LIST = ", ".join("@" + d for d in DIRECTIVES)
HEADER_ONLY = {"voice", "rate", "pitch", "seed", "library", "preset"}
NAME_RE = re.compile(r"[a-z][a-z0-9_]*\Z")
_ARG_RE = re.compile(r'"([^"]*)"|\'([^\']*)\'|(\S+)')


@dataclass
class Arg:
    text: str
    col: int  # 1-based column in the file
    length: int


class DirectiveContext:
    """Collects diagnostics while directives update the header."""

    def __init__(self, file: str, base_dir: Path, header: Header, builtin_style_names) -> None:
        self.file = file
        self.base_dir = base_dir
        self.header = header
        self.reserved = set(builtin_style_names)
        self.diagnostics: list[Diagnostic] = []
        self.pending_audio: AudioRef | None = None
        self.pending_gap: tuple[float, Span] | None = None  # ``@gap`` after the first utterance
        self.in_header = True

    def report(self, rule: rules.Rule, line: int, col: int, length: int, **kw) -> None:
        self.diagnostics.append(rule.at(self.file, line, col, length, **kw))

    def setting(self, key: str, what: str, where: Span) -> None:
        """Record where setting ``key`` is given; warn when it was given before (the last wins)."""
        earlier = self.header.settings_where.get(key)
        if earlier is not None:
            self.report(rules.DUPLICATE, where.line, where.col, where.length, what=what,
                        related=(Related("the earlier one, overridden", self.file, *earlier),))
        self.header.settings_where[key] = where


def split_args(text: str, line: int, first_col: int) -> list[Arg]:
    args = []
    for m in _ARG_RE.finditer(text):
        value = next(g for g in m.groups() if g is not None)
        args.append(Arg(value, first_col + m.start(), m.end() - m.start()))
    return args


def apply_directive(ctx: DirectiveContext, text: str, line: int, first_utterance: Span | None) -> None:
    """Check one directive line and apply it to ``ctx.header``; ``first_utterance`` is where the
    first utterance is when one came before this line (None in the header)."""
    m = re.match(r"@([A-Za-z_][A-Za-z0-9_\-]*)?", text)
    name = m.group(1) if m else None
    if not name:
        ctx.report(rules.DIRECTIVE_NAME, line, 1, 1, names=DIRECTIVE_LIST)
        return
    if name not in DIRECTIVES:
        hint, fixes = rules.did_you_mean(name, DIRECTIVES, line, 1, len(name) + 1, "@{}")
        ctx.report(rules.UNKNOWN_DIRECTIVE, line, 1, len(name) + 1, name=name, names=DIRECTIVE_LIST,
                   fixes=fixes, **({"hint": hint} if hint else {}))
        return
    if name in HEADER_ONLY and first_utterance is not None:
        ctx.report(rules.HEADER_ONLY, line, 1, len(name) + 1, name=name,
                   related=(Related("the first utterance is here: the header ends before it", ctx.file, *first_utterance),))
        return
    ctx.in_header = first_utterance is None
    args = split_args(text[m.end():], line, m.end() + 1)
    handler = globals()[f"_do_{name}"]
    handler(ctx, args, line, Span(line, 1, len(name) + 1))


def _speaker_and_rest(ctx: DirectiveContext, args: list[Arg], line: int, directive: str) -> tuple[str, list[Arg]]:
    """The speaker a per-speaker directive names ("" for none) and its other arguments; the
    name and its place are recorded in the header (:data:`core.rules.UNKNOWN_SPEAKER`)."""
    if args and args[0].text.endswith(":") and len(args[0].text) > 1:
        name, rest = args[0].text[:-1], args[1:]
    elif len(args) >= 2 and args[1].text == ":":
        name, rest = args[0].text, args[2:]
    else:
        return "", args
    quoted = args[0].length > len(args[0].text)  # '"knight":' is written with its quotes
    ctx.header.speaker_refs.append((name, Span(line, args[0].col + quoted, len(name)), directive))
    return name, rest


def _set_voice(ctx: DirectiveContext, speaker: str, key: str, value, where: Span) -> None:
    """Set a voice setting for everyone ("") or for one speaker (an override)."""
    who = f" for speaker '{speaker}'" if speaker else ""
    ctx.setting(f"{key}:{speaker}", f"'@{'voice' if key == 'name' else key}'{who}", where)
    if speaker:
        ctx.header.speaker_overrides.setdefault(speaker, {})[key] = value
    else:
        setattr(ctx.header.voice, key, value)


def _need_one(ctx, args, line, where, what, example) -> Arg | None:
    if not args:
        ctx.report(rules.MISSING_VALUE, line, where.col, where.length, directive=what, what="a value", example=example)
        return None
    for extra in args[1:]:
        ctx.report(rules.EXTRA_ARGUMENT, line, extra.col, extra.length, text=extra.text, directive=what, example=example,
                   fixes=(rules.delete(line, extra.col, extra.length, f"remove '{extra.text}'"),))
    return args[0]


def _int_in_range(ctx, arg: Arg, line: int, what: str, lo: int, hi: int) -> int | None:
    try:
        value = int(arg.text)
    except ValueError:
        ctx.report(rules.BAD_NUMBER, line, arg.col, arg.length, what=what, text=arg.text, lo=lo, hi=hi)
        return None
    if not lo <= value <= hi:
        ctx.report(rules.OUT_OF_RANGE, line, arg.col, arg.length, what=what, value=value, allowed=f"a value from {lo} to {hi}")
        return None
    return value


def _do_voice(ctx, args, line, where):
    speaker, rest = _speaker_and_rest(ctx, args, line, "voice")
    arg = _need_one(ctx, rest, line, where, "voice", "@voice en-us   or   @voice guide: en-gb")
    if arg is None:
        return
    span = Span(line, arg.col, arg.length)
    _set_voice(ctx, speaker, "name", arg.text, span)
    ctx.header.voice_where[speaker] = span


def _do_rate(ctx, args, line, where):
    speaker, rest = _speaker_and_rest(ctx, args, line, "rate")
    arg = _need_one(ctx, rest, line, where, "rate", "@rate 160")
    if arg is not None:
        value = _int_in_range(ctx, arg, line, "speaking rate (words per minute)", *RATE_RANGE)
        if value is not None:
            _set_voice(ctx, speaker, "rate", value, Span(line, arg.col, arg.length))


def _do_pitch(ctx, args, line, where):
    speaker, rest = _speaker_and_rest(ctx, args, line, "pitch")
    arg = _need_one(ctx, rest, line, where, "pitch", "@pitch 50")
    if arg is not None:
        value = _int_in_range(ctx, arg, line, "pitch", *PITCH_RANGE)
        if value is not None:
            _set_voice(ctx, speaker, "pitch", value, Span(line, arg.col, arg.length))


def _do_seed(ctx, args, line, where):
    arg = _need_one(ctx, args, line, where, "seed", "@seed 7")
    if arg is not None:
        value = _int_in_range(ctx, arg, line, "seed", 0, SEED_MAX)
        if value is not None:
            ctx.setting("seed", "'@seed'", Span(line, arg.col, arg.length))
            ctx.header.seed = value


def _do_library(ctx, args, line, where):
    arg = _need_one(ctx, args, line, where, "library", "@library ./my_gestures")
    if arg is None:
        return
    path = Path(arg.text).expanduser()
    if not path.is_absolute():
        path = ctx.base_dir / path
    if not path.is_dir():
        if path.exists():
            ctx.report(rules.WRONG_KIND, line, arg.col, arg.length, what="gesture folder", text=arg.text,
                       kind=_kind(path), expected="a folder of gesture specs")
        else:
            ctx.report(rules.MISSING_FOLDER, line, arg.col, arg.length, text=arg.text, path=path)
        return
    span = Span(line, arg.col, arg.length)
    ctx.setting(f"library:{path.resolve()}", f"gesture folder '{arg.text}'", span)
    if path not in ctx.header.library_dirs:
        ctx.header.library_dirs.append(path)
    ctx.header.library_where[path] = span


def _do_preset(ctx, args, line, where):
    example = "@preset excited = speed:+2 space:+1.5"
    if not args:
        ctx.report(rules.MISSING_VALUE, line, where.col, where.length, directive="preset", what="a name and style values", example=example)
        return
    name_arg, rest = args[0], args[1:]
    name = name_arg.text
    if "=" in name and name != "=":  # "@preset excited=speed:+2"
        name, _, tail = name.partition("=")
        if tail:
            rest = [Arg(tail, name_arg.col + len(name) + 1, len(tail))] + rest
    elif rest and rest[0].text == "=":
        rest = rest[1:]
    elif rest and rest[0].text.startswith("="):
        first = rest[0]
        rest = [Arg(first.text[1:], first.col + 1, first.length - 1)] + rest[1:]
    if not NAME_RE.match(name):
        ctx.report(rules.BAD_NAME, line, name_arg.col, name_arg.length, name=name)
        ctx.header.broken_presets.add(name)
        return
    if name in ctx.reserved:
        ctx.report(rules.RESERVED_NAME, line, name_arg.col, len(name), name=name)
        return
    ctx.setting(f"preset:{name}", f"preset '{name}'", Span(line, name_arg.col, len(name)))
    if not rest:
        ctx.report(rules.MISSING_VALUE, line, name_arg.col, name_arg.length, directive="preset",
                   what=f"style values after '{name} ='", example=example)
        ctx.header.broken_presets.add(name)
        return
    values: dict[str, float] = {}
    seen: dict[str, Arg] = {}
    broken = False
    for arg in rest:
        item, sep, value_text = arg.text.partition(":")
        if item in seen:
            earlier = seen[item]
            ctx.report(rules.DUPLICATE, line, arg.col, arg.length, what=f"style item '{item}'",
                       related=(Related("the earlier one, overridden", ctx.file, line, earlier.col, earlier.length),))
        seen[item] = arg
        result = parse_style_value(item, value_text if sep else None)
        if isinstance(result, tuple):
            rule, fields = result
            kw = {}
            if rule is rules.UNKNOWN_STYLE:
                hint, fixes = rules.did_you_mean(item, STYLE_NAMES, line, arg.col, len(item))
                kw = {"fixes": fixes, **({"hint": hint} if hint else {})}
            ctx.report(rule, line, arg.col, arg.length, **fields, **kw)
            broken = True
            continue
        values[item] = result
    ctx.header.presets.pop(name, None)
    if broken:  # reported once here; its uses are not errors again
        ctx.header.broken_presets.add(name)
    else:
        ctx.header.broken_presets.discard(name)
        ctx.header.presets[name] = values


def _do_gap(ctx, args, line, where):
    arg = _need_one(ctx, args, line, where, "gap", "@gap 0.8s")
    if arg is None:
        return
    negative = arg.text.startswith("-")
    seconds = parse_duration(arg.text[1:] if negative else arg.text)
    if seconds is not None and negative:
        seconds = -seconds  # between two lines: the next one interrupts (see Plan.lay_out)
    lo = 0.0 if ctx.in_header else -MAX_GAP
    if seconds is None or not lo <= seconds <= MAX_GAP:
        ctx.report(rules.BAD_GAP, line, arg.col, arg.length, text=arg.text, lo=f"{lo:g}s", hi=f"{MAX_GAP:g}",
                   where=" in the header" if ctx.in_header else " (negative: the next line interrupts)",
                   negative="; a negative gap goes just before the line that interrupts" if ctx.in_header and negative else "")
        return
    span = Span(line, arg.col, arg.length)
    if ctx.in_header:
        ctx.setting("gap", "'@gap'", span)
        ctx.header.gap = seconds
        return
    if ctx.pending_gap is not None:
        earlier = ctx.pending_gap[1]
        ctx.report(rules.DUPLICATE, line, where.col, where.length, what="'@gap' before one utterance",
                   related=(Related("the earlier one, overridden", ctx.file, earlier.line, earlier.col, earlier.length),))
    ctx.pending_gap = (seconds, span)


def _do_audio(ctx, args, line, where):
    if not args:
        ctx.report(rules.MISSING_VALUE, line, where.col, where.length, directive="audio", what="a file",
                   example="@audio rec/line1.wav timings=rec/line1.TextGrid")
        return
    audio_arg, timings, timings_where = args[0], None, None
    for arg in args[1:]:
        key, sep, value = arg.text.partition("=")
        if key != "timings" or not sep or not value:
            hint, fixes = rules.did_you_mean(key, ("timings",), line, arg.col, len(key))
            ctx.report(rules.UNKNOWN_AUDIO_OPTION, line, arg.col, arg.length, text=arg.text, fixes=fixes,
                       **({"hint": hint} if hint else {}))
            continue
        vcol = arg.col + len(key) + 1
        tpath = _resolve_file(ctx, value, line, vcol, len(value), "word timings file")
        if tpath is not None:
            if tpath.suffix.lower() not in (".textgrid", ".json"):
                ctx.report(rules.BAD_FORMAT, line, vcol, len(value), suffix=tpath.suffix)
            else:
                timings, timings_where = tpath, Span(line, vcol, len(value))
    apath = _resolve_file(ctx, audio_arg.text, line, audio_arg.col, audio_arg.length, "audio file")
    if apath is None:
        return
    span = Span(line, audio_arg.col, audio_arg.length)
    if ctx.pending_audio is not None:
        ctx.report(rules.DUPLICATE, line, 1, 6, what="'@audio' for one utterance",
                   related=(Related("the earlier one, overridden", ctx.file, ctx.pending_audio.where.line, 1, 6),))
    ctx.pending_audio = AudioRef(apath, timings, span, timings_where)


def _resolve_file(ctx, text, line, col, length, what) -> Path | None:
    path = Path(text).expanduser()
    if not path.is_absolute():
        path = ctx.base_dir / path
    why = not_a_file(path)
    if why is not None:
        ctx.report(rules.WRONG_KIND, line, col, length, what=what, text=text, kind=_kind(path), expected="a regular file")
        return None
    if not path.is_file():
        ctx.report(rules.MISSING_FILE, line, col, length, what=what, text=text, path=path)
        return None
    return path


def _kind(path: Path) -> str:
    """What ``path`` is, for WRONG_KIND: "a folder", "a FIFO (named pipe)", "a file"..."""
    mode = os.stat(path).st_mode
    return "a file" if stat.S_ISREG(mode) else kind_of(mode)
