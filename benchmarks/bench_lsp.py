"""Benchmark of `sgt lsp`: from a change to its diagnostics, on a 500-line script (target: 50 ms).

    python benchmarks/bench_lsp.py [--lines 500] [--repeat 21]

A real server process (`python -m sgt_tui.cli lsp`) and a pygls client over stdio: the client
opens a script of ``--lines`` lines (benchmarks/bench_check.py's, made of the examples'
utterances), waits for its first diagnostics, then ``--repeat`` times types one character at
the end of a random utterance (an incremental didChange) and measures the time until the
server's publishDiagnostics for that version arrives: the protocol both ways, the analysis of
the changed utterance (the editor's chunked analysis) and the diagnostics' conversion. Every
fifth change makes an error (an unknown gesture) so the diagnostics really change. Prints the
median and the minimum; the in-process analysis of the same changes is printed beside it.
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


if __name__ == "__main__":
    main()
