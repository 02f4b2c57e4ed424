"""Issue 22, part 5: slips that used to pass in silence are reported, each with its fix.

A per-speaker directive naming no speaker (SGT212), speaker names that differ only in case
(SGT213), an utterance with no words (SGT311), ``hold 300ms`` (SGT312: one error, not two),
an unknown voice variant (SGT211 with a did-you-mean). The checks of the whole script's
speakers give the same result in the editor, which analyses a script in chunks.
"""

from __future__ import annotations

import json

from dsl.compiler import compile_text
from sgt_tui import cli
from sgt_tui.editor.analysis import Analyser
from tests.test_rules import apply_fix

SLIPS = """@voice knigth: en-gb
knight: Halt.
Knight: Who goes?
merchant:
knight: [pose:nod hold 300ms] Yes.
"""


def _diags(text: str, path: str = "s.sgt"):
    return compile_text(text, path, timing="estimate").diagnostics


def _codes(text: str) -> list[tuple[str, int, int]]:
    return [(d.code, d.line, d.col) for d in _diags(text)]


def test_the_issues_script_reports_every_slip_with_its_fix(tmp_path, capsys):
    script = tmp_path / "slips.sgt"
    script.write_text(SLIPS)
    assert cli.main(["check", "--format", "json", str(script)]) == 1  # the hold is an error
    found = {d["code"]: d for d in json.loads(capsys.readouterr().out)["diagnostics"]}
    assert sorted(found) == ["SGT212", "SGT213", "SGT311", "SGT312"]

    voice = found["SGT212"]
    assert (voice["severity"], voice["line"], voice["col"], voice["length"]) == ("warning", 1, 8, 6)
    assert voice["message"] == "'@voice' is for speaker 'knigth', but no line has that speaker: it applies to nothing"
    assert voice["hint"] == "did you mean 'knight'?"  # not 'Knight': that spelling is warned about
    assert [f["edits"] for f in voice["fixes"]] == [[{"line": 1, "col": 8, "length": 6, "text": "knight"}]]
    assert [(r["line"], r["col"]) for r in voice["related"]] == [(2, 1)]

    case = found["SGT213"]
    assert (case["severity"], case["line"], case["col"]) == ("warning", 3, 1)
    assert case["message"] == "speaker 'Knight' differs from 'knight' only in case: they are two speakers"
    assert [(r["line"], r["col"], r["length"]) for r in case["related"]] == [(2, 1, 6)]
    assert [f["edits"] for f in case["fixes"]] == [[{"line": 3, "col": 1, "length": 6, "text": "knight"}]]

    silent = found["SGT311"]
    assert (silent["severity"], silent["line"]) == ("warning", 4)
    assert silent["fixes"] == [{"title": "remove the line", "edits": [{"line": 4, "col": 1, "length": 9, "text": ""}]}]

    hold = found["SGT312"]
    assert (hold["severity"], hold["line"], hold["col"], hold["length"]) == ("error", 5, 19, 10)
    assert hold["message"] == "'hold 300ms' needs '=' between the option and its duration"
    assert hold["fixes"] == [{"title": "write hold=300ms", "edits": [{"line": 5, "col": 19, "length": 10, "text": "hold=300ms"}]}]

    # compile says the same; with every fix applied the script is clean
    assert cli.main(["compile", "--format", "json", str(script), "-o", str(tmp_path / "p.json")]) == 1
    assert sorted(d["code"] for d in json.loads(capsys.readouterr().out)["diagnostics"]) == sorted(found)
    text = SLIPS
    for d in sorted(_diags(text), key=lambda d: (d.line, d.col), reverse=True):
        text = apply_fix(text, d.fixes[0])
    assert _diags(text) == [] and "knight: [pose:nod hold=300ms] Yes." in text
    assert [u.speaker for u in compile_text(text, timing="estimate").script.utterances] == ["knight"] * 3


