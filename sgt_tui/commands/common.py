"""Helpers shared by the subcommands: reading scripts, printing diagnostics."""

from __future__ import annotations

import os
import sys
from pathlib import Path

#: ``--smoothing`` choices of the neural engine, first the default. The same names as
#: ``model.postprocess.SMOOTHERS`` (a test checks), spelt out here so that building the parser
#: does not import numpy.
SMOOTHING_CHOICES = ("one_euro", "moving_average", "none")


def existing_file(path: str) -> Path:
    from sgt_tui.errors import UsageError

    p = Path(path)
    if not p.exists():
        raise UsageError(f"no such file: {path}")
    if p.is_dir():
        raise UsageError(f"{path} is a folder, not a script file")
    return p


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
            stream.write(f"{file}: {n} more problem{'s' if n != 1 else ''} not shown (--max-errors 0 shows all)\n")
        if summarise:
            stream.write(summary(diags) + "\n")


def exit_code(diags) -> int:
    return 1 if any(d.is_error for d in diags) else 0
