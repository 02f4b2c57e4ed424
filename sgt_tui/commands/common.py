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


def print_diagnostics(diags, sources: dict[str, str], fmt: str = "text", stream=None) -> None:
    from core.diagnostics import format_json, format_text, summary

    stream = stream or sys.stderr
    if fmt == "json":
        sys.stdout.write(format_json(diags) + "\n")
        return
    if diags:
        stream.write(format_text(diags, sources, color=use_color(stream)) + "\n")
        stream.write(summary(diags) + "\n")


def exit_code(diags) -> int:
    return 1 if any(d.is_error for d in diags) else 0
