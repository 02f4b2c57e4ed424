"""sgt explain: what a diagnostic means, an example that triggers it, and how to fix it."""

from __future__ import annotations

import argparse

HELP = "explain a diagnostic code (SGT201) or name (unknown-gesture)"
DESCRIPTION = """\
Print the long explanation of a diagnostic: what it means, an example script that
triggers it (and what 'sgt check' says about that example), and how to fix it.
Codes are shown in every message, e.g. 'error: [SGT201] unknown gesture'.

Code ranges: 1xx layout and syntax, 2xx names and references, 3xx values,
4xx speech and timing, 5xx gesture specs and configuration, 6xx files and encodings."""


def register(sub) -> None:
    p = sub.add_parser("explain", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("code", nargs="?", metavar="CODE", help="a code (SGT201) or a name (unknown-gesture)")
    p.add_argument("--list", action="store_true", help="list every code with its name, severity and message")
    p.add_argument("--no-run", action="store_true", help="do not run the example through 'sgt check'")
    p.set_defaults(run=run)


def run(args) -> int:
    from core import rules
    from sgt_tui.errors import UsageError

    if args.list:
        for r in rules.RULES.values():
            print(f"{r.code}  {r.name:<22} {r.severity:<8} {r.template}")
        return 0
    if not args.code:
        raise UsageError("give a code (e.g. SGT201) or a name (e.g. unknown-gesture), or --list")
    r = rules.lookup(args.code)
    if r is None:
        from core.diagnostics import suggest

        close = suggest(args.code.lower(), [x.name for x in rules.RULES.values()] + list(rules.RULES))
        more = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        raise UsageError(f"no diagnostic '{args.code}'{more} ('sgt explain --list' lists them)")
    print(f"{r.code} {r.name} ({r.severity})")
    print(f"message: {r.template}")
    if r.hint:
        print(f"hint:    {r.hint}")
    print()
    print(r.explanation)
    if r.example:
        print()
        _example(r, run_check=not args.no_run)
    return 0


def _example(r, run_check: bool) -> None:
    import os
    import tempfile

    from core import rules
    from core.diagnostics import format_text

    shown = r.example if r.encoding == "utf-8" else r.example + f"(saved as {r.encoding.upper()})\n"
    print("Example (example.sgt):")
    for line in shown.rstrip("\n").split("\n"):
        print("    " + "".join(_printable(c) for c in line))
    for rel, text in r.files:
        what = f"a silent recording of {text.split(':', 1)[1]} s" if text.startswith("@silence:") else repr(text)
        print(f"  with {rel}: {what}")
    for key, value in r.env:
        print(f"  with {key}={value}")
    if not run_check:
        return
    from dsl.compiler import compile_file

    saved_env = {k: os.environ.get(k) for k, _ in r.env}
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="sgt-explain-") as tmp:
        try:
            script = rules.materialise_example(r, tmp)
            os.environ.update(dict(r.env))
            os.chdir(tmp)
            result = compile_file(script.name, timing="estimate")
        finally:
            os.chdir(cwd)
            for k, v in saved_env.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
        mine = [d for d in result.diagnostics if d.code == r.code]
        if mine:
            print()
            print("sgt check says:")
            sources = {"example.sgt": result.script.source}
            text = format_text(mine, sources).replace(tmp + os.sep, "")
            for line in text.split("\n"):
                print("    " + line)


def _printable(c: str) -> str:
    """A character of an example as it can be printed: invisible ones spelt out."""
    if c.isprintable():
        return c
    if 0xDC80 <= ord(c) <= 0xDCFF:  # a byte that is not UTF-8 (surrogateescape)
        return f"<byte 0x{ord(c) - 0xDC00:02X}>"
    return f"<U+{ord(c):04X}>"
