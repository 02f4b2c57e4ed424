"""Hostile files for training and motion, each made here by the test (nothing committed), each
given to the command a user runs, in a process of its own whose peak memory is measured
(``os.wait4``) and whose time is bounded:

- a checkpoint whose pickle would run code, a truncated one (and a real one still resumes);
- BVH takes that declare millions of frames, a frame count or a frame time that is not a
  number sgt can use, a NaN channel; a FIFO and a link to /dev/zero as a take; a take's audio
  at 1 Hz, or a FIFO;
- a training run whose loss diverges;
- NPZ motion files with a damaged deflate stream or a zip bomb (export, render, view), a
  matching database bomb, a corpus shard bomb.

Each answer is one line, no traceback, a non-zero exit, under :data:`PEAK_MIB` of memory.
"""

from __future__ import annotations

import io
import json
import os
import re
import struct
import subprocess
import sys
import tempfile
import wave
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from special_files import FifoWriter

from tests.test_loaders import body_bvh

ROOT = Path(__file__).resolve().parent.parent
#: The most memory a command may take on any of these inputs (a few KB to 9 MB), MiB.
PEAK_MIB = 1024
#: What a bomb would inflate to (more than PEAK_MIB: reading it whole fails the test).
BOMB_MIB = 1280

# -- running a command ------------------------------------------------------------------------


@dataclass
class Run:
    rc: int
    out: str
    err: str
    peak_mib: float


#: Runs the command given as its arguments and writes that command's peak resident memory (KiB,
#: ``RUSAGE_CHILDREN`` of this small process: a process forked from the test's own, which may
#: hold a gigabyte by the end of the suite, starts with that much resident) to the file in argv[1].
_LAUNCHER = ("import resource, subprocess, sys\n"
             "rc = subprocess.call(sys.argv[2:])\n"
             "open(sys.argv[1], 'w').write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))\n"
             "sys.exit(rc)\n")


def sgt(*args: str, cwd: Path, timeout: float = 60) -> Run:
    """``sgt ARGS`` in a process of its own: its exit status, output, and peak memory (measured
    by a launcher process, see :data:`_LAUNCHER`); killed, and the test failed, after ``timeout`` s."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, tempfile.TemporaryDirectory() as tmp:
        peak_file = Path(tmp) / "peak"
        proc = subprocess.Popen([sys.executable, "-c", _LAUNCHER, str(peak_file), sys.executable, "-m", "sgt_tui.cli", *args],
                                cwd=cwd, stdin=subprocess.DEVNULL, stdout=out, stderr=err, start_new_session=True,
                                env={**os.environ, "PYTHONPATH": str(ROOT), "SGT_CACHE_DIR": str(cwd / ".cache")})
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, 9)
            proc.wait()
            pytest.fail(f"sgt {' '.join(args)} still ran after {timeout} s")
        out.seek(0)
        err.seek(0)
        peak_kib = int(peak_file.read_text()) if peak_file.exists() else 0
        return Run(proc.returncode, out.read().decode(errors="replace"), err.read().decode(errors="replace"), peak_kib / 1024)


def refused(run: Run, *needles: str) -> str:
    """The one error line of a refused command, checked: a non-zero exit, no traceback, the
    needles in that line, memory under PEAK_MIB."""
    assert "Traceback" not in run.err, run.err[-3000:]
    errors = [line for line in run.err.splitlines() if "error:" in line]
    assert run.rc != 0 and len(errors) == 1, (run.rc, run.err[-3000:])
    assert run.peak_mib < PEAK_MIB, f"peak {run.peak_mib:.0f} MiB: {errors[0]}"
    for needle in needles:
        assert needle in errors[0], (needle, errors[0])
    return errors[0]


# -- training takes ---------------------------------------------------------------------------

TRAIN = ("--steps", "2", "--batch", "4", "--hidden", "32", "--no-gru", "--threads", "1")


def takes(folder: Path, first: str | None = None, n: int = 3) -> Path:
    """A folder of ``n`` BVH takes (GENEA layout, no audio); ``first`` replaces take0.bvh's text."""
    (folder / "Motion").mkdir(parents=True)
    for i in range(n):
        (folder / "Motion" / f"take{i}.bvh").write_text(body_bvh(n=121) if i or first is None else first)
    return folder


GOOD = body_bvh(n=31)
NO_CHANNELS = re.sub(r"\n\s*CHANNELS [^\n]*", "", GOOD).split("MOTION")[0]


