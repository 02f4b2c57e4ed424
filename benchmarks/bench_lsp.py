"""Benchmark of `sgt lsp`: from a change to its diagnostics, on a 500-line script (target: 50 ms),
and formatting long scripts of equal lines.

    python benchmarks/bench_lsp.py [--lines 500] [--repeat 21] [--format-lines 20000]

A real server process (`python -m sgt_tui.cli lsp`) and a pygls client over stdio: the client
opens a script of ``--lines`` lines (benchmarks/bench_check.py's, made of the examples'
utterances), waits for its first diagnostics, then ``--repeat`` times types one character at
the end of a random utterance (an incremental didChange) and measures the time until the
server's publishDiagnostics for that version arrives: the protocol both ways, the analysis of
the changed utterance (the editor's chunked analysis) and the diagnostics' conversion. Every
fifth change makes an error (an unknown gesture) so the diagnostics really change. Prints the
median and the minimum; the in-process analysis of the same changes is printed beside it.

Formatting: a script of ``--format-lines`` equal lines, already formatted (no edit) and with
every other line to format, over the protocol (a formatting request to its answer: ``sgt fmt``'s
layout and the edits) and the edits alone (:func:`sgt_tui.lsp.actions._changes`, in process).
"""

from __future__ import annotations

import argparse
import asyncio
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path

from lsprotocol import types as lsp
from pygls.lsp.client import LanguageClient

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def ms(values) -> str:
    return f"median {statistics.median(values) * 1000:6.1f} ms   min {min(values) * 1000:6.1f} ms   (n={len(values)})"


def changes(text: str, repeat: int) -> list[tuple[int, int, str]]:
    """(row, column, inserted text) of each change, in order, on the script as it becomes."""
    from sgt_tui.editor.analysis import Analyser

    rows = text.split("\n")
    utterances = [u.line - 1 for u in Analyser(Path("x.sgt")).run(text).utterances]
    rng = random.Random(0)
    out = []
    for n in range(repeat):
        row = rng.choice(utterances)
        typed = " [pose:wavy]" if n % 5 == 4 else "a"
        out.append((row, len(rows[row]), typed))
        rows[row] += typed
    return out


async def lsp_latency(path: Path, text: str, edits) -> tuple[float, list[float]]:
    client = LanguageClient("bench-lsp", "1")
    arrived: dict[int, float] = {}
    waiting: dict[int, asyncio.Future] = {}

    @client.feature(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    def diagnostics(ls, params: lsp.PublishDiagnosticsParams) -> None:
        if params.version is not None and params.uri == path.as_uri():
            arrived[params.version] = time.perf_counter()
            future = waiting.pop(params.version, None)
            if future is not None and not future.done():
                future.set_result(None)

    async def published(version: int) -> float:
        if version not in arrived:
            waiting[version] = asyncio.get_running_loop().create_future()
            await asyncio.wait_for(waiting[version], 60)
        return arrived[version]

    await client.start_io(sys.executable, "-m", "sgt_tui.cli", "lsp")
    await client.initialize_async(lsp.InitializeParams(capabilities=lsp.ClientCapabilities(), root_uri=path.parent.as_uri()))
    client.initialized(lsp.InitializedParams())
    uri = path.as_uri()
    t = time.perf_counter()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(uri, "sgt", 1, text)))
    first = await published(1) - t
    times = []
    for version, (row, col, typed) in enumerate(edits, start=2):
        await asyncio.sleep(0.05)  # one change at a time, as typed
        change = lsp.TextDocumentContentChangePartial(lsp.Range(lsp.Position(row, col), lsp.Position(row, col)), typed)
        t = time.perf_counter()
        client.text_document_did_change(lsp.DidChangeTextDocumentParams(
            lsp.VersionedTextDocumentIdentifier(version=version, uri=uri), [change]))
        times.append(await published(version) - t)
    await client.shutdown_async(None)
    client.exit(None)
    await client.stop()
    return first, times


