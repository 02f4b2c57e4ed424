"""What the subcommands share: checking files and values named on the command line, outputs
(``-o -`` for stdout), and printing diagnostics.

Numpy-free: parsers are built from here for ``sgt --help``.

Exit status, the same for every command (``sgt_tui.cli`` maps the errors):

- 0: done;
- 1: a problem in the input: errors in a script (diagnostics are printed), an input file or
  folder that is missing, unreadable, of the wrong kind or not in the expected format (as
  ``sgt check`` reports a missing script among others and goes on), an output that cannot be
  written (permission denied, a full disk): :class:`~sgt_tui.errors.InputError`,
  :class:`core.fileio.OutputError`;
- 2: the command line is wrong: an unknown option or a bad value, a name or number that
  matches nothing (``--utterance 50``, ``library show nope``, ``--engine foo``), an output
  path that can never be written (a folder, a name ending in ``/``, a path under a file),
  binary output to a terminal: :class:`~sgt_tui.errors.UsageError`,
  :class:`core.fileio.OutputPathError`;
- 130: interrupted (ctrl+c).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from core.counting import index_of, no_utterance, plural
from core.fileio import check_not_input, check_output, check_output_folder
from core.seeds import SEED_MAX
from model.engines import DEFAULT_ENGINE, ENGINES, EVAL_ENGINES  # noqa: F401  (EVAL_ENGINES: for the commands)
from sgt_tui.errors import InputError, UsageError

#: ``--smoothing`` choices of the neural engine, first the default. The same names as
#: ``model.postprocess.SMOOTHERS`` (a test checks), spelt out here so that building the parser
#: does not import numpy.
SMOOTHING_CHOICES = ("one_euro", "moving_average", "none")

#: ``--engine`` choices, the default first (``model.engines``: names only, no numpy).
ENGINE_CHOICES = tuple(ENGINES)

#: The output name that means standard output.
STDOUT = "-"


# -- values (argparse types: a bad value is a usage error, exit 2) --------------------------


def seed(text: str) -> int:
    """``--seed``: an integer in the range of a script's ``@seed``."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{value} is out of range: use 0 to {SEED_MAX}")
    return value


def utterance_number(text: str) -> int:
    """``--utterance N``: 1 or more, as people count utterances (:mod:`core.counting`); returns
    the utterance's 0-based index (whether the script has it is checked once it is read)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value}: utterances count from 1 (the first is --utterance 1)")
    return index_of(value)


def positive_int(text: str) -> int:
    return _number(text, int, 1)


def non_negative_int(text: str) -> int:
    return _number(text, int, 0)


def positive_float(text: str) -> float:
    return _number(text, float, 0.0, strict=True)


def non_negative_float(text: str) -> float:
    return _number(text, float, 0.0)


def share(text: str) -> float:
    """A share of something: a number from 0 to 1."""
    value = _number(text, float, 0.0)
    if value > 1:
        raise argparse.ArgumentTypeError(f"{text} must be at most 1 (a share)")
    return value


def _number(text: str, kind, low, strict: bool = False):
    import math

    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a {'whole ' if kind is int else ''}number") from None
    if kind is float and not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    if value < low or (strict and value == low):
        raise argparse.ArgumentTypeError(f"{text} must be {'more than' if strict else 'at least'} {low:g}")
    return value


def text(value: str, option: str) -> str:
    """A text option that ends up inside a file: it must be UTF-8 (a command line can carry
    other bytes, which Python keeps as lone surrogates)."""
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise UsageError(f"{option} must be UTF-8 text") from None
    return value


def add_post_options(p) -> None:
    """``--smoothing`` and ``--no-blend``: the neural engine's post-processing (generate, build)."""
    p.add_argument("--smoothing", choices=SMOOTHING_CHOICES, default=SMOOTHING_CHOICES[0],
                   help="post-filter of the neural engine (default one_euro: the 1-euro filter forwards and backwards, no lag)")
    p.add_argument("--no-blend", action="store_true",
                   help="neural engine: leave control following to the network (no exact pose blend, no speed correction)")
    add_take_posture_option(p)


