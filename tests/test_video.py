"""MP4 with sound (renders/video.py): 15 fps H.264 + AAC, audio sample 0 plays with frame 0."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

av = pytest.importorskip("av")

from renders.video import VideoError, encode_mp4  # noqa: E402

SR = 22050


def _decode(path):
    """Video frames as (presentation time, image); audio as (presentation time, sample) chunks,
    timed by the container's timestamps as a player does."""
    with av.open(str(path)) as c:
        video = [(float(f.time), f.to_ndarray(format="rgb24")) for f in c.decode(video=0)]
    with av.open(str(path)) as c:
        audio = [(float(f.time), f.to_ndarray().reshape(-1)) for f in c.decode(audio=0)]
    return video, audio


def _onset(audio, threshold=0.1) -> float:
    for t, samples in audio:
        loud = np.flatnonzero(np.abs(samples) > threshold)
        if len(loud):
            return t + loud[0] / SR
    raise AssertionError("no sound")


@pytest.mark.parametrize("flash", [7, 20, 33])
def test_a_sound_and_a_flash_on_the_same_frame_stay_together(tmp_path, flash):
    n = 45
    frames = [np.full((96, 98, 3), 250 if i == flash else 20, np.uint8) for i in range(n)]
    audio = np.zeros(int(n / 15 * SR), np.float32)
    a = int(flash / 15 * SR)
    audio[a : a + 1500] = 0.5 * np.sin(np.arange(1500) * 0.3)
    path = tmp_path / "t.mp4"
    path.write_bytes(encode_mp4(frames, audio=audio, sample_rate=SR))
    video, decoded = _decode(path)
    assert len(video) == n
    bright = [t for t, img in video if img.mean() > 128]
    onset = _onset(decoded)
    assert len(bright) == 1 and abs(bright[0] - flash / 15) < 1e-6
    assert abs(onset - bright[0]) < 1 / 15  # within one frame


def test_without_audio_and_odd_sizes(tmp_path):
    frames = (np.zeros((31, 45, 3), np.uint8) for _ in range(10))  # an iterator: streamed
    path = tmp_path / "silent.mp4"
    path.write_bytes(encode_mp4(frames))
    with av.open(str(path)) as c:
        assert [s.type for s in c.streams] == ["video"]
        assert c.streams.video[0].width == 46 and c.streams.video[0].height == 32


def test_no_frames_is_an_error():
    with pytest.raises(VideoError, match="no frames"):
        encode_mp4([])


@pytest.mark.skipif(shutil.which("ffprobe") is None, reason="ffprobe (Debian's ffmpeg) is not installed")
def test_ffprobe_reads_15_fps_video_and_audio_of_the_same_length(tmp_path):
    n = 60
    frames = [np.full((64, 64, 3), i * 4, np.uint8) for i in range(n)]
    audio = 0.1 * np.sin(np.arange(int(n / 15 * SR)) * 0.05).astype(np.float32)
    path = tmp_path / "p.mp4"
    path.write_bytes(encode_mp4(frames, audio=audio, sample_rate=SR))
    out = subprocess.run(["ffprobe", "-v", "error", "-show_streams", "-of", "json", str(path)],
                         capture_output=True, text=True, check=True).stdout
    streams = {s["codec_type"]: s for s in json.loads(out)["streams"]}
    assert streams["video"]["codec_name"] == "h264" and streams["video"]["avg_frame_rate"] == "15/1"
    assert int(streams["video"]["nb_frames"]) == n
    assert streams["audio"]["codec_name"] == "aac"
    assert abs(float(streams["audio"]["duration"]) - n / 15) < 1 / 15
    assert abs(float(streams["video"]["duration"]) - n / 15) < 1e-6


def test_the_same_frames_give_the_same_bytes_every_time():
    """The same frames and sound, encoded again and again in one process with other videos
    encoded in between (as an editor or a service does): the same file every time. x264's
    AVX-512 shortcuts made the result depend on what the encodes before had left in memory
    (here: 6 different files in 20); :data:`renders.video.X264_OPTIONS` keeps to its canonical
    code."""
    from fractions import Fraction

    rng = np.random.default_rng(1)
    base = (rng.random((96, 192, 3)) * 255).astype(np.uint8)
    frames = [np.roll(base, i, axis=1) for i in range(183)]
    sound = (rng.random(SR * 13) - 0.5).astype(np.float32) * 0.2

    def another_video():
        cc = av.CodecContext.create("libx264", "w")
        cc.width, cc.height, cc.pix_fmt, cc.time_base = 192, 96, "yuv420p", Fraction(1, 15)
        cc.options = {"crf": "30", "preset": "veryfast"}
        for i, a in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(a, format="rgb24")
            frame.pts = i
            cc.encode(frame)
        cc.encode()

    files = set()
    for _ in range(20):
        files.add(encode_mp4(iter(frames), audio=sound, sample_rate=SR))
        another_video()
    assert len(files) == 1
