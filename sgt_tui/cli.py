"""The ``sgt`` command: a thin argparse front over the core packages.

Each subcommand lives in its own module under :mod:`sgt_tui.commands` with two functions:
``register(subparsers)`` (cheap: only argparse work, no heavy imports) and ``run(args) -> int``.
Heavy libraries (torch, librosa, pyrender, textual) are imported inside ``run`` so that
``sgt --help`` stays fast.

Exit codes: 0 success, 1 errors in the user's input (diagnostics were printed), 2 usage errors.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from sgt_tui.errors import UsageError

#: Subcommand modules, in the order ``sgt --help`` lists them.
COMMANDS = ("check", "compile", "explain", "say", "voices", "library_cmd", "generate", "train", "render", "export", "corpus",
            "eval", "edit")

EPILOG = """\
exit status: 0 when clean, 1 when the input has errors (diagnostics are printed),
2 for usage errors.

Run 'sgt COMMAND --help' for the options of one command.
The script language is documented in docs/language.md."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sgt",
        description="Author co-speech gestures for embodied agents from .sgt scripts.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"sgt {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"sgt_tui.commands.{name}")
        module.register(sub)
    return parser


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("sgt")
    except PackageNotFoundError:  # not installed: running from a checkout
        return "0.1.0"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "run", None):
        parser.print_help()
        return 2
    try:
        return int(args.run(args) or 0)
    except UsageError as exc:
        print(f"sgt {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
