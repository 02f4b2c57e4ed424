"""Error messages: every problem reported in one run, at the right place, with a fix.

The rendered messages are compared with reviewed snapshots in tests/snapshots/. After an
intended change of wording, regenerate them with SGT_UPDATE_SNAPSHOTS=1 and review the diff.
A missing snapshot is written (and the test passes) only on a developer's machine: where the
environment variable CI is set, a missing snapshot fails the test.
"""

import json
import os
from pathlib import Path

import pytest

from core.diagnostics import format_json, format_text
from dsl.parser import analyse

NAMES = ["open_arms", "point_right", "point_left", "wave", "nod", "beat_both"]
SNAPSHOTS = Path(__file__).with_name("snapshots")

CASES = {
    "unknown_names": "guide: hi [pose:point_rigth] and <hapy>smile</hapy> [paws 300ms] ok\n",
    "bad_values": "a [pose:wave x4 hold=2] <speed:7 space:fast>b</> [pause 3] [pause 20s] c\n",
    "unclosed_and_mismatched": "a [pose:wave b <speed:1> c </space> d\nsecond [pose:nod] line ] x <speed:1\n",
    "stray_and_escapes": "a ] b > c \\q d \\\n",
    "empty_utterance_pose": "guide: [pose:wave]\n",
    "directives": "@voise en-us\n@rate 9000\n@seed -1\n@preset happy = speed:1\n@preset x1 = sped:1\n@library nowhere\n@audio missing.wav\nhi\n@seed 3\n  indented continuation after a directive\n",
    "options": "a [pose:wave x2 x3 flip=1 mirror] b [pose:] c\n",
    "dangling_audio": "hello\n@audio missing.wav timings=x.txt\n",
    # carets by display width: CJK and emoji take two columns, a combining accent none
    "wide_characters": "guide: 日本語 🙂 cafe\u0301 [pose:wavee] ok\n",
    # a long line is shown as a window around the caret
    "long_line": "guide: " + "word " * 60 + "[pose:wavee] " + "more " * 60 + "\n",
    # each root cause once: crossed spans, a broken preset and its uses
    "cascades": "@preset Excited = speed:1\n@preset calm2 = sped:1\nhi <Excited>there</Excited> <calm2>now</calm2> ok\n"
                "a <speed:1><space:1>x</speed> y </space> z\n",
    "speakers": "mall guide: Hello\nJosé: hola\ng:hello\nguide: Lo[pose:nod]ok there\n",
    "hidden_characters": "guide: hel\u200blo \u202eereht\x00\x00 x\n",
    "duplicates": "@seed 1\n@seed 2\n@voice bob: en-us\n@voice bob: en-gb\n@preset p = speed:1 speed:2\n"
                  "guide: <speed:1 speed:2>a</> [pose:wave flip flip hold=1s hold=2s] b\nbob: c\n",
}


def render(name):
    src = CASES[name]
    s = analyse(src, f"{name}.sgt", gesture_names=NAMES, base_dir=Path("/nonexistent-base"))
    return s, format_text(s.diagnostics, {f"{name}.sgt": src})


def check_snapshot(snap: Path, text: str, environ=os.environ) -> None:
    """Compare ``text`` with the reviewed snapshot file; write it when asked to, or when it is
    missing on a developer's machine (never under CI, where a missing snapshot fails)."""
    if environ.get("SGT_UPDATE_SNAPSHOTS") or (not snap.exists() and not environ.get("CI")):
        snap.write_text(text + "\n", encoding="utf-8")
    if not snap.exists():
        pytest.fail(f"snapshot {snap.name} is missing: run the tests once locally (without CI set) and commit it")
    assert text + "\n" == snap.read_text(encoding="utf-8")


@pytest.mark.parametrize("name", sorted(CASES))
def test_message_snapshot(name):
    _, text = render(name)
    text = text.replace("/nonexistent-base/", "")
    check_snapshot(SNAPSHOTS / f"{name}.txt", text)


def test_a_missing_snapshot_fails_under_ci_and_is_written_locally(tmp_path):
    snap = tmp_path / "new.txt"
    with pytest.raises(pytest.fail.Exception, match="missing"):
        check_snapshot(snap, "text", environ={"CI": "true"})
    assert not snap.exists()
    check_snapshot(snap, "text", environ={})
    assert snap.read_text() == "text\n"
    with pytest.raises(AssertionError):
        check_snapshot(snap, "other", environ={"CI": "true"})


def test_every_error_in_a_file_is_reported_not_just_the_first():
    s, _ = render("unclosed_and_mismatched")
    lines = {d.line for d in s.diagnostics if d.is_error}
    assert lines == {1, 2}
    assert sum(d.is_error for d in s.diagnostics) >= 4


def test_suggestions_for_misspelt_names():
    s, _ = render("unknown_names")
    sugg = {d.name: d.suggestions for d in s.diagnostics}
    assert "point_right" in sugg["unknown-gesture"]
    assert "happy" in sugg["unknown-style"]
    assert "pause" in sugg["unknown-tag"]


