"""The performance clock: @gap, where utterances play, continuous tracks per speaker with
listening motion, and joins without jumps for every engine."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.skeleton import FPS, JOINT_INDEX, REST_POSE, normalize_pose, positions_from_pose
from dsl.compiler import compile_text
from dsl.script import DEFAULT_GAP
from model.performance import listening

WRISTS = [JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]]
DIALOGUE = """@seed 4
guide: Hello, and welcome to Riverside Mall! [pose:wave] I can help you find anything.
visitor: Thank you. [pose:shrug] Where is the food court?
guide: The food court is [pose:point_up] upstairs, on the second floor.
guide: And the cinema is [pose:point_right] over there.
visitor: Great, [pose:thumbs_up] thanks a lot!
"""


def _codes(result):
    return [(d.code, d.line) for d in result.diagnostics]


def _wrist_steps(positions) -> np.ndarray:
    """(T-1,) the larger of the two wrists' displacements between consecutive frames, metres."""
    return np.linalg.norm(np.diff(positions[:, WRISTS], axis=0), axis=-1).max(-1)


# -- @gap and the layout ----------------------------------------------------------------------

def test_gap_in_the_header_and_between_utterances():
    r = compile_text("@gap 1.2s\na: one two three\nb: four five\n@gap 3s\na: six seven\nb: eight\n", timing="estimate")
    assert r.ok, _codes(r)
    gaps = [u.gap for u in r.plan.utterances]
    assert gaps == [1.2, 1.2, 3.0, 1.2]
    assert compile_text("a: hi\nb: yes\n", timing="estimate").plan.utterances[1].gap == DEFAULT_GAP


def test_speech_starts_the_gap_after_the_previous_speech_on_whole_frames():
    r = compile_text("@gap 700ms\na: [pose:wave] hello there my friend\nb: yes [pose:point_right] over there\n"
                     "@gap 2s\nb: [pose:shrug] I do not know\na: fine\n", timing="estimate")
    assert r.ok, _codes(r)
    us = r.plan.utterances
    assert us[0].start_frame == 0
    for prev, u in zip(us, us[1:]):
        speech_start = u.start + u.audio_offset
        prev_end = prev.start + prev.audio_offset + prev.speech_duration
        assert u.audio_offset * FPS == pytest.approx(round(u.audio_offset * FPS))  # audio on a whole frame
        if u.speaker != prev.speaker:  # the next speaker starts as soon as the gap is over
            assert speech_start == pytest.approx(math.ceil((prev_end + u.gap) * FPS - 1e-6) / FPS)
        else:  # the same speaker's motion waits for its previous motion, so at least the gap
            assert speech_start >= prev_end + u.gap - 1e-9
            assert u.start_frame >= prev.start_frame + prev.n_frames
    assert r.plan.n_frames == max(u.start_frame + u.n_frames for u in us)
    doc = r.plan.to_dict()
    assert doc["version"] == 2 and doc["frames"] == r.plan.n_frames
    assert [(x["start"], x["audio_offset"]) for x in doc["utterances"]] == [
        (round(u.start, 6), round(u.audio_offset, 6)) for u in us]


@pytest.mark.parametrize("line,code", [("@gap 2", "SGT310"), ("@gap long", "SGT310"), ("@gap 31s", "SGT310"),
                                       ("@gap -1s", "SGT310"), ("@gap", "SGT113"), ("@gap 1s 2s", "SGT114")])
def test_bad_gap_values_are_errors_with_their_place(line, code):
    r = compile_text(f"{line}\na: hello\n", timing="estimate")
    assert not r.ok and (code, 1) in _codes(r)
    d = next(d for d in r.diagnostics if d.code == code)
    if code == "SGT310":
        assert d.col == 6 and "from 0s to 30s" in d.message


def test_a_gap_after_the_last_utterance_and_twice_before_one_are_warnings():
    r = compile_text("a: hi\n@gap 1s\n@gap 2s\nb: yes\n@gap 4s\n", timing="estimate")
    assert r.ok and ("SGT210", 3) in _codes(r) and ("SGT118", 5) in _codes(r)
    assert r.plan.utterances[1].gap == 2.0  # the last one wins


# -- tracks -----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rules_take():
    from model.generate import generate

    return generate(source=DIALOGUE, engine="rules", timing="estimate")