def add_take_posture_option(p) -> None:
    """``--no-take-posture``: the neural engine draws no take posture or drift (model/take_posture.py; generate, build, eval)."""
    p.add_argument("--no-take-posture", action="store_true",
                   help="neural engine: no take posture or drift (by default each speaker holds the posture of one "
                        "of the weights' training takes, chosen by the seed, and wanders slowly around it as that take "
                        "did, except where the script requests a pose, space or handedness, or a slower speed for "
                        "the wandering; docs/model.md)")


def add_database_option(p) -> None:
    """``--database``: the matching engine's database (generate, build, serve; read by :func:`database_option`)."""
    p.add_argument("--database", metavar="PATH",
                   help="the matching engine's database (default: the shipped model/weights/matching_db.npz; "
                        "'sgt train --engine matching' builds one of your own takes)")


def add_seed_option(p, help_text: str) -> None:
    p.add_argument("--seed", type=seed, metavar="N", help=f"{help_text} (0 to {SEED_MAX})")


# -- inputs ----------------------------------------------------------------------------------


def existing_file(path: str) -> Path:
    """An input file named on the command line; missing, a folder, or out of reach
    (permissions): an input problem (exit 1), as a script that ``sgt check`` cannot read."""
    return _existing(path, "file")


def existing_folder(path: str, option: str) -> Path:
    """An input folder named on the command line, by :func:`existing_file`'s rule."""
    return _existing(path, "folder", option)


def _existing(path: str, kind: str, option: str = "") -> Path:
    import stat

    where = f"{option} {path}" if option else path
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError, ValueError):
        raise InputError(f"no such {kind}: {where}") from None
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    if kind == "file" and stat.S_ISDIR(st.st_mode):
        raise InputError(f"{where} is a folder, not a file")
    if kind == "folder" and not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{where} is a file, not a folder")
    return Path(path)


def database_option(path: str | None, engine: str | None) -> str | None:
    """``--database PATH`` checked before any work: the file (missing or unreadable: exit 1), read
    as a matching database (damaged, another format, built with other settings: the engine's
    one-line message, exit 1). A usage error when ``engine`` (None: the default engine) is not
    ``matching``, which alone reads it; ``engine="matching"`` where each request chooses (serve)."""
    if path is None:
        return None
    from model import matching  # lazy: numpy, the engine

    if (engine or DEFAULT_ENGINE) != "matching":
        raise UsageError(f"--database is the matching engine's database; the {engine or DEFAULT_ENGINE} engine "
                         "does not read it: add --engine matching")
    found = str(existing_file(path))
    try:
        matching.load(found)
    except matching.DatabaseError as exc:
        raise InputError(str(exc)) from None
    return found


def check_utterances(script, requested) -> None:
    """Usage error when a requested utterance (an index, as :func:`utterance_number` gives it)
    is not in the script; the message counts from 1."""
    if requested and script.header is not None:
        missing = script.missing_utterance(requested)
        if missing is not None:
            raise UsageError(no_utterance(missing, [u.index for u in script.utterances]))


# -- outputs ---------------------------------------------------------------------------------


def output_file(text: str, option: str = "-o", *, binary: bool = False, inputs=()):
    """Check an output file named on the command line before any work is done.

    Returns what to hand to a writer: the path, or the standard output's binary stream for
    ``-``. Binary data is never written to a terminal (usage error); a path that cannot be
    written raises :class:`core.fileio.OutputError` (see the module's exit status); an output
    that is one of the command's ``inputs`` (:func:`inputs_of`; through a link or a hard link
    too) is refused (:class:`core.fileio.OutputPathError`, exit 2).
    """
    if text == STDOUT:
        if binary and _isatty(sys.stdout):
            raise UsageError(f"{option} -: will not write binary data to a terminal; redirect it (> FILE) or pipe it")
        return _Stdout()
    check_output(text)
    check_not_input(text, inputs, option)
    return text


