"""The VS Code extension (editors/vscode): its TextMate grammar, run by vscode-textmate in node as
VS Code runs it, colours what sgt's own highlighter (the language's scanner) colours, on every
example and on lines that test the corners; and `vsce package` builds it.

Needs node and the extension's npm packages: `cd editors/vscode && npm ci` (scripts/install.sh
runs it); without them the tests are skipped, saying so.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest

from sgt_tui.editor.highlight import line_spans
from sgt_tui.lsp.server import PREVIEW

ROOT = Path(__file__).resolve().parent.parent
EXT = ROOT / "editors" / "vscode"
NODE = shutil.which("node")
MODULES = EXT / "node_modules"
needs_modules = pytest.mark.skipif(
    NODE is None or not (MODULES / "vscode-textmate").is_dir() or not (MODULES / "vscode-oniguruma").is_dir(),
    reason="needs node and the extension's npm packages: run 'npm ci' in editors/vscode (scripts/install.sh does)")

CORNERS = """\
# corners of the language
@voice knight: en-gb+m3   # a comment after a directive
@preset shy = space:-2 handedness:-1
Σωκράτης: γεια [pose:wave] σου
guide: \\[not a tag\\] and \\# not a comment # but this is
guide: [ pose : point_right  hold = 500ms x2 flip ] <calm speed:-1>slow</ calm > <space:+1></>
    [pause 300ms] a continuation <happy>line</happy>.
mall guide: no speaker here [pose:nod]
guide:[pose:shrug]x
"""

#: For each class of sgt's highlighter, the scope a token must have (a prefix of one of its scopes).
SCOPES = {
    "comment": "comment.line",
    "directive": "keyword.control.directive",
    "speaker": ("entity.name.type.speaker", "punctuation.separator.speaker"),
    "tag": ("punctuation.definition.tag", "keyword.other.tag", "invalid.illegal"),
    "name": "entity.name.function",
    "value": ("constant.other", "constant.numeric"),
    "escape": "constant.character.escape",
}


def _tokenize(files: list[Path]) -> list[dict]:
    r = subprocess.run([NODE, str(EXT / "test" / "tokenize.js"), *map(str, files)], check=False, capture_output=True, text=True,
                       timeout=120, cwd=EXT)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def _scopes_at(tokens: list[dict], line: str, char: int) -> list[str]:
    unit = len(line[:char].encode("utf-16-le")) // 2  # node counts UTF-16 units
    for t in tokens:
        if t["start"] <= unit < t["end"]:
            return t["scopes"]
    return []


def _mismatches(text: str, tokenized: dict) -> list[str]:
    bad = []
    for row, (line, tokens) in enumerate(zip(text.split("\n"), tokenized["lines"])):
        covered = set()
        for start, end, cls in line_spans(line):
            want = SCOPES[cls] if isinstance(SCOPES[cls], tuple) else (SCOPES[cls],)
            for i in range(start, end):
                covered.add(i)
                scopes = _scopes_at(tokens, line, i)
                if not any(s.startswith(w) for s in scopes for w in want):
                    bad.append(f"{row + 1}:{i + 1} {line[i]!r} is {cls} for sgt, {scopes[1:]} for the grammar: {line}")
        for i, c in enumerate(line):  # plain text stays plain (':' separators inside tags aside)
            if i not in covered and not c.isspace() and c != ":" and _scopes_at(tokens, line, i) != ["source.sgt"]:
                bad.append(f"{row + 1}:{i + 1} {c!r} is text for sgt, {_scopes_at(tokens, line, i)[1:]} for the grammar: {line}")
    return bad


@needs_modules
def test_the_grammar_colours_what_sgt_colours(tmp_path):
    corners = tmp_path / "corners.sgt"
    corners.write_text(CORNERS, encoding="utf-8")
    files = sorted((ROOT / "examples").glob("*.sgt")) + [corners]
    bad = []
    for path, tokenized in zip(files, _tokenize(files)):
        bad += [f"{path.name}:{m}" for m in _mismatches(path.read_text(encoding="utf-8"), tokenized)]
    assert bad == [], "\n".join(bad[:20])


@pytest.mark.skipif(NODE is None or not (MODULES / "@vscode" / "vsce").is_dir(),
                    reason="needs node and @vscode/vsce: run 'npm ci' in editors/vscode (scripts/install.sh does)")
def test_vsce_packages_the_extension(tmp_path):
    out = tmp_path / "sgt.vsix"
    vsce = MODULES / "@vscode" / "vsce" / "vsce"
    r = subprocess.run([NODE, str(vsce), "package", "--skip-license", "--allow-missing-repository", "-o", str(out)],
                       check=False, cwd=EXT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    names = set(zipfile.ZipFile(out).namelist())
    assert {"extension/package.json", "extension/extension.js", "extension/syntaxes/sgt.tmLanguage.json",
            "extension/language-configuration.json", "extension/node_modules/vscode-languageclient/package.json"} <= names
    assert not any(n.startswith(("extension/test/", "extension/node_modules/vscode-textmate/")) for n in names)


def test_the_manifest_names_files_that_exist_and_the_servers_command():
    manifest = json.loads((EXT / "package.json").read_text(encoding="utf-8"))
    contributes = manifest["contributes"]
    assert (EXT / contributes["grammars"][0]["path"]).is_file()
    assert (EXT / contributes["languages"][0]["configuration"]).is_file()
    assert contributes["languages"][0]["extensions"] == [".sgt"]
    assert f'"{PREVIEW}"' in (EXT / "extension.js").read_text(encoding="utf-8")
    json.loads((EXT / "syntaxes" / "sgt.tmLanguage.json").read_text(encoding="utf-8"))
    if NODE is not None:  # the client's code at least parses
        r = subprocess.run([NODE, "--check", str(EXT / "extension.js")], check=False, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr


def test_the_documented_helix_set_up_starts_the_server_and_formats():
    import tomllib

    doc = (ROOT / "docs" / "editors.md").read_text(encoding="utf-8").split("## Helix", 1)[1]
    config = tomllib.loads(doc.split("```toml\n", 1)[1].split("```", 1)[0])
    (language,) = config["language"]
    assert language["file-types"] == ["sgt"] and language["language-servers"] == ["sgt-lsp"]
    assert [language["formatter"]["command"], *language["formatter"]["args"]] == ["sgt", "fmt", "--stdin"]
    server = config["language-server"]["sgt-lsp"]
    assert [server["command"], *server["args"]] == ["sgt", "lsp"]
