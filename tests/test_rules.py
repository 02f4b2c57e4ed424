"""The rule registry (core.rules): every diagnostic has a code, a name, an explanation and an
example that really triggers it, and every registered rule is emitted somewhere."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest

from core import rules
from core.diagnostics import Fix, TextEdit
from dsl.compiler import compile_file
from sgt_tui import cli

ROOT = Path(__file__).resolve().parent.parent
SOURCES = [p for d in ("core", "dsl", "library", "model", "renders", "sgt_tui") for p in (ROOT / d).rglob("*.py")]
#: Rules no script can trigger (the explanation says why); each is still emitted by code.
NO_EXAMPLE = {
    "syntax": "a fallback: the specific syntax rules cover every case",
    "speech": "the speech engine or aligner fails: not the script",
    "timing": "a broken engine or cache entry: not the script",
    "speech-crash": "the speech process dies (a signal, a crash in the library): not the script",
    "io": "the script file itself cannot be read",
    "generation": "an editor job fails for a reason outside the script (tests/test_editor_app.py triggers it)",
    "refused-path": "only a request to sgt serve triggers it (tests/test_serve.py)",
    "voice-not-installed": "what is installed, not the script (tests/test_piper.py hides piper)",
}


def test_codes_names_and_ranges():
    assert len(rules.RULES) >= 50
    for code, r in rules.RULES.items():
        assert re.fullmatch(r"SGT[1-6]\d\d", code) and code == r.code
        assert re.fullmatch(r"[a-z0-9]+(-[a-z0-9]+)*", r.name)
        assert r.severity in (rules.ERROR, rules.WARNING, rules.NOTE)
        assert rules.lookup(code) is r and rules.lookup(code.lower()) is r and rules.lookup(r.name) is r
    assert rules.lookup("nope") is None


def test_every_rule_has_a_real_explanation():
    for r in rules.RULES.values():
        text = r.explanation
        assert len(text) > 200, r.code
        assert "Fix:" in text and ("Example" in text or r.name in NO_EXAMPLE), r.code
        assert "{" not in r.explanation.replace("{\"", "").replace("`{", ""), r.code  # no unformatted fields


def test_every_rule_is_emitted_somewhere():
    # Emitted: `RULE.at(` or the rule handed to a report helper (`report(..., rules.RULE`) or
    # returned for one (`return rules.RULE, {...}`). The examples prove the rest (below).
    source = "\n".join(p.read_text(encoding="utf-8") for p in SOURCES if p.name != "rules.py")
    for r in rules.RULES.values():
        var = next(k for k, v in vars(rules).items() if v is r)
        pattern = rf"\b{var}\.at\(|report\(.*\brules\.{var}\b|return rules\.{var}, "
        assert re.search(pattern, source), f"{r.code} {r.name} ({var}) is never emitted"


def test_no_diagnostic_is_built_by_hand_outside_core():
    for path in SOURCES:
        if path.parent.name == "core":
            continue
        assert not re.search(r"\bDiagnostic\(", path.read_text(encoding="utf-8")), path


def _run_example(r, folder: Path, monkeypatch):
    script = rules.materialise_example(r, folder)
    for key, value in r.env:
        monkeypatch.setenv(key, value)
    monkeypatch.chdir(folder)
    return compile_file(script.name, timing="estimate")


@pytest.mark.parametrize("code", sorted(c for c, r in rules.RULES.items() if r.name not in NO_EXAMPLE))
def test_the_example_triggers_its_rule(code, tmp_path, monkeypatch):
    r = rules.RULES[code]
    result = _run_example(r, tmp_path, monkeypatch)
    mine = [d for d in result.diagnostics if d.code == code]
    assert mine, [(d.code, d.message) for d in result.diagnostics]
    d = mine[0]
    assert d.name == r.name and d.severity == r.severity
    if d.file == "example.sgt" and d.line:  # the caret points at text of the line
        line = result.script.source.splitlines()[d.line - 1]
        assert line[d.col - 1 : d.col - 1 + d.length].strip() or d.name in ("indent",)


def test_rules_without_an_example_say_so_and_are_triggered_otherwise(tmp_path, monkeypatch, capsys):
    assert all(not rules.lookup(name).example for name in NO_EXAMPLE)
    # syntax: only a '#' reaching a body (the line splitter strips comments first)
    from dsl.lines import Statement
    from dsl.parser import _Analyser
    from dsl.script import Header

    stmt = Statement(kind="utterance", text="a # b", line=1)
    stmt.add_piece(0, 1, 1)
    a = _Analyser("t.sgt", None, tmp_path)
    a.utterance(stmt, 0, Header())
    assert [(d.name, d.col) for d in a.diags] == [("syntax", 3)]
    # io: a script that cannot be read
    assert cli.main(["check", str(tmp_path / "missing.sgt")]) == 1
    assert "[SGT601]" in capsys.readouterr().out
    # speech: the engine cannot be loaded; check and compile both say so, at the utterance
    from dsl.speech import _espeak, synth

    script = tmp_path / "s.sgt"
    script.write_text("@seed 1\nhello there\n")

    def broken():
        raise _espeak.EngineError("missing-lib", "the espeak-ng speech library could not be loaded")

    with monkeypatch.context() as m:
        m.setattr(_espeak, "engine", broken)
        m.setattr(synth, "_checked_voices", {})
        for argv in (["check"], ["compile", "-o", str(tmp_path / "p.json")]):
            assert cli.main([*argv, "--format", "json", str(script)]) == 1
            (d,) = json.loads(capsys.readouterr().out)["diagnostics"]
            assert (d["name"], d["line"]) == ("speech", 2) and "could not be loaded" in d["message"]
    # timing: the engine returns another number of words than the script has
    from dsl import compiler
    from dsl.timing import estimate_timing

    def short(utt, cache_dir=None):
        t = estimate_timing(utt)
        t.words = t.words[:-1]
        return t

    monkeypatch.setattr(compiler, "speech_timing", short)
    result = compile_file(script, timing="speech")
    assert [(d.name, d.message) for d in result.diagnostics] == [("timing", "speech timing returned times for 1 of 2 words")]


def test_hints_and_templates_take_their_fields():
    d = rules.OUT_OF_RANGE.at("a.sgt", 2, 3, 4, what="pitch", value=300, allowed="a value from 0 to 100")
    assert (d.message, d.hint, d.code, d.name) == ("pitch 300 is out of range", "use a value from 0 to 100", "SGT302", "out-of-range")
    assert rules.OUT_OF_RANGE.at("a.sgt", 1, 1, 1, hint=None, what="x", value=1, allowed="y").hint is None
    assert rules.OVERLAP.at("a.sgt", 1, 1, severity=rules.ERROR, name="a", other="b", late=3, secs="0.20", word="w",
                            how="", why="r").is_error


def test_did_you_mean_gives_fixes_named_by_the_hint():
    hint, fixes = rules.did_you_mean("wavee", ["wave", "nod", "point_right"], 3, 12, 5)
    assert hint == "did you mean 'wave'?"
    assert fixes == (Fix("replace with 'wave'", (TextEdit(3, 12, 5, "wave"),)),)
    d = rules.UNKNOWN_GESTURE.at("a.sgt", 3, 12, 5, name="wavee", hint=hint, fixes=fixes)
    assert d.suggestions == ("wave",)
    assert rules.did_you_mean("zzzz", ["wave"], 1, 1, 4) == (None, ())


# -- sgt explain --------------------------------------------------------------------------


def test_explain_prints_the_explanation_and_runs_the_example(capsys):
    assert cli.main(["explain", "SGT201"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("SGT201 unknown-gesture (error)")
    assert rules.UNKNOWN_GESTURE.explanation in out
    assert "Example (example.sgt):\n    guide: hi [pose:wavee] there" in out
    assert "sgt check says:\n    example.sgt:1:17: error: [SGT201] unknown gesture 'wavee'" in out
    assert cli.main(["explain", "unknown-gesture", "--no-run"]) == 0
    assert "sgt check says" not in capsys.readouterr().out


def test_explain_shows_invisible_characters_and_files(capsys):
    assert cli.main(["explain", "bidi-control"]) == 0
    assert "hello <U+202E>ereht" in capsys.readouterr().out
    assert cli.main(["explain", "unreadable-audio", "--no-run"]) == 0
    assert "with notes.wav: 'these are my notes, not audio\\n'" in capsys.readouterr().out


def test_explain_list_and_unknown_codes(capsys):
    assert cli.main(["explain", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(rules.RULES) and lines[0].startswith("SGT101  indent")
    assert cli.main(["explain", "unknown-gestur"]) == 2
    assert "did you mean 'unknown-gesture'" in capsys.readouterr().err
    assert cli.main(["explain"]) == 2


def test_explain_restores_the_environment(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("SGT_LIBRARY_PATH", raising=False)
    assert cli.main(["explain", "library-folder"]) == 0
    assert "(from SGT_LIBRARY_PATH) does not exist" in capsys.readouterr().out
    assert "SGT_LIBRARY_PATH" not in os.environ and Path.cwd() == tmp_path


def apply_fix(text: str, fix: Fix) -> str:
    """``text`` with the fix's edits applied (positions refer to the unchanged text)."""
    lines = text.split("\n")
    for e in sorted(fix.edits, key=lambda e: (e.line, e.col), reverse=True):
        line = lines[e.line - 1]
        lines[e.line - 1] = line[: e.col - 1] + e.text + line[e.col - 1 + e.length :]
    return "\n".join(lines)


def test_each_fix_of_an_example_removes_its_diagnostic(tmp_path, monkeypatch):
    checked = []
    for r in rules.RULES.values():
        if not r.example or r.encoding != "utf-8":
            continue
        folder = tmp_path / r.name
        folder.mkdir()
        with monkeypatch.context() as m:
            result = _run_example(r, folder, m)
            before = sum(x.code == r.code for x in result.diagnostics)
            mine = [d for d in result.diagnostics if d.code == r.code and d.file == "example.sgt" and d.fixes]
            for fix in mine[0].fixes if mine else ():
                fixed = apply_fix(r.example, fix)
                (folder / "example.sgt").write_text(fixed, encoding="utf-8")
                after = [x for x in compile_file("example.sgt", timing="estimate").diagnostics if x.code == r.code]
                assert len(after) < before, (r.name, fix.title, fixed, after)
                checked.append((r.name, fix.title))
    assert len({name for name, _ in checked}) >= 20, checked
