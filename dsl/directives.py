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

All but ``@audio`` belong to the header, before the first utterance.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from core.diagnostics import ERROR, WARNING, Diagnostic, did_you_mean
from core.seeds import SEED_MAX
from dsl.script import AudioRef, Header, Span
from dsl.styles import STYLE_ITEM_HELP, parse_style_value

DIRECTIVES = ("voice", "rate", "pitch", "seed", "library", "preset", "audio")
HEADER_ONLY = {"voice", "rate", "pitch", "seed", "library", "preset"}
RATE_RANGE = (80, 450)
PITCH_RANGE = (0, 100)
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

    def error(self, line: int, col: int, length: int, message: str, hint: str | None = None, code: str = "", severity: str = ERROR, suggestions=()) -> None:
        self.diagnostics.append(Diagnostic(severity, message, self.file, line, col, max(1, length), hint, code, tuple(suggestions)))


def split_args(text: str, line: int, first_col: int) -> list[Arg]:
    args = []
    for m in _ARG_RE.finditer(text):
        value = next(g for g in m.groups() if g is not None)
        args.append(Arg(value, first_col + m.start(), m.end() - m.start()))
    return args


def apply_directive(ctx: DirectiveContext, text: str, line: int, seen_utterance: bool) -> None:
    """Check one directive line and apply it to ``ctx.header``."""
    m = re.match(r"@([A-Za-z_][A-Za-z0-9_\-]*)?", text)
    name = m.group(1) if m else None
    if not name:
        ctx.error(line, 1, 1, "a directive needs a name after '@'", "directives are: " + ", ".join("@" + d for d in DIRECTIVES), "directive-name")
        return
    if name not in DIRECTIVES:
        hint, sugg = did_you_mean(name, DIRECTIVES)
        ctx.error(line, 1, len(name) + 1, f"unknown directive '@{name}'", hint or ("directives are: " + ", ".join("@" + d for d in DIRECTIVES)), "unknown-directive", suggestions=tuple("@" + s for s in sugg))
        return
    if name in HEADER_ONLY and seen_utterance:
        ctx.error(line, 1, len(name) + 1, f"'@{name}' must be in the header, before the first utterance", "move it to the top of the file", "header-only")
        return
    args = split_args(text[m.end():], line, m.end() + 1)
    handler = globals()[f"_do_{name}"]
    handler(ctx, args, line, Span(line, 1, len(name) + 1))


def _speaker_and_rest(args: list[Arg]) -> tuple[str, list[Arg]]:
    if args and args[0].text.endswith(":") and len(args[0].text) > 1:
        return args[0].text[:-1], args[1:]
    if len(args) >= 2 and args[1].text == ":":
        return args[0].text, args[2:]
    return "", args


def _set_voice(ctx: DirectiveContext, speaker: str, key: str, value) -> None:
    """Set a voice setting for everyone ("") or for one speaker (an override)."""
    if speaker:
        ctx.header.speaker_overrides.setdefault(speaker, {})[key] = value
    else:
        setattr(ctx.header.voice, key, value)


def _need_one(ctx, args, line, where, what, example) -> Arg | None:
    if not args:
        ctx.error(line, where.col, where.length, f"'@{what}' needs a value", f"for example: {example}", "missing-value")
        return None
    for extra in args[1:]:
        ctx.error(line, extra.col, extra.length, f"unexpected '{extra.text}' after '@{what}' value", f"for example: {example}", "extra-argument")
    return args[0]


def _int_in_range(ctx, arg: Arg, line: int, what: str, lo: int, hi: int) -> int | None:
    try:
        value = int(arg.text)
    except ValueError:
        ctx.error(line, arg.col, arg.length, f"{what} must be a whole number, not '{arg.text}'", f"use a value from {lo} to {hi}", "bad-number")
        return None
    if not lo <= value <= hi:
        ctx.error(line, arg.col, arg.length, f"{what} {value} is out of range", f"use a value from {lo} to {hi}", "out-of-range")
        return None
    return value


def _do_voice(ctx, args, line, where):
    speaker, rest = _speaker_and_rest(args)
    arg = _need_one(ctx, rest, line, where, "voice", "@voice en-us   or   @voice guide: en-gb")
    if arg is None:
        return
    _set_voice(ctx, speaker, "name", arg.text)
    ctx.header.voice_where[speaker] = Span(line, arg.col, arg.length)


def _do_rate(ctx, args, line, where):
    speaker, rest = _speaker_and_rest(args)
    arg = _need_one(ctx, rest, line, where, "rate", "@rate 160")
    if arg is not None:
        value = _int_in_range(ctx, arg, line, "speaking rate (words per minute)", *RATE_RANGE)
        if value is not None:
            _set_voice(ctx, speaker, "rate", value)


