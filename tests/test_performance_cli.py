"""The performance clock on the command line: generate (tracks, --threads), export per speaker
(timeline sidecar, CSV utterance column), say --mix, render to MP4 with the speech in sync."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess

import numpy as np
import pytest

from core.motion import VERSION, load_motion_file
from core.skeleton import FPS

SCRIPT = """@seed 2
@gap 800ms
guide: Hello there, [pose:wave] welcome to the mall.
visitor: Thanks! Where is the cinema?
guide: It is [pose:point_right] over there.
"""


def _main(argv) -> int:
    from sgt_tui.cli import main

    return main([str(a) for a in argv])


@pytest.fixture(scope="module")
def take(tmp_path_factory):
    """A two-speaker script and its generated take (rules engine, real speech timing)."""
    d = tmp_path_factory.mktemp("take")
    script = d / "dialogue.sgt"
    script.write_text(SCRIPT)
    out = d / "take.json"
    assert _main(["generate", script, "-o", out, "--engine", "rules"]) == 0
    return script, out


def test_generate_writes_the_clock_and_one_track_per_speaker(take):
    script, out = take
    doc = json.loads(out.read_text())
    assert doc["version"] == VERSION == 3 and doc["source"] == "dialogue.sgt"  # 3: with the face
    assert [t["speaker"] for t in doc["tracks"]] == ["guide", "visitor"]
    assert all(len(t["poses"]) == doc["frames"] for t in doc["tracks"])
    starts = [u["start"] for u in doc["utterances"]]
    assert starts[0] == 0 and starts == sorted(starts)
    assert all(u["audio_offset"] >= 0 for u in doc["utterances"])


def test_export_writes_one_file_per_speaker_and_a_timeline(take, tmp_path, capsys):
    _, motion = take
    whole = load_motion_file(motion)
    assert _main(["export", motion, "-o", tmp_path / "t.bvh"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.bvh.timeline.json", "t.guide.bvh", "t.visitor.bvh"]
    for name in ("guide", "visitor"):
        assert f"Frames: {whole.tracks[0].n_frames}\n" in (tmp_path / f"t.{name}.bvh").read_text()
    timeline = json.loads((tmp_path / "t.bvh.timeline.json").read_text())
    assert timeline["files"] == {"guide": "t.guide.bvh", "visitor": "t.visitor.bvh"}
    assert [(u["speaker"], u["start_frame"], u["frames"]) for u in timeline["utterances"]] == [
        (c.speaker, c.start_frame, c.n_frames) for c in whole.clips]
    assert [u["audio_offset"] for u in timeline["utterances"]] == [round(c.audio_offset, 6) for c in whole.clips]

    assert _main(["export", motion, "-o", tmp_path / "v.csv", "--speaker", "visitor"]) == 0
    with open(tmp_path / "v.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == whole.tracks[1].n_frames
    visitor = next(c for c in whole.clips if c.speaker == "visitor")
    column = [r["utterance"] for r in rows]
    expect = ["" for _ in rows]
    expect[visitor.start_frame: visitor.start_frame + visitor.n_frames] = [str(visitor.index)] * visitor.n_frames
    assert column == expect  # the visitor's one line, empty before and after it
    assert np.allclose(np.array([[float(r["right_wrist_x"]), float(r["right_wrist_y"]), float(r["right_wrist_z"])] for r in rows]),
                       whole.tracks[1].positions[:, -1], atol=1e-5)
    capsys.readouterr()
    assert _main(["export", motion, "-o", "-", "--format", "csv"]) == 2
    assert "2 speakers; name one with --speaker" in capsys.readouterr().err
    assert _main(["export", motion, "-o", tmp_path / "x.bvh", "--speaker", "nobody"]) == 2
    assert "no such speaker" in capsys.readouterr().err and not (tmp_path / "x.bvh").exists()


def test_export_with_a_rig_writes_per_speaker_files(take, tmp_path):
    _, motion = take
    assert _main(["export", motion, "-o", tmp_path / "t.glb", "--rig", "vrm"]) == 0
    assert {p.name for p in tmp_path.iterdir()} == {"t.guide.glb", "t.visitor.glb", "t.glb.timeline.json"}


def test_say_mix_is_the_performance_on_the_motion_clock(take, tmp_path):
    import soundfile as sf

    script, motion = take
    whole = load_motion_file(motion)
    mix_path = tmp_path / "mix.wav"
    assert _main(["say", script, "-o", tmp_path / "speech", "--mix", mix_path, "--json"]) == 0
    audio, rate = sf.read(str(mix_path), dtype="float32")
    n_frames = whole.tracks[0].n_frames
    assert abs(len(audio) / rate - n_frames / FPS) <= 1 / FPS
    # every utterance's speech starts where the motion file says, and the gaps are silent
    loud = np.abs(audio) > 0.02
    for c in whole.clips:
        at = int((c.start + c.audio_offset) * rate)
        lo = max(0, at - int(0.3 * rate))
        first = lo + int(np.argmax(loud[lo:]))
        assert abs(first - at) / rate < 0.08, (c.text, first / rate, at / rate)
        assert not loud[lo:first].any()  # silence before it
    # the per-utterance WAVs stay
    assert len(list((tmp_path / "speech").glob("*.wav"))) == 3


def test_say_mix_needs_a_wav(tmp_path, capsys):
    script = tmp_path / "a.sgt"
    script.write_text("guide: hello\n")
    assert _main(["say", script, "--mix", tmp_path / "m.mp3"]) == 2
    assert "expected a .wav file" in capsys.readouterr().err


def _decode(path):
    av = pytest.importorskip("av")
    with av.open(str(path)) as c:
        video = [(float(f.time), f.to_ndarray(format="rgb24")) for f in c.decode(video=0)]
    with av.open(str(path)) as c:
        frames = [(float(f.time), f.to_ndarray().reshape(-1)) for f in c.decode(audio=0)]
        rate = c.streams.audio[0].sample_rate
    start = frames[0][0]
    audio = np.concatenate([a for _, a in frames])
    return video, audio, rate, start


def _ffprobe(path) -> dict:
    out = subprocess.run(["ffprobe", "-v", "error", "-show_streams", "-of", "json", str(path)],
                         capture_output=True, text=True, check=True).stdout
    return {s["codec_type"]: s for s in json.loads(out)["streams"]}


@pytest.fixture(scope="module")
def video(take, tmp_path_factory):
    _, motion = take
    path = tmp_path_factory.mktemp("video") / "take.mp4"
    code = _main(["render", motion, "-o", path, "--size", "160x160", "--speaker", "guide"])
    if code and not path.exists():  # pragma: no cover - machines without offscreen GL
        pytest.skip("no offscreen GL")
    assert code == 0
    return path


def test_the_word_overlay_and_its_audio_start_within_one_frame(take, video):
    """Each utterance's first word after a silence: the first frame that shows it in the
    overlay and the first loud audio sample are at most one frame apart."""
    whole = load_motion_file(take[1])
    frames, audio, rate, start = _decode(video)
    assert abs(start) < 1e-6 and abs(frames[0][0]) < 1e-6
    strip = np.array([img[2:30, 50:110].min(axis=-1) for _, img in frames])  # where the word is drawn
    shows_word = (strip < 80).sum(axis=(1, 2)) > 5  # dark text in the top middle
    loud = np.abs(audio) > 0.05
    after_silence = [c for c in whole.clips if c.speaker == "guide" and c.start + c.audio_offset > 0.5]
    assert after_silence
    for c in after_silence:
        speech = c.start + c.audio_offset
        f0 = int(speech * FPS) - 5  # from a little before the speech (the gap is silent)
        first_frame = f0 + int(np.argmax(shows_word[f0:]))
        assert shows_word[first_frame] and not shows_word[f0]
        a0 = int((speech - 0.3) * rate)
        onset = (a0 + int(np.argmax(loud[a0:]))) / rate
        assert abs(first_frame / FPS - onset) <= 1 / FPS, (c.text, first_frame / FPS, onset)


@pytest.mark.skipif(shutil.which("ffprobe") is None, reason="ffprobe (Debian's ffmpeg) is not installed")
def test_ffprobe_sees_15_fps_video_and_audio_as_long_as_the_take(take, video):
    whole = load_motion_file(take[1])
    streams = _ffprobe(video)
    n = whole.tracks[0].n_frames
    assert streams["video"]["codec_name"] == "h264" and streams["video"]["avg_frame_rate"] == "15/1"
    assert int(streams["video"]["nb_frames"]) == n
    assert streams["audio"]["codec_name"] == "aac"
    assert abs(float(streams["audio"]["duration"]) - n / FPS) <= 1 / FPS


def test_render_from_the_script_shows_every_speaker_side_by_side(take, tmp_path):
    script, _ = take
    path = tmp_path / "both.mp4"
    code = _main(["render", script, "-o", path, "--size", "64x64", "--engine", "rules"])
    if code and not path.exists():  # pragma: no cover
        pytest.skip("no offscreen GL")
    frames, audio, rate, _ = _decode(path)
    assert frames[0][1].shape[:2] == (64, 128)  # two panels
    assert np.abs(audio).max() > 0.1


def test_a_video_needs_the_script_of_the_take(take, tmp_path, capsys):
    _, motion = take
    moved = tmp_path / "elsewhere.json"
    moved.write_text(motion.read_text())  # "source" is relative: the script is not beside it now
    assert _main(["render", moved, "-o", tmp_path / "x.mp4", "--size", "32x32"]) == 1
    err = capsys.readouterr().err
    assert "which is not there any more" in err and "Traceback" not in err
    assert not (tmp_path / "x.mp4").exists()


def test_threads_option(tmp_path, capsys):
    import torch

    from model.neural import DEFAULT_THREADS, use_threads

    use_threads(None)
    assert torch.get_num_threads() == DEFAULT_THREADS
    use_threads(2)
    assert torch.get_num_threads() == 2
    use_threads(None)
    script = tmp_path / "a.sgt"
    script.write_text("guide: hello\n")
    assert _main(["generate", script, "-o", tmp_path / "a.json", "--threads", "0"]) == 2
    assert "--threads" in capsys.readouterr().err
