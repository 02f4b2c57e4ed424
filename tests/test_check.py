"""`sgt check` accepts exactly what `sgt compile` accepts, and reports like a compiler.

Issue 13: check and compile share one analysis (:func:`dsl.compiler.load_script`), so a script
gets the same exit status and the same errors from both, whatever the timing. The agreement
test runs both commands on every script in examples/ and tests/, on every script the tests
write (found in their source), on the diagnostics snapshot cases and on the example of every
diagnostic rule.
"""

from __future__ import annotations

import ast
import json
import os
from pathlib import Path

import pytest

from core import rules
from sgt_tui import cli

ROOT = Path(__file__).resolve().parent.parent


def _scripts_the_tests_write() -> dict[str, str]:
    """Script texts written by the tests: string constants given to ``.write_text`` of a path
    named ``*.sgt`` and to ``analyse``/``compile_file`` as source, found in tests/*.py."""
    found: dict[str, str] = {}
    for test in sorted((ROOT / "tests").glob("test_*.py")):
        tree = ast.parse(test.read_text(encoding="utf-8"))
        sgt_names = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and ".sgt" in ast.unparse(node.value):
                sgt_names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call) or not node.args:
                continue
            arg = node.args[0]
            if not (isinstance(arg, ast.Constant) and isinstance(arg.value, str)):
                continue
            func = node.func
            if isinstance(func, ast.Attribute) and func.attr == "write_text":
                target = func.value
                if ".sgt" in ast.unparse(target) or (isinstance(target, ast.Name) and target.id in sgt_names):
                    found[f"{test.stem}:{node.lineno}"] = arg.value
            elif isinstance(func, ast.Name) and func.id == "analyse":
                found[f"{test.stem}:{node.lineno}"] = arg.value
    return found


def _corpus() -> dict[str, tuple[str, object]]:
    """name -> (script text, rule whose example it is or None)."""
    from tests.test_diagnostics import CASES

    out: dict[str, tuple[str, object]] = {}
    for path in sorted(ROOT.glob("examples/*.sgt")) + sorted(ROOT.glob("tests/**/*.sgt")):
        out[str(path.relative_to(ROOT))] = (path.read_text(encoding="utf-8", errors="surrogateescape"), None)
    for name, text in _scripts_the_tests_write().items():
        out[name] = (text, None)
    for name, text in CASES.items():
        out[f"snapshot:{name}"] = (text, None)
    for r in rules.RULES.values():
        if r.example:
            out[f"rule:{r.code}"] = (r.example, r)
    return out


CORPUS = _corpus()


def test_the_corpus_covers_the_examples_the_tests_and_every_rule():
    names = set(CORPUS)
    assert {"examples/mall_guide.sgt", "examples/lecture.sgt", "examples/game_dialogue.sgt"} <= names
    assert sum(n.startswith(("test_compiler:", "test_grammar:")) for n in names) >= 10
    assert sum(n.startswith("rule:") for n in names) >= 45


def _run(argv, capsys) -> tuple[int, dict]:
    code = cli.main(argv)
    out = capsys.readouterr().out
    data = json.loads(out[out.index("{"):]) if "{" in out else {"diagnostics": []}
    return code, data


def _errors(data, folder: Path) -> set:
    return {(Path(d["file"]).name, d["line"], d["col"], d["code"]) for d in data["diagnostics"] if d["severity"] == "error"}


@pytest.fixture(scope="module")
def speech_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("speech-cache")


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_check_and_compile_agree(name, tmp_path, capsys, monkeypatch, speech_cache):
    text, rule = CORPUS[name]
    monkeypatch.setenv("SGT_CACHE_DIR", str(speech_cache))
    monkeypatch.chdir(tmp_path)
    if rule is not None:
        script = rules.materialise_example(rule, tmp_path)
        for key, value in rule.env:
            monkeypatch.setenv(key, value)
    else:
        script = tmp_path / "script.sgt"
        script.write_bytes(text.encode("utf-8", "surrogateescape"))
    check_code, check = _run(["check", "--format", "json", str(script)], capsys)
    compile_code, compiled = _run(["compile", "--format", "json", str(script), "-o", str(tmp_path / "plan.json")], capsys)
    assert check_code == compile_code, (check["diagnostics"], compiled["diagnostics"])
    assert _errors(check, tmp_path) == _errors(compiled, tmp_path)
    assert (tmp_path / "plan.json").exists() == (compile_code == 0)


# -- the command ------------------------------------------------------------------------


