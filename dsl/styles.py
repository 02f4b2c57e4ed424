"""Style items inside ``<...>`` tags and ``@preset`` lines: ``speed:-1``, ``space:+0.5``, ``happy``."""

from __future__ import annotations

from core.controls import STYLE_LIMIT, STYLE_NAMES

STYLE_ITEM_HELP = (
    "style items are speed:V, space:V and handedness:V with V from -3 to 3 "
    "(e.g. <speed:-1 space:+0.5>), or a preset such as <happy>"
)


def parse_style_value(name: str, value_text: str | None) -> float | str:
    """The value of one style element, or an error message."""
    if name not in STYLE_NAMES:
        return f"unknown style element '{name}'"
    if value_text is None or value_text == "":
        return f"'{name}' needs a value, e.g. {name}:-1 (from -3 to 3)"
    try:
        value = float(value_text)
    except ValueError:
        return f"'{name}' value must be a number from -3 to 3, not '{value_text}'"
    if value != value or abs(value) == float("inf"):
        return f"'{name}' value must be a number from -3 to 3, not '{value_text}'"
    if not -STYLE_LIMIT <= value <= STYLE_LIMIT:
        return f"'{name}' value {value_text} is out of range: use -3 to 3"
    return value
