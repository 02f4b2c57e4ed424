"""The matching engine (model/matching.py) and its database (model/training/matching_db.py):
the database builds deterministically and loads, the engine joins segments without jumps,
follows pose controls exactly and style requests in their direction, is deterministic for a
seed, snaps stroke ends onto accents, and runs without torch."""

from __future__ import annotations

import hashlib
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core.controls import ControlArrays
from core.skeleton import N_BONES, REST_POSE, normalize_pose
from core.words import TimedWord
from model import matching
from model.features import AUDIO_DIM, word_features
from model.generate import EngineInputs, GenerateError, engine_function
from model.style import style as style_of
from model.teacher import teach
from model.training import matching_db

ROOT = Path(__file__).resolve().parent.parent
WORDS = "well here is the thing you asked about and there it is on the left not the right".split()


def _words(n_words: int, rng, start: float = 0.3) -> list[TimedWord]:
    out, t = [], start
    for k in range(n_words):
        d = float(rng.uniform(0.15, 0.45))
        out.append(TimedWord(WORDS[k % len(WORDS)], round(t, 3), round(t + d, 3)))
        t += d + float(rng.uniform(0.0, 0.6 if k % 7 else 1.2))
    return out


def _audio(words, n: int, rng) -> np.ndarray:
    """Speech-like features: a floor, words louder with a rise at their onsets."""
    a = np.full((n, AUDIO_DIM), -2.0, np.float32)
    for _, s, e in words:
        fa, fb = int(s * 15), min(n, int(np.ceil(e * 15)))
        a[fa:fb] = rng.uniform(0.2, 1.0, size=(fb - fa, AUDIO_DIM))
        a[fa:fb, -1] = np.linspace(1.0, 0.4, fb - fa)
    return a


def _clip(seed: int, n_words: int = 14) -> dict:
    rng = np.random.default_rng(seed)
    words = _words(n_words, rng)
    n = int(words[-1].end * 15) + 10
    ids, onsets = word_features(words, n)
    style = {k: float(rng.uniform(-2, 2)) for k in ("speed", "space", "handedness")}
    poses = teach(words, n, style=style, rng=np.random.default_rng(seed))
    return {"id": f"c{seed}", "poses": poses, "audio": _audio(words, n, rng), "word_ids": ids, "onsets": onsets,
            "words": words}


@pytest.fixture(scope="module")
def clips():
    return [_clip(s) for s in range(12)]


@pytest.fixture(scope="module")
def db_file(clips, tmp_path_factory):
    path = tmp_path_factory.mktemp("matching") / "db.npz"
    arrays, meta = matching_db.build_from_clips(clips[:10])
    digest = matching_db.write(path, arrays, meta)
    return path, digest


@pytest.fixture(scope="module")
def db(db_file):
    return matching.load(db_file[0])


def _max_step_deg(poses) -> float:
    d = np.asarray(poses, np.float64).reshape(len(poses), N_BONES, 3)
    cos = np.clip((d[1:] * d[:-1]).sum(-1), -1, 1)
    return float(np.degrees(np.arccos(cos)).max())


def test_database_is_deterministic_and_refuses_damage(clips, db_file, tmp_path):
    """The same takes give the same bytes; a file of another format or settings is refused with the fix."""
    arrays, meta = matching_db.build_from_clips(clips[:10])
    assert matching_db.write(tmp_path / "again.npz", arrays, meta) == db_file[1]
    assert meta["takes"] == 10 and meta["candidates"] > 0
    (tmp_path / "junk.npz").write_bytes(b"not a database")
    with pytest.raises(matching.DatabaseError, match="matching_db"):
        matching.load(tmp_path / "junk.npz")
    with pytest.raises(matching.DatabaseError, match="build it with"):
        matching.load(tmp_path / "missing.npz")
    other = dict(meta, segment=matching.SEGMENT + 1)
    matching_db.write(tmp_path / "other.npz", arrays, other)
    with pytest.raises(matching.DatabaseError, match="other settings"):
        matching.load(tmp_path / "other.npz")


def test_joins_never_jump_and_continue_the_takes(db, clips):
    """The matched motion of unseen speech turns no bone faster than the takes themselves do
    (plus a little for the cross-fades), and whole stretches are the database's own frames."""
    own = max(_max_step_deg(c["poses"]) for c in clips[:10])
    for c in clips[10:]:
        arrays = ControlArrays.empty(len(c["poses"]))
        out = matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=1, take=0)
        assert out.shape == c["poses"].shape and np.isfinite(out).all()
        assert _max_step_deg(out) <= own + 2.0
        norms = np.linalg.norm(out.reshape(len(out), N_BONES, 3), axis=-1)
        assert np.allclose(norms, 1.0, atol=1e-4)


def test_matching_without_the_cross_fade_jumps(db, clips, monkeypatch):
    """The check above can fail: segments pasted without the cross-fade, chosen for their speech
    alone (the entry-pose cost drowned), jump."""
    monkeypatch.setattr(matching, "W_SPEECH", 1e4)
    monkeypatch.setattr(matching, "BLEND", 0)
    monkeypatch.setattr(matching, "CONTINUE_BONUS", -100.0)  # always switch
    monkeypatch.setattr(matching, "SNAP_FRAMES", 0)
    own = max(_max_step_deg(c["poses"]) for c in clips[:10])
    c = clips[10]
    out = matching.match(db, c["audio"], c["word_ids"], c["onsets"], ControlArrays.empty(len(c["poses"])), seed=1)
    assert _max_step_deg(out) > own + 2.0