def test_every_speaker_has_one_track_over_the_whole_performance(rules_take):
    take = rules_take
    assert [t.speaker for t in take.tracks] == ["guide", "visitor"]
    n = take.plan.n_frames
    for t in take.tracks:
        assert t.poses.shape == (n, 27) and np.isfinite(t.poses).all()
        assert np.allclose(np.linalg.norm(t.poses.reshape(n, 9, 3), axis=-1), 1.0, atol=1e-4)
    for u, c in zip(take.plan.utterances, take.clips):
        assert (c.index, c.start, c.audio_offset) == (u.index, u.start, u.audio_offset)
        track = next(t for t in take.tracks if t.speaker == u.speaker)
        mid = slice(u.start_frame + c.n_frames // 2 - 2, u.start_frame + c.n_frames // 2 + 2)
        # in the middle of an utterance the track is the utterance's own motion
        assert np.allclose(track.poses[mid], c.poses[c.n_frames // 2 - 2: c.n_frames // 2 + 2], atol=1e-5)


def test_no_wrist_jump_at_boundaries_and_listeners_move_calmly(rules_take):
    take = rules_take
    for t in take.tracks:
        steps = _wrist_steps(t.positions)
        speaking = np.zeros(t.n_frames, bool)
        for u in take.plan.utterances:
            if u.speaker == t.speaker:
                speaking[u.start_frame: u.start_frame + u.n_frames] = True
                for b in (u.start_frame, u.start_frame + u.n_frames):
                    if 0 < b < t.n_frames:
                        assert steps[b - 1] < 0.05, f"{t.speaker}: {100 * steps[b - 1]:.1f} cm at frame {b}"
        listening = steps[~speaking[1:] & ~speaking[:-1]] * FPS
        talking = steps[speaking[1:] & speaking[:-1]] * FPS
        assert listening.max() > 0.0  # never a freeze
        assert np.median(listening) < np.median(talking)


@pytest.mark.parametrize("arms,moved,fastest", [((0.0, 0.0, 1.0), 0.6, 0.05),  # straight forward: 90 degrees
                                                 ((0.0, 1.0, 0.0), 1.0, 0.07)])  # straight up: 180 degrees
def test_easing_covers_a_far_pose_without_a_jump(arms, moved, fastest):
    from model.performance import listening, place

    track = listening(160, [], np.random.default_rng(0))
    far = REST_POSE.reshape(9, 3).copy()
    far[[4, 5, 7, 8]] = arms
    clip = np.repeat(normalize_pose(far.reshape(1, 27)), 70, axis=0)
    before = np.linalg.norm(positions_from_pose(track[60])[WRISTS] - positions_from_pose(clip[0])[WRISTS], axis=-1).max()
    assert before > moved
    place(track, clip, 60, 30, 30)
    steps = _wrist_steps(positions_from_pose(track))
    assert steps.max() < fastest, f"{100 * steps.max():.1f} cm"
    assert np.abs(np.diff(steps)).max() < 0.01  # speeds change smoothly: no jolt anywhere
    assert np.allclose(track[95], clip[35], atol=1e-6)  # the middle is the clip's own


def test_listeners_nod_after_the_other_speakers_accented_words():
    from model.performance import listening

    n = 150
    calm = listening(n, [], np.random.default_rng(3))
    nodding = listening(n, [2.0, 2.8, 3.6, 5.0, 6.2, 7.0], np.random.default_rng(3))
    nose = JOINT_INDEX["nose"]
    dy = positions_from_pose(nodding)[:, nose, 1] - positions_from_pose(calm)[:, nose, 1]
    assert dy.min() < -0.004  # the face dips
    assert np.abs(dy[:20]).max() < 1e-6  # and only after the accents (the first is at 2 s)


@pytest.mark.parametrize("script", ["mall_guide", "game_dialogue", "lecture"])
def test_examples_have_no_wrist_jump_at_boundaries_with_the_neural_engine(script):
    from model.generate import generate
    from model.weights import WeightsError, load_weights

    try:
        load_weights(None)
    except WeightsError as exc:  # pragma: no cover - a checkout without the shipped weights
        pytest.skip(str(exc))
    take = generate(f"examples/{script}.sgt", engine="neural", timing="estimate")
    for t in take.tracks:
        steps = _wrist_steps(t.positions)
        for u in take.plan.utterances:
            for b in (u.start_frame, u.start_frame + u.n_frames):
                if u.speaker == t.speaker and 0 < b < t.n_frames:
                    assert steps[b - 1] < 0.05, f"{script} {t.speaker}: {100 * steps[b - 1]:.1f} cm at frame {b}"


def test_a_long_script_has_no_wrist_jump_at_boundaries():
    from model.generate import generate

    lines = DIALOGUE.splitlines()[1:]
    take = generate(source="@seed 9\n" + "\n".join(lines * 8) + "\n", engine="rules", timing="estimate")
    assert len(take.clips) == 40
    worst = 0.0
    for t in take.tracks:
        steps = _wrist_steps(t.positions)
        for u in take.plan.utterances:
            for b in (u.start_frame, u.start_frame + u.n_frames):
                if u.speaker == t.speaker and 0 < b < t.n_frames:
                    worst = max(worst, steps[b - 1])
    assert worst < 0.05, f"{100 * worst:.1f} cm"


