"""The compiler: timing -> controls -> plan and control arrays (estimated timing: no engine)."""

import json

import numpy as np
import pytest

from core.controls import STYLE_INDEX
from core.skeleton import BONE_NAMES, FPS, REST_POSE, seconds_to_frame
from dsl.compiler import compile_file
from library import load_library
from sgt_tui import cli


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


def build(tmp_path, text, lib, **kw):
    path = tmp_path / "s.sgt"
    path.write_text(text, encoding="utf-8")
    return compile_file(path, timing="estimate", library=lib, **kw)


def test_pose_stroke_lands_on_the_next_word_onset(tmp_path, lib):
    r = build(tmp_path, "one two three four five [pose:point_right] six seven eight nine ten\n", lib)
    assert r.ok, r.diagnostics
    u = r.plan.utterances[0]
    (c,) = [c for c in u.controls if c.kind == "pose"]
    clip = lib.get("point_right").clip()
    assert c.start_frame + clip.stroke_frame == seconds_to_frame(u.words[5].start)
    assert c.end_frame - c.start_frame == len(clip.poses)
    # a one-handed point requests the right arm only; the rest of the body stays free
    span = slice(c.start_frame, c.end_frame)
    arm = np.repeat([b.startswith("right_") for b in BONE_NAMES], 3)
    assert np.allclose(u.arrays.pose[span][:, arm], clip.poses[:, arm])
    assert not u.arrays.pose[span][:, ~arm].any()
    assert (u.arrays.bones()[span] == arm[::3]).all() and not u.arrays.bones()[: c.start_frame].any()
    assert u.arrays.pose_mask.sum() == len(clip.poses)
    assert (c.line, c.col) == (1, 25) and c.options == {"speed": 1, "flip": False}


def test_pose_with_no_following_word_anchors_to_the_end_of_the_previous(tmp_path, lib):
    r = build(tmp_path, "please look at this one right here [pose:nod x2]\n", lib)
    u = r.plan.utterances[0]
    (c,) = u.controls
    stroke = lib.get("nod").clip(speed=2).stroke_frame
    assert c.start_frame + stroke == seconds_to_frame(u.words[-1].end)


def test_speed_flip_and_hold_reach_the_arrays(tmp_path, lib):
    r = build(tmp_path, "a b c d e f g [pose:point_right x2 flip hold=600ms] h i j k l m n o p\n", lib)
    u = r.plan.utterances[0]
    (c,) = u.controls
    clip = lib.get("point_right").clip(speed=2, flip=True, hold=0.6)
    assert _requested(u.arrays, c.start_frame, c.end_frame, clip.poses)
    assert c.options == {"speed": 2, "flip": True, "hold": 0.6}


def test_lead_in_makes_room_for_a_gesture_on_the_first_word(tmp_path, lib):
    r = build(tmp_path, "[pose:wave] Hello there, friend.\n", lib)
    assert r.ok and not r.diagnostics
    u = r.plan.utterances[0]
    (c,) = u.controls
    stroke = lib.get("wave").clip().stroke_frame
    assert u.lead_in == pytest.approx(stroke / FPS - seconds_to_frame(0.05) / FPS, abs=1 / FPS)
    assert c.start_frame == 0
    assert c.start_frame + stroke == seconds_to_frame(u.words[0].start)
    assert u.speech["lead_in"] == round(u.lead_in, 6)


def test_style_spans_nest_inner_wins_and_masks_are_per_element(tmp_path, lib):
    r = build(tmp_path, "w1 w2 <happy>w3 w4 <speed:-1>w5 w6</speed> w7</happy> w8 w9 w10 w11 w12\n", lib)
    u = r.plan.utterances[0]
    a = u.arrays
    outer, inner = [c for c in u.controls if c.kind == "style"]
    assert outer.name == "happy" and inner.name == "speed"
    sp, sc, hd = STYLE_INDEX["speed"], STYLE_INDEX["space"], STYLE_INDEX["handedness"]
    mid = (inner.start_frame + inner.end_frame) // 2
    assert a.style[mid, sp] == -1.0 and a.style[mid, sc] == 1.5  # inner speed, inherited space
    first = outer.start_frame
    assert a.style[first, sp] == 2.5
    assert a.style_mask[first, sp] == 1 and a.style_mask[first, hd] == 0
    assert a.style_mask[: outer.start_frame].sum() == 0 and a.style_mask[outer.end_frame :].sum() == 0
    assert outer.start_frame == seconds_to_frame(u.words[2].start)