def test_positions_point_at_the_offending_text():
    src = CASES["unknown_names"]
    s, _ = render("unknown_names")
    for d in s.diagnostics:
        line = src.splitlines()[d.line - 1]
        snippet = line[d.col - 1 : d.col - 1 + d.length]
        assert snippet.strip(), (d, snippet)
    g = next(d for d in s.diagnostics if d.name == "unknown-gesture")
    assert src.splitlines()[0][g.col - 1 : g.col - 1 + g.length] == "point_rigth"


def test_json_format_carries_the_same_diagnostics():
    s, _ = render("bad_values")
    data = json.loads(format_json(s.diagnostics))
    assert data["errors"] == sum(d.is_error for d in s.diagnostics)
    first = data["diagnostics"][0]
    assert {"file", "line", "col", "length", "severity", "message", "hint", "suggestions"} <= set(first)


# -- rendering: carets by display width, long lines, invisible characters -------------------


def _caret_column(rendered: str) -> int:
    """Terminal column (0-based, after the gutter) of the caret in a rendered excerpt."""
    caret_line = [line for line in rendered.splitlines() if line.strip().startswith("|") and "^" in line][0]
    return caret_line.index("^") - caret_line.index("|") - 2


@pytest.mark.parametrize("prefix, columns", [
    ("guide: ", 7), ("日本語 ", 7), ("🙂🙂 ", 5), ("cafe\u0301 ", 5), ("ｆｕｌｌ ", 9), ("a\t", 2),
])
def test_the_caret_sits_under_the_name_whatever_comes_before(prefix, columns):
    src = f"{prefix}[pose:wavee] x\n"
    s = analyse(src, "w.sgt", gesture_names=NAMES)
    (d,) = s.diagnostics
    assert d.col == len(prefix) + 7  # columns count characters
    assert _caret_column(format_text(s.diagnostics, {"w.sgt": src})) == columns + 6  # terminal columns


def test_a_long_line_is_cut_around_the_caret():
    src = "g: " + "x" * 5000 + " [pose:wavee] " + "y" * 5000 + "\n"
    s = analyse(src, "l.sgt", gesture_names=NAMES)
    text = format_text(s.diagnostics, {"l.sgt": src})
    shown = [line for line in text.splitlines() if line.startswith("     1 |")][0]
    assert len(shown) < 120 and shown.count("…") == 2 and "[pose:wavee]" in shown
    caret = _caret_column(text)
    assert shown[9 + caret : 9 + caret + 5] == "wavee"


def test_invisible_characters_are_shown_not_echoed():
    src = "g: a\u202eb\x00c [pose:wavee]\n"
    s = analyse(src, "v.sgt", gesture_names=NAMES)
    text = format_text(s.diagnostics, {"v.sgt": src})
    assert "\u202e" not in text and "\x00" not in text and "a\ufffdb\u2400c" in text
    d = next(d for d in s.diagnostics if d.name == "unknown-gesture")
    assert _caret_column(format_text([d], {"v.sgt": src})) == src.index("wavee")


def test_json_format_carries_the_same_diagnostics_as_data():
    s, _ = render("unclosed_and_mismatched")
    data = json.loads(format_json(s.diagnostics))
    assert data["errors"] == sum(d.is_error for d in s.diagnostics)
    first = data["diagnostics"][0]
    assert {"file", "line", "col", "length", "severity", "code", "name", "message", "hint", "suggestions",
            "related", "fixes"} <= set(first)
    mismatched = next(d for d in data["diagnostics"] if d["name"] == "mismatched-close")
    assert mismatched["related"][0]["line"] == 1 and mismatched["related"][0]["col"] == 16
    assert "(line" not in mismatched["message"] + mismatched["hint"]  # places are data, never text


def test_the_editor_moves_related_spans_and_fixes_with_their_chunk():
    from sgt_tui.editor.analysis import Analyser

    # the third utterance's chunk is analysed one line higher than it is (shift 1)
    text = "@preset p = speed:1\nfirst line\nmiddle line\n\nsecond <speed:1><space:1>x</speed> y [pose:wavee] z\n"
    mine = Analyser("m.sgt").run(text).diagnostics
    close = next(d for d in mine if d.name == "mismatched-close")
    assert (close.line, close.related[0].line, close.related[0].col) == (5, 5, 17)
    assert close.fixes[0].edits[0].line == 5
    gesture = next(d for d in mine if d.name == "unknown-gesture")
    assert all(e.line == 5 for f in gesture.fixes for e in f.edits) and gesture.fixes
    text2 = "@seed 1\nfirst\n\nsecond\n@seed 2\n"  # a related span in the header is not moved
    (late,) = [d for d in Analyser("m.sgt").run(text2).diagnostics if d.name == "header-only"]
    assert (late.line, late.related[0].line) == (5, 2)


def test_excerpts_split_lines_as_the_script_does():
    # a form feed or U+2028 is not a line end for the language (nor for the excerpt)
    src = "a\x0cb\u2028c\nhi [pose:wavee]\n"
    s = analyse(src, "f.sgt", gesture_names=NAMES)
    (d,) = [d for d in s.diagnostics if d.name == "unknown-gesture"]
    assert d.line == 2 and "     2 | hi [pose:wavee]" in format_text([d], {"f.sgt": src})
