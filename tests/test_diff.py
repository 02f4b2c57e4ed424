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

from dsl.diff import DIFF_FORMAT, KINDS, diff_scripts

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
    assert doc["format"] == DIFF_FORMAT and doc["version"] == 1
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
    assert script["counts"] == {"changed": 3, "moved": 0, "added": 1, "removed": 0, "same": 2}
    added = [u for u in script["utterances"] if u["status"] == "added"]
    assert [u["new"]["text"] for u in added] == ["And the socks?"]
    for u in script["utterances"]:
        if u["status"] == "changed":  # the lines after it: the same words and gestures, played later
            assert [c["kind"] for c in u["changes"]] == ["retimed"]
            assert u["changes"][0]["new"] > u["changes"][0]["old"]


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
    court = by_text["The food court is upstairs."]["changes"]
    kinds = [c["kind"] for c in court]
    assert kinds == ["gap", "retimed"]
    retimed = court[1]
    assert retimed["new"] - retimed["old"] == pytest.approx(0.5 + 1.5, abs=0.14)  # the pause, then the longer gap


def test_a_voice_changed(repo):
    edit(repo, "@voice visitor: en-gb", "@voice visitor: en-us")
    (script,) = json_diff(repo, "HEAD", "lobby.sgt")["scripts"]
    voiced = [u for u in script["utterances"] if any(c["kind"] == "voice" for c in u["changes"])]
    assert {u["new"]["speaker"] for u in voiced} == {"visitor"} and len(voiced) == 2
    change = next(c for c in voiced[0]["changes"] if c["kind"] == "voice")
    assert change["old"].startswith("en-gb") and change["new"].startswith("en-us")


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
