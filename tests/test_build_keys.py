"""sgt build's cache keys: a change in each input that changes an utterance's motion changes
its key; nothing else does (tests/test_build.py builds for real)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import soundfile as sf

from dsl.compiler import load_script
from library import BUILTIN_DIR
from model.weights import DEFAULT_WEIGHTS
from sgt_tui.build import keys as keys_module
from sgt_tui.build.keys import Settings, utterance_key

# Utterance 0 (guide) uses every kind of mark; utterance 1 (robot) is the bystander; utterance
# 2 speaks a recording.
BASE = """\
# a comment
@seed 3
@voice guide: en-us
@rate guide: 160
@pitch guide: 50
@library ./gestures
@preset eager = speed:+1
guide: Hello there [pose:wave] my <speed:+1>good</speed> friend. [pause 300ms] [pose:mine x2] Bye.
robot: Look at [pose:point_right] the shelf.
@audio rec.wav timings=rec.json
guide: Well hello.
"""
UTTERANCES = 3


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "gestures").mkdir()
    spec = (BUILTIN_DIR / "wave.toml").read_text().replace('name = "wave"', 'name = "mine"')
    (tmp_path / "gestures" / "mine.toml").write_text(spec)
    t = np.arange(16000) / 16000
    sf.write(str(tmp_path / "rec.wav"), 0.3 * np.sin(2 * np.pi * 220 * t), 16000)
    (tmp_path / "rec.json").write_text(json.dumps([{"word": "Well", "start": 0.1, "end": 0.4},
                                                   {"word": "hello", "start": 0.5, "end": 0.9}]))
    return tmp_path


def keys(folder, text=BASE, settings=None, name="script.sgt", check=None):
    script, lib, diags = load_script(folder / name, source=text)
    errors = [d for d in diags if d.is_error]
    assert not errors, errors
    assert len(script.utterances) == UTTERANCES
    if check:
        check(script)
    settings = settings or Settings()
    return [utterance_key(u, lib, script.header.seed, settings) for u in script.utterances]


def changed(before, after) -> set[int]:
    return {i for i, (a, b) in enumerate(zip(before, after)) if a != b}


# (what, old text, new text, the utterances whose motion changes, a check that the edit means what it says)
EDITS = [
    ("spoken text", "Hello there", "Hello here", {0}, None),
    ("pose control: gesture", "[pose:wave]", "[pose:shrug]", {0}, None),
    ("pose control: speed", "[pose:wave]", "[pose:wave x2]", {0}, None),
    ("pose control: flip", "[pose:wave]", "[pose:wave flip]", {0}, None),
    ("pose control: hold", "[pose:wave]", "[pose:wave hold=500ms]", {0}, None),
    ("pose control: moved to another word", "there [pose:wave] my", "[pose:wave] there my", {0}, None),
    ("style control: value", "<speed:+1>good</speed>", "<speed:+2>good</speed>", {0}, None),
    ("style control: element", "<speed:+1>good</speed>", "<space:+1>good</space>", {0}, None),
    ("style control: a preset's values", "@preset eager = speed:+1", "@preset eager = speed:+2", {0},
     None),  # replaced below: the preset is used by utterance 0 only
    ("pause", "[pause 300ms]", "[pause 400ms]", {0}, None),
    ("voice (utterance 2 is the guide too, but speaks a recording)", "@voice guide: en-us", "@voice guide: en-gb", {0},
     lambda s: s.utterances[0].voice.name == "en-gb"),
    ("rate", "@rate guide: 160", "@rate guide: 170", {0}, lambda s: s.utterances[0].voice.rate == 170),
    ("pitch", "@pitch guide: 50", "@pitch guide: 60", {0}, lambda s: s.utterances[0].voice.pitch == 60),
    ("the script's seed", "@seed 3", "@seed 4", {0, 1, 2}, None),
    ("speaker", "robot: Look", "guard: Look", {1}, None),
]


def test_base_keys_are_distinct_and_stable(folder):
    a = keys(folder)
    assert len(set(a)) == UTTERANCES
    assert keys(folder) == a


@pytest.mark.parametrize("what,old,new,expected,check", EDITS, ids=[e[0] for e in EDITS])
def test_an_edit_invalidates_exactly_the_utterances_it_changes(folder, what, old, new, expected, check):
    base = BASE
    if what.startswith("style control: a preset"):
        base = BASE.replace("<speed:+1>good</speed>", "<eager>good</eager>")
    assert old in base
    before = keys(folder, base)
    after = keys(folder, base.replace(old, new), check=check)
    assert changed(before, after) == expected


def test_a_gesture_definition_invalidates_the_utterances_that_play_it(folder):
    before = keys(folder)
    spec = folder / "gestures" / "mine.toml"
    text = spec.read_text()
    assert "right_wrist = [-0.330, 0.852, 0.406]" in text
    spec.write_text(text.replace("right_wrist = [-0.330, 0.852, 0.406]", "right_wrist = [-0.330, 0.862, 0.406]"))
    assert changed(before, keys(folder)) == {0}
    spec.write_text(text.replace("time = 0.6", "time = 0.62"))
    assert changed(before, keys(folder)) == {0}


def test_a_recording_and_its_timings_invalidate_their_utterance(folder):
    before = keys(folder)
    t = np.arange(16000) / 16000
    sf.write(str(folder / "rec.wav"), 0.3 * np.sin(2 * np.pi * 330 * t), 16000)
    after = keys(folder)
    assert changed(before, after) == {2}
    timings = json.loads((folder / "rec.json").read_text())
    timings[1]["start"] = 0.55
    (folder / "rec.json").write_text(json.dumps(timings))
    assert changed(after, keys(folder)) == {2}


def test_the_speech_engine_build_invalidates_synthesized_speech_only(folder, monkeypatch):
    before = keys(folder)
    monkeypatch.setattr(keys_module, "_espeak_build", lambda: "libespeak-ng.so.1.2.3:999")
    assert changed(before, keys(folder)) == {0, 1}


@pytest.mark.parametrize("settings,expected", [
    (Settings(engine="rules"), {0, 1, 2}),
    (Settings(seed=7), {0, 1, 2}),
    (Settings(smoothing="none"), {0, 1, 2}),
    (Settings(blend=False), {0, 1, 2}),
    (Settings(take_posture=False), {0, 1, 2}),
], ids=["engine", "--seed", "smoothing", "blend", "take-posture"])
def test_generator_settings_invalidate_everything(folder, settings, expected):
    assert changed(keys(folder), keys(folder, settings=settings)) == expected


def test_weights_content_invalidates_the_neural_engine_only(folder, tmp_path):
    alone = tmp_path / "alone" / "same.pt"
    alone.parent.mkdir()
    shutil.copyfile(DEFAULT_WEIGHTS, alone)
    # without its ONNX export the same weights run in PyTorch, whose numbers differ in the last bits
    neural = Settings(engine="neural")
    assert changed(keys(folder, settings=neural), keys(folder, settings=Settings(engine="neural", weights=str(alone)))) == {0, 1, 2}
    copy = tmp_path / "same.pt"
    shutil.copyfile(DEFAULT_WEIGHTS, copy)
    shutil.copyfile(DEFAULT_WEIGHTS.with_suffix(".onnx"), copy.with_suffix(".onnx"))
    # the content counts, not the path
    assert keys(folder, settings=Settings(engine="neural", weights=str(copy))) == keys(folder, settings=neural)
    other = tmp_path / "other.pt"
    other.write_bytes(DEFAULT_WEIGHTS.read_bytes() + b"\0")
    assert changed(keys(folder, settings=neural), keys(folder, settings=Settings(engine="neural", weights=str(other)))) == {0, 1, 2}
    keyframe = Settings(engine="keyframe")
    assert keys(folder, settings=keyframe) == keys(folder, settings=Settings(engine="keyframe", weights=str(other)))


def test_the_code_version_invalidates_everything(folder, monkeypatch):
    before = keys(folder)
    monkeypatch.setattr(keys_module, "CODE_VERSION", keys_module.CODE_VERSION + 1)
    assert changed(before, keys(folder)) == {0, 1, 2}


# -- nothing else ---------------------------------------------------------------------------


@pytest.mark.parametrize("what,old,new", [
    ("comments and blank lines above (every line number moves)", "# a comment\n", "# a comment\n# more\n\n\n"),
    ("a comment between utterances", "robot: Look", "# about the shelf\nrobot: Look"),
    ("an unused preset", "@preset eager = speed:+1", "@preset eager = speed:+1\n@preset calm2 = speed:-1"),
    ("spaces around a directive's value", "@seed 3", "@seed  3"),
])
def test_edits_that_change_no_motion_keep_every_key(folder, what, old, new):
    assert old in BASE
    assert keys(folder, BASE.replace(old, new)) == keys(folder)


def test_another_utterance_or_another_name_keeps_the_key(folder):
    base = keys(folder)
    assert changed(base, keys(folder, BASE.replace("the shelf", "the door"))) == {1}
    assert keys(folder, name="renamed.sgt") == base


def test_a_gesture_files_description_and_comments_do_not_count(folder):
    before = keys(folder)
    spec = folder / "gestures" / "mine.toml"
    text = spec.read_text()
    spec.write_text("# a comment\n" + text.replace("Wave hello", "Wave a greeting"))
    assert keys(folder) == before


def test_seedless_engine_ignores_the_seed_and_neural_settings(folder):
    keyframe = keys(folder, settings=Settings(engine="keyframe"))
    assert keys(folder, BASE.replace("@seed 3", "@seed 4"), settings=Settings(engine="keyframe")) == keyframe
    assert keys(folder, settings=Settings(engine="keyframe", seed=9, smoothing="none", blend=False)) == keyframe
    # the rules engine draws random numbers: its seed counts
    rules = keys(folder, settings=Settings(engine="rules"))
    assert changed(rules, keys(folder, settings=Settings(engine="rules", seed=9))) == {0, 1, 2}