def test_pause_lengthens_the_speech_and_is_a_control(tmp_path, lib):
    base = build(tmp_path, "one two three four\n", lib).plan.utterances[0]
    r = build(tmp_path, "one two [pause 1.2s] three four\n", lib).plan.utterances[0]
    assert r.duration == pytest.approx(base.duration + 1.2)
    assert r.words[2].start == pytest.approx(base.words[2].start + 1.2)
    (p,) = r.controls
    assert p.kind == "pause" and p.options == {"seconds": 1.2}
    assert p.end_frame - p.start_frame == pytest.approx(1.2 * FPS, abs=1)


def test_a_stroke_that_cannot_make_its_word_warns_with_how_late_and_a_fix(tmp_path, lib):
    r = build(tmp_path, "guide: Look [pose:point_left x3] [pose:point_right x3] there now.\n", lib)
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    u = r.plan.utterances[0]
    left, right = [c for c in u.controls if c.kind == "pose"]
    late = right.stroke_frame - right.word_frame
    assert late >= 2 and left.stroke_frame == left.word_frame
    assert d.severity == "warning" and f"lands {late} frames" in d.message and "'there'" in d.message
    assert "point_left" in d.message and "degrees" in d.message
    assert d.hint == "move [pose:point_right] one word later (before 'now')"
    assert (d.line, d.col) == (1, 34)
    (other,) = d.related  # the other gesture is a related span, not text in the message
    assert (other.line, other.col) == (1, 13) and "line 1" not in d.message


def _requested(arrays, start, end, poses) -> bool:
    """Frames [start, end) of ``arrays`` request exactly ``poses`` on the bones they control."""
    got = arrays.pose[start:end].reshape(end - start, -1, 3)
    bones = arrays.bones()[start:end] > 0.5
    want = np.asarray(poses).reshape(end - start, -1, 3)
    return bool(bones.any(axis=1).all()) and np.allclose(got[bones], want[bones])


def _pose_frames(u, lib, index, name):
    """(natural start frame, stroke frame, clip) of the pose control anchored to word ``index``."""
    clip = lib.get(name).clip()
    return seconds_to_frame(u.words[index].start) - clip.stroke_frame, clip.stroke_frame, clip


def _turns(poses) -> np.ndarray:
    """Degrees each bone turns between consecutive frames, (T-1, 9)."""
    d = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)
    return np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(-1), -1, 1)))


def test_a_gesture_that_follows_before_the_arm_could_rest_prepares_from_the_earlier_stroke(tmp_path, lib):
    """point_left would start its preparation (from rest) before point_right's stroke is done:
    point_right keeps its stroke, its retraction is cut, and point_left turns the arm from the
    pointing pose to its own stroke, which lands on its word. The arm never drops toward rest
    between them, and no bone turns faster than 900 degrees per second."""
    r = build(tmp_path, "look [pose:point_right] here [pose:point_left] and there now\n", lib)
    assert r.ok and not [d for d in r.diagnostics if d.name == "overlap"]
    u = r.plan.utterances[0]
    right_start, right_stroke, right_clip = _pose_frames(u, lib, 1, "point_right")
    left_start, left_stroke, left_clip = _pose_frames(u, lib, 2, "point_left")
    assert left_start < right_start + right_stroke + 1  # the case this test is about
    right, left = [c for c in u.controls if c.kind == "pose"]
    assert right.stroke_frame == right.word_frame and left.stroke_frame == left.word_frame  # both on their words
    keep = right_start + right_stroke + 1
    assert (right.start_frame, right.end_frame) == (right_start, keep)  # cut where its stroke is over
    a = u.arrays
    assert _requested(a, right_start, keep, right_clip.poses[: keep - right_start])
    stroke = left.stroke_frame
    assert _requested(a, stroke, left.end_frame, left_clip.poses[left_stroke : left_stroke + left.end_frame - stroke])
    arm = [BONE_NAMES.index(b) for b in ("right_elbow", "right_wrist")]
    pose = a.pose.reshape(u.n_frames, -1, 3)
    way = pose[keep - 1 : stroke + 1][:, arm]  # from the end of the first stroke to the second
    rest = np.asarray(REST_POSE).reshape(-1, 3)[arm]
    to_rest = np.degrees(np.arccos(np.clip((way * rest).sum(-1), -1, 1)))
    # no dip toward rest (before, the arm fell to rest for the second preparation): the way
    # between the strokes stays at least 80 % as far from rest as its ends are
    assert (to_rest.min(axis=0) >= 0.8 * np.minimum(to_rest[0], to_rest[-1])).all()
    assert (a.bones()[right_start : left.end_frame] > 0.5)[:, arm].all()  # the arm is held all along
    assert _turns(pose[right_start : left.end_frame][:, arm].reshape(-1, 6)).max() <= 60.0  # 900 deg/s


