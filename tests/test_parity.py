"""One analysis, one verdict: `sgt check`, the editor (`sgt edit`'s analysis) and the language
server (`sgt lsp`) give the same diagnostics, with the same codes, places, severities and
messages, for every script.

The scripts: every ``*.sgt`` of tests/, examples/ and docs/, the scripts written in the docs
(```` ```sgt ```` blocks), every rule's example (with its files and settings), the scripts the
tests write inline (their string constants that read as a script), the issue's cases, and
scripts generated with a seed (tests/scripts_gen.py: 2 to 5 speakers looking at each other and
at names they lack, expressions, voices for speakers, names in two cases, slips).

`sgt check --format json` runs once per group of scripts that share their settings; the
editor's :class:`~sgt_tui.editor.analysis.Analyser` analyses each script whole and, for many,
after a sequence of edits that arrive at the same text (the incremental path: chunks cached,
speakers coming and going); the language server's published diagnostics come from its
documents in this process (:func:`sgt_tui.lsp.actions.published`, the same code the server
runs), and from one real `sgt lsp` over several scripts, opened and edited by pytest-lsp's client.
"""

from __future__ import annotations

import ast
import asyncio
import json
import os
import random
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

try:  # the real server's client, as tests/test_lsp.py drives it
    import pytest_lsp
    from lsprotocol import types as lsp
    from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities
except ImportError:  # pragma: no cover - installed with the project's test tools
    pytest_lsp = None

from core import rules
from core.diagnostics import ERROR, WARNING, Diagnostic
from core.fileio import json_text
from sgt_tui.editor.analysis import Analyser
from sgt_tui.editor.files import FileError, ScriptFile
from tests import scripts_gen

ROOT = Path(__file__).resolve().parent.parent
GENERATED = 120  # generated scripts (seeds 0..GENERATED-1)
CHECK_TIMEOUT = 300
#: A string constant of a test reads as a script when a line starts with a directive or a
#: speaker, or it has a tag.
_SCRIPTY = re.compile(r"(?m)^(?:@[a-z]+\b|[^\W\d][\w\-]*:(?:[ \t]|$))|\[(?:pose|look|pause)\b")

MIN = "ann: [look:bob] Hello there.\nbob: Hi.\n"
TAVERN = """\
@voice innkeeper: en-gb
@rate bard: 180
innkeeper: [look:bard] Another song, friend? [look:smith] You look thirsty.
bard: [look:innkeeper] Gladly! [pose:open_arms] [look:maid] And you, dear?
maid: [look:bard hold=1s] Not tonight. <face:smile>Maybe tomorrow.</face>
smith: [look:innkeeper] An ale, [pose:nod] please. [look:Bard] Who's singing?
"""
SLIP = "guide:[pose:nod] Yes.\nguide:hello\nguide: Fine.\nguide:<happy>Good.</happy>\n"
ISSUE = {"min": MIN, "tavern": TAVERN, "slip": SLIP}


@dataclass
class Case:
    name: str
    path: Path
    root: Path  # the folder `sgt check` ran in (unless ``cwd``)
    env: tuple = ()
    cwd: Path | None = None
    text: str | None = None  # as the editor reads the file (None: it refuses the file)
    edited: bool = False  # also analysed after a sequence of edits
    served: bool = False  # also opened in the real `sgt lsp`
    recordings: bool = False
    check: list[dict] = field(default_factory=list)


def _inline_scripts() -> dict[str, str]:
    """The string constants of tests/*.py that read as a script, once each."""
    found: dict[str, str] = {}
    for f in sorted((ROOT / "tests").glob("*.py")):
        if f.name == Path(__file__).name:
            continue
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Constant) and isinstance(node.value, str) and len(node.value) < 20_000
                    and _SCRIPTY.search(node.value) and node.value not in found.values()):
                found[f"{f.stem}:{node.lineno}"] = node.value
    return found


def _doc_scripts() -> dict[str, str]:
    found = {}
    for md in sorted((ROOT / "docs").glob("*.md")):
        for n, m in enumerate(re.finditer(r"```sgt\n(.*?)```", md.read_text(encoding="utf-8"), re.DOTALL)):
            found[f"{md.stem}#{n}"] = m.group(1)
    return found


