"""sgt lsp: the Language Server Protocol server for editors (sgt_tui/lsp)."""

from __future__ import annotations

import argparse

HELP = "the language server for editors (LSP over stdio: VS Code, Neovim, Helix)"
DESCRIPTION = """\
Run the Language Server Protocol server on standard input and output. An editor starts
it for .sgt files; it runs the same analysis as 'sgt check' and 'sgt edit' and offers
diagnostics as you type (with 'sgt explain' links), completion of gestures, options,
styles, presets, directives, voices and speakers, hover, go to definition, references and
rename, code actions (every diagnostic's fixes, re-timing a late gesture), formatting (the
same as 'sgt fmt'), document symbols, folding, semantic tokens, inlay hints and the
command 'sgt.preview' (render the utterance at the cursor to a GIF).

Set-ups for VS Code, Neovim and Helix: docs/editors.md."""


def register(sub) -> None:
    p = sub.add_parser("lsp", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--stdio", action="store_true", help="talk over standard input and output (the default; editors pass it)")
    p.set_defaults(run=run)


def run(args) -> int:
    from sgt_tui.lsp.server import serve

    serve()
    return 0
