"""Gestures from the words for a script file: ``sgt suggest``, and the ``--auto-gestures`` of
``sgt generate`` and ``sgt build`` (the rules are :mod:`dsl.suggest`'s, the table
:mod:`library.words`'s)."""

from __future__ import annotations

from pathlib import Path

from dsl.suggest import apply_suggestions, suggest
from library import load_library
from library.words import WordRulesError, load_word_rules


class SuggestError(Exception):
    """The script cannot take suggestions: its errors (``diagnostics``, with ``sources`` to
    show them), or a words table that cannot be used (the message)."""

    def __init__(self, message: str, diagnostics=(), sources=None) -> None:
        super().__init__(message)
        self.diagnostics = list(diagnostics)
        self.sources = sources or {}


def suggestions_for(path: Path, extra_dirs=(), source: str | None = None):
    """(script, suggestions, the text with them) for the script ``path`` (its text ``source``
    when given): analysed as every command analyses it, with its library (built-in, the user's
    folders, its ``@library`` folders and ``extra_dirs``) and the words tables of those folders."""
    from dsl.compiler import load_script  # lazy: lark, the library

    library = None
    if extra_dirs:
        from dsl.parser import analyse  # lazy: as above

        header = analyse(source if source is not None else Path(path).read_text(encoding="utf-8", errors="replace"),
                         str(path), base_dir=Path(path).parent).header
        library = load_library(extra_dirs=[*(header.library_dirs if header else []), *map(Path, extra_dirs)])
    script, lib, diags = load_script(path, library=library, source=source)
    errors = [d for d in diags if d.is_error]
    if errors or lib is None:
        raise SuggestError(f"{path}: has errors", errors, {str(path): script.source})
    try:
        rules = load_word_rules(folder for origin, folder in lib.folders if origin != "built-in")
    except WordRulesError as exc:
        raise SuggestError(str(exc)) from None
    found = suggest(script, lib, rules)
    return script, found, apply_suggestions(script.source, found)


def with_suggestions(path: Path, script, lib):
    """An analysed script (``script``, its library ``lib``) analysed again with the gestures
    its words call for inserted: (script, library, diagnostics), as :func:`dsl.compiler.load_script`."""
    from dsl.compiler import load_script  # lazy: lark

    try:
        rules = load_word_rules(folder for origin, folder in lib.folders if origin != "built-in")
    except WordRulesError as exc:
        raise SuggestError(str(exc)) from None
    text = apply_suggestions(script.source, suggest(script, lib, rules))
    return load_script(path, library=lib, source=text)
