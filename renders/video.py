"""MP4 video with sound: H.264 frames at the motion's frame rate, the speech as an AAC track.

PyAV (``av`` on PyPI) brings FFmpeg's encoders inside its wheel, so nothing else needs to be
installed. The audio is on the motion clock: sample 0 plays with frame 0 (the caller mixes
the performance's speech at its offsets, see :func:`renders.audio_mix`), and the container's
time bases say so (no edit lists, no encoder delay: the first video frame and the first
audio sample both have pts 0).

Frames come one at a time from an iterator of RGB images (numpy uint8 (H, W, 3) or PIL
images), so memory does not grow with the length of the take; the encoded file is written
atomically at the end.
"""

from __future__ import annotations

import io
from fractions import Fraction
from typing import Iterable

import numpy as np

from core.fileio import atomic_write
from core.interrupts import import_optional
from core.skeleton import FPS

#: H.264 quality: constant rate factor (lower is better; 23 is x264's default).
CRF = 23
#: x264's settings besides the quality: the same bytes from the same frames, every time and on
#: any machine. ``cpu-independent``: x264's own code for its CPU-specific shortcuts (the
#: macroblock-tree propagation, the nine-way intra searches); their AVX-512 versions gave
#: results that depended on what earlier allocations had left in memory (the same frames
#: encoded 250 times in one process: 61 different files, the first difference at a random
#: frame; none with ``cpu-independent`` or with AVX-512 masked off). One thread: x264's slices
#: follow its thread count, which by default follows the machine's cores (the render's frame
#: workers use the other cores).
X264_OPTIONS = {"preset": "veryfast", "x264-params": "cpu-independent=1"}
X264_THREADS = 1


class VideoError(Exception):
    """The video could not be encoded (a one-line message for users)."""


def _even(n: int) -> int:
    return n + (n % 2)


def encode_mp4(frames: Iterable, *, audio: np.ndarray | None = None, sample_rate: int | None = None,
               fps: int = FPS, n_frames: int | None = None, progress=None) -> bytes:
    """The bytes of an MP4 of ``frames`` (RGB) at ``fps``, with mono ``audio`` (float in [-1, 1])
    starting with frame 0. The audio is cut or padded with silence to the video's length, so
    both streams end together."""
    try:
        av = import_optional("av")  # lazy: PyAV (FFmpeg) is only needed for videos
    except ImportError as exc:  # a broken install: say what to install
        raise VideoError(f"MP4 needs PyAV: pip install av ({exc})") from None
    buf = io.BytesIO()
    container = av.open(buf, mode="w", format="mp4")
    video = audio_stream = None
    count = 0
    try:
        for img in frames:
            arr = np.asarray(img, dtype=np.uint8)
            if arr.ndim != 3 or arr.shape[2] != 3:
                raise VideoError(f"frames must be RGB images, got shape {arr.shape}")
            if video is None:
                h, w = arr.shape[:2]
                video = container.add_stream("libx264", rate=Fraction(fps, 1))
                video.width, video.height = _even(w), _even(h)
                video.pix_fmt = "yuv420p"
                video.time_base = Fraction(1, fps)
                video.options = {"crf": str(CRF), **X264_OPTIONS}
                video.codec_context.thread_count = X264_THREADS
                if audio is not None:
                    audio_stream = container.add_stream("aac", rate=int(sample_rate))
                    audio_stream.layout = "mono"
                    audio_stream.time_base = Fraction(1, int(sample_rate))
            if arr.shape[0] != video.height or arr.shape[1] != video.width:
                pad = np.zeros((video.height, video.width, 3), np.uint8)
                pad[: arr.shape[0], : arr.shape[1]] = arr[: video.height, : video.width]
                arr = pad
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(arr), format="rgb24")
            frame.pts = count
            frame.time_base = Fraction(1, fps)
            for packet in video.encode(frame):
                container.mux(packet)
            count += 1
            if progress:
                progress(count, n_frames or count, "frames")
        if video is None:
            raise VideoError("no frames to encode")
        for packet in video.encode():
            container.mux(packet)
        if audio_stream is not None:
            _encode_audio(av, container, audio_stream, audio, int(sample_rate), count / fps)
    finally:
        container.close()
    return buf.getvalue()


def _encode_audio(av, container, stream, audio: np.ndarray, sample_rate: int, seconds: float) -> None:
    n = int(round(seconds * sample_rate))
    samples = np.zeros(n, np.float32)
    a = np.asarray(audio, np.float32).reshape(-1)[:n]
    samples[: len(a)] = np.clip(a, -1.0, 1.0)
    chunk = 1024  # AAC frame size
    for start in range(0, n, chunk):
        part = samples[start : start + chunk]
        frame = av.AudioFrame.from_ndarray(part[None, :], format="flt", layout="mono")
        frame.sample_rate = sample_rate
        frame.pts = start
        frame.time_base = Fraction(1, sample_rate)
        for packet in stream.encode(frame):
            container.mux(packet)
    for packet in stream.encode():
        container.mux(packet)


def write_mp4(path, frames: Iterable, **kw) -> dict:
    """Encode (see :func:`encode_mp4`) and write ``path`` atomically; returns a summary."""
    data = encode_mp4(frames, **kw)
    atomic_write(path, data)
    return {"bytes": len(data)}