def _do_pitch(ctx, args, line, where):
    speaker, rest = _speaker_and_rest(args)
    arg = _need_one(ctx, rest, line, where, "pitch", "@pitch 50")
    if arg is not None:
        value = _int_in_range(ctx, arg, line, "pitch", *PITCH_RANGE)
        if value is not None:
            _set_voice(ctx, speaker, "pitch", value)


def _do_seed(ctx, args, line, where):
    arg = _need_one(ctx, args, line, where, "seed", "@seed 7")
    if arg is not None:
        value = _int_in_range(ctx, arg, line, "seed", 0, SEED_MAX)
        if value is not None:
            ctx.header.seed = value


def _do_library(ctx, args, line, where):
    arg = _need_one(ctx, args, line, where, "library", "@library ./my_gestures")
    if arg is None:
        return
    path = Path(arg.text).expanduser()
    if not path.is_absolute():
        path = ctx.base_dir / path
    if not path.is_dir():
        ctx.error(line, arg.col, arg.length, f"gesture folder '{arg.text}' does not exist", f"looked for {path}; paths are relative to the script's folder", "missing-folder")
        return
    ctx.header.library_dirs.append(path)
    ctx.header.library_where[path] = Span(line, arg.col, arg.length)


def _do_preset(ctx, args, line, where):
    example = "@preset excited = speed:+2 space:+1.5"
    if not args:
        ctx.error(line, where.col, where.length, "'@preset' needs a name and style values", f"for example: {example}", "missing-value")
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
        ctx.error(line, name_arg.col, name_arg.length, f"preset name '{name}' is not valid", "use lower-case letters, digits and '_', starting with a letter", "bad-name")
        return
    if name in ctx.reserved:
        ctx.error(line, name_arg.col, len(name), f"preset name '{name}' is taken by a built-in style name or preset", "pick another name", "reserved-name")
        return
    if name in ctx.header.presets:
        ctx.error(line, name_arg.col, len(name), f"preset '{name}' is defined twice", "remove one definition", "duplicate", severity=WARNING)
    if not rest:
        ctx.error(line, name_arg.col, name_arg.length, f"preset '{name}' has no style values", f"for example: {example}", "missing-value")
        return
    values: dict[str, float] = {}
    for arg in rest:
        item, sep, value_text = arg.text.partition(":")
        problem = parse_style_value(item, value_text if sep else None)
        if isinstance(problem, str):
            hint = STYLE_ITEM_HELP
            if "unknown style" in problem:
                h, _ = did_you_mean(item, ("speed", "space", "handedness"))
                hint = h or hint
            ctx.error(line, arg.col, arg.length, problem, hint, "bad-style")
            continue
        values[item] = problem
    if values:
        ctx.header.presets[name] = values


def _do_audio(ctx, args, line, where):
    if not args:
        ctx.error(line, where.col, where.length, "'@audio' needs a file", "for example: @audio rec/line1.wav timings=rec/line1.TextGrid", "missing-value")
        return
    audio_arg, timings = args[0], None
    for arg in args[1:]:
        key, sep, value = arg.text.partition("=")
        if key != "timings" or not sep or not value:
            hint, sugg = did_you_mean(key, ("timings",))
            ctx.error(line, arg.col, arg.length, f"unknown '@audio' option '{arg.text}'", hint or "the only option is timings=FILE (a TextGrid or JSON word list)", "unknown-option", suggestions=sugg)
            continue
        tpath = _resolve_file(ctx, value, line, arg.col + len(key) + 1, len(value), "word timings file")
        if tpath is not None:
            if tpath.suffix.lower() not in (".textgrid", ".json"):
                ctx.error(line, arg.col, arg.length, f"word timings must be a .TextGrid or .json file, not '{tpath.suffix}'", None, "bad-format")
            else:
                timings = tpath
    apath = _resolve_file(ctx, audio_arg.text, line, audio_arg.col, audio_arg.length, "audio file")
    if apath is None:
        return
    if ctx.pending_audio is not None:
        ctx.error(line, 1, 6, "two '@audio' directives for one utterance", "put each '@audio' just before its utterance", "duplicate")
    ctx.pending_audio = AudioRef(apath, timings, Span(line, audio_arg.col, audio_arg.length))


def _resolve_file(ctx, text, line, col, length, what) -> Path | None:
    path = Path(text).expanduser()
    if not path.is_absolute():
        path = ctx.base_dir / path
    if not path.is_file():
        ctx.error(line, col, length, f"{what} '{text}' not found", f"looked for {path}; paths are relative to the script's folder", "missing-file")
        return None
    return path
