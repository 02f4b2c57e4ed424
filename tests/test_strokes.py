"""What you mark is what ships (issue 22): on the speakers' tracks that render, export, build
and serve hand on, every pose control's stroke is its gesture's stroke pose (within 3
degrees on the bones it drives) on the onset of its word (within 2 frames, or a warning
says why and how to fix it), and no bone turns faster than 900 degrees per second.

Checked over 200 scripts (the examples, the cases of the issue, generated ones with
back-to-back gestures, lines that open with a gesture, fast styles and counted lists;
tests/strokes.py) through every output path: `generate` (each engine), `sgt build` and
`sgt serve` read back as files and answers, and an exported BVH read by bvhio. The last test
takes the pose-control pass off the tracks and sees the check fail.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import strokes

from core.motion import load_motion_file
from dsl.compiler import compile_file
from library import load_library
from model import generate as generate_module
from model.generate import generate
from model.performance import Exact

SCRIPTS = strokes.scripts()


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


def _take_problems(text: str, engine: str, lib) -> list[str]:
    take = generate(source=text, engine=engine, timing="estimate", library=lib)
    return strokes.check(take.clips, take.tracks, lib, strokes.warned_marks(take.diagnostics))


def test_there_are_200_scripts_of_every_kind():
    assert len(SCRIPTS) >= 200
    texts = [t for _, t in SCRIPTS]
    assert sum("count_three" in t for t in texts) >= 20  # counted lists
    assert sum(any(line.split(": ", 1)[-1].startswith("[pose:") for line in t.splitlines()) for t in texts) >= 50
    assert sum("<speed:+3" in t for t in texts) >= 10


@pytest.mark.parametrize("engine", ["neural", "rules", "keyframe"])
def test_every_stroke_is_on_its_word_on_the_track(engine, lib):
    scripts = SCRIPTS if engine == "neural" else SCRIPTS[::5]  # the default engine on all of them
    problems = [f"{name}: {p}" for name, text in scripts for p in _take_problems(text, engine, lib)]
    assert not problems, "\n".join(problems[:20])


def test_the_strokes_are_checked_for_real(lib):
    """Every script has strokes to check, and late strokes occur (with their warnings)."""
    controls = warned = 0
    for _, text in SCRIPTS:
        result = compile_file("<s>.sgt", source=text, timing="estimate", library=lib)
        controls += sum(1 for u in result.plan.utterances for c in u.controls if c.stroke_frame is not None)
        warned += len(strokes.warned_marks(result.diagnostics))
    assert controls > 1500 and warned > 0


def test_taking_the_pose_controls_off_the_tracks_fails_the_check(monkeypatch, lib):
    """The track assembly reverted (eases and listening motion as they are, no pose-control
    pass over the tracks): strokes are missed by many degrees."""
    monkeypatch.setattr(generate_module, "exact_for", lambda engine, options=None: Exact(blend=False))
    problems = [p for _, text in SCRIPTS[:40] for p in _take_problems(text, "neural", lib)]
    assert sum("degrees from its pose" in p for p in problems) > 20


def test_build_outputs_keep_the_strokes(tmp_path, lib):
    from sgt_tui.cli import main

    src = tmp_path / "src"
    src.mkdir()
    chosen = SCRIPTS[::8]
    for name, text in chosen:
        (src / f"{name.replace('.sgt', '')}.sgt").write_text(text)
    assert main(["build", str(src), "-o", str(tmp_path / "out"), "--engine", "keyframe", "--quiet",
                 "--cache", str(tmp_path / "cache")]) == 0
    for name, text in chosen:
        motion = load_motion_file(tmp_path / "out" / f"{name.replace('.sgt', '')}.json")
        warned = strokes.warned_marks(compile_file(src / f"{name.replace('.sgt', '')}.sgt", timing="speech",
                                                   library=lib).diagnostics)
        problems = strokes.check(motion.clips, motion.tracks, lib, warned)
        assert not problems, (name, problems[:5])


def test_service_answers_keep_the_strokes(tmp_path, lib):
    from fastapi.testclient import TestClient

    from sgt_tui.serve.app import create_app
    from sgt_tui.serve.config import ServeConfig, checked

    with TestClient(create_app(checked(ServeConfig(max_text=20_000)))) as api:
        for name, text in SCRIPTS[::10]:
            r = api.post("/v1/generate", json={"script": text, "timing": "estimate"})
            assert r.status_code == 200, (name, r.text[:300])
            answer = r.json()
            (tmp_path / "answer.json").write_text(json.dumps(answer["motion"]))
            motion = load_motion_file(tmp_path / "answer.json")
            warned = {(d["line"], d["col"]) for d in answer["diagnostics"] if d.get("code") == "SGT401"}
            problems = strokes.check(motion.clips, motion.tracks, lib, warned)
            assert not problems, (name, problems[:5])


def test_an_exported_bvh_read_by_bvhio_keeps_the_strokes(tmp_path, lib):
    """The rotations written for another tool put every driven bone at its gesture's stroke
    pose at every stroke frame, as bvhio's own forward kinematics reads the file."""
    from rig_readers import read_bvh_bvhio

    from core.skeleton import BONES, bone_angles
    from renders.clips import track_clip
    from renders.export import write_bvh

    checked = 0
    for name, text in SCRIPTS[3:60:6]:
        take = generate(source=text, engine="neural", timing="estimate", library=lib)
        for track in take.tracks:
            path = tmp_path / "t.bvh"
            write_bvh(path, track_clip(track, take.clips))
            heads = read_bvh_bvhio(path)["heads"]
            dirs = np.stack([heads[child] - heads[parent] for parent, child in BONES], axis=1)  # (T, 9, 3)
            read = dirs.reshape(len(dirs), -1)
            for c in take.clips:
                if c.speaker != track.speaker:
                    continue
                for k in c.controls:
                    if k.stroke_frame is None:
                        continue
                    opts = k.options
                    clip = lib.get(k.name).clip(speed=opts["speed"], flip=opts["flip"], hold=opts.get("hold", 0.0))
                    off = bone_angles(read[c.start_frame + k.stroke_frame], clip.poses[clip.stroke_frame])
                    assert off[np.asarray(clip.bones, bool)].max() <= strokes.MAX_STROKE_DEG, (name, k.name, off)
                    checked += 1
    assert checked > 30
