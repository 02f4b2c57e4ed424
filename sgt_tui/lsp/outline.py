"""The shape of a script for the editor: document symbols (the header, then each speaker's
utterances), folding ranges, semantic tokens (the editor's own highlighting classes,
:mod:`sgt_tui.editor.highlight`) and inlay hints (each utterance's start and length)."""

from __future__ import annotations

from lsprotocol import types as lsp

from core.counting import number, plural
from dsl.lines import strip_comment
from sgt_tui.editor.highlight import line_spans
from sgt_tui.lsp.documents import Document, units
from sgt_tui.lsp.index import occurrences

#: Semantic token types, in the legend's order, for the highlighting classes.
TOKEN_TYPES = ("comment", "keyword", "class", "operator", "function", "number", "string")
_CLASS_TYPE = {"comment": 0, "directive": 1, "speaker": 2, "tag": 3, "name": 4, "value": 5, "escape": 6}
LEGEND = lsp.SemanticTokensLegend(token_types=list(TOKEN_TYPES), token_modifiers=[])


def symbols(doc: Document) -> list[lsp.DocumentSymbol]:
    analysis = doc.analysis()
    out: list[lsp.DocumentSymbol] = []
    infos = analysis.utterances
    header_end = (infos[0].line - 1) if infos else len(doc.lines)
    presets = [o for o in occurrences("\n".join(doc.lines[:header_end])) if o.kind == "preset_def"]
    directives = [n for n in range(header_end) if doc.line(n).startswith("@")]
    if directives:
        children = [lsp.DocumentSymbol(o.name, lsp.SymbolKind.Constant, doc.range(o.row, 0, len(doc.line(o.row))),
                                       doc.range(o.row, o.col, o.col + o.length), detail=doc.line(o.row).strip())
                    for o in presets]
        first, last = directives[0], directives[-1]
        out.append(lsp.DocumentSymbol("header", lsp.SymbolKind.Namespace, doc.range(first, 0, len(doc.line(last)), last),
                                      doc.range(first, 0, len(doc.line(first))), detail=plural(len(directives), "directive"),
                                      children=children))
    by_speaker: dict[str, list] = {}
    for info in infos:
        by_speaker.setdefault(info.speaker or "", []).append(info)
    for speaker, group in by_speaker.items():
        children = []
        for info in group:
            row, last = info.line - 1, info.last_line - 1
            text = info.utterance.display if info.utterance is not None else strip_comment(doc.line(row)).strip()
            name = f"{number(info.index)}. {text[:60] or '(silent)'}"
            children.append(lsp.DocumentSymbol(name, lsp.SymbolKind.String, doc.range(row, 0, len(doc.line(last)), last),
                                               doc.range(row, 0, len(doc.line(row)))))
        first, final = group[0].line - 1, group[-1].last_line - 1
        sel_len = len(speaker) if speaker else len(doc.line(first))
        out.append(lsp.DocumentSymbol(speaker or "(no speaker)", lsp.SymbolKind.Class,
                                      doc.range(first, 0, len(doc.line(final)), final), doc.range(first, 0, sel_len),
                                      detail=plural(len(group), "utterance"), children=children))
    return out


def folding(doc: Document) -> list[lsp.FoldingRange]:
    out: list[lsp.FoldingRange] = []
    infos = doc.analysis().utterances
    header_end = (infos[0].line - 1) if infos else len(doc.lines)
    header = [n for n in range(header_end) if strip_comment(doc.line(n)).strip()]
    if len(header) >= 2:
        out.append(lsp.FoldingRange(header[0], header[-1], kind=lsp.FoldingRangeKind.Region))
    out += [lsp.FoldingRange(info.line - 1, info.last_line - 1) for info in infos if info.last_line > info.line]
    run: list[int] = []
    for n in range(len(doc.lines) + 1):
        comment = n < len(doc.lines) and doc.line(n).lstrip().startswith("#")
        if comment:
            run.append(n)
            continue
        if len(run) >= 2:
            out.append(lsp.FoldingRange(run[0], run[-1], kind=lsp.FoldingRangeKind.Comment))
        run = []
    return out


def semantic_tokens(doc: Document) -> lsp.SemanticTokens:
    data: list[int] = []
    prev_row = prev_col = 0
    for row, line in enumerate(doc.lines):
        end = 0
        for start, stop, cls in line_spans(line):
            if start < end or cls not in _CLASS_TYPE or stop <= start:
                continue
            col = units(line[:start], doc.encoding)
            length = units(line[start:stop], doc.encoding)
            data += [row - prev_row, col - prev_col if row == prev_row else col, length, _CLASS_TYPE[cls], 0]
            prev_row, prev_col, end = row, col, stop
    return lsp.SemanticTokens(data=data)


def inlay_hints(doc: Document, rng: lsp.Range, timing) -> list[lsp.InlayHint]:
    out = []
    for info, start, length, real in timing.performance(doc):
        row = info.line - 1
        if not rng.start.line <= row <= rng.end.line:
            continue
        code = strip_comment(doc.line(row)).rstrip()
        label = f"{'' if real else '≈'}{start:.2f} s · {length:.2f} s"
        tip = ("start on the performance clock and length, from the speech" if real else
               "start on the performance clock and length, estimated from the text (a preview gives the real timing)")
        out.append(lsp.InlayHint(doc.position(row, len(code)), label, padding_left=True, tooltip=tip))
    return out
