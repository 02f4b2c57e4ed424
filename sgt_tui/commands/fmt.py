"""sgt fmt: rewrite scripts in the canonical layout (dsl/fmt.py)."""

from __future__ import annotations

import argparse
import sys

HELP = "rewrite scripts in the canonical layout (--check for CI, --stdin for editors)"
DESCRIPTION = """\
Rewrite .sgt scripts in place in one canonical layout: tags without inner padding and
pose options in the order speed, flip, hold=; one space between words; 'speaker: text';
directives one space apart; continuation lines indented by four spaces; comments kept, two
spaces after code; at most one blank line in a row. Nothing is lined up across lines, so a
change to one line never rewrites another.

Only whitespace and the order of pose options of different kinds change: what is spoken
and gestured stays the same. A script with a syntax error (an unknown escape such as \\q
and a closing tag that closes nothing among them) is not touched: its errors are printed
and the status is 1. A script with other hard links is rewritten in place, so that every
link keeps showing the same text. Folders are searched for *.sgt files.

--check writes nothing: it prints a unified diff of what would change and exits 1 when a
file is not formatted (for CI and pre-commit). --stdin formats standard input to standard
output (for editors). The layout is described in docs/language.md."""


def register(sub) -> None:
    p = sub.add_parser("fmt", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("paths", nargs="*", metavar="PATH", help="script files (.sgt) or folders")
    p.add_argument("--check", action="store_true", help="write nothing; print a diff and exit 1 if a file would change")
    p.add_argument("--stdin", action="store_true", help="format standard input to standard output")
    p.add_argument("--stdin-filename", metavar="NAME", default="<stdin>",
                   help="the name of the script read with --stdin, for messages")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing for files that are formatted already")
    p.set_defaults(run=run)


def run(args) -> int:
    from sgt_tui.errors import UsageError

    if args.stdin == bool(args.paths):
        raise UsageError("give PATHs to format, or --stdin (not both)")
    if args.stdin:
        return _stdin(args)
    status = 0
    changed = 0
    files = _files(args.paths)
    for path in files:
        result = _one(path, args)
        status = max(status, result[0])
        changed += result[1]
    if not args.quiet or changed:
        verb = "would be reformatted" if args.check else "reformatted"
        print(f"{changed} of {len(files)} file{'s' if len(files) != 1 else ''} {verb}", file=sys.stderr)
    return status


def _files(paths: list[str]):
    from pathlib import Path

    from sgt_tui.errors import InputError

    out = []
    for name in paths:
        path = Path(name)
        if path.is_dir():
            out += sorted(p for p in path.rglob("*.sgt") if p.is_file())
        elif path.exists():
            out.append(path)
        else:
            raise InputError(f"no such file or folder: {name}")
    return out


def _stdin(args) -> int:
    from dsl.fmt import FormatError, format_source
    from dsl.lines import decode_source

    data = sys.stdin.buffer.read() if hasattr(sys.stdin, "buffer") else sys.stdin.read().encode("utf-8", "surrogatepass")
    bom = data.startswith(b"\xef\xbb\xbf")
    source, bad = decode_source(data)
    if bad is not None:
        print(f"sgt fmt: error: {args.stdin_filename}: not UTF-8 (byte {bad})", file=sys.stderr)
        return 1
    source = ("\ufeff" if bom else "") + source
    try:
        formatted = format_source(source, args.stdin_filename)
    except FormatError as exc:
        _refused(exc, {args.stdin_filename: source}, args.stdin_filename)
        return 1
    if args.check:
        if formatted != source:
            sys.stdout.write(_diff(source, formatted, args.stdin_filename))
            return 1
        return 0
    sys.stdout.write(formatted)
    return 0


def _one(path, args) -> tuple[int, int]:
    """Format one file: (status, 1 if it changed or would change)."""
    from core.diagnostics import format_text
    from core.fileio import atomic_write
    from dsl.fmt import FormatError, format_source
    from dsl.parser import read_source

    name = str(path)
    try:
        source, problems = read_source(path)
        with open(path, "rb") as f:
            bom = f.read(3) == b"\xef\xbb\xbf"
    except OSError as exc:
        print(f"sgt fmt: error: {name}: {getattr(exc, 'reason', None) or exc.strerror or exc}", file=sys.stderr)
        return 1, 0
    if problems:  # not UTF-8: nothing to format safely
        print(format_text(problems, {name: source}), file=sys.stderr)
        return 1, 0
    try:
        formatted = format_source(source, name)
    except FormatError as exc:
        _refused(exc, {name: source}, name)
        return 1, 0
    if formatted == source:
        return 0, 0
    if args.check:
        sys.stdout.write(_diff(source, formatted, name))
        return 1, 1
    # in place: a script with other hard links keeps them (core.fileio: the same file, rewritten)
    atomic_write(path, (("\ufeff" if bom else "") + formatted).encode("utf-8", "surrogatepass"), keep_hard_links=True)
    if not args.quiet:
        print(f"reformatted {name}", file=sys.stderr)
    return 0, 1


def _refused(exc, sources: dict[str, str], name: str) -> None:
    from sgt_tui.commands.common import print_diagnostics

    print_diagnostics(exc.diagnostics, sources, stream=sys.stderr)
    print(f"sgt fmt: {name} not formatted: fix its syntax errors first", file=sys.stderr)


def _diff(before: str, after: str, name: str) -> str:
    """A unified diff of the two texts, as ``diff -u`` and git write it."""
    import difflib

    out = []
    for line in difflib.unified_diff(before.splitlines(keepends=True), after.splitlines(keepends=True),
                                     fromfile=f"a/{name}", tofile=f"b/{name}"):
        out.append(line if line.endswith("\n") else line + "\n\\ No newline at end of file\n")
    return "".join(out)