#: Scripts of equal lines to format: (name, the script of n lines).
FORMAT_CASES = (("equal lines, formatted already", lambda n: "guide: hi\n" * n),
                ("every other line to format", lambda n: "guide: hi\nguide:  hi\n" * (n // 2)))


async def lsp_formatting(folder: Path, n: int) -> list[tuple[str, float, int]]:
    """(case, seconds from the formatting request to its answer, edits) per case (each script
    opened and its first diagnostics received before)."""
    client = LanguageClient("bench-lsp", "1")
    analysed: dict[str, asyncio.Future] = {}

    @client.feature(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    def diagnostics(ls, params: lsp.PublishDiagnosticsParams) -> None:
        future = analysed.get(params.uri)
        if future is not None and not future.done():
            future.set_result(None)

    await client.start_io(sys.executable, "-m", "sgt_tui.cli", "lsp")
    await client.initialize_async(lsp.InitializeParams(capabilities=lsp.ClientCapabilities(), root_uri=folder.as_uri()))
    client.initialized(lsp.InitializedParams())
    out = []
    for k, (name, make) in enumerate(FORMAT_CASES):
        uri = (folder / f"format{k}.sgt").as_uri()
        analysed[uri] = asyncio.get_running_loop().create_future()
        client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(uri, "sgt", 1, make(n))))
        await asyncio.wait_for(analysed[uri], 600)  # its first analysis is not the formatting's time
        t = time.perf_counter()
        edits = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
            lsp.TextDocumentIdentifier(uri), lsp.FormattingOptions(4, True)))
        out.append((name, time.perf_counter() - t, len(edits or [])))
    await client.shutdown_async(None)
    client.exit(None)
    await client.stop()
    return out


def edits_alone(n: int) -> list[float]:
    from dsl.fmt import format_source
    from sgt_tui.lsp.actions import _changes, _lines_with_ends

    times = []
    for _, make in FORMAT_CASES:
        text = make(n)
        before, after = _lines_with_ends(text), _lines_with_ends(format_source(text))
        t = time.perf_counter()
        _changes(before, after)
        times.append(time.perf_counter() - t)
    return times


def analysis_alone(path: Path, text: str, edits) -> list[float]:
    from sgt_tui.editor.analysis import Analyser

    a = Analyser(path)
    a.run(text)
    rows = text.split("\n")
    times = []
    for row, _, typed in edits:
        rows[row] += typed
        t = time.perf_counter()
        a.run("\n".join(rows))
        times.append(time.perf_counter() - t)
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lines", type=int, default=500)
    ap.add_argument("--repeat", type=int, default=21)
    ap.add_argument("--format-lines", type=int, default=20_000)
    args = ap.parse_args()
    from bench_check import make_script

    text = make_script(args.lines)
    path = Path(tempfile.mkdtemp(prefix="bench-lsp-")) / "big.sgt"
    path.write_text(text, encoding="utf-8")
    edits = changes(text, args.repeat)
    first, times = asyncio.run(lsp_latency(path, text, edits))
    alone = analysis_alone(path, text, edits)
    print(f"script: {len(text.splitlines())} lines; first diagnostics after opening: {first * 1000:.0f} ms")
    print(f"{'change -> diagnostics published (sgt lsp)':<44} {ms(times)}")
    print(f"{'the analysis alone, in process':<44} {ms(alone)}")
    formatted = asyncio.run(lsp_formatting(path.parent, args.format_lines))
    for (name, seconds, edits), alone_s in zip(formatted, edits_alone(args.format_lines)):
        print(f"formatting {args.format_lines} lines, {name}: {seconds * 1000:.0f} ms over the protocol "
              f"({edits} edit{'s' if edits != 1 else ''}); the edits alone {alone_s * 1000:.1f} ms")


if __name__ == "__main__":
    main()
