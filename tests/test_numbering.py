"""Utterances count from 1 wherever a person reads their number (core/counting.py): every
``--utterance N`` of every command, the messages, ``sgt say``'s table and the speech files;
``--speaker`` with ``--utterance`` when they agree; counts with their noun ("1 utterance")."""

from __future__ import annotations

import argparse
import json

import pytest

from sgt_tui.cli import build_parser, main

SCRIPT = ("guide: Welcome to the shop. [pose:open_arms]\n"
          "robot: [pose:nod] Yes, it is open.\n"
          "guide: The shelf is [pose:point_right] over there.\n")
TEXTS = ("Welcome to the shop.", "Yes, it is open.", "The shelf is over there.")


def _utterance_options() -> dict[str, argparse.Action]:
    """Every command's ``--utterance`` ("library add": the subcommand's), found in the parser."""
    found: dict[str, argparse.Action] = {}

    def walk(parser: argparse.ArgumentParser, path: tuple[str, ...]) -> None:
        for action in parser._actions:
            if "--utterance" in action.option_strings:
                found[" ".join(path)] = action
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, path + (name,))

    walk(build_parser(), ())
    return found


def test_every_utterance_option_counts_from_1(capsys):
    found = _utterance_options()
    assert {"export", "render", "generate", "compile", "say", "align", "library add"} <= set(found)
    for command in found:
        assert main(command.split() + ["--utterance", "0"]) == 2, command
        err = capsys.readouterr().err
        assert "--utterance: 0: utterances count from 1 (the first is --utterance 1)" in err, command
        assert "0-based" not in found[command].help and "the first is 1" in found[command].help, command


@pytest.fixture(scope="module")
def motion(tmp_path_factory):
    """The three utterances above, generated (keyframe engine, estimated timing), in a file."""
    from dsl import compile_text
    from model.generate import generate

    result = compile_text(SCRIPT, timing="estimate")
    path = tmp_path_factory.mktemp("take") / "take.json"
    generate(result.plan, engine="keyframe").save(path)
    return path


def _texts(path) -> list[str]:
    return [u["text"] for u in json.loads(path.read_text())["utterances"]]


def test_utterance_n_is_the_nth_of_the_file(motion, tmp_path, capsys):
    out = tmp_path / "one.json"
    assert main(["export", str(motion), "-o", str(out), "--utterance", "2"]) == 0
    assert _texts(out) == [TEXTS[1]]
    assert f"wrote {out}: 1 utterance, 0 tracks" in capsys.readouterr().err
    assert main(["export", str(motion), "-o", str(out), "--utterance", "4"]) == 2
    assert "no utterance 4: the motion has 3 (1..3)" in capsys.readouterr().err


def test_utterance_n_of_a_script_is_its_nth_line(tmp_path, capsys):
    script = tmp_path / "shop.sgt"
    script.write_text(SCRIPT)
    out = tmp_path / "third.json"
    assert main(["generate", str(script), "-o", str(out), "--engine", "keyframe", "--utterance", "3"]) == 0
    (u,) = json.loads(out.read_text())["utterances"]
    assert u["text"] == TEXTS[2] and u["index"] == 2  # the file's index counts from 0
    assert "wrote" in capsys.readouterr().err
    assert main(["generate", str(script), "-o", str(out), "--engine", "keyframe", "--utterance", "4"]) == 2
    assert "no utterance 4: the script has 3 (1..3)" in capsys.readouterr().err
    assert main(["check", str(script)]) == 0
    assert f"{script}: ok (3 utterances)" in capsys.readouterr().out
    one = tmp_path / "one.sgt"
    one.write_text("guide: Hello.\n")
    assert main(["check", str(one)]) == 0
    assert f"{one}: ok (1 utterance)" in capsys.readouterr().out


def test_say_numbers_its_table_and_its_files_from_1(tmp_path, capsys):
    script = tmp_path / "shop.sgt"
    script.write_text(SCRIPT)
    assert main(["say", str(script), "-o", str(tmp_path / "speech"), "--utterance", "2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("[2] robot: Yes, it is open.\n") and "shop_002.wav" in out
    assert sorted(p.name for p in (tmp_path / "speech").iterdir()) == ["shop_002.wav"]


@pytest.mark.parametrize("command", ["export", "render"])
def test_speaker_with_utterance_works_when_they_agree(motion, tmp_path, capsys, command):
    out = tmp_path / ("robot.json" if command == "export" else "robot.gif")
    tail = [] if command == "export" else ["--size", "64"]
    assert main([command, str(motion), "-o", str(out), "--speaker", "robot", "--utterance", "2", *tail]) == 0
    capsys.readouterr()
    if command == "export":
        assert _texts(out) == [TEXTS[1]]
    refused = tmp_path / ("x.bvh" if command == "export" else "x.gif")
    assert main([command, str(motion), "-o", str(refused), "--speaker", "guide", "--utterance", "2"]) == 2
    err = capsys.readouterr().err
    assert err == (f"sgt {command}: error: --speaker guide and --utterance 2 disagree: utterance 2 is robot's; "
                   "drop --speaker, or give --speaker robot\n")
    assert not refused.exists()


def test_motion_file_problems_name_the_utterance_as_people_count(motion, tmp_path, capsys):
    doc = json.loads(motion.read_text())
    doc["utterances"][1] = "not an object"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    assert main(["export", str(bad), "-o", str(tmp_path / "x.bvh")]) == 1
    assert f"{bad}: utterance 2 is not an object" in capsys.readouterr().err
