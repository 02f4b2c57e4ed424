"""Open scripts as the language server holds them: text, version and analysis, and positions
between the Language Server Protocol's and sgt's.

sgt counts lines and columns from 1, in characters (code points); the protocol counts from 0,
in the units of the position encoding agreed at start-up (UTF-16 by default, UTF-32 or UTF-8
when the client offers them). Every conversion goes through :class:`Document`.

The analysis is the editor's (:class:`sgt_tui.editor.analysis.Analyser`, one per document):
the same diagnostics as ``sgt check``, and after a change only the utterances that changed
are analysed again. In the server, an ``@audio`` recording that the aligner checks is left out
of the analysis until a child process has aligned it (:mod:`sgt_tui.lsp.aligning`): no request
waits for the aligner.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from lsprotocol import types as lsp
from pygls.uris import from_fs_path, to_fs_path

from sgt_tui.editor.analysis import Analyser, Analysis
from sgt_tui.lsp.aligning import Aligner, Recording, recordings


def units(text: str, encoding: str) -> int:
    """The length of ``text`` in the code units of ``encoding``."""
    if encoding == lsp.PositionEncodingKind.Utf8:
        return len(text.encode("utf-8", "surrogatepass"))
    if encoding == lsp.PositionEncodingKind.Utf32 or text.isascii():
        return len(text)
    return len(text.encode("utf-16-le", "surrogatepass")) // 2


def char_index(text: str, column: int, encoding: str) -> int:
    """The character index in ``text`` of a column counted in ``encoding``'s code units (a
    column inside a character counts as that character; past the end: the end)."""
    if encoding == lsp.PositionEncodingKind.Utf32 or text.isascii():
        return max(0, min(column, len(text)))
    count = 0
    for i, c in enumerate(text):
        if count >= column:
            return i
        count += units(c, encoding)
    return len(text)


def uri_of(path: str | Path) -> str:
    return from_fs_path(str(path)) or str(path)


def path_of(uri: str) -> Path:
    """The file a URI names; an ``untitled:`` document is a script in the current folder."""
    fs = to_fs_path(uri) if uri.startswith("file:") else None
    return Path(fs) if fs else Path.cwd() / (uri.rsplit("/", 1)[-1].rsplit(":", 1)[-1] or "untitled.sgt")


@dataclass
class Document:
    """One open script."""

    uri: str
    text: str
    version: int | None = None
    encoding: str = lsp.PositionEncodingKind.Utf16
    #: The server's aligner (None: recordings are aligned where the analysis runs, as ``sgt check``).
    aligner: Aligner | None = None
    opened: bool = True  # the client opened it (else read from its file for one request: nothing is aligned for it)
    path: Path = field(init=False)
    analyser: Analyser = field(init=False)
    #: Of the last analysis: the recordings still aligning, and those that failed with why
    #: (both left out of it).
    aligning: list[Recording] = field(default_factory=list, init=False)
    failed: list[tuple[Recording, str]] = field(default_factory=list, init=False)
    _lines: list[str] | None = field(default=None, init=False, repr=False)
    _analysis: tuple[str, tuple, Analysis] | None = field(default=None, init=False, repr=False)
    _recordings: tuple[str, list[Recording]] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        self.path = path_of(self.uri)
        self.analyser = Analyser(self.path)
        self.set_text(self.text, self.version)

    def set_text(self, text: str, version: int | None) -> None:
        # sgt's lines end at CRLF, CR or LF, as the protocol's do: the same line numbers
        self.text = text.replace("\r\n", "\n").replace("\r", "\n")
        self.version = version
        self._lines = None

    @property
    def lines(self) -> list[str]:
        if self._lines is None:
            self._lines = self.text.split("\n")
        return self._lines

    def line(self, row: int) -> str:
        """The text of 0-based line ``row`` ("" past the end)."""
        lines = self.lines
        return lines[row] if 0 <= row < len(lines) else ""

    def analysis(self) -> Analysis:
        """The analysis of the current text (analysed once per text and state of its
        recordings), never waiting for the aligner when the server has one."""
        text = self.text
        left_out: tuple = ()
        if self.aligner is not None:
            recs = self._recordings
            if recs is None or recs[0] is not text:
                recs = self._recordings = (text, recordings(text, self.path))
            self.aligning, self.failed = self.aligner.state(self.uri, recs[1], queue=self.opened)
            left_out = tuple(sorted({r.line for r in self.aligning} | {r.line for r, _ in self.failed}))
        hit = self._analysis
        if hit is None or hit[0] is not text or hit[1] != left_out:
            hit = self._analysis = (text, left_out, self.analyser.run(self.analysed(text, left_out)))
        return hit[2]

    def analysed(self, text: str, left_out: tuple | None = None) -> str:
        """``text`` as the server analyses it: the ``@audio`` lines of the recordings it waits
        for (or that failed) blanked, so that no line moves (``left_out``: 1-based lines;
        default: those of the last analysis)."""
        if left_out is None:
            left_out = self._analysis[1] if self._analysis is not None else ()
        if not left_out:
            return text
        lines = text.split("\n")
        for n in left_out:
            if 0 < n <= len(lines):
                lines[n - 1] = ""
        return "\n".join(lines)

    # -- positions -----------------------------------------------------------------------------
    def position(self, row: int, col: int) -> lsp.Position:
        """The protocol's position of 0-based ``row`` and character ``col``."""
        text = self.line(row)
        return lsp.Position(max(row, 0), units(text[: max(col, 0)], self.encoding))

    def range(self, row: int, col: int, end_col: int, end_row: int | None = None) -> lsp.Range:
        """0-based rows, character columns."""
        return lsp.Range(self.position(row, col), self.position(row if end_row is None else end_row, end_col))

    def span(self, line: int, col: int, length: int) -> lsp.Range:
        """The range of an sgt span (1-based line and column, a length in characters; line 0 is
        the whole file: its start)."""
        if line <= 0:
            return lsp.Range(lsp.Position(0, 0), lsp.Position(0, 0))
        start = max(col - 1, 0)
        return self.range(line - 1, start, start + max(length, 0))

    def char_at(self, pos: lsp.Position) -> tuple[int, int]:
        """(0-based row, character column) of a protocol position."""
        return pos.line, char_index(self.line(pos.line), pos.character, self.encoding)


class Documents:
    """The open documents by URI."""

    def __init__(self, aligner: Aligner | None = None) -> None:
        self.by_uri: dict[str, Document] = {}
        self.encoding = lsp.PositionEncodingKind.Utf16
        self.aligner = aligner

    def open(self, uri: str, text: str, version: int | None) -> Document:
        doc = self.by_uri[uri] = Document(uri, text, version, self.encoding, self.aligner)
        return doc

    def unopened(self, uri: str, text: str) -> Document:
        """A document the client did not open (read from its file), not kept."""
        return Document(uri, text, None, self.encoding, self.aligner, opened=False)

    def get(self, uri: str) -> Document | None:
        return self.by_uri.get(uri)

    def close(self, uri: str) -> None:
        self.by_uri.pop(uri, None)
        if self.aligner is not None:
            self.aligner.forget(uri)