def with_header(frames: str = "31", frame_time: str = "0.03333333") -> str:
    """The 31-frame take with its MOTION header's values replaced."""
    return re.sub(r"Frames: \S+\nFrame Time: \S+", f"Frames: {frames}\nFrame Time: {frame_time}", GOOD)


def nan_at(frame: int, column: int) -> str:
    """The take with value ``column`` of ``frame`` replaced by nan."""
    head, numbers = GOOD.split("Frame Time:")
    lines = numbers.splitlines()
    row = lines[1 + frame].split()
    row[column] = "nan"
    lines[1 + frame] = " ".join(row)
    return head + "Frame Time:" + "\n".join(lines) + "\n"


def deep_chain(links: int, frames: int) -> str:
    """A take whose neck hangs under ``links`` joints without channels (the root has one
    channel): forward kinematics of every joint would be ``links * frames`` joint-frames."""
    arms = "".join(f"JOINT {side}Arm {{ OFFSET {x} 0 0 JOINT {side}ForeArm {{ OFFSET {x} 0 0 "
                   f"JOINT {side}Hand {{ OFFSET {x} 0 0 }} }} }}\n" for side, x in (("Left", 15), ("Right", -15)))
    chain = "".join(f"JOINT link{i} {{ OFFSET 0 0.001 0\n" for i in range(links))
    return ("HIERARCHY\nROOT Hips { OFFSET 0 100 0 CHANNELS 1 Xposition\nJOINT Spine { OFFSET 0 20 0\n" + arms + chain
            + "JOINT Neck { OFFSET 0 10 0 JOINT Head { OFFSET 0 10 0 } }\n" + "}\n" * (links + 2)
            + f"MOTION\nFrames: {frames}\nFrame Time: 0.0333333\n" + "0\n" * frames)


def line_of_frame(frame: int) -> int:
    """The line (1-based) of ``frame`` in the take: the lines after 'Frame Time:'."""
    return [line.startswith("Frame Time:") for line in GOOD.splitlines()].index(True) + 2 + frame


#: (case, the take's text, what its error line says)
BVH_CASES = [
    # 1.2 KB declaring 3,000,000 frames of no channels: 6.8 GB of forward kinematics
    ("three_million_frames", NO_CHANNELS + "MOTION\nFrames: 3000000\nFrame Time: 0.0333333\n", ["no CHANNELS"]),
    ("frames_1e9_no_channels", NO_CHANNELS + "MOTION\nFrames: 1e9\nFrame Time: 0.0333333\n", ["no CHANNELS"]),
    # 20,000 links above the neck, 1,000 frames (730 KB): 20 million joint-frames, 1.9 GB computed for every joint
    ("deep_chain", deep_chain(20_000, 1_000), ["1000 frames of 20010 joints", "split the take"]),
    ("frames_1e9", with_header(frames="1e9"), ["frame count", "'1e9'"]),
    ("fractional_frames", with_header(frames="30.5"), ["frame count", "'30.5'"]),
    ("frames_beyond_the_numbers", with_header(frames="300000", frame_time="0.008333"), ["needs 12600000 numbers", "1302"]),
    ("frame_time_inf", with_header(frame_time="inf"), ["frame time", "'inf'"]),
    ("frame_time_1e300", with_header(frame_time="1e300"), ["frame time is 1e+300 s"]),
    ("frame_time_0", with_header(frame_time="0"), ["frame time is 0 s"]),
    ("frame_time_negative", with_header(frame_time="-0.03"), ["frame time is -0.03 s"]),
    # columns 18-20 are LeftShoulder's Zrotation Xrotation Yrotation (Hips has 6, the 4 joints before it 3 each)
    ("nan_channel", nan_at(5, 19), [f"take0.bvh:{line_of_frame(5)}: frame 5, Xrotation of joint 'LeftShoulder' is nan"]),
]


@pytest.mark.parametrize("case,text,said", BVH_CASES, ids=[c[0] for c in BVH_CASES])
def test_a_hostile_bvh_take_is_refused_in_one_line(tmp_path, case, text, said):
    data = takes(tmp_path / "data", first=text)
    line = refused(sgt("train", "--data", str(data), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN, cwd=tmp_path),
                   "take0.bvh", *said)
    assert not (tmp_path / "run" / "generator.pt").exists(), line


