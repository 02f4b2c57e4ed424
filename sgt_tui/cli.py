"""The ``sgt`` command: a thin argparse front over the core packages.

Each subcommand lives in its own module under :mod:`sgt_tui.commands` with two functions:
``register(subparsers)`` (cheap: only argparse work, no heavy imports) and ``run(args) -> int``.
Heavy libraries (torch, librosa, pyrender, textual) are imported inside ``run`` so that
``sgt --help`` stays fast.

Exit codes: 0 success, 1 problems in the user's input, 2 usage errors, 130 interrupted (the
rule is spelt out in :mod:`sgt_tui.commands.common`).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from core.fileio import OutputError, OutputPathError
from core.interrupts import caused_by_interrupt, noting_interrupts
from sgt_tui.errors import InputError, UsageError

#: Subcommand modules, in the order ``sgt --help`` lists them.
COMMANDS = ("check", "fmt", "compile", "explain", "say", "align", "voices", "library_cmd", "generate", "build", "train", "render", "export", "import_cmd", "play_nao", "corpus",
            "eval", "edit", "lsp", "serve", "diff", "view", "suggest")

EPILOG = """\
exit status: 0 when done; 1 for problems in the input (errors in a script, a file
that cannot be read or written); 2 for usage errors (a bad option or value, a file
that does not exist, a folder for a file, a name or number that matches nothing);
130 when interrupted.

'-o -' writes a text or JSON output to standard output. An output that is a symbolic
link is written through to its target; a device or a FIFO is written in place, never
replaced; missing parent folders are created.

Run 'sgt COMMAND --help' for the options of one command.
The script language is documented in docs/language.md."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sgt",
        description="Author co-speech gestures for embodied agents from .sgt scripts.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"sgt_tui.commands.{name}")
        module.register(sub)
    return parser


class _Version(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata
    costs 10 ms of every command's start otherwise)."""

    def __call__(self, parser, *_):  # (namespace, values, option_string)
        print(f"sgt {_version()}")  # on standard output, as argparse's own version action does
        parser.exit()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("sgt")
    except PackageNotFoundError:  # not installed: running from a checkout
        return "0.1.0"


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns the exit status. Errors become one line on stderr (the status
    codes are in :mod:`sgt_tui.commands.common`), never a traceback; ctrl+c is "interrupted"
    and 130, whatever a library turns it into (:func:`core.interrupts.noting_interrupts`)."""
    with noting_interrupts():
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    command = "sgt"
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # argparse printed the usage error (or --help): a status, not an exit
            return exc.code if isinstance(exc.code, int) else 2
        if not getattr(args, "run", None):
            parser.print_help()
            return 2
        command = f"sgt {args.command}"
        return _status(args.run(args))
    except SystemExit as exc:  # a library that exits (uvicorn exits 3): still one of this command's statuses
        return _status(exc.code)
    except UsageError as exc:
        return _fail(command, exc, 2)
    except InputError as exc:
        return 1 if exc.printed else _fail(command, exc, 1)
    except OutputError as exc:
        return _fail(command, exc, 2 if isinstance(exc, OutputPathError) else 1)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (`sgt ... | head`): not an error
        _silence_stdout()
        return 0
    except OSError as exc:  # a file that exists but cannot be read
        where = f"{exc.filename}: " if exc.filename else ""
        return _fail(command, f"{where}{exc.strerror or exc}", 1)
    except Exception as exc:
        if not caused_by_interrupt(exc):
            raise
        print("interrupted", file=sys.stderr)
        return 130


def _status(code) -> int:
    """``code`` as one of the statuses sgt exits with (0, 1, 2, 130): anything else is 1."""
    if code is None:
        return 0
    return code if isinstance(code, int) and code in (0, 1, 2, 130) else 1


def _fail(command: str, message, code: int) -> int:
    print(f"{command}: error: {message}", file=sys.stderr)
    return code


def _silence_stdout() -> None:
    """After a broken pipe, point stdout at /dev/null so the flush at exit stays quiet."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":
    sys.exit(main())