def _sgt_files() -> list[Path]:
    return sorted(p for folder in ("tests", "examples", "docs") for p in (ROOT / folder).rglob("*.sgt")
                  if "node_modules" not in p.parts)


def _write(root: Path, n: int, text: str) -> Path:
    folder = root / f"s{n:04d}"
    folder.mkdir()
    path = folder / "script.sgt"
    path.write_bytes(text.encode("utf-8", "surrogateescape"))
    return path


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> list[Case]:
    """Every script, written in a folder of its own (relative paths resolve there), with what
    `sgt check --format json` says of it."""
    root = tmp_path_factory.mktemp("parity")
    cases: list[Case] = []
    for p in _sgt_files():  # where they are
        cases.append(Case(str(p.relative_to(ROOT)), p, root, edited=True, served=True))
    for r in rules.RULES.values():
        if not r.example:
            continue
        folder = root / f"rule-{r.name}"
        folder.mkdir()
        path = rules.materialise_example(r, folder)
        config = any(rel == "sgt.toml" for rel, _ in r.files)  # read from the current folder
        cases.append(Case(f"rule {r.code}", path, root, tuple(r.env), folder if config else None,
                          recordings=any(t.startswith("@speech:") for _, t in r.files)))
    texts = [(f"issue {k}", v, True) for k, v in ISSUE.items()]
    texts += [(f"docs {k}", v, True) for k, v in _doc_scripts().items()]
    texts += [(f"generated {seed}", scripts_gen.script(seed), True) for seed in range(GENERATED)]
    texts += [(f"tests {k}", v, False) for k, v in _inline_scripts().items()]
    for n, (name, text, edited) in enumerate(texts):
        cases.append(Case(name, _write(root, n, text), root, edited=edited,
                          served=name.startswith(("issue", "docs")) or name in {f"generated {s}" for s in range(12)}))
    for case in cases:
        try:
            case.text = ScriptFile.open(case.path).document.text
        except FileError:
            case.text = None  # not UTF-8: the editor refuses it (and says why), nothing to compare
    groups: dict[tuple, list[Case]] = {}
    for case in cases:
        groups.setdefault((case.env, case.cwd), []).append(case)
    for (env, cwd), members in groups.items():
        out = subprocess.run([sys.executable, "-m", "sgt_tui.cli", "check", "--format", "json", *(str(c.path) for c in members)],
                             check=False, capture_output=True, text=True, cwd=cwd or root, env={**os.environ, **dict(env)},
                             timeout=CHECK_TIMEOUT)
        assert out.returncode in (0, 1) and "Traceback" not in out.stderr, out.stderr[-2000:]
        by_file: dict[str, list[dict]] = {}
        for d in json.loads(out.stdout)["diagnostics"]:
            by_file.setdefault(d["file"], []).append(d)
        for case in members:
            case.check = by_file.pop(str(case.path), [])
        for other, diags in by_file.items():  # a gesture spec's (or folder's) problems: its script's
            owners = [c for c in members if c.path.parent in Path(other).parents] or members
            assert len(owners) == 1, other
            owners[0].check += diags
    return cases


def _plain(diags: list[Diagnostic]) -> list[dict]:
    return [json.loads(json_text(d.to_dict())) for d in diags]


def _sorted(diags: list[dict]) -> list[str]:
    return sorted(json.dumps(d, sort_keys=True) for d in diags)


def _settings(case: Case, monkeypatch):
    """Run the analysis as `sgt check` ran: its settings and its current folder."""
    for key, value in case.env:
        monkeypatch.setenv(key, value)
    monkeypatch.chdir(case.cwd or case.root)


def test_the_corpus_holds_every_script_of_the_repository(corpus):
    names = {c.name for c in corpus}
    assert {str(p.relative_to(ROOT)) for p in _sgt_files()} <= names and len(_sgt_files()) >= 4
    assert {f"rule {r.code}" for r in rules.RULES.values() if r.example} <= names
    assert sum(n.startswith("tests ") for n in names) >= 300 and sum(n.startswith("docs ") for n in names) >= 5
    checked = [d for c in corpus for d in c.check]
    codes = {d["code"] for d in checked}
    # the generated scripts reach what depends on the whole script
    assert {"SGT212", "SGT213", "SGT214", "SGT218", "SGT401", "SGT409", "SGT411", "SGT116"} <= codes
    assert any(d["code"] == "SGT116" and d["message"].startswith("'guide:[pose:nod]'") for d in checked)


