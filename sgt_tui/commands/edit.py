"""sgt edit: the terminal authoring app (Textual), imported only when the command runs."""

from __future__ import annotations

import argparse
import sys

HELP = "edit a script in the terminal: live diagnostics, timeline, preview, library, jobs"
DESCRIPTION = """\
Open a script in the terminal editor: syntax highlighting and live diagnostics, a
timeline of the utterance at the cursor, a stick-figure preview of its motion, the
motion library with previews, style sliders and presets, generation and GIF rendering
in the background, one undo history, atomic saves and crash recovery.

A file that does not exist opens empty and is created on the first save. Press F1 in
the editor for every key, ctrl+p for the command palette. See docs/editor.md."""


def register(sub) -> None:
    from sgt_tui.commands.common import DEFAULT_ENGINE, ENGINE_CHOICES

    p = sub.add_parser("edit", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt); created on the first save if missing")
    p.add_argument("--engine", choices=ENGINE_CHOICES, default=None,
                   help=f"generation engine (default {DEFAULT_ENGINE}; ctrl+e cycles through them in the editor)")
    p.set_defaults(run=run)


def run(args) -> int:
    import signal

    from sgt_tui.editor.files import FileError, ScriptFile

    try:  # a folder, a FIFO, a device (/dev/zero), a file over the size limit, not UTF-8: one line
        script = ScriptFile.open(args.file)
    except FileError as exc:
        print(f"sgt edit: error: {exc}", file=sys.stderr)
        return 1
    if not sys.stdin.isatty() or not sys.stdout.isatty():
        print("sgt edit: error: needs a terminal (stdin and stdout must be a TTY)", file=sys.stderr)
        return 2
    engine = args.engine  # None: the default engine (model.engines.DEFAULT_ENGINE)
    from sgt_tui.app.main import EditorApp

    app = EditorApp(script, engine=engine)

    def hang_up(signum, frame):  # the terminal went away (a dropped SSH connection): keep the work
        try:
            app.recovery.write()
        finally:
            import os

            os._exit(128 + signum)

    signal.signal(signal.SIGHUP, hang_up)
    signal.signal(signal.SIGTERM, hang_up)
    app.run()
    return int(app.return_code or 0)