def test_counting_in_a_row_adds_fingers_and_lands_every_count(tmp_path, lib):
    r = build(tmp_path, "guide: Today we cover [pose:count_one x2] one, [pose:count_two x2] two, "
                        "[pose:count_three x2] three topics.\n", lib)
    assert not [d for d in r.diagnostics if d.name == "overlap"]
    u = r.plan.utterances[0]
    counts = [c for c in u.controls if c.kind == "pose"]
    assert [c.stroke_frame - c.word_frame for c in counts] == [0, 0, 0]
    hands, mask = u.hands
    from core.hands import openness

    right = 1
    opened = [float(openness(hands.fingers[c.stroke_frame, right][None])[0]) for c in counts]
    assert opened == sorted(opened) and opened[0] < opened[-1]  # one, two, three fingers
    # between the counts the right arm stays up (it never hangs at rest) and the hand is set
    first, last = counts[0].stroke_frame, counts[-1].stroke_frame
    wrist = u.arrays.pose.reshape(u.n_frames, -1, 3)[first:last + 1, BONE_NAMES.index("right_elbow")]
    assert (wrist[:, 1] > -0.9).all() and (mask[first:last + 1, right] == 1).all()


def test_a_gesture_that_waits_past_the_end_extends_the_utterance(tmp_path, lib):
    r = build(tmp_path, "[pose:point_right] [pose:point_left] hi\n", lib)  # both on the only word
    u = r.plan.utterances[0]
    right, left = [c for c in u.controls if c.kind == "pose"]
    assert left.stroke_frame > left.word_frame and right.end_frame <= left.stroke_frame
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    assert "give 'point_left' a word of its own" in d.hint
    assert u.n_frames == left.end_frame > seconds_to_frame(u.words[-1].end)  # nothing is cut
    assert u.speech["tail"] > 0 and u.duration == u.n_frames / FPS  # the motion runs on after the speech


def test_a_gesture_after_the_earlier_stroke_cuts_its_retraction_and_approaches(tmp_path, lib):
    r = build(tmp_path, "look [pose:point_right] here and [pose:beat_right] there now more\n", lib)
    assert r.ok
    u = r.plan.utterances[0]
    right_start, right_stroke, right_clip = _pose_frames(u, lib, 1, "point_right")
    beat_start, beat_stroke, beat_clip = _pose_frames(u, lib, 3, "beat_right")
    assert right_start + right_stroke < beat_start < right_start + len(right_clip.poses)  # the case
    right, beat = [c for c in u.controls if c.kind == "pose"]
    assert (right.start_frame, right.end_frame) == (right_start, beat_start)  # cut where the approach starts
    assert (beat.start_frame, beat.stroke_frame) == (beat_start, beat.word_frame)  # on its word
    assert _requested(u.arrays, right_start, beat_start, right_clip.poses[: beat_start - right_start])
    assert _requested(u.arrays, beat.stroke_frame, beat.end_frame, beat_clip.poses[beat_stroke:])
    arm = [BONE_NAMES.index(b) for b in ("right_elbow", "right_wrist")]
    held = u.arrays.pose.reshape(u.n_frames, -1, 3)[right_start : beat.end_frame][:, arm]
    assert _turns(held.reshape(-1, 6)).max() <= 60.0
    assert not [d for d in r.diagnostics if d.name == "overlap"]


def test_gestures_on_different_limbs_layer_instead_of_colliding(tmp_path, lib):
    # the same placement as above, but a nod: it drives the head, point_right the right arm
    r = build(tmp_path, "look [pose:point_right] here and [pose:nod] there now more\n", lib)
    u = r.plan.utterances[0]
    right_start, _, right_clip = _pose_frames(u, lib, 1, "point_right")
    nod_start, _, nod_clip = _pose_frames(u, lib, 3, "nod")
    assert nod_start < right_start + len(right_clip.poses)  # they overlap in time
    assert not [d for d in r.diagnostics if d.name == "overlap"]
    right, nod = [c for c in u.controls if c.kind == "pose"]
    assert (right.start_frame, right.end_frame) == (right_start, right_start + len(right_clip.poses))  # whole
    assert (nod.start_frame, nod.end_frame) == (nod_start, nod_start + len(nod_clip.poses))
    both = u.arrays.bones()[nod_start : right.end_frame] > 0.5
    head, arm = [BONE_NAMES.index(b) for b in ("nose", "right_wrist")]
    assert both[:, head].all() and both[:, arm].all() and not both[:, BONE_NAMES.index("left_wrist")].any()
    pose = u.arrays.pose.reshape(u.n_frames, -1, 3)
    assert np.allclose(pose[right_start : right.end_frame, arm], right_clip.poses.reshape(-1, 9, 3)[:, arm])
    assert np.allclose(pose[nod_start : nod.end_frame, head], nod_clip.poses.reshape(-1, 9, 3)[:, head])
    # the hands are layered too: the point sets the right hand only, the nod neither
    _, hand_mask = u.hands
    assert (hand_mask[right_start : right.end_frame, 1] == 1).all() and not hand_mask[:, 0].any()
    assert not hand_mask[right.end_frame : nod.end_frame].any()


