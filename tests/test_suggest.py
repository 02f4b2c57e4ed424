"""Gestures chosen from the words (issue 26, part 2): `sgt suggest`, `--auto-gestures`, the
editor's f6, and the table in library/words.toml that the rules engine shares."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from suggest_eval import evaluate, read_labels, report

from dsl.parser import analyse
from dsl.suggest import SPACING, WORDS_PER_MARK, apply_suggestions, suggest
from library import load_library
from library.words import WordRulesError, load_word_rules
from sgt_tui.cli import main

SCRIPT = """\
@seed 3
guide: Hello, and welcome! Today we cover one, two and three topics.
guide: Look over there, on your right. [pose:nod] The shoes are upstairs, not here.
visitor: What do you think? I have no idea, but it is huge.
"""


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


def test_on_the_labelled_sentences_most_calls_get_an_acceptable_gesture_and_few_a_wrong_one():
    """tests/data/suggest_labels.txt: at least 200 sentences; at least 80 % of the words that call
    for a gesture get an acceptable one, fewer than 10 % a wrong one, and fewer than 10 % of the
    suggestions land on words that call for none."""
    c = evaluate()
    print(report(c))
    assert c["sentences"] >= 200 and c["calls"] >= 200
    assert c["hit"] / c["calls"] >= 0.80, report(c)
    assert c["wrong"] / c["calls"] < 0.10, report(c)
    assert c["spurious"] / c["suggestions"] < 0.10, report(c)


def test_the_scoring_counts_a_wrong_gesture_and_a_spurious_one():
    """The scorer itself: a label that accepts another gesture is a wrong one, a sentence with no
    label makes any suggestion spurious."""
    labels = [("Turn left at the end of the hall.", [[("left", 1, {"point_right"})]]),
              ("Hello, and welcome to the mall!", [])]
    c = evaluate(labels)
    assert (c["hit"], c["wrong"], c["spurious"]) == (0, 1, 1)
    assert len(read_labels()) >= 200


def test_suggestions_leave_everything_else_and_keep_their_distances(lib):
    rules = load_word_rules()
    script = analyse(SCRIPT, "s.sgt")
    found = suggest(script, lib, rules)
    text = apply_suggestions(SCRIPT, found)
    assert re.sub(r"\[pose:(?!nod\])\w+\] ", "", text) == SCRIPT  # nothing but the inserted marks
    assert {(s.word, s.gesture) for s in found} >= {("Hello", "wave"), ("one", "count_one"), ("upstairs", "point_up"),
                                                    ("What", "what"), ("idea", "shrug"), ("huge", "big")}
    again = analyse(text, "s.sgt")
    for u in again.utterances:
        marked = [m.word_index for m in u.poses]
        assert len(marked) <= max(1, len(u.words) // WORDS_PER_MARK) + sum(  # counting lists count on
            1 for m in u.poses if m.name.startswith("count_")), (u.display, marked)
        names = {m.word_index: m.name for m in u.poses}
        for a in marked:
            for b in marked:
                close = a != b and abs(a - b) < SPACING
                assert not close or (names[a].startswith("count_") and names[b].startswith("count_")), (u.display, names)
    # the author's nod: nothing within two words of it ("right" is one word before it)
    assert not any(s.word == "right" for s in found)
    assert not suggest(analyse(text, "s.sgt"), lib, rules)  # nothing more to add: it converges


def test_context_decides(lib):
    rules = load_word_rules()

    def got(text):
        return [(s.word.lower(), s.gesture) for s in suggest(analyse(f"a: {text}\n", "x.sgt"), lib, rules)]

    assert ("left", "point_left") in got("Turn left at the end of the hall.")
    assert not any(w == "left" for w, _ in got("I left my umbrella at home."))
    assert not any(w == "there" for w, _ in got("There is a problem with the printer."))
    assert ("where", "what") in got("Where is the train station?")
    assert not any(w == "where" for w, _ in got("I know where the station is."))  # no question
    assert ("right", "point_right") in got("The food court is on your right.")
    assert not any(w == "right" for w, _ in got("That's right, well done."))


def test_sgt_suggest_writes_the_script_or_the_json_and_never_over_its_input(tmp_path, capsys):
    src = tmp_path / "lobby.sgt"
    src.write_text(SCRIPT)
    out = tmp_path / "lobby.suggested.sgt"
    assert main(["suggest", str(src), "-o", str(out)]) == 0
    assert "gestures suggested on 3 lines" in capsys.readouterr().err
    text = out.read_text()
    assert "[pose:wave] Hello" in text and "[pose:count_two] two" in text and src.read_text() == SCRIPT
    assert main(["check", str(out)]) == 0  # what it writes compiles
    capsys.readouterr()
    assert main(["suggest", str(src), "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    first = doc["suggestions"][0]
    assert first == {"utterance": 0, "line": 2, "col": 8, "gesture": "wave", "word": "Hello", "kind": "greeting",
                     "sense": "'hello' as an interjection", "via": "'hello' in the built-in table (greeting)"}
    assert main(["suggest", str(src), "-o", str(src)]) == 2  # the input is never the output
    assert src.read_text() == SCRIPT
    bad = tmp_path / "bad.sgt"
    bad.write_text("guide: [pose:wavee] hi\n")
    assert main(["suggest", str(bad)]) == 1
    assert "unknown gesture" in capsys.readouterr().err


def test_generate_and_build_with_auto_gestures(tmp_path, capsys):
    from core.motion import load_motion_file

    src = tmp_path / "src"
    src.mkdir()
    (src / "lobby.sgt").write_text(SCRIPT)
    assert main(["generate", str(src / "lobby.sgt"), "-o", str(tmp_path / "take.json"), "--engine", "keyframe",
                 "--auto-gestures"]) == 0
    assert "gestures chosen from the words" in capsys.readouterr().err
    take = load_motion_file(tmp_path / "take.json")
    names = [c.name for clip in take.clips for c in clip.controls if c.kind == "pose"]
    assert "wave" in names and "count_three" in names and names.count("nod") == 1
    assert main(["build", str(src), "-o", str(tmp_path / "out"), "--engine", "keyframe", "--auto-gestures", "-q",
                 "--cache", str(tmp_path / "cache")]) == 0
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["settings"]["auto_gestures"] is True
    built = load_motion_file(tmp_path / "out" / "lobby.json")
    assert [c.name for clip in built.clips for c in clip.controls if c.kind == "pose"] == names


def test_a_users_words_table_extends_and_replaces_and_is_checked(tmp_path, lib):
    folder = tmp_path / "gestures"
    folder.mkdir()
    (folder / "words.toml").write_text('[[words]]\nwords = "hello hi"\ngestures = ["bow"]\nkind = "greeting"\n'
                                       '[[words]]\nwords = "bazinga"\ngestures = ["celebrate"]\nkind = "celebration"\n')
    rules = load_word_rules([folder])
    got = [(s.word, s.gesture) for s in suggest(analyse("a: Hello there, bazinga!\n", "x.sgt"), lib, rules)]
    assert ("Hello", "bow") in got
    assert load_library([folder]).problems == []  # words.toml is not a gesture spec
    assert ("Bazinga", "celebrate") in [(s.word, s.gesture) for s in suggest(analyse("a: Bazinga, that was it.\n", "x.sgt"), lib, rules)]
    (folder / "words.toml").write_text('[[words]]\nwords = "hi"\ngestures = ["bow"]\nsugest = "bow"\n')
    with pytest.raises(WordRulesError, match=r"words.toml: \[\[words\]\] entry 1: unknown key sugest"):
        load_word_rules([folder])


def test_the_rules_engine_reads_the_same_table():
    from model.teacher import TRIGGERS

    rules = load_word_rules()
    assert TRIGGERS == rules.triggers()
    assert TRIGGERS["here"] == ("point_down", "point_front") and "upstairs" not in TRIGGERS  # suggestions only
    lib = load_library(use_config=False)
    assert all(g in lib for gestures in TRIGGERS.values() for g in gestures)
    assert all(r.suggest in lib for r in rules.rules if r.suggest is not None)


def test_the_editor_suggests_for_the_utterance_at_the_cursor(tmp_path):
    from sgt_tui.editor.analysis import Analyser
    from sgt_tui.editor.document import Document
    from sgt_tui.editor.edits import EditRefused, suggest_gestures

    doc = Document(SCRIPT)
    a = Analyser(tmp_path / "s.sgt").run(doc.text)
    action = suggest_gestures(doc, a.utterance_at(4), a.library, load_word_rules())
    assert action.message.startswith("3 gestures suggested: what on 'What', shrug on 'idea', big on 'huge'")
    assert {r.start[0] for r in action.replacements} == {3}  # only the utterance at the cursor (line 4)
    assert {r.text for r in action.replacements} == {"[pose:what] ", "[pose:shrug] ", "[pose:big] "}
    with pytest.raises(EditRefused):
        suggest_gestures(doc, None, a.library, load_word_rules())


def test_suggest_help_runs():
    r = subprocess.run([sys.executable, "-m", "sgt_tui.cli", "suggest", "--help"], capture_output=True, text=True,
                       cwd=Path(__file__).resolve().parent.parent, check=False)
    assert r.returncode == 0 and "At most one mark per three words" in r.stdout
