"""`sgt train --engine matching` builds the matching engine's database of a user's own BVH takes,
and `sgt generate --engine matching --database` (and build, serve) plays them: the generated
motion is the user's, not the shipped database's; short takes, empty folders, damaged
databases and outputs that are inputs are one line each, never a traceback."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sys

import numpy as np
import pytest
import soundfile as sf

from core.skeleton import N_BONES
from dsl.compiler import load_script
from model import matching
from model.training import matching_db
from model.training.loaders import load_folder
from sgt_tui.build.keys import Settings, utterance_key
from sgt_tui.cli import main
from tests.test_loaders import body_bvh

SCRIPT = "guide: Well here is the thing you asked about, and there it is on the left, not the right.\n"
WORDS = ["here", "is", "the", "thing", "you", "asked", "about"]


def write_takes(folder, n_takes: int = 3, frames: int = 121, audio: bool = True) -> None:
    """GENEA-layout takes (BVH at 30 fps, WAV, JSON timings): the right arm held straight out to
    the side (a T-pose arm, which the shipped corpus's teacher never holds) while the left arm
    sweeps from out to down."""
    for d in ("Motion", "Audio", "Transcripts"):
        (folder / d).mkdir(parents=True, exist_ok=True)
    sr = 16000
    for i in range(n_takes):
        (folder / "Motion" / f"take{i}.bvh").write_text(body_bvh(n=frames))
        seconds = frames / 30
        t = np.arange(int(seconds * sr)) / sr
        if audio:
            speech = 0.2 * np.sin(2 * np.pi * (150 + 20 * i) * t) * (np.sin(2 * np.pi * 2 * t) > 0)
            sf.write(folder / "Audio" / f"take{i}.wav", speech.astype(np.float32), sr)
        timings = [{"word": w, "start": 0.5 * k, "end": 0.5 * k + 0.25} for k, w in enumerate(WORDS) if 0.5 * k + 0.25 < seconds]
        (folder / "Transcripts" / f"take{i}.json").write_text(json.dumps(timings))


def _dirs(poses) -> np.ndarray:
    return np.asarray(poses, np.float64).reshape(len(poses), N_BONES, 3)


def _generated(tmp_path, *extra) -> np.ndarray:
    script = tmp_path / "one.sgt"
    script.write_text(SCRIPT)
    out = tmp_path / "motion.json"
    assert main(["generate", str(script), "-o", str(out), "--engine", "matching", *extra]) == 0
    return np.array(json.loads(out.read_text())["utterances"][0]["poses"])


def _one_error_line(err: str, *needles: str) -> None:
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], err


@pytest.fixture(scope="module")
def user_db(tmp_path_factory):
    """(database path, the takes' poses (N, 27), what sgt train printed) of three user takes."""
    root = tmp_path_factory.mktemp("takes")
    write_takes(root / "data")
    out = root / "run"
    capture = root / "stderr.txt"
    with open(capture, "w") as f, contextlib.redirect_stderr(f):
        rc = main(["train", "--engine", "matching", "--data", str(root / "data"), "-o", str(out)])
        sys.stderr.flush()
    assert rc == 0, capture.read_text()
    poses = np.concatenate([c["poses"] for c in load_folder(root / "data")])
    return out / "matching_db.npz", poses, capture.read_text()


def test_train_builds_a_database_of_every_take_and_says_how_to_use_it(user_db):
    path, poses, err = user_db
    db = matching.load(path)
    assert db.meta["takes"] == 3 and db.meta["frames"] == len(poses) == 3 * 61  # all three: no validation split
    assert db.meta["source"] == "bvh" and db.meta["candidates"] == len(db.cands) > 0
    assert np.abs(db.poses - poses).max() < 1e-3  # the takes' own motion (int16 storage)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    m = re.search(r"wrote (\S+): 3 takes, 183 frames .*?(\d+) candidate segments, .*sha256 ([0-9a-f]{64})", err)
    assert m, err
    assert m.group(1) == str(path) and int(m.group(2)) == db.meta["candidates"] and m.group(3) == digest
    assert f"--engine matching --database {path}" in err
    assert "Traceback" not in err and "warning" not in err


def test_generate_with_the_users_database_plays_the_users_motion(user_db, tmp_path):
    """The takes hold the right arm straight out to the side; motion generated with the user's
    database holds it there (between easing in from and back out to the listening motion), and
    every pose there is one of the takes'; the shipped database's motion holds no such pose."""
    path, poses, _ = user_db
    takes = _dirs(poses)
    out_arm = takes[0, 7]  # the right upper arm (shoulder -> elbow): (-1, 0, 0) in every take frame
    assert np.allclose(takes[:, 7], out_arm, atol=1e-3)

    def measure(generated):
        g = _dirs(generated)
        arm = np.degrees(np.arccos(np.clip(g[:, 7] @ out_arm, -1, 1)))
        # each generated pose's distance to the nearest take pose: mean angle over the bones
        cos = np.clip(np.einsum("gbk,tbk->gtb", g, takes), -1, 1)
        nearest = np.degrees(np.arccos(cos)).mean(2).min(1)
        return arm, nearest

    mine = _generated(tmp_path, "--database", str(path))
    shipped = _generated(tmp_path)
    arm, nearest = measure(mine)
    # from the middle to two thirds: the performance eases the line in from the listening pose over as
    # many frames as the distance needs (28 of its 69 here, the arm turning 80 degrees) and out at its end
    later = slice(len(mine) // 2, 2 * len(mine) // 3)
    assert np.median(arm) < 10 and arm[later].max() < 10, np.round(arm)
    assert nearest[later].max() < 8, np.round(nearest)
    arm, nearest = measure(shipped)
    assert np.median(arm) > 45 and nearest[later].min() > 15, (np.round(arm), np.round(nearest))


def test_train_matching_refuses_what_it_cannot_use(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["train", "--engine", "matching", "--data", str(empty), "-o", str(tmp_path / "o1")]) == 1
    _one_error_line(capsys.readouterr().err, "no .bvh files")

    short = tmp_path / "short"  # 31 frames at 30 fps: 16 frames at 15 fps, under a segment and its blend
    write_takes(short, n_takes=2, frames=31)
    assert main(["train", "--engine", "matching", "--data", str(short), "-o", str(tmp_path / "o2")]) == 1
    err = capsys.readouterr().err
    _one_error_line(err, "no usable take", f"{matching_db.min_frames()} frames")
    assert err.count("left out") == 2 and not (tmp_path / "o2" / "matching_db.npz").exists()

    # a short take among good ones, and a take without audio: warnings, the rest is built
    mixed = tmp_path / "mixed"
    write_takes(mixed, n_takes=2)
    (mixed / "Motion" / "brief.bvh").write_text(body_bvh(n=31))
    (mixed / "Audio" / "take1.wav").unlink()
    assert main(["train", "--engine", "matching", "--data", str(mixed), "-o", str(tmp_path / "o3")]) == 0
    err = capsys.readouterr().err
    assert "take 'brief' is 1.07 s (16 frames), shorter than a segment" in err and "left out" in err
    assert "take 'take1' has no audio" in err and "Traceback" not in err
    assert matching.load(tmp_path / "o3" / "matching_db.npz").meta["takes"] == 2

    # the network's options do not apply: a usage error naming them
    assert main(["train", "--engine", "matching", "--data", str(mixed), "-o", str(tmp_path / "o4"),
                 "--epochs", "3", "--no-gan"]) == 2
    _one_error_line(capsys.readouterr().err, "--epochs, --no-gan", "--engine matching")


def test_train_matching_refuses_an_output_that_is_an_input(tmp_path, capsys):
    write_takes(tmp_path / "data", n_takes=1)
    take = tmp_path / "data" / "Motion" / "take0.bvh"
    before = take.read_bytes()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "matching_db.npz").symlink_to(take)
    assert main(["train", "--engine", "matching", "--data", str(tmp_path / "data"), "-o", str(tmp_path / "out")]) == 2
    _one_error_line(capsys.readouterr().err, "the output is an input")
    assert take.read_bytes() == before


def test_generate_refuses_a_damaged_or_foreign_database_in_one_line(user_db, tmp_path, capsys):
    path, _, _ = user_db
    script = tmp_path / "one.sgt"
    script.write_text(SCRIPT)
    data = path.read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(data[: len(data) // 2])  # a zip cut short: BadZipFile, not an OSError
    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0xFF  # a damaged member: zlib's or zipfile's CRC error
    damaged = tmp_path / "damaged.npz"
    damaged.write_bytes(bytes(flipped))
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files if k != "meta"}
        meta = json.loads(str(z["meta"]))
    foreign = tmp_path / "foreign.npz"
    matching_db.write(foreign, arrays, dict(meta, segment=matching.SEGMENT + 2))
    for bad, says in ((truncated, "not a readable matching database"), (damaged, "not a readable matching database"),
                      (foreign, "built with other settings")):
        assert main(["generate", str(script), "-o", str(tmp_path / "m.json"), "--engine", "matching",
                     "--database", str(bad)]) == 1, bad
        _one_error_line(capsys.readouterr().err, says, "sgt train --engine matching")
    assert not (tmp_path / "m.json").exists()

    # the motion file must not overwrite the database it reads
    assert main(["generate", str(script), "-o", str(path), "--engine", "matching", "--database", str(path)]) == 2
    _one_error_line(capsys.readouterr().err, "the output is an input")
    assert path.read_bytes() == data
    # only the matching engine reads a database: another engine with one is a usage error
    assert main(["generate", str(script), "-o", str(tmp_path / "m.json"), "--engine", "rules", "--database", str(path)]) == 2
    _one_error_line(capsys.readouterr().err, "--database", "add --engine matching")
    # sgt serve checks it before anything else (a token too short would fail next: exit 2, not a
    # server left listening should the check go), sgt build before building
    assert main(["serve", "--database", str(truncated), "--token", "short"]) == 1
    _one_error_line(capsys.readouterr().err, "not a readable matching database")
    assert main(["build", str(script), "-o", str(tmp_path / "built"), "--engine", "matching", "--database", str(foreign)]) == 1
    _one_error_line(capsys.readouterr().err, "built with other settings")


def test_a_database_rebuilt_in_place_is_read_again(user_db, tmp_path):
    """A running service or editor reads a database rebuilt at the same path, not its old copy."""
    path, _, _ = user_db
    copy = tmp_path / "db.npz"
    copy.write_bytes(path.read_bytes())
    assert matching.load(copy).meta["takes"] == 3
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files if k != "meta"}
        meta = json.loads(str(z["meta"]))
    matching_db.write(copy, arrays, dict(meta, takes=7))  # (meta only: same size on disk, perhaps)
    os.utime(copy, ns=(1, 1))  # another time, whatever the clock's resolution
    assert matching.load(copy).meta["takes"] == 7


def test_the_build_cache_key_holds_the_databases_content(user_db, tmp_path):
    path, _, _ = user_db
    script, lib, diags = load_script(tmp_path / "one.sgt", source=SCRIPT)
    assert not [d for d in diags if d.is_error]

    def key(**settings):
        return utterance_key(script.utterances[0], lib, script.header.seed, Settings(engine="matching", **settings))

    copy = tmp_path / "copy.npz"
    copy.write_bytes(path.read_bytes())
    assert key(database=str(path)) != key()  # the user's database, not the shipped one
    assert key(database=str(copy)) == key(database=str(path))  # its content counts, not its path
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files if k != "meta"}
        meta = json.loads(str(z["meta"]))
    other = tmp_path / "other.npz"
    matching_db.write(other, arrays, dict(meta, data="other"))
    assert key(database=str(other)) != key(database=str(path))
    # the matching engine's post-processing counts too (it runs the neural engine's)
    assert key(database=str(path), blend=False) != key(database=str(path))
    assert key(database=str(path), smoothing="none") != key(database=str(path))
