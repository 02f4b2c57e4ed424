"""The registry of diagnostic rules: every problem sgt reports has one entry here.

A :class:`Rule` has a stable code (``SGT201``), a name (``unknown-gesture``), a default
severity, a message template with named fields, a default hint and a long explanation that
``sgt explain CODE`` prints. Code that finds a problem calls the rule with the place and the
template's fields::

    from core import rules
    d = rules.UNKNOWN_GESTURE.at("a.sgt", 3, 12, 5, name="wavee",
                                 fixes=rules.replacements("a.sgt", 3, 12, 5, ["wave"]))

The rule fills in the code, name, severity, message and hint; nothing else formats a
diagnostic (the renderer in :mod:`core.diagnostics` is the only place that turns one into
text). Code ranges: 1xx layout and syntax, 2xx names and references, 3xx values, 4xx speech
and timing, 5xx gesture specs and configuration, 6xx files and encodings.
"""

from __future__ import annotations

from dataclasses import dataclass

from core.diagnostics import ERROR, NOTE, WARNING, Diagnostic, Fix, Related, TextEdit

__all__ = ["Rule", "RULES", "lookup", "replacements", "ERROR", "WARNING", "NOTE"]


@dataclass(frozen=True)
class Rule:
    code: str
    name: str
    severity: str
    template: str
    hint: str | None
    explanation: str

    def message(self, **fields) -> str:
        return self.template.format(**fields)

    def at(self, file: str, line: int, col: int, length: int = 1, *, hint: str | None = "default",
           related: tuple[Related, ...] | list[Related] = (), fixes: tuple[Fix, ...] | list[Fix] = (),
           severity: str | None = None, **fields) -> Diagnostic:
        """A diagnostic of this rule at ``file:line:col`` (1-based; line 0 = the whole file).

        ``hint="default"`` takes the rule's hint; pass a string to give a specific one, or None
        for none. ``severity`` overrides the rule's default (e.g. a timing problem found with
        estimated timing)."""
        return Diagnostic(
            severity=severity or self.severity,
            message=self.message(**fields),
            file=file,
            line=line,
            col=col,
            length=max(1, length),
            hint=self.hint if hint == "default" else hint,
            code=self.code,
            name=self.name,
            related=tuple(related),
            fixes=tuple(fixes),
        )


RULES: dict[str, Rule] = {}
_BY_NAME: dict[str, Rule] = {}


def rule(code: str, name: str, severity: str, template: str, hint: str | None, explanation: str) -> Rule:
    """Register a rule (module level only: codes and names are unique)."""
    if code in RULES or name in _BY_NAME:
        raise ValueError(f"duplicate rule {code} {name}")
    r = Rule(code, name, severity, template, hint, explanation.strip())
    RULES[code] = _BY_NAME[name] = r
    return r


def lookup(code_or_name: str) -> Rule | None:
    """A rule by code (``SGT201``, case-insensitive) or name (``unknown-gesture``)."""
    return RULES.get(code_or_name.upper()) or _BY_NAME.get(code_or_name.lower())


def replacements(file: str, line: int, col: int, length: int, texts, title: str = "replace with '{}'") -> tuple[Fix, ...]:
    """One fix per text, each replacing the span ``line:col`` (``length`` characters) by it."""
    return tuple(Fix(title.format(t), (TextEdit(line, col, length, t),)) for t in texts)