def test_the_editor_gives_the_verdict_of_sgt_check(corpus, monkeypatch):
    """The whole text, analysed at once, and after edits that arrive at it."""
    compared = edited = 0
    for case in corpus:
        if case.text is None:
            continue
        with monkeypatch.context() as m:
            _settings(case, m)
            whole = Analyser(case.path).run(case.text).diagnostics
            assert _sorted(_plain(whole)) == _sorted(case.check), case.name
            compared += 1
            if case.edited:
                analyser = Analyser(case.path)
                for text in _edits(case.text, random.Random(case.name)):
                    analyser.run(text)
                assert analyser.run(case.text).diagnostics == whole, case.name
                edited += 1
    assert compared > 400 and edited > 100


def _edits(text: str, rng: random.Random) -> list[str]:
    """Texts on the way to ``text``: nothing, its lines coming in a few at a time (speakers
    appear one by one), a speaker renamed everywhere and back, a snippet typed in and out."""
    lines = text.split("\n")
    steps = [""]
    step = max(1, len(lines) // 5)
    steps += ["\n".join(lines[:n]) for n in range(step, len(lines), step)]
    steps.append(text)
    speakers = re.findall(r"(?m)^([^\W\d][\w\-]*):[ \t]", text)
    if speakers:
        name = rng.choice(speakers)
        steps.append(re.sub(rf"\b{re.escape(name)}\b", name + "x", text))
        steps.append(text)
    at = rng.randrange(len(text) + 1)
    snippet = rng.choice(["[pose:wavee] ", "\nbob: [look:ann] hi\n", "[look:nobody] ", "\n@gap -300ms\n", "<"])
    steps.append(text[:at] + snippet + text[at:])
    return steps


# -- the language server ---------------------------------------------------------------------------

_SEVERITY = {ERROR: 1, WARNING: 2}


def _utf16(text: str) -> int:
    return len(text.encode("utf-16-le", "surrogatepass")) // 2


def _wire(d: dict, script: Path, lines: list[str]) -> tuple:
    """What the protocol should carry for one of `sgt check`'s diagnostics: (file, code, start,
    end, severity, message with its hint), positions in UTF-16 units of the script's lines."""
    if d["file"] == str(script):
        if d["line"] <= 0:
            start = end = (0, 0)
        else:
            row = d["line"] - 1
            line = lines[row] if row < len(lines) else ""
            c0 = max(d["col"] - 1, 0)
            start, end = (row, _utf16(line[:c0])), (row, _utf16(line[: c0 + max(d["length"], 0)]))
    else:  # a file the server does not hold (a gesture spec): characters as units
        row, c0 = max(d["line"] - 1, 0), max(d["col"] - 1, 0)
        start, end = (row, c0), (row, c0 + max(d["length"], 0))
    message = d["message"] + (f"\nhint: {d['hint']}" if d["hint"] else "")
    return Path(d["file"]).resolve().as_uri(), d["code"], start, end, _SEVERITY.get(d["severity"], 3), message


def _published(by_uri: dict) -> list[tuple]:
    return sorted((Path(uri.removeprefix("file://")).resolve().as_uri(), d.code, (d.range.start.line, d.range.start.character),
                   (d.range.end.line, d.range.end.character), int(d.severity), d.message)
                  for uri, diags in by_uri.items() for d in diags)


def _expected(case: Case, own: bool = False) -> list[tuple]:
    """``case``'s diagnostics as the protocol carries them (``own``: only those in the script)."""
    return sorted(_wire(d, case.path, case.text.split("\n")) for d in case.check if not own or d["file"] == str(case.path))


def test_the_servers_documents_publish_the_verdict_of_sgt_check(corpus, monkeypatch):
    """The server's documents (its analysis per document, in this process: recordings are
    aligned where the analysis runs, as `sgt check` does), opened and then edited."""
    from sgt_tui.lsp.actions import published  # lazy: the server's code (pygls)
    from sgt_tui.lsp.documents import Documents, uri_of  # lazy: the server's code (pygls)

    docs = Documents()
    compared = 0
    for case in corpus:
        if case.text is None:
            continue
        with monkeypatch.context() as m:
            _settings(case, m)
            doc = docs.open(uri_of(case.path), case.text, 1)
            assert _published(published(doc)) == _expected(case), case.name
            if case.edited and case.name.startswith(("issue", "generated 1")):
                for version, text in enumerate(_edits(case.text, random.Random(case.name)), start=2):
                    doc.set_text(text, version)
                    published(doc)
                doc.set_text(case.text, 100)
                assert _published(published(doc)) == _expected(case), case.name
            docs.close(doc.uri)
            compared += 1
    assert compared > 400


@pytest.fixture(scope="module")
def served(corpus) -> list[Case]:
    cases = [c for c in corpus if c.served and c.text is not None and not c.env and not c.recordings]
    assert len(cases) >= 20
    return cases


if pytest_lsp is not None:
    @pytest_lsp.fixture(config=ClientServerConfig(server_command=[sys.executable, "-m", "sgt_tui.cli", "lsp"]))
    async def client(lsp_client: LanguageClient, served):
        root = served[-1].root
        await lsp_client.initialize_session(lsp.InitializeParams(
            capabilities=client_capabilities("neovim"), root_uri=root.as_uri(),
            workspace_folders=[lsp.WorkspaceFolder(root.as_uri(), "parity")]))
        yield
        await lsp_client.shutdown_session()


@pytest.mark.skipif(pytest_lsp is None, reason="pytest-lsp is not installed")
@pytest.mark.asyncio
async def test_a_real_sgt_lsp_publishes_the_verdict_of_sgt_check(client: LanguageClient, served):
    """One `sgt lsp` over several scripts: each opened, every third one reached by partial
    changes on the way (the server applies them), and the diagnostics it published for the
    last version equal what `sgt check` says."""
    seen: dict[str, tuple[int | None, list]] = {}

    def got(params):  # every publication, in order (the next is awaited before this returns)
        seen[params.uri] = (params.version, list(params.diagnostics))
        client.protocol.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS, got)

    client.protocol.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS, got)
    final: dict[str, int] = {}
    for n, case in enumerate(served):
        uri = case.path.as_uri()
        steps = _edits(case.text, random.Random(case.name)) if n % 3 == 0 else []
        before = steps[0] if steps else case.text
        client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(uri, "sgt", 1, before)))
        for version, text in enumerate(steps[1:] + [case.text] if steps else [], start=2):
            client.text_document_did_change(lsp.DidChangeTextDocumentParams(
                lsp.VersionedTextDocumentIdentifier(uri=uri, version=version), [_change(before, text)]))
            before = text
        final[uri] = 1 + len(steps)
    loop = asyncio.get_running_loop()
    deadline = loop.time() + 60
    while any(seen.get(uri, (None,))[0] != version for uri, version in final.items()):
        assert loop.time() < deadline, "the server did not publish every script's last version"
        await asyncio.sleep(0.05)
    for case in served:
        uri = case.path.as_uri()
        assert _published({uri: seen[uri][1]}) == _expected(case, own=True), case.name


def _change(before: str, after: str):
    """The partial change (a range of ``before`` replaced) that makes ``after``."""
    head = 0
    while head < min(len(before), len(after)) and before[head] == after[head]:
        head += 1
    tail = 0
    while tail < min(len(before), len(after)) - head and before[-1 - tail] == after[-1 - tail]:
        tail += 1

    def pos(text: str, i: int) -> lsp.Position:
        line = text.count("\n", 0, i)
        return lsp.Position(line, _utf16(text[text.rfind("\n", 0, i) + 1 : i]))

    return lsp.TextDocumentContentChangePartial(lsp.Range(pos(before, head), pos(before, len(before) - tail)),
                                                after[head : len(after) - tail])
