"""sgt diff on real git repositories: what changed, utterance by utterance (issue 24, part 1).

Each case commits a script, changes it as an author would (a line inserted, deleted, moved,
re-timed, a voice changed, the file renamed), and runs the real command (`sgt diff ...` in a
subprocess, as a reviewer or a CI job would) or its JSON, checking what it says changed and
what it says did not.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from dsl.diff import DIFF_FORMAT, DIFF_VERSION, KINDS, diff_scripts

pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="git is not installed")

BASE = """\
@voice en-us
@voice visitor: en-gb
guide: [pose:wave] Hello, and welcome to the mall!
visitor: Where are the shoes?
guide: Look at the shelf [pose:point_right x2] <speed:-1>over there</speed>, on your right.
guide: The food court is [pose:point_up] upstairs.
visitor: [pose:nod] Thank you.
"""


def sgt(*args, cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300, check=False, env={**os.environ, **(env or {})})


def git(*args, cwd: Path) -> str:
    r = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True)
    return r.stdout


@pytest.fixture
def repo(tmp_path):
    git("init", "-q", cwd=tmp_path)
    git("config", "user.email", "t@example.com", cwd=tmp_path)
    git("config", "user.name", "t", cwd=tmp_path)
    (tmp_path / "lobby.sgt").write_text(BASE)
    git("add", ".", cwd=tmp_path)
    git("commit", "-qm", "base", cwd=tmp_path)
    return tmp_path


def json_diff(repo: Path, *args) -> dict:
    r = sgt("diff", "--format", "json", *args, cwd=repo)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["format"] == DIFF_FORMAT and doc["version"] == DIFF_VERSION == 2
    return doc


def edit(repo: Path, old: str, new: str, name: str = "lobby.sgt") -> None:
    p = repo / name
    text = p.read_text()
    assert old in text
    p.write_text(text.replace(old, new))


def statuses(script: dict) -> list[tuple[str, str]]:
    return [(u["status"], (u["new"] or u["old"])["text"]) for u in script["utterances"]]


def test_an_inserted_line_is_added_and_the_later_lines_only_retimed(repo):
    edit(repo, "visitor: Where are the shoes?\n", "visitor: Where are the shoes?\nvisitor: And the socks?\n")
    (script,) = json_diff(repo, "HEAD", "lobby.sgt")["scripts"]
    assert script["counts"] == {"changed": 0, "moved": 0, "added": 1, "removed": 0, "affected": 3, "same": 2}
    added = [u for u in script["utterances"] if u["status"] == "added"]
    assert [u["new"]["text"] for u in added] == ["And the socks?"]
    # the lines after it: the same words and gestures, played later, said once for all three
    (shift,) = script["shifts"]
    later = [u for u in script["utterances"] if u["status"] == "affected"]
    assert shift["lines"] == [u["new"]["line"] for u in later] == [6, 7, 8] and shift["to_end"]
    assert shift["seconds"] > 0 and shift["range"] == [shift["seconds"]] * 2
    for u in later:
        assert u["changes"] == [] and u["shift"] == 0 and u["header"] == []
        assert u["new"]["start"] - u["old"]["start"] == pytest.approx(shift["seconds"], abs=2e-3)


def test_a_deleted_line_is_removed_where_it_was(repo):
    edit(repo, "visitor: Where are the shoes?\n", "")
    r = sgt("diff", "HEAD", "lobby.sgt", "--color", "never", cwd=repo)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("HEAD:lobby.sgt -> lobby.sgt") and "1 removed" in lines[0]
    removed = [line for line in lines if line.startswith("- ")]
    assert removed == ['- line 4  visitor: "Where are the shoes?"']
    assert "\x1b[" not in r.stdout  # --color never


def test_a_moved_line_is_moved_not_removed_and_added(repo):
    edit(repo, "visitor: [pose:nod] Thank you.\n", "")
    edit(repo, "guide: [pose:wave] Hello", "visitor: [pose:nod] Thank you.\nguide: [pose:wave] Hello")
    (script,) = json_diff(repo, "HEAD", "lobby.sgt")["scripts"]
    moved = [u for u in script["utterances"] if u["status"] == "moved"]
    assert [u["new"]["text"] for u in moved] == ["Thank you."]
    assert moved[0]["old"]["line"] == 7 and moved[0]["new"]["line"] == 3
    assert not [u for u in script["utterances"] if u["status"] in ("added", "removed")]


def test_a_gesture_moved_to_another_word_retimed_and_played_otherwise(repo):
    edit(repo, "Look at the shelf [pose:point_right x2] <speed:-1>over there</speed>",
         "Look at the [pose:point_right x3] shelf <speed:-1>over there</speed>")
    edit(repo, "[pose:point_up] upstairs", "[pose:point_up flip] upstairs")
    (script,) = json_diff(repo, "--all", "HEAD", "lobby.sgt")["scripts"]
    by_text = {u["new"]["text"]: u for u in script["utterances"] if u["new"]}
    look = by_text["Look at the shelf over there, on your right."]["changes"]
    assert {"kind": "pose-moved", "what": "point_right", "old": "over", "new": "shelf"} in look
    assert {"kind": "pose-options", "what": "point_right", "old": "x2", "new": "x3"} in look
    up = by_text["The food court is upstairs."]["changes"]
    assert [c["kind"] for c in up] == ["pose-options"] and up[0]["new"] == "x1 flip"
    assert by_text["Hello, and welcome to the mall!"]["changes"] == []  # listed with --all only
    assert by_text["Hello, and welcome to the mall!"]["status"] == "same"


def test_a_pause_and_a_gap_retime_what_follows(repo):
    edit(repo, "guide: The food court", "@gap 2s\nguide: The food court")
    edit(repo, "Hello, and welcome", "Hello, [pause 500ms] and welcome")
    (script,) = json_diff(repo, "HEAD", "lobby.sgt")["scripts"]
    by_text = {u["new"]["text"]: u for u in script["utterances"]}
    hello = by_text["Hello, and welcome to the mall!"]["changes"]
    assert [c["kind"] for c in hello] == ["pause-added", "length"]
    court = by_text["The food court is upstairs."]
    assert [c["kind"] for c in court["changes"]] == ["gap"]
    # the pause moves the two lines after it; the longer gap moves the court's line and the last one more
    first, second = script["shifts"]
    assert first["seconds"] == pytest.approx(0.5, abs=0.07) and first["lines"] == [4, 5] and not first["to_end"]
    assert court["shift"] == 1 and second["lines"] == [7, 8] and second["to_end"]
    assert second["seconds"] == pytest.approx(0.5 + 1.5, abs=0.14)


def test_a_voice_changed(repo):
    edit(repo, "@voice visitor: en-gb", "@voice visitor: en-us")
    edit(repo, "visitor: [pose:nod] Thank you.", "visitor: [pose:nod] [pose:wave] Thank you.")
    (script,) = json_diff(repo, "HEAD", "lobby.sgt")["scripts"]
    (header,) = script["header"]
    assert header["kind"] == "voice" and header["speakers"] == ["visitor"] and header["lines"] == [4, 7]
    assert header["settings"] == [{"directive": "@voice", "old": "en-gb", "new": "en-us"}]
    assert header["old"].startswith("en-gb") and header["new"].startswith("en-us")
    # said once: each visitor line names the header change and lists only what else changed in it
    visitor = [u for u in script["utterances"] if u["header"]]
    assert [(u["new"]["line"], u["status"], [c["kind"] for c in u["changes"]]) for u in visitor] == \
        [(4, "affected", []), (7, "changed", ["pose-added", "length"])]
    assert not any(c["kind"] == "voice" for u in script["utterances"] for c in u["changes"])
    r = sgt("diff", "HEAD", "lobby.sgt", "--color", "never", cwd=repo)
    assert r.stdout.count("en-gb") == 1 and "* @voice visitor: en-gb -> en-us (2 lines)\n" in r.stdout
    assert "line 4" not in r.stdout and "~ line 7  visitor:" in r.stdout


DIALOGUE = "@voice en-us\n@voice visitor: en-gb\n@rate visitor: 160\n" + "".join(
    f"{'guide' if n % 2 == 0 else 'visitor'}: This is line number {n} of the [pose:nod] dialogue.\n" for n in range(16))


def test_a_rate_change_is_said_once_not_on_each_of_16_lines(tmp_path):
    """One @rate line changed: one line for the header change (with the lengths it changed) and
    one for the starts it moved, not a voice, a length and a start on each of 16 lines."""
    (tmp_path / "a.sgt").write_text(DIALOGUE)
    (tmp_path / "b.sgt").write_text(DIALOGUE.replace("@rate visitor: 160", "@rate visitor: 190"))
    r = sgt("diff", "a.sgt", "b.sgt", "--color", "never", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0] == "a.sgt -> b.sgt  (15 affected; 1 unchanged)"
    assert lines[1].startswith("* @rate visitor: 160 -> 190 (8 lines, ") and lines[1].endswith(" s shorter)")
    assert lines[2].startswith("* from line 6 on, every line starts earlier, by ")  # line 5 starts where it did
    assert lines[3:] == [""]  # and nothing else
    doc = json_diff(tmp_path, "a.sgt", "b.sgt")
    (script,) = doc["scripts"]
    (header,) = script["header"]
    assert header["settings"] == [{"directive": "@rate", "old": 160, "new": 190}]
    assert [x["line"] for x in header["lengths"]] == header["lines"] == list(range(5, 20, 2))
    assert all(x["new"] < x["old"] for x in header["lengths"])
    (shift,) = script["shifts"]
    assert shift["seconds"] is None and shift["lines"] == list(range(6, 20)) and shift["to_end"]
    # per utterance, a tool still finds every effect: the header change, the shift, the times
    for u in script["utterances"]:
        assert u["changes"] == [] and u["status"] == "affected"
        assert (u["header"] == [0]) == (u["new"]["speaker"] == "visitor") and (u["shift"] == 0) == (u["new"]["line"] > 5)
    starts = {x["line"]: x for x in shift["starts"]}
    for u in script["utterances"][1:]:  # all but line 5 (line 4 is the same: not listed)
        assert (starts[u["new"]["line"]]["old"], starts[u["new"]["line"]]["new"]) == (u["old"]["start"], u["new"]["start"])


def test_the_headers_gap_is_said_once_and_the_starts_it_drifts_are_one_shift(tmp_path):
    """A longer @gap in the header moves each line a little more than the one before: one
    header line, one shift with its range; --all lists the lines it applies to (mark '.')."""
    (tmp_path / "a.sgt").write_text(BASE)
    (tmp_path / "b.sgt").write_text(BASE.replace("@voice en-us\n", "@voice en-us\n@gap 0.8s\n"))
    r = sgt("diff", "a.sgt", "b.sgt", "--color", "never", cwd=tmp_path)
    lines = r.stdout.splitlines()
    assert lines[:2] == ["a.sgt -> b.sgt  (4 affected; 1 unchanged)", "* @gap: 0.5 s -> 0.8 s (the silence between lines)"]
    assert lines[2].startswith("* from line 5 on, every line starts later, by 0.") and lines[3:] == [""]
    r = sgt("diff", "a.sgt", "b.sgt", "--color", "never", "--all", cwd=tmp_path)
    assert [x[:14] for x in r.stdout.splitlines()[3:-1]] == ["* from line 5 ", ". line 4 -> 5 ", ". line 5 -> 6 ",
                                                              ". line 6 -> 7 ", ". line 7 -> 8 "]
    (script,) = json_diff(tmp_path, "a.sgt", "b.sgt")["scripts"]
    assert [(h["kind"], h["settings"], h["lines"]) for h in script["header"]] == \
        [("gap", [{"directive": "@gap", "old": 0.5, "new": 0.8}], [])]
    (shift,) = script["shifts"]
    assert shift["seconds"] is None and 0 < shift["range"][0] < shift["range"][1]


def test_a_removed_line_moves_the_later_ones_once(tmp_path):
    """The lines after a removed one are not listed: one line says they all start earlier; a
    line further on that changed in itself is listed with its own change, and where its new
    length moves the lines after it again, that is a second shift."""
    lines = DIALOGUE.splitlines(keepends=True)
    (tmp_path / "a.sgt").write_text(DIALOGUE)
    (tmp_path / "b.sgt").write_text("".join(lines[:5] + lines[6:]))  # line 6 removed
    r = sgt("diff", "a.sgt", "b.sgt", "--color", "never", cwd=tmp_path)
    out = r.stdout.splitlines()
    assert out[0] == "a.sgt -> b.sgt  (1 removed, 13 affected; 2 unchanged)"
    assert out[1].startswith("- line 6  guide:")
    (shifted,) = [x for x in out if x.startswith("* ")]
    assert shifted.startswith("* from line 6 on, every line starts ") and shifted.endswith(" s earlier")
    assert out.index(shifted) == 3 and "starts" not in r.stdout.replace(shifted, "")
    # a line further on is reworded: it keeps its text and length; the lines after it move by another amount
    text = "".join(lines[:5] + lines[6:]).replace("line number 9 of", "line number 9, the longest one, of")
    (tmp_path / "b.sgt").write_text(text)
    (script,) = json_diff(tmp_path, "a.sgt", "b.sgt")["scripts"]
    first, second = script["shifts"]
    assert first["lines"] == list(range(6, 13)) and not first["to_end"] and first["seconds"] < 0
    assert second["lines"] == list(range(13, 19)) and second["to_end"] and first["seconds"] < second["seconds"] < 0
    (reworded,) = [u for u in script["utterances"] if u["status"] == "changed"]
    assert [c["kind"] for c in reworded["changes"]] == ["text", "length"] and reworded["shift"] == 0
    r = sgt("diff", "a.sgt", "b.sgt", "--color", "never", cwd=tmp_path)
    assert [x[:22] for x in r.stdout.splitlines() if x.startswith("* ")] == ["* lines 6 to 12 start ", "* from line 13 on, eve"]


def test_options_after_double_dash_are_paths_as_in_git(repo):
    """Everything after '--' is a path (git diff's rule): an option there is a path that does
    not exist, refused in one line that says where options go; before '--' options may stand
    anywhere."""
    edit(repo, "Thank you.", "Thank you so much.")
    git("commit", "-qam", "thanks", cwd=repo)
    r = sgt("diff", "HEAD~1..HEAD", "--", "lobby.sgt", "--format", "json", cwd=repo)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == ("sgt diff: error: --format: no such file or folder in HEAD~1 or HEAD; everything after '--' "
                        "is a path: put options before '--' (sgt diff --format json A..B -- PATHS)\n")
    for args in (["--format", "json", "HEAD~1..HEAD", "--", "lobby.sgt"], ["HEAD~1..HEAD", "--format", "json", "--", "lobby.sgt"],
                 ["HEAD~1..HEAD", "--", "lobby.sgt"]):
        r = sgt("diff", *args, cwd=repo)
        assert r.returncode == 0, (args, r.stderr)
        if "json" in args:
            assert json.loads(r.stdout)["scripts"][0]["new"] == "HEAD:lobby.sgt"
        else:
            assert r.stdout.startswith("HEAD~1:lobby.sgt -> HEAD:lobby.sgt  (1 changed; 4 unchanged)")
    r = sgt("diff", "HEAD", "nope.sgt", cwd=repo)
    assert (r.returncode, r.stderr) == (2, "sgt diff: error: nope.sgt: no such file or folder in HEAD or the working tree\n")
    # a path that only one version has is a path: a deleted script is compared (all removed)
    git("rm", "-q", "lobby.sgt", cwd=repo)
    git("commit", "-qm", "gone", cwd=repo)
    (script,) = json_diff(repo, "HEAD~1..HEAD", "--", "lobby.sgt")["scripts"]
    assert script["counts"]["removed"] == 5


def test_a_renamed_file_between_two_revisions_is_followed(repo):
    git("mv", "lobby.sgt", "hall.sgt", cwd=repo)
    edit(repo, "Thank you.", "Thank you so much.", name="hall.sgt")
    (repo / "other.txt").write_text("not a script")
    git("add", ".", cwd=repo)
    git("commit", "-qm", "rename", cwd=repo)
    doc = json_diff(repo, "HEAD~1..HEAD")
    (script,) = doc["scripts"]
    assert script["old"] == "HEAD~1:lobby.sgt" and script["new"] == "HEAD:hall.sgt"
    (changed,) = [u for u in script["utterances"] if u["status"] == "changed"]
    assert changed["changes"][0] == {"kind": "text", "what": "text", "old": "Thank you.", "new": "Thank you so much."}
    # limited to paths: none of them changed
    assert json_diff(repo, "HEAD~1..HEAD", "--", "other.txt")["scripts"] == []


def test_two_files_two_folders_and_gits_external_diff(repo, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "lobby.sgt").write_text(BASE)
    (b / "lobby.sgt").write_text(BASE.replace("[pose:wave] ", ""))
    (b / "new.sgt").write_text("guide: A new scene.\n")
    doc = json_diff(repo, str(a / "lobby.sgt"), str(b / "lobby.sgt"))
    u = doc["scripts"][0]["utterances"][0]
    assert u["changes"][0] == {"kind": "pose-removed", "what": "wave", "old": "Hello", "new": None}
    # without the wave's preparation before the first word, every line plays earlier
    assert all(c["kind"] == "retimed" and c["new"] < c["old"] for u in doc["scripts"][0]["utterances"][1:]
               for c in u["changes"])
    doc = json_diff(repo, str(a), str(b))
    assert [(s["old"].endswith("lobby.sgt"), s["counts"]["added"]) for s in doc["scripts"]] == [(True, 0), (False, 1)]
    # git diff with sgt as its external diff driver (git passes seven arguments)
    edit(repo, "Where are the shoes?", "Where are the red shoes?")
    driver = f"{sys.executable} -m sgt_tui.cli diff --color never"
    r = subprocess.run(["git", "diff"], cwd=repo, capture_output=True, text=True, check=False,
                       env={**os.environ, "GIT_EXTERNAL_DIFF": driver})
    assert r.returncode == 0, r.stderr
    assert "a/lobby.sgt -> b/lobby.sgt" in r.stdout
    assert 'text: "Where are the shoes?" -> "Where are the red shoes?"' in r.stdout


def test_exit_code_bad_arguments_and_a_version_with_errors(repo):
    assert sgt("diff", "HEAD", "lobby.sgt", "--exit-code", cwd=repo).returncode == 0  # nothing changed
    edit(repo, "Thank you.", "Thanks.")
    assert sgt("diff", "HEAD", "lobby.sgt", "--exit-code", cwd=repo).returncode == 1
    r = sgt("diff", "nope", "lobby.sgt", cwd=repo)
    assert r.returncode == 2 and "not a git revision" in r.stderr and "Traceback" not in r.stderr
    r = sgt("diff", "HEAD..nope", cwd=repo)
    assert r.returncode == 2 and "nope: not a git revision" in r.stderr
    edit(repo, "[pose:nod]", "[pose:nodd]")  # an error: still compared, timing left out
    (script,) = json_diff(repo, "HEAD", "lobby.sgt")["scripts"]
    assert script["problems"] and "unknown gesture" in script["problems"][0]
    assert not any(c["kind"] == "retimed" for u in script["utterances"] for c in u["changes"])


def test_render_writes_a_before_and_after_of_each_changed_utterance(repo):
    from PIL import Image

    edit(repo, "Look at the shelf [pose:point_right x2] <speed:-1>over there</speed>",
         "Look at the [pose:point_right x2] shelf <speed:-1>over there</speed>")
    edit(repo, "visitor: Where are the shoes?\n", "visitor: Where are the shoes, please?\n")
    r = sgt("diff", "HEAD", "lobby.sgt", "--render", "out", "--engine", "keyframe", "--size", "64x64", cwd=repo)
    assert r.returncode == 0, r.stderr
    made = sorted(p.name for p in (repo / "out").iterdir())
    assert made == ["lobby_line0004.gif", "lobby_line0005.gif"]  # not the lines only retimed
    im = Image.open(repo / "out" / "lobby_line0005.gif")
    assert im.size == (128, 64)  # old and new side by side


def test_the_engine_matches_by_content():
    """Without git: an utterance reworded is "changed" with its text, one with other words
    entirely is removed and added, and every kind of change is one of KINDS."""
    d = diff_scripts("a: one two three four.\na: alpha beta.\n", "a: one two three five.\na: gamma delta.\n",
                     timing="estimate")
    got = [(u.status, [c.kind for c in u.changes]) for u in d.utterances]
    assert ("changed", ["text"]) in got
    assert sorted(s for s, _ in got) == ["added", "changed", "removed"]
    assert all(c.kind in KINDS for u in d.utterances for c in u.changes)