def test_a_nan_channel_builds_no_matching_database(tmp_path):
    """The matching engine's database of the takes (``--engine matching``) reads them the same way."""
    data = takes(tmp_path / "data", first=nan_at(3, 7))
    refused(sgt("train", "--engine", "matching", "--data", str(data), "-o", str(tmp_path / "db"), cwd=tmp_path),
            f"take0.bvh:{line_of_frame(3)}: frame 3", "is nan")
    assert not (tmp_path / "db" / "matching_db.npz").exists()


def test_a_fifo_or_a_link_to_dev_zero_as_a_take_is_refused_unread(tmp_path):
    data = takes(tmp_path / "data")
    fifo = data / "Motion" / "take0.bvh"
    fifo.unlink()
    writer = FifoWriter(fifo, GOOD.encode())  # even one that would give a good take
    try:
        refused(sgt("train", "--data", str(data), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN, cwd=tmp_path),
                "take0.bvh", "it is a FIFO (named pipe), not a file")
    finally:
        writer.close()
    fifo.unlink()
    fifo.symlink_to("/dev/zero")  # (read only: nothing here writes to a device)
    refused(sgt("train", "--data", str(data), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN, cwd=tmp_path),
            "take0.bvh", "it is a character device, not a file")


def wav(path: Path, rate: int, samples: int) -> None:
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(np.zeros(samples, "<i2").tobytes())


def test_a_takes_audio_at_1_hz_nan_or_a_fifo_is_refused(tmp_path):
    """A WAV saying 1 sample a second would be resampled into 16,000 times its samples (a
    400 KB file: 51 GB); a float WAV with a NaN sample made NaN speech features (a database of
    garbage); a FIFO named as a take's audio is refused, not skipped as no audio."""
    data = takes(tmp_path / "data")
    (data / "Audio").mkdir()
    wav(data / "Audio" / "take0.wav", 1, 200_000)
    refused(sgt("train", "--data", str(data), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN, cwd=tmp_path),
            "take0.wav", "sample rate of 1 Hz")
    import soundfile as sf

    samples = np.zeros(16_000, np.float32)
    samples[8_000] = np.nan  # a float WAV holds what it is given
    sf.write(data / "Audio" / "take0.wav", samples, 16_000, subtype="FLOAT")
    refused(sgt("train", "--engine", "matching", "--data", str(data), "-o", str(tmp_path / "db"), cwd=tmp_path),
            "take0.wav: at 0.500 s a sample is nan")
    (data / "Audio" / "take0.wav").unlink()
    os.mkfifo(data / "Audio" / "take0.wav")
    refused(sgt("train", "--data", str(data), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN, cwd=tmp_path),
            "take0.wav", "FIFO")


def test_a_diverging_loss_stops_training_without_weights(tmp_path):
    """A loss that is no longer a number stops the run before the step that would spoil the
    weights; nothing is written and no weights path is printed."""
    data = takes(tmp_path / "data")
    line = refused(sgt("train", "--data", str(data), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN,
                       "--style-weight", "1e308", cwd=tmp_path),
                   "training diverged in epoch 1, step 1", "no weights were written")
    assert "weights:" not in line and not list((tmp_path / "run").glob("*.pt"))


# -- checkpoints ------------------------------------------------------------------------------


class Payload:
    """What a hostile checkpoint holds: unpickled, it creates ``marker``."""

    def __init__(self, marker: Path) -> None:
        self.marker = str(marker)

    def __reduce__(self):
        return open, (self.marker, "w")


def test_a_checkpoint_that_would_run_code_is_refused_and_nothing_runs(tmp_path):
    import torch

    data = takes(tmp_path / "data")
    run, marker = tmp_path / "run", tmp_path / "ran"
    run.mkdir()
    torch.save({"model": Payload(marker), "epoch": 1}, run / "checkpoint.pt")
    answer = sgt("train", "--data", str(data), "-o", str(run), "--epochs", "1", *TRAIN, cwd=tmp_path)
    assert not marker.exists()
    refused(answer, "checkpoint.pt", "nothing in it ran", "--fresh")