def test_every_per_speaker_directive_is_checked_against_the_lines():
    text = "@rate Knight: 200\n@pitch bob: 40\n@voice knight: en-gb\nknight: hi\n"
    d = {x.line: x for x in _diags(text)}
    assert sorted(d) == [1, 2] and {x.code for x in d.values()} == {"SGT212"}
    assert d[1].message.startswith("'@rate' is for speaker 'Knight'")
    assert d[1].hint == "did you mean 'knight'? (speaker names are case-sensitive)" and d[1].suggestions == ("knight",)
    assert d[2].message.startswith("'@pitch' is for speaker 'bob'") and d[2].fixes == ()
    assert d[2].hint == "start the lines of 'bob' with 'bob: ', or name a speaker the script has"
    # a header with no line yet is not checked; a name the lines use is fine; quotes are skipped
    assert _diags("@voice bob: en-gb\n") == []
    assert _codes('@voice "bob": en-gb\nbob: hi\n') == []
    assert [(x.col, x.length) for x in _diags('@voice "bbo": en-gb\nbob: hi\n')] == [(9, 3)]


def test_a_spelling_that_differs_in_case_is_warned_once_and_fixed_on_all_its_lines():
    text = "knight: a\nKnight: b\nmerchant: c\nKnight: d\nKNIGHT: e\n"
    d = [x for x in _diags(text) if x.code == "SGT213"]
    assert [(x.line, x.message) for x in d] == [
        (2, "speaker 'Knight' differs from 'knight' only in case: they are two speakers"),
        (5, "speaker 'KNIGHT' differs from 'knight' only in case: they are two speakers")]
    assert d[0].fixes[0].title == "write 'knight' on its 2 lines" and [e.line for e in d[0].fixes[0].edits] == [2, 4]
    fixed = apply_fix(apply_fix(text, d[1].fixes[0]), d[0].fixes[0])
    assert _diags(fixed) == [] and fixed.count("knight:") == 4


def test_an_utterance_without_words_is_a_warning_that_says_what_it_does():
    # it compiles (as it always did): a short silent line that the next one waits for
    result = compile_text("knight: Halt.\nmerchant:\nknight: Yes.\n", timing="estimate")
    assert result.ok and [len(u.words) for u in result.plan.utterances] == [1, 0, 1]
    assert [d.code for d in result.diagnostics] == ["SGT311"]
    assert result.diagnostics[0].message == "this utterance has no words: it plays as a silent line that delays the next one"
    assert result.diagnostics[0].hint == "remove the line, or write what 'merchant' says"
    # only marks: pauses, style tags (the empty span is the same root cause: not reported again)
    assert _codes("merchant: [pause 1s]\n") == [("SGT311", 1, 1)]
    assert _codes("merchant: <calm>...</calm>\n") == [("SGT311", 1, 1)]
    assert _diags("... !\n")[0].hint == "remove the line, or write what it says"
    # a pose control there is the error it was (empty-utterance); an error on the line says enough
    assert _codes("merchant: [pose:wave]\n") == [("SGT308", 1, 11)]
    assert [c for c, _, _ in _codes("merchant: [pose:wave\n")] == ["SGT104"]
    # continuation lines are removed with it; what is left is blank (and a comment stays)
    text = "knight: Halt.\nmerchant: [pause 1s]  # later\n    [pause 2s]\nknight: Yes.\n"
    (d,) = _diags(text)
    fixed = apply_fix(text, d.fixes[0])
    assert fixed == "knight: Halt.\n  # later\n    \nknight: Yes.\n" and _diags(fixed) == []


def test_hold_without_its_equals_sign_is_one_error_with_its_fix():
    assert _codes("guide: [pose:nod hold=300ms] Yes.\n") == []
    (d,) = _diags("guide: [pose:nod hold 300ms] Yes.\n")
    assert (d.code, d.name, d.severity, d.hint) == ("SGT312", "hold-form", "error", "write hold=300ms")
    (d,) = _diags("guide: [pose:nod hold 2] Yes.\n")  # no unit: both readings
    assert [f.edits[0].text for f in d.fixes] == ["hold=2ms", "hold=2s"] and d.hint == "write hold=2ms or hold=2s"
    # the other options around it are still read; a hold given twice is still a duplicate
    assert [c for c, _, _ in _codes("guide: [pose:nod x2 hold 1s flip] Yes.\n")] == ["SGT312"]
    assert sorted(c for c, _, _ in _codes("guide: [pose:nod hold=1s hold 2s] Yes.\n")) == ["SGT210", "SGT312"]
    # 'hold' with no duration after it is the error it was
    assert [c for c, _, _ in _codes("guide: [pose:nod hold] Yes.\n")] == ["SGT303"]