def test_a_missing_file_is_reported_and_the_others_are_still_checked(tmp_path, capsys):
    a, b = tmp_path / "a.sgt", tmp_path / "b.sgt"
    a.write_text("hello there\n")
    b.write_text("hi [pose:wavee]\n")
    code = cli.main(["check", str(a), str(tmp_path / "missing.sgt"), str(b), str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 1
    assert f"{a}: ok (1 utterance)" in out
    assert f"{tmp_path / 'missing.sgt'}: error: [SGT601] cannot read the script: no such file or directory" in out
    assert f"{b}:1:10: error: [SGT201] unknown gesture 'wavee'" in out
    assert f"{tmp_path}: error: [SGT601] cannot read the script: it is a folder" in out
    assert out.rstrip().endswith("3 errors")
    assert cli.main(["check", str(a)]) == 0


def test_max_errors_caps_the_output_per_file_and_counts_the_rest(tmp_path, capsys):
    path = tmp_path / "many.sgt"
    path.write_text("".join(f"line {i} [pose:nope{i}]\n" for i in range(30)))
    assert cli.main(["check", "--max-errors", "4", str(path)]) == 1
    out = capsys.readouterr().out
    assert out.count("error: [SGT201]") == 4
    assert f"{path}: 26 more problems not shown (--max-errors 0 shows all)" in out
    assert out.rstrip().endswith("30 errors")  # the summary counts everything
    assert cli.main(["check", "--max-errors", "0", str(path)]) == 1
    assert capsys.readouterr().out.count("error: [SGT201]") == 30
    assert cli.main(["check", "--format", "json", "--max-errors", "5", str(path)]) == 1
    data = json.loads(capsys.readouterr().out)
    assert len(data["diagnostics"]) == 5 and data["errors"] == 30 and data["omitted"] == {str(path): 25}
    assert cli.main(["check", "--max-errors", "-1", str(path)]) == 2


def test_default_cap_keeps_a_file_of_thousands_of_errors_short(tmp_path, capsys):
    path = tmp_path / "huge.sgt"
    path.write_text("x [pose:nope]\n" * 3000)
    assert cli.main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert len(out.splitlines()) < 300 and "2950 more problems not shown" in out


def test_json_carries_code_name_related_spans_and_fixes(tmp_path, capsys):
    path = tmp_path / "s.sgt"
    path.write_text("a <speed:1>b</space> c [pose:wavee] d\n")
    for command in (["check"], ["compile", "--estimate", "-o", str(tmp_path / "p.json")]):
        assert cli.main([*command, "--format", "json", str(path)]) == 1
        data = json.loads(capsys.readouterr().out)
        by_name = {d["name"]: d for d in data["diagnostics"]}
        close = by_name["mismatched-close"]
        assert close["code"] == "SGT109" and (close["line"], close["col"]) == (1, 13)
        assert close["related"] == [{"message": "the innermost open span, <speed...>, opens here", "file": str(path),
                                     "line": 1, "col": 3, "length": 9}]
        assert [f["edits"] for f in close["fixes"]] == [[{"line": 1, "col": 13, "length": 8, "text": "</speed>"}],
                                                         [{"line": 1, "col": 13, "length": 8, "text": "</>"}]]
        gesture = by_name["unknown-gesture"]
        assert gesture["code"] == "SGT201" and gesture["suggestions"][0] == "wave"
        # the suggestions are exactly the names the hint gives, and each is a fix replacing the name
        quoted = [f"'{s}'" for s in gesture["suggestions"]]
        listed = quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]
        assert gesture["hint"] == f"did you mean {listed}?"
        assert gesture["fixes"] == [{"title": f"replace with '{s}'", "edits": [{"line": 1, "col": 30, "length": 5, "text": s}]}
                                    for s in gesture["suggestions"]]


def test_a_utf16_file_says_so_instead_of_garbage(tmp_path, capsys):
    path = tmp_path / "win.sgt"
    path.write_bytes("guide: hello [pose:wave] there\n".encode("utf-16"))
    assert cli.main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert "error: [SGT603] this file is UTF-16 (little-endian); sgt reads UTF-8" in out
    assert "malformed" not in out and out.count("error:") == 1
    path.write_bytes("guide: hello there\n".encode("utf-16-be"))  # no byte-order mark
    assert cli.main(["check", str(path)]) == 1
    assert "UTF-16 (big-endian)" in capsys.readouterr().out


def test_a_file_of_nul_bytes_is_not_ok(tmp_path, capsys):
    path = tmp_path / "nul.sgt"
    path.write_bytes(b"\0" * 2000)
    assert cli.main(["check", str(path)]) == 0  # a warning: there is nothing else wrong with it
    out = capsys.readouterr().out
    assert "warning: [SGT611] 2000 NUL characters (U+0000)" in out and ": ok" not in out


# -- the outside world, checked as the compiler uses it -----------------------------------------


def _silence(path: Path, seconds: float = 2.0) -> None:
    import numpy as np
    import soundfile as sf

    sf.write(path, np.zeros(int(16000 * seconds), np.float32), 16000)


def test_unknown_voice_is_an_error_in_check_pointing_at_the_directive_and_sgt_voices(tmp_path, capsys):
    path = tmp_path / "s.sgt"
    path.write_text("@voice en-us\n@voice bot: en-uss\nbot: hello there\n")
    assert cli.main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert f"{path}:2:13: error: [SGT211] unknown voice 'en-uss'" in out
    assert "did you mean 'en-us'" in out and "'sgt voices' lists the voices" in out
    assert "list_voices" not in out


def test_unreadable_audio_and_malformed_timings_are_errors_with_the_caret_in_place(tmp_path, capsys):
    (tmp_path / "notes.wav").write_text("not audio")
    _silence(tmp_path / "rec.wav")
    (tmp_path / "rec.json").write_text('[{"word": "hello", "start": 0.5}]')
    path = tmp_path / "s.sgt"
    path.write_text("@audio notes.wav\nhello\n@audio rec.wav timings=rec.json\nhello\n")
    assert cli.main(["check", "--format", "json", str(path)]) == 1
    data = json.loads(capsys.readouterr().out)
    got = {d["name"]: (d["line"], d["col"], d["length"], d["message"]) for d in data["diagnostics"]}
    assert got["unreadable-audio"][:3] == (1, 8, 9) and "notes.wav" in got["unreadable-audio"][3]
    assert got["bad-timings"][:3] == (3, 24, 8)  # under the timings= value, not the audio file
    assert got["bad-timings"][3] == "malformed timings file 'rec.json': entry 1 has no 'end'"


def test_timings_that_do_not_match_point_at_the_word_and_note_the_file(tmp_path, capsys):
    _silence(tmp_path / "rec.wav")
    (tmp_path / "rec.json").write_text(json.dumps([{"word": "hello", "start": 0.2, "end": 0.6},
                                                   {"word": "there", "start": 0.7, "end": 1.2}]))
    path = tmp_path / "s.sgt"
    path.write_text("@audio rec.wav timings=rec.json\nbot: Hello where.\n")
    assert cli.main(["check", "--format", "json", str(path)]) == 1
    (d,) = json.loads(capsys.readouterr().out)["diagnostics"]
    assert (d["name"], d["line"], d["col"]) == ("timings-mismatch", 2, 12)
    assert d["related"][0]["line"] == 1 and d["related"][0]["col"] == 24


def test_library_problems_carry_the_toml_place_and_the_skipped_spec_is_noted(tmp_path, capsys):
    moves = tmp_path / "moves"
    moves.mkdir()
    (moves / "broken.toml").write_text('name = "broken"\nduration = 1\n[[keyframes]]\ntime = 0\nright_elbw = [1, 0, 0]\n')
    path = tmp_path / "s.sgt"
    path.write_text("@library moves\nhello [pose:broken] there\n")
    assert cli.main(["check", "--format", "json", str(path)]) == 1
    data = json.loads(capsys.readouterr().out)
    spec = next(d for d in data["diagnostics"] if d["name"] == "bad-spec")
    assert spec["file"] == str(moves / "broken.toml") and (spec["line"], spec["col"], spec["length"]) == (5, 1, 10)
    assert spec["hint"] == "did you mean 'right_elbow'?" and spec["suggestions"] == ["right_elbow"]
    unknown = next(d for d in data["diagnostics"] if d["name"] == "unknown-gesture")
    (note,) = unknown["related"]
    assert note["file"] == str(moves / "broken.toml") and note["line"] == 5
    assert note["message"].startswith("broken.toml was skipped because it is malformed")


def test_a_missing_library_folder_names_the_folder_and_where_it_comes_from(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SGT_LIBRARY_PATH", "/nonexistent")
    path = tmp_path / "s.sgt"
    path.write_text("hello\n")
    assert cli.main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "/nonexistent: warning: [SGT502] gesture folder '/nonexistent' (from SGT_LIBRARY_PATH) does not exist" in out
    assert "skipped: :" not in out


def test_sgt_voices_lists_the_voices_check_accepts(capsys):
    assert cli.main(["voices", "en-"]) == 0
    out = capsys.readouterr().out
    assert "en-us" in out and "English (America)" in out and "matching 'en-'" in out
    assert cli.main(["voices", "--json"]) == 0
    names = [v["name"] for v in json.loads(capsys.readouterr().out)]
    from dsl.speech import list_voices

    assert names == sorted(list_voices())


def test_check_never_synthesizes_speech(tmp_path, capsys, monkeypatch):
    # `sgt check` never synthesizes: it works with the speech engine's worker broken
    from dsl.speech import _espeak

    def refuse(*a, **k):
        raise AssertionError("sgt check must not synthesize speech")

    monkeypatch.setattr(_espeak, "run_synth", refuse)
    path = tmp_path / "s.sgt"
    path.write_text("guide: [pose:wave] Hello and welcome, a sentence never spoken before 8u2x.\n")
    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    assert cli.main(["check", str(path)]) == 0
    assert os.listdir(tmp_path) == ["s.sgt"]
