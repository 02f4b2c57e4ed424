"""The keyframe engine (SGToolkit's MANUAL condition) and generate_clips."""

import numpy as np
import pytest

from core.controls import ControlArrays
from core.skeleton import REST_POSE
from library import load_library
from model.generate import GenerateError, clips_from_plan, engine_function
from model.keyframe import generate


def test_passes_through_every_key_and_is_smooth_and_unit():
    lib = load_library(use_config=False)
    clip = lib.get("point_right").clip().poses
    a = ControlArrays.empty(60)
    a.set_pose(20, clip)
    out = generate(a)
    assert out.shape == (60, 27)
    assert np.allclose(out[20 : 20 + len(clip)], clip, atol=1e-6)
    assert np.allclose(out[0], REST_POSE, atol=1e-6) and np.allclose(out[-1], REST_POSE, atol=1e-6)
    norms = np.linalg.norm(out.reshape(60, 9, 3), axis=-1)
    assert np.allclose(norms, 1, atol=1e-5)
    step = np.abs(np.diff(out, axis=0)).max()
    assert step < 0.6


def test_no_controls_is_the_mean_pose():
    out = generate(ControlArrays.empty(10))
    assert np.allclose(out, REST_POSE)


def test_unknown_engine_is_refused():
    with pytest.raises(GenerateError):
        engine_function("magic")


def test_clips_from_plan(tmp_path):
    from dsl.compiler import compile_file

    p = tmp_path / "s.sgt"
    p.write_text("bot: look [pose:point_left] at that one over there, please\n")
    plan = compile_file(p, timing="estimate").plan
    (clip,) = clips_from_plan(plan, engine="keyframe")
    u = plan.utterances[0]
    assert clip.poses.shape == (u.n_frames, 27) and clip.positions.shape == (u.n_frames, 10, 3)
    assert clip.speaker == "bot" and clip.words[0].word == "look"
    bones = np.repeat(u.arrays.bones() > 0.5, 3, axis=1)  # point_left drives the right arm only
    assert bones.any() and not bones.all()
    assert np.allclose(clip.poses[bones], u.arrays.pose[bones], atol=1e-6)