def test_an_unknown_voice_variant_offers_the_close_ones():
    (d,) = _diags("@voice x: en-us+klat\nx: hello\n")
    assert (d.code, d.message) == ("SGT211", "unknown voice variant 'en-us+klat'")
    assert "en-us+klatt" in d.suggestions and "'sgt voices --variants'" in d.hint
    assert d.fixes[0].edits[0].text.startswith("en-us+klatt")
    (d,) = _diags("@voice x: en-us+zz9\nx: hello\n")  # nothing close: the hint names the list
    assert d.fixes == () and d.hint == "'sgt voices --variants' lists the variants"


def test_the_editor_reports_the_whole_scripts_speakers_as_check_does():
    """The editor analyses a script in chunks (header + one utterance each): what depends on
    every line is computed on the whole text, so it equals the whole-file analysis."""
    texts = [
        SLIPS.replace(" hold 300ms", ""),
        "@voice knigth: en-gb\n@rate merchant: 200\nknight: Halt.\nmerchant: hi\nKnight: Who goes?\n",
        "@voice guide: en-gb\nhello there\nguide: hi\n",  # the speaker only after the first chunk
        "knight: a\nmerchant:\nKnight: b\n@gap -300ms\nknight: c\nKNIGHT: d\n",
        "guide: hello there, my friends\n@gap -300ms\nthe line without a speaker\n",  # the stand-in has none either
        "knight: Halt, who goes there?\n@gap -400ms\nknight: Answer me.\nmerchant: Yes.\n@gap -5s\nknight: Good.\n",
    ]
    for text in texts:
        mine = Analyser("t.sgt").run(text).diagnostics
        full = compile_text(text, "t.sgt", timing="estimate").diagnostics
        assert sorted(map(repr, mine)) == sorted(map(repr, full)), text
    assert [d.code for d in mine] == ["SGT409", "SGT410"]  # the interruptions, from the plans laid out together


def test_a_speaker_colon_right_before_a_mark_is_the_same_slip():
    """`guide:[pose:nod] Yes.` has no speaker and says "guide": SGT116, as `guide:hello`, with
    its fixes (make 'guide' the speaker, or speak the colon), in check and in the editor."""
    text = "guide:[pose:nod] Yes.\nguide:<happy>Good.</happy>\nguide\\:[pose:nod] Said.\n"
    first, second = _diags(text)
    assert (first.code, first.line, first.col, first.length) == ("SGT116", 1, 1, len("guide:[pose:nod]"))
    assert first.message == "'guide:[pose:nod]' looks like a speaker without a space after the colon: it is spoken as text"
    assert first.hint == "write 'guide: [pose:nod]' for a speaker, or 'guide\\:[pose:nod]' to speak it"
    assert (second.code, second.line) == ("SGT116", 2)  # a style tag too; the escaped colon is meant
    spoken = compile_text(text, "s.sgt", timing="estimate").script.utterances[0]
    assert spoken.speaker is None and [w.text for w in spoken.words] == ["guide", "Yes"]
    made = compile_text(apply_fix(text, first.fixes[0]), "s.sgt", timing="estimate")
    assert made.script.utterances[0].speaker == "guide" and [w.text for w in made.script.utterances[0].words] == ["Yes"]
    assert "SGT116" not in [(d.code, d.line) for d in made.diagnostics if d.line == 1]
    assert apply_fix(text, first.fixes[1]).startswith("guide\\:[pose:nod] Yes.")
    assert Analyser("s.sgt").run(text).diagnostics == _diags(text)


def test_say_prints_a_line_without_a_speaker_with_every_word_it_speaks(tmp_path, capsys, monkeypatch):
    """`sgt say` shows who speaks each line and what it says: a line without a speaker that
    starts with a name says so, never reading as that speaker's line."""
    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    script = tmp_path / "slip.sgt"
    script.write_text("guide:[pose:nod] Yes.\nguide: Fine.\n")
    assert cli.main(["say", str(script), "-o", str(tmp_path / "wav")]) == 0
    out, err = capsys.readouterr()
    assert "[1] (no speaker) guide: Yes.\n" in out and "[2] guide: Fine.\n" in out
    assert [line.split()[0] for line in out.split("[2]")[0].splitlines()[3:] if line.strip()] == ["guide", "Yes"]
    assert "SGT116" in err