def test_a_truncated_checkpoint_is_refused_in_one_line(tmp_path):
    import torch

    data = takes(tmp_path / "data")
    run = tmp_path / "run"
    run.mkdir()
    buf = io.BytesIO()
    torch.save({"model": {"w": torch.zeros(20_000)}, "epoch": 1}, buf)
    (run / "checkpoint.pt").write_bytes(buf.getvalue()[: len(buf.getvalue()) // 2])
    refused(sgt("train", "--data", str(data), "-o", str(run), "--epochs", "1", *TRAIN, cwd=tmp_path),
            "checkpoint.pt", "truncated", "--fresh")


def test_a_real_checkpoint_still_resumes(tmp_path):
    """What train saves (state dicts, numpy's random states, the settings) loads weights-only."""
    data = takes(tmp_path / "data")
    run = tmp_path / "run"
    first = sgt("train", "--data", str(data), "-o", str(run), "--epochs", "2", "--minutes", "0.00001", *TRAIN, cwd=tmp_path)
    assert first.rc == 0 and "after epoch 1" in first.err, first.err
    second = sgt("train", "--data", str(data), "-o", str(run), "--epochs", "2", *TRAIN, cwd=tmp_path)
    assert second.rc == 0 and f"resumed from {run / 'checkpoint.pt'} after epoch 1" in second.err, second.err
    assert [json.loads(line)["epoch"] for line in (run / "metrics.jsonl").read_text().splitlines()] == [1, 2]


# -- NPZ archives -----------------------------------------------------------------------------


def npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, array, allow_pickle=False)
    return buf.getvalue()


def zip_of(members: list[tuple[str, int, bytes, int, int]]) -> bytes:
    """A zip archive of (name, method, data as stored, CRC-32, size inflated), written by hand:
    zipfile cannot store a deflate stream made elsewhere."""
    out, central = bytearray(), bytearray()
    for name, method, data, crc, size in members:
        offset, raw = len(out), name.encode()
        out += struct.pack("<4s5H3L2H", b"PK\x03\x04", 20, 0, method, 0, 0x21, crc, len(data), size, len(raw), 0)
        out += raw + data
        central += struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 20, 20, 0, method, 0, 0x21, crc, len(data), size,
                               len(raw), 0, 0, 0, 0, 0, offset) + raw
    start = len(out)
    out += central + struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, len(members), len(members), len(central), start, 0)
    return bytes(out)