def test_a_flipped_gesture_collides_on_the_mirrored_limb(tmp_path, lib):
    # point_right flip drives the left arm: it collides with beat_left, not with beat_right
    for other, collides in (("beat_left", True), ("beat_right", False)):
        r = build(tmp_path, f"look [pose:point_right flip] here and [pose:{other}] there now more\n", lib)
        point, beat = [c for c in r.plan.utterances[0].controls if c.kind == "pose"]
        assert (point.end_frame < point.start_frame + len(lib.get("point_right").clip().poses)) == collides, other


def test_plan_json_is_deterministic_and_complete(tmp_path, lib):
    text = open("examples/lecture.sgt", encoding="utf-8").read()
    a = build(tmp_path, text, lib).plan.to_json()
    b = build(tmp_path, text, lib).plan.to_json()
    assert a == b
    data = json.loads(a)
    assert data["fps"] == FPS and len(data["utterances"]) == 6
    u = data["utterances"][1]
    assert {"speaker", "text", "duration", "words", "controls"} <= set(u)
    for c in u["controls"]:
        assert {"kind", "name", "start_frame", "end_frame", "line", "col", "options"} <= set(c)
        assert 0 <= c["start_frame"] < c["end_frame"] <= u["frames"]
    starts = [w["start"] for w in u["words"]]
    assert starts == sorted(starts) and all(w["end"] <= u["duration"] for w in u["words"])


def test_npz_holds_the_arrays(tmp_path, lib):
    r = build(tmp_path, open("examples/mall_guide.sgt", encoding="utf-8").read(), lib)
    r.plan.save_npz(tmp_path / "c.npz")
    with np.load(tmp_path / "c.npz") as z:
        for i, u in enumerate(r.plan.utterances):
            assert z[f"pose_{i}"].shape == (u.n_frames, 27)
            assert z[f"pose_mask_{i}"].shape == (u.n_frames,)
            assert z[f"style_{i}"].shape == (u.n_frames, 3)
            assert np.array_equal(z[f"style_mask_{i}"], u.arrays.style_mask)
        assert json.loads(str(z["plan"]))["source"].endswith("s.sgt")


def test_errors_give_no_plan(tmp_path, lib):
    r = build(tmp_path, "hi [pose:nope]\n", lib)
    assert not r.ok and r.plan is None


def test_cli_compile_writes_plan_and_exit_codes(tmp_path, capsys):
    good = tmp_path / "g.sgt"
    good.write_text("guide: hello [pose:nod] there, how are you today?\n")
    out = tmp_path / "plan.json"
    assert cli.main(["compile", str(good), "--estimate", "-o", str(out), "--npz", str(tmp_path / "c.npz")]) == 0
    assert json.loads(out.read_text())["utterances"][0]["speaker"] == "guide"
    bad = tmp_path / "b.sgt"
    bad.write_text("hello [pose:wav]\n")
    assert cli.main(["compile", str(bad), "--estimate", "-o", str(tmp_path / "x.json")]) == 1
    assert not (tmp_path / "x.json").exists()
    err = capsys.readouterr().err
    assert "b.sgt:1:13: error: [SGT201] unknown gesture 'wav'" in err and "did you mean 'wave'" in err
    # a script that cannot be read is a problem with the input (exit 1), as in `sgt check`
    assert cli.main(["compile", str(tmp_path / "missing.sgt")]) == 1
    assert "missing.sgt: error: [SGT601] cannot read the script: no such file or directory" in capsys.readouterr().err


def test_cli_check_many_files_and_json(tmp_path, capsys):
    a = tmp_path / "a.sgt"
    a.write_text("x [pose:wave] y z\n")
    b = tmp_path / "b.sgt"
    b.write_text("x <speed:5>y</>\nz [pose:nodd]\n")
    assert cli.main(["check", str(a), str(b)]) == 1
    out = capsys.readouterr().out
    assert "a.sgt: ok" in out and "b.sgt:1:4: error" in out and "b.sgt:2:9: error" in out
    assert cli.main(["check", "--format", "json", str(b)]) == 1
    data = json.loads(capsys.readouterr().out)
    assert data["errors"] == 2 and {d["line"] for d in data["diagnostics"]} == {1, 2}