def test_deterministic_for_a_seed(db, clips):
    c = clips[11]
    arrays = ControlArrays.empty(len(c["poses"]))
    a = matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=4, take=2)
    b = matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=4, take=2)
    assert np.array_equal(a, b)
    others = [matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=s, take=2) for s in range(5, 9)]
    assert any(not np.array_equal(a, o) for o in others)


def test_pose_controls_are_exact_and_style_requests_followed(db, clips):
    """The engine's post-processing is the neural engine's: requested poses exactly, with a
    ramp; a requested space moves the space of the motion its way."""
    c = clips[10]
    n = len(c["poses"])
    arrays = ControlArrays.empty(n)
    want = normalize_pose(np.asarray(clips[3]["poses"][20], np.float32))
    arrays.pose[30:35] = want
    arrays.pose_mask[30:35] = 1.0
    raw = matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=0)
    out = matching.finish(raw, arrays, words=c["words"])
    assert np.allclose(out[30:35], want, atol=1e-5)
    assert _max_step_deg(out) < 40.0
    space = []
    for v in (-2.0, 2.0):
        a = ControlArrays.empty(n)
        a.style[:, 1], a.style_mask[:, 1] = v, 1.0
        space.append(style_of(matching.finish(matching.match(db, c["audio"], c["word_ids"], c["onsets"], a, seed=0), a))[:, 1].mean())
    assert space[1] > space[0] + 0.5


def test_pauses_hold_the_pose_and_resume_from_it(db, clips):
    """Inside a pause the matched motion stays near the pose the speaker paused in, and the
    segment after it starts from there: no rush back from wherever the take went meanwhile."""
    c = clips[10]
    n = len(c["poses"])
    pauses = np.zeros(n, bool)
    pauses[40:70] = True
    arrays = ControlArrays.empty(n)
    out = matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=0, pauses=pauses)
    free = matching.match(db, c["audio"], c["word_ids"], c["onsets"], arrays, seed=0)
    assert [p for p in matching.schedule(n, pauses) if p[2]] == [(40, 30, True)]

    def moved(poses):  # largest bone turn (degrees) away from the pose at the pause's start
        d = poses.reshape(len(poses), N_BONES, 3)
        return float(np.degrees(np.arccos(np.clip((d * d[:1]).sum(-1), -1, 1))).max())

    assert moved(out[39:70]) < moved(free[39:70])
    assert moved(out[39:70]) < 12.0
    assert _max_step_deg(out[60:90]) <= 22.0 + 1e-3


def test_snap_beats_puts_stroke_ends_on_accents():
    """A stroke that stops 3 frames after an accent is re-timed to stop on it (within the frame
    the stop's flat end allows); the ends stay."""
    n = 60
    t = np.arange(n, dtype=np.float64)
    poses = np.repeat(REST_POSE.reshape(1, N_BONES, 3), n, 0).astype(np.float64)
    angle = 0.6 * np.sin(np.clip((t - 14) / 18, 0, 1) * np.pi)  # out and back from 14 to 32: stops at 23
    for b in range(N_BONES):  # swing every bone about one axis: the wrists move fast, then stop
        poses[:, b, 0] += np.sin(angle)
    poses = normalize_pose(poses.reshape(n, 27)).astype(np.float32)
    ends = matching.stroke_ends(poses)
    assert len(ends) and abs(int(ends[0]) - 23) <= 1
    target = int(ends[0]) - 3
    snapped = matching.snap_beats(poses, np.array([target]))
    assert abs(int(matching.stroke_ends(snapped)[0]) - target) <= 1
    assert np.allclose(snapped[0], poses[0]) and np.allclose(snapped[-1], poses[-1])
    assert matching.snap_beats(poses, np.array([int(ends[0]) - 6])) is poses  # too far: untouched


def test_shipped_database_is_the_one_in_the_card():
    """The shipped file loads, and its sha256 is the one docs/model.md gives."""
    data = matching.DEFAULT_DB.read_bytes()
    card = (ROOT / "docs" / "model.md").read_text()
    m = re.search(r"matching_db\.npz`[^`]*sha256 `([0-9a-f]{64})`", card)
    assert m, "docs/model.md gives the database's sha256"
    assert hashlib.sha256(data).hexdigest() == m.group(1)
    db = matching.load()
    assert db.meta["format"] == matching.FORMAT and db.meta["takes"] > 100
    assert len(data) < 200 * 2**20


def test_engine_through_generate_without_torch(tmp_path):
    """`generate(..., engine="matching")` makes motion for a script with a pose control and
    never imports torch (it would cost 1.2-1.7 s of every cold start)."""
    code = (
        "import sys\n"
        "from model.generate import generate\n"
        "take = generate(source='guide: Look at the shelf [pose:point_right] over there, on your right.', "
        "engine='matching', timing='estimate', seed=3)\n"
        "c = take.clips[0]\n"
        "assert c.poses.shape[1] == 27 and len(c.poses) > 20\n"
        "print('torch' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_missing_database_is_a_generate_error(monkeypatch, tmp_path):
    monkeypatch.setattr(matching, "DEFAULT_DB", tmp_path / "none.npz")
    with pytest.raises(GenerateError, match="matching_db"):
        engine_function("matching")


def test_engine_inputs_path(db_file, clips):
    """The engine's generate() on EngineInputs (no audio file: silence features) with a
    database path in its options."""
    c = clips[11]
    inputs = EngineInputs(ControlArrays.empty(len(c["poses"])), c["words"])
    opts = matching.Options(database=str(db_file[0]))
    a = matching.generate(inputs, seed=2, options=opts)
    assert a.shape == c["poses"].shape and np.array_equal(a, matching.generate(inputs, seed=2, options=opts))