def bomb(name: str, mib: int = BOMB_MIB) -> tuple[str, int, bytes, int, int]:
    """A member ``name`` holding ``mib`` MiB of float32 zeros in about 1 KB per MiB: one deflated
    MiB of zeros repeated (each ends on a full flush, so copies of it chain into one stream).
    Its CRC is left 0: readers check it only once everything is inflated, too late."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False, "shape": (mib << 18,)})
    co = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = co.compress(header.getvalue() + bytes(1 << 20)) + co.flush(zlib.Z_FULL_FLUSH)
    again = co.compress(bytes(1 << 20)) + co.flush(zlib.Z_FULL_FLUSH)
    data = first + again * (mib - 1) + co.flush()
    return name + ".npy", zipfile.ZIP_DEFLATED, data, 0, len(header.getvalue()) + (mib << 20)


def motion_file(path: Path) -> Path:
    """A real motion file (NPZ) of one utterance of 20 frames."""
    from core.motion import MotionClip, save_motion
    from core.skeleton import REST_POSE

    save_motion(path, [MotionClip(np.repeat(REST_POSE[None], 20, 0), audio_offset=0.0)])
    return path


def replaced(path: Path, name: str, member) -> bytes:
    """The members of the archive at ``path`` (stored again) with ``name`` replaced by ``member``."""
    with zipfile.ZipFile(path) as z:
        members = [(i.filename, zipfile.ZIP_STORED, z.read(i), i.CRC, i.file_size) for i in z.infolist()]
    return zip_of([member if m[0] == name else m for m in members])


def damaged(path: Path) -> Path:
    """``path`` with the deflate stream of its poses made invalid (block type 3, which does not
    exist): reading it raised zlib.error."""
    with zipfile.ZipFile(path) as z:
        info = z.getinfo("poses_0.npy")
    data = bytearray(path.read_bytes())
    name_len, extra_len = struct.unpack_from("<2H", data, info.header_offset + 26)
    data[info.header_offset + 30 + name_len + extra_len] = 0xFF
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("command", [["export", "-o", "take.bvh"], ["render", "-o", "take.gif"]])
def test_a_damaged_motion_file_is_one_line(tmp_path, command):
    take = damaged(motion_file(tmp_path / "take.npz"))
    refused(sgt(command[0], str(take), *command[1:], cwd=tmp_path), "take.npz", "damaged compressed data")


def test_sgt_view_shows_a_damaged_motion_files_line(tmp_path):
    from fastapi.testclient import TestClient

    from sgt_tui.serve.config import ServeConfig, checked
    from sgt_tui.view.server import create_view_app
    from sgt_tui.view.takes import Viewer

    take = damaged(motion_file(tmp_path / "take.npz"))
    with TestClient(create_view_app(Viewer(take), checked(ServeConfig(port=0)))) as c:
        c.get("/api/take")
        error = c.get("/api/status").json()["takes"][0]["error"]
    assert "take.npz" in error and "damaged compressed data" in error and "internal error" not in error


def test_a_zip_bomb_motion_file_is_refused_before_it_inflates(tmp_path):
    take = tmp_path / "take.npz"
    take.write_bytes(replaced(motion_file(take), "poses_0.npy", bomb("poses_0")))
    assert take.stat().st_size < 2 << 20
    refused(sgt("export", str(take), "-o", "take.bvh", cwd=tmp_path), "take.npz", f"inflate to {BOMB_MIB + 0.0:.1f} MiB",
            "zip bomb")


def test_a_matching_database_bomb_is_refused_before_it_inflates(tmp_path):
    from model.matching import DEFAULT_DB

    db = tmp_path / "db.npz"
    db.write_bytes(replaced(DEFAULT_DB, "frame_style.npy", bomb("frame_style")))
    (tmp_path / "s.sgt").write_text("guide: Hello there.\n")
    refused(sgt("generate", "s.sgt", "-o", "take.json", "--engine", "matching", "--database", str(db), cwd=tmp_path),
            "db.npz", "zip bomb")


def test_a_corpus_shard_bomb_is_refused_before_it_inflates(tmp_path):
    corpus = tmp_path / "corpus"
    corpus.mkdir()
    clip = {"id": "0000_000", "split": "train", "shard": "shard_0000.npz", "position": 0}
    (corpus / "manifest.json").write_text(json.dumps({"format": "sgt-corpus", "shards": [{"file": "shard_0000.npz"}],
                                                      "clips": [clip, {**clip, "split": "val"}]}))
    stored = [(f"{k}.npy", zipfile.ZIP_STORED, npy(v), zlib.crc32(npy(v)), len(npy(v)))
              for k, v in {"offsets": np.array([0, 40]), "poses": np.zeros((40, 27), np.float32)}.items()]
    (corpus / "shard_0000.npz").write_bytes(zip_of([*stored, bomb("audio")]))
    refused(sgt("train", "--corpus", str(corpus), "-o", str(tmp_path / "run"), "--epochs", "1", *TRAIN, cwd=tmp_path),
            "shard_0000.npz", "zip bomb")


def test_an_fgd_extractor_that_is_a_fifo_is_refused_unread(tmp_path):
    """``sgt eval --extractor PATH`` reads it last, after a whole evaluation: its reader, in a
    process of its own (torch.load opened a FIFO and waited for a writer forever)."""
    os.mkfifo(tmp_path / "extractor.pt")
    code = ("from model.training.fgd import ExtractorError, load\ntry:\n    load('extractor.pt')\n"
            "except ExtractorError as exc:\n    print(exc)\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60, check=False,
                       env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0 and "extractor.pt: it is a FIFO (named pipe), not a file" in r.stdout, r.stdout + r.stderr


@pytest.mark.parametrize("kind", ["fifo", "zip of compressed entries"])
def test_generator_weights_that_are_a_fifo_or_a_foreign_archive_are_refused_unread(tmp_path, kind):
    """``sgt generate --weights PATH``: a FIFO is refused unread (torch.load waited for a writer
    forever), an archive whose entries are compressed (not what torch.save writes: memory would
    no longer be bounded by the file's size) is refused before torch reads it."""
    (tmp_path / "a.sgt").write_text("guide: Hello there.\n")
    if kind == "fifo":
        os.mkfifo(tmp_path / "w.pt")
    else:
        with zipfile.ZipFile(tmp_path / "w.pt", "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("archive/data.pkl", b"\0" * 100_000)
    run = sgt("generate", "a.sgt", "-o", "a.json", "--engine", "neural", "--weights", "w.pt", cwd=tmp_path)
    refused(run, "w.pt", "FIFO" if kind == "fifo" else "compressed")
    assert not (tmp_path / "a.json").exists()
