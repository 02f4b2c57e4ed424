"""The compiler: timing -> controls -> plan and control arrays (estimated timing: no engine)."""

import json

import numpy as np
import pytest

from core.controls import STYLE_INDEX
from core.skeleton import FPS, seconds_to_frame
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
    assert np.allclose(u.arrays.pose[c.start_frame : c.end_frame], clip.poses)
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
    assert np.allclose(u.arrays.pose[c.start_frame : c.end_frame], clip.poses)
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


def test_overlapping_poses_warn_with_estimated_timing(tmp_path, lib):
    r = build(tmp_path, "look [pose:point_right] here [pose:point_left] and there now\n", lib)
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    assert d.severity == "warning" and "point_left" in d.message and "point_right" in d.message
    assert (d.line, d.col) == (1, 30)
    (other,) = d.related  # the other gesture is a related span, not text in the message
    assert (other.line, other.col) == (1, 6) and "line 1" not in d.message


def _pose_frames(u, lib, index, name):
    """(natural start frame, stroke frame, clip) of the pose control anchored to word ``index``."""
    clip = lib.get(name).clip()
    return seconds_to_frame(u.words[index].start) - clip.stroke_frame, clip.stroke_frame, clip


def test_overlap_the_later_gesture_waits_for_the_earlier_stroke(tmp_path, lib):
    # point_left would start before point_right's stroke is done: it waits until then, and
    # point_right's retraction is cut there.
    r = build(tmp_path, "look [pose:point_right] here [pose:point_left] and there now\n", lib)
    assert r.ok and r.plan is not None  # a warning: same verdict as with any timing
    u = r.plan.utterances[0]
    right_start, right_stroke, right_clip = _pose_frames(u, lib, 1, "point_right")
    left_start, _, left_clip = _pose_frames(u, lib, 2, "point_left")
    assert left_start < right_start + right_stroke + 1  # the case this test is about
    right, left = [c for c in u.controls if c.kind == "pose"]
    keep = right_start + right_stroke + 1
    assert (right.start_frame, right.end_frame) == (right_start, keep)
    assert (left.start_frame, left.end_frame) == (keep, keep + len(left_clip.poses))
    a = u.arrays
    assert np.allclose(a.pose[right_start:keep], right_clip.poses[: keep - right_start])
    assert np.allclose(a.pose[keep : keep + len(left_clip.poses)], left_clip.poses)
    assert a.pose_mask.sum() == (keep - right_start) + len(left_clip.poses)
    assert u.n_frames >= left.end_frame
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    assert f"waits {keep - left_start} frames" in d.message


def test_a_gesture_that_waits_past_the_end_extends_the_utterance(tmp_path, lib):
    r = build(tmp_path, "[pose:point_right] [pose:point_left] hi\n", lib)  # both on the only word
    u = r.plan.utterances[0]
    right, left = [c for c in u.controls if c.kind == "pose"]
    clip = lib.get("point_left").clip()
    assert left.start_frame == right.end_frame and left.end_frame - left.start_frame == len(clip.poses)
    assert u.n_frames == left.end_frame > seconds_to_frame(u.words[-1].end)  # nothing is cut
    assert np.allclose(u.arrays.pose[left.start_frame : left.end_frame], clip.poses)
    assert u.arrays.pose_mask.sum() == (right.end_frame - right.start_frame) + len(clip.poses)
    assert u.speech["tail"] > 0 and u.duration == u.n_frames / FPS  # the motion runs on after the speech


def test_overlap_after_the_stroke_cuts_the_earlier_retraction(tmp_path, lib):
    r = build(tmp_path, "look [pose:point_right] here and [pose:nod] there now more\n", lib)
    assert r.ok
    u = r.plan.utterances[0]
    right_start, right_stroke, right_clip = _pose_frames(u, lib, 1, "point_right")
    nod_start, _, nod_clip = _pose_frames(u, lib, 3, "nod")
    assert right_start + right_stroke < nod_start < right_start + len(right_clip.poses)  # the case
    right, nod = [c for c in u.controls if c.kind == "pose"]
    assert (right.start_frame, right.end_frame) == (right_start, nod_start)  # cut where nod starts
    assert (nod.start_frame, nod.end_frame) == (nod_start, nod_start + len(nod_clip.poses))  # on its word
    assert np.allclose(u.arrays.pose[right_start:nod_start], right_clip.poses[: nod_start - right_start])
    assert np.allclose(u.arrays.pose[nod_start : nod.end_frame], nod_clip.poses)
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    assert "cut after its stroke" in d.message


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
    path.write_text("look [pose:point_right] here [pose:point_left] and there now\n")
    r = compile_file(path, timing="speech", library=lib, cache_dir=tmp_path / "cache")
    (d,) = [d for d in r.diagnostics if d.name == "overlap"]
    assert d.severity == "warning" and r.ok and r.plan is not None
    poses = sorted((c.start_frame, c.end_frame) for c in r.plan.utterances[0].controls if c.kind == "pose")
    assert all(a[1] <= b[0] for a, b in zip(poses, poses[1:]))  # resolved: nothing overlaps


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
    assert cli.main(["say", str(path), "-o", str(tmp_path / "wav"), "--json", "--utterance", "0"]) == 0
    data = json.loads(capsys.readouterr().out)
    (u,) = data
    assert 0 <= u["words"][0]["start"] < 0.2  # audio time: no gesture lead-in in the table
    assert u["words"][-1]["end"] <= sf.info(wavs[0]).duration + 1e-6