# -- real speech (espeak-ng) -------------------------------------------------------------


def test_real_speech_timing_is_increasing_and_inside_the_audio(tmp_path, lib):
    import soundfile as sf

    path = tmp_path / "s.sgt"
    path.write_text("guide: [pose:wave] Welcome! Look at the shelf [pose:point_right x2] over there, in the 1990s aisle.\n")
    r = compile_file(path, timing="speech", library=lib, cache_dir=tmp_path / "cache")
    assert r.ok, r.diagnostics
    u = r.plan.utterances[0]
    audio_seconds = sf.info(str(u.audio_path)).duration
    starts = [w.start for w in u.words]
    assert starts == sorted(starts) and len(set(starts)) == len(starts)
    for w in u.words:
        assert u.lead_in <= w.start <= w.end <= u.lead_in + audio_seconds + 1e-6
    assert u.duration >= u.lead_in + audio_seconds - 1 / 15
    assert u.speech["engine"] == "espeak-ng" and u.speech["voice"] == "en-us"


def test_real_speech_overlap_is_a_warning_resolved_as_with_estimated_timing(tmp_path, lib):
    # issue 13: check (estimated timing) and compile (real timing) must give the same verdict
    path = tmp_path / "s.sgt"
    path.write_text("guide: Look [pose:point_left x3] [pose:point_right x3] there now.\n")
    r = compile_file(path, timing="speech", library=lib, cache_dir=tmp_path / "cache")
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    assert d.severity == "warning" and r.ok and r.plan is not None
    left, right = [c for c in r.plan.utterances[0].controls if c.kind == "pose"]
    assert right.stroke_frame - right.word_frame >= 2 and left.stroke_frame == left.word_frame  # resolved as with estimates


def test_unknown_voice_points_at_the_directive(tmp_path, lib):
    path = tmp_path / "s.sgt"
    path.write_text("@voice en-uss\nhello there\n")
    r = compile_file(path, timing="speech", library=lib, cache_dir=tmp_path / "cache")
    (d,) = r.diagnostics
    assert d.is_error and (d.line, d.col) == (1, 8)
    assert "'en-us'" in d.hint  # the fix: the nearest voice


def test_recording_with_json_timings_and_a_mismatch(tmp_path, lib):
    import json

    import numpy as np
    import soundfile as sf

    sf.write(tmp_path / "rec.wav", np.zeros(16000 * 2, np.float32), 16000)
    words = [{"word": "hello", "start": 0.2, "end": 0.6}, {"word": "there", "start": 0.7, "end": 1.2}]
    (tmp_path / "rec.json").write_text(json.dumps(words))
    path = tmp_path / "s.sgt"
    path.write_text("@audio rec.wav timings=rec.json\nbot: Hello [pose:nod] there.\n")
    r = compile_file(path, timing="speech", library=lib, cache_dir=tmp_path / "cache")
    assert r.ok, r.diagnostics
    u = r.plan.utterances[0]
    assert [round(w.start - u.lead_in, 3) for w in u.words] == [0.2, 0.7]
    assert u.speech["audio"] == "rec.wav" and u.speech["timings"] == "rec.json"
    path.write_text("@audio rec.wav timings=rec.json\nbot: Hello [pose:nod] where.\n")
    r = compile_file(path, timing="speech", library=lib, cache_dir=tmp_path / "cache")
    (d,) = r.diagnostics
    assert d.is_error and (d.line, d.col) == (2, 23) and "where" in d.message and "0.7" in d.message


def test_cli_say_writes_wavs_and_prints_the_table(tmp_path, capsys, monkeypatch):
    import soundfile as sf

    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "s.sgt"
    path.write_text("a: [pose:wave] Hello world.\nb: Second line here.\n")
    assert cli.main(["say", str(path), "-o", str(tmp_path / "wav")]) == 0
    out = capsys.readouterr().out
    assert "Hello" in out and "Second" in out
    wavs = sorted((tmp_path / "wav").glob("*.wav"))
    assert len(wavs) == 2
    assert cli.main(["say", str(path), "-o", str(tmp_path / "wav"), "--json", "--utterance", "1"]) == 0
    data = json.loads(capsys.readouterr().out)
    (u,) = data
    assert 0 <= u["words"][0]["start"] < 0.2  # audio time: no gesture lead-in in the table
    assert u["words"][-1]["end"] <= sf.info(wavs[0]).duration + 1e-6
