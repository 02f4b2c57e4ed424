"""One way from a script to motion (model.generate.generate), from a file, a string or a plan.

The commands (`sgt generate`, `sgt render`/`sgt export` of a script) and the editor's worker
all go through it: the same script gives them the same motion and the same errors.
"""

from __future__ import annotations

import tempfile

import numpy as np
import pytest

from core.motion import load_motion
from dsl import compile_file, compile_text
from library import load_library
from model.generate import GenerateError, NoSuchUtterance, generate, generate_clips
from sgt_tui.cli import main

TEXT = "guide: Hello [pose:wave] there, <speed:-1>slowly</speed>.\nguide: And once more.\n"
BAD = "guide: Hello [pose:point_rigth] there.\n"


@pytest.fixture
def no_temp_files(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("a temporary file was made")

    for name in ("mkstemp", "mkdtemp", "NamedTemporaryFile", "TemporaryFile", "TemporaryDirectory"):
        monkeypatch.setattr(tempfile, name, refuse)


def test_compile_text_is_compile_file_without_the_file(tmp_path):
    path = tmp_path / "lobby.sgt"
    path.write_text(TEXT)
    from_file = compile_file(path, timing="estimate").plan.to_dict()
    from_text = compile_text(TEXT, path=path, timing="estimate").plan.to_dict()
    assert from_text == from_file
    default = compile_text(TEXT, timing="estimate").plan
    assert default.source == "<text>" and default.to_dict()["utterances"] == from_file["utterances"]


def test_generate_from_text_and_from_a_plan_with_no_files(tmp_path, monkeypatch, no_temp_files):
    path = tmp_path / "lobby.sgt"
    path.write_text(TEXT)
    from_file = generate(path, engine="rules", seed=4, timing="estimate")
    monkeypatch.chdir(tmp_path)
    from_text = generate(source=TEXT, engine="rules", seed=4, timing="estimate")
    plan = compile_text(TEXT, timing="estimate").plan
    from_plan = generate(plan, engine="rules", seed=4)
    for take in (from_text, from_plan):
        assert len(take.clips) == 2
        for a, b in zip(take.clips, from_file.clips):
            np.testing.assert_array_equal(a.poses, b.poses)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lobby.sgt"]  # nothing written
    assert from_text.utterances == [0, 1] and from_text.timing == "estimate"
    one = generate(plan, engine="rules", seed=4, utterances=[1], perform=False)  # the engine's clip: its own
    assert one.utterances == [1]
    np.testing.assert_array_equal(one.clips[0].poses, generate(plan, engine="rules", seed=4, perform=False).clips[1].poses)
    assert [c.poses.shape for c in generate_clips(source=TEXT, engine="keyframe", timing="estimate")] == \
        [c.poses.shape for c in from_file.clips]


def test_text_with_a_path_resolves_files_against_its_folder(tmp_path, monkeypatch):
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    (tmp_path / "gestures").mkdir()
    wave = load_library(use_config=False).get("wave").path.read_text()
    (tmp_path / "gestures" / "mine.toml").write_text(wave.replace('name = "wave"', 'name = "mine"'))
    text = "@library gestures\nguide: Hello [pose:mine] there.\n"
    take = generate(source=text, engine="keyframe", timing="estimate", script=tmp_path / "new.sgt")
    assert [c.name for c in take.plan.utterances[0].controls] == ["mine"]
    assert not (tmp_path / "new.sgt").exists()
    with pytest.raises(GenerateError, match="gesture folder 'gestures' does not exist"):
        generate(source=text, engine="keyframe", timing="estimate")  # the current folder has no gestures/


def test_errors_and_unknown_utterances(tmp_path):
    with pytest.raises(GenerateError) as e:
        generate(source=BAD, engine="keyframe", timing="estimate")
    assert "<text> has 1 error (line 1: unknown gesture 'point_rigth')" in str(e.value)
    assert e.value.diagnostics[0].line == 1 and e.value.source == BAD
    with pytest.raises(NoSuchUtterance, match="no utterance 7: the script has 2"):
        generate(source=TEXT, engine="keyframe", timing="estimate", utterances=[0, 7])
    plan = compile_text(TEXT, timing="estimate").plan
    with pytest.raises(NoSuchUtterance):
        generate(plan, engine="keyframe", utterances=[5])
    with pytest.raises(GenerateError, match="seed -1 is out of range"):
        generate(plan, engine="rules", seed=-1)
    with pytest.raises(GenerateError, match="unknown engine"):
        generate(plan, engine="nope")


def test_commands_and_the_editor_worker_make_the_same_motion_and_errors(tmp_path, capsys):
    from sgt_tui.editor.worker import _clips

    path = tmp_path / "lobby.sgt"
    path.write_text(TEXT)
    assert main(["generate", str(path), "-o", str(tmp_path / "g.json"), "--engine", "rules", "--seed", "4"]) == 0
    assert main(["export", str(path), "-o", str(tmp_path / "e.json"), "--engine", "rules", "--seed", "4"]) == 0
    clips, indices, timing, _ = _clips({"id": "1", "path": str(path), "source": TEXT, "engine": "rules", "seed": 4},
                                    lambda event: None)
    by_generate, by_export = load_motion(tmp_path / "g.json"), load_motion(tmp_path / "e.json")
    assert indices == [0, 1] and timing == "espeak-ng"
    for a, b, c in zip(by_generate, by_export, clips):
        np.testing.assert_allclose(a.poses, c.poses, atol=1e-5)
        np.testing.assert_array_equal(a.poses, b.poses)
    capsys.readouterr()

    path.write_text(BAD)
    errors = []
    for argv in (["generate", str(path), "-o", str(tmp_path / "x.json"), "--engine", "keyframe"],
                 ["export", str(path), "-o", str(tmp_path / "x.bvh"), "--engine", "keyframe"],
                 ["render", str(path), "-o", str(tmp_path / "x.gif"), "--engine", "keyframe"]):
        assert main(argv) == 1
        errors.append(capsys.readouterr().err)
    assert errors[0] == errors[1] == errors[2] and "lobby.sgt:1:" in errors[0] and "point_right" in errors[0]
    with pytest.raises(GenerateError) as e:
        _clips({"id": "2", "path": str(path), "source": BAD, "engine": "keyframe"}, lambda event: None)
    assert [f"[{d.code}] {d.message}" for d in e.value.diagnostics] in [[line.split("error: ", 1)[1]] for line in errors[0].splitlines()
                                                                       if "error: " in line]


def test_engine_choices_and_seed_range_match_everywhere():
    """`--engine` choices (numpy-free, for the parsers) are the engines; `--seed`, `@seed` and the
    API accept the same range."""
    from core.seeds import SEED_MAX
    from model.generate import ENGINES
    from sgt_tui.commands.common import ENGINE_CHOICES

    assert set(ENGINE_CHOICES) == set(ENGINES)
    top = compile_text(f"@seed {SEED_MAX}\nguide: hi\n", timing="estimate")
    assert top.plan is not None and top.plan.seed == SEED_MAX
    over = compile_text(f"@seed {SEED_MAX + 1}\nguide: hi\n", timing="estimate")
    assert over.plan is None and any("seed" in d.message for d in over.diagnostics)
    assert generate(top.plan, engine="rules", seed=SEED_MAX).clips
    with pytest.raises(GenerateError):
        generate(top.plan, engine="rules", seed=SEED_MAX + 1)