def inputs_of(*paths) -> list[Path]:
    """Every file a command reads for the inputs ``paths`` (None skipped): each path and, for a
    script, the recordings and timings files it names, resolved as the compiler resolves them
    (``~`` expanded, relative to the script's folder). What cannot be read is left out (the
    command reports it when it reads it)."""
    from core.reading import read_bytes

    out = []
    for path in paths:
        if path is None:
            continue
        path = Path(path)
        out.append(path)
        if path.suffix.lower() != ".sgt":
            continue
        try:
            source = read_bytes(path, "script").decode("utf-8", "replace")
        except OSError:
            continue
        from dsl.plain import file_references  # lazy: the scanner (numpy-free, but not needed for --help)

        for ref in file_references(source):
            if ref.kind in ("audio", "timings"):
                named = Path(ref.text).expanduser()
                out.append(named if named.is_absolute() else path.parent / named)
    return out


def output_folder(text: str, option: str = "-o") -> Path:
    """Check an output folder named on the command line (created when first written to)."""
    if text == STDOUT:
        raise UsageError(f"{option} names a folder; '-' (standard output) cannot be one")
    check_output_folder(text)
    return Path(text)


def output_format(text: str, chosen: str | None, formats: tuple[str, ...], option: str = "-o", what: str = "output") -> str:
    """The format of an output: ``--format`` when given, else the file's extension; JSON for ``-``."""
    if chosen is not None:
        return chosen
    if text == STDOUT:
        return "json"
    suffix = Path(text).suffix.lower().lstrip(".")
    if suffix not in formats:
        listed = ", ".join(f".{f}" for f in formats)
        raise UsageError(f"{option} {text}: unknown {what} type '{('.' + suffix) if suffix else '(none)'}' "
                         f"(use {listed}, or --format)")
    return suffix


def one_stdout(**outputs) -> None:
    """Usage error when more than one output goes to standard output (``None`` counts as not)."""
    named = [option for option, value in outputs.items() if value == STDOUT]
    if len(named) > 1:
        raise UsageError(f"only one output can go to standard output, not {' and '.join(named)}")


class _Stdout:
    """The standard output as a binary stream for :func:`core.fileio.atomic_write` (looked up
    when written: tests and callers may replace ``sys.stdout``)."""

    def write(self, data: bytes) -> None:
        sys.stdout.flush()
        buffer = getattr(sys.stdout, "buffer", None)
        if buffer is not None:
            buffer.write(data)
        else:  # a text-only stream (io.StringIO)
            sys.stdout.write(data.decode("utf-8", errors="replace"))

    def flush(self) -> None:
        (getattr(sys.stdout, "buffer", None) or sys.stdout).flush()


def is_stdout(target) -> bool:
    return not isinstance(target, (str, Path))


def shown(target) -> str:
    """An output's name for messages: control characters, invisible marks and bytes that are
    not UTF-8 as escapes (:func:`core.printable.escaped`), so that any terminal prints it as
    it is named."""
    if is_stdout(target):
        return "standard output"
    from core.printable import escaped

    return escaped(str(target))


def _isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


# -- diagnostics -----------------------------------------------------------------------------


def use_color(stream) -> bool:
    return hasattr(stream, "isatty") and stream.isatty() and "NO_COLOR" not in os.environ


def max_per_file(requested: int | None, fmt: str, default: int) -> int | None:
    """``--max-errors``: None or 0 show everything; unset, text output shows ``default``."""
    if requested is None:
        return default if fmt == "text" else None
    return requested or None


def print_diagnostics(diags, sources: dict[str, str], fmt: str = "text", stream=None, *,
                      max_per_file: int | None = None, summarise: bool = True) -> None:
    """Diagnostics as text on ``stream`` (default stderr) with a summary line, or as JSON on
    stdout; at most ``max_per_file`` per file, and a line that counts the rest."""
    from core.diagnostics import cap, format_json, format_text, summary

    stream = stream or sys.stderr
    if fmt == "json":
        sys.stdout.write(format_json(diags, max_per_file) + "\n")
        return
    if diags:
        shown, left = cap(diags, max_per_file)
        stream.write(format_text(shown, sources, color=use_color(stream)) + "\n")
        for file, n in left.items():
            stream.write(f"{file}: {plural(n, 'more problem')} not shown (--max-errors 0 shows all)\n")
        if summarise:
            stream.write(summary(diags) + "\n")


def exit_code(diags) -> int:
    return 1 if any(d.is_error for d in diags) else 0
