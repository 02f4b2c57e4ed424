"""Text from files, requests and names made safe to print on a terminal.

A terminal obeys the control characters in what it prints (``\x1b[2J`` in a file name would
clear the screen), and bidirectional and invisible marks reorder or hide the text around
them. :func:`escaped` writes each such character as an escape; what prints a name or a word
that a user did not type at that moment (a file of a repository, a speaker of a script, a
request's text) goes through it.

Standard library only.
"""

from __future__ import annotations

import re

#: What is never printed as it is: C0 and C1 control characters and DEL (a terminal obeys
#: them: ``\x1b[2J`` in a file name would clear the screen), the bidirectional and invisible
#: formatting marks (they reorder or hide the text around them), and lone surrogates (bytes of
#: a file name that are not UTF-8).
UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u200b\u200e\u200f\u202a-\u202e\u2060\u2066-\u2069\ufeff\ud800-\udfff]")
_NAMED = {"\t": "\\t", "\n": "\\n", "\r": "\\r"}


def _escape(m: re.Match) -> str:
    c = m.group()
    if c in _NAMED:
        return _NAMED[c]
    o = ord(c)
    if 0xDC80 <= o <= 0xDCFF:  # a byte that is not UTF-8, as Python keeps it in a name
        return f"\\x{o - 0xDC00:02x}"
    return f"\\x{o:02x}" if o <= 0xFF else f"\\u{o:04x}"


def escaped(text: str) -> str:
    """``text`` (a file's name, words, speakers, messages) with every character of
    :data:`UNSAFE` written as an escape (``\\x1b``, ``\\t``, ``\\u202e``): safe to print."""
    return UNSAFE.sub(_escape, text)
