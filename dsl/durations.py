"""Durations as scripts write them: a number and a unit, ``300ms`` or ``1.2s``."""

from __future__ import annotations

import re

DURATION_RE = re.compile(r"(\d+(?:\.\d*)?|\.\d+)(ms|s)\Z")


def parse_duration(text: str) -> float | None:
    """``300ms`` / ``1.2s`` -> seconds, or None when malformed."""
    m = DURATION_RE.match(text)
    if not m:
        return None
    value = float(m.group(1))
    return value / 1000.0 if m.group(2) == "ms" else value
