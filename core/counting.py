"""Numbers as people read them: counts with their noun, and utterances counted from 1.

Utterance numbers shown to people count from 1, as lines do (the first utterance is
utterance 1): ``--utterance N``, every message, the editor's status line and the files it
names (``lobby.u2.gif``), the speech files ``sgt say`` and ``sgt build --wav`` write
(``lobby_002.wav``), the language server's outline. The ``index`` fields of files and APIs
count from 0 (motion files, plans, manifests, timelines, ``sgt serve``'s ``utterances``), as
do the ``utterance`` columns of the CSV exports. Code holds the index (``u.index``) and turns
it into the number people read with :func:`number` where it prints it.
"""

from __future__ import annotations

from collections.abc import Iterable


def plural(n: int, noun: str, nouns: str | None = None) -> str:
    """``n`` with its noun: ``1 utterance``, ``2 utterances`` (``nouns``: an irregular plural)."""
    return f"{n} {noun if n == 1 else nouns or noun + 's'}"


def number(index: int) -> int:
    """The number people read for the utterance at 0-based ``index``."""
    return index + 1


def index_of(number_: int) -> int:
    """The 0-based index of the utterance people call ``number_``."""
    return number_ - 1


def no_utterance(missing: int, known: Iterable[int], *, first: int = 1, what: str = "the script") -> str:
    """Why the utterance at index ``missing`` is not among ``known`` (indices), counted from
    ``first`` (1 for people; 0 for an API's indices): ``no utterance 5: the script has 3 (1..3)``."""
    known = sorted(known)
    shift = first
    have = f"{len(known)} ({known[0] + shift}..{known[-1] + shift})" if known else "none"
    return f"no utterance {missing + shift}: {what} has {have}"


def speech_file(stem: str, index: int) -> str:
    """The speech of the utterance at ``index`` of the script ``stem`` (``sgt say``, ``sgt build
    --wav``, read back by ``sgt view``): ``lobby_002.wav`` for the second."""
    return f"{stem}_{number(index):03d}.wav"
