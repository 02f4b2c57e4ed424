"""Style items inside ``<...>`` tags and ``@preset`` lines: ``speed:-1``, ``space:+0.5``, ``happy``."""

from __future__ import annotations

from core import rules
from core.controls import STYLE_LIMIT, STYLE_NAMES


def parse_style_value(name: str, value_text: str | None) -> float | tuple[rules.Rule, dict]:
    """The value of one style element, or the rule it breaks and the rule's fields.

    An unknown ``name`` gives :data:`core.rules.UNKNOWN_STYLE` with ``what`` "style element"
    (a tag that also allows presets says "style or preset")."""
    if name not in STYLE_NAMES:
        return rules.UNKNOWN_STYLE, {"what": "style element", "name": name}
    if value_text is None or value_text == "":
        return rules.STYLE_VALUE, {"name": name, "given": ""}
    try:
        value = float(value_text)
    except ValueError:
        return rules.STYLE_VALUE, {"name": name, "given": f", not '{value_text}'"}
    if value != value or abs(value) == float("inf"):
        return rules.STYLE_VALUE, {"name": name, "given": f", not '{value_text}'"}
    if not -STYLE_LIMIT <= value <= STYLE_LIMIT:
        return rules.OUT_OF_RANGE, {"what": f"'{name}' value", "value": value_text, "allowed": "a value from -3 to 3"}
    return value
