"""The procedural corpus: sentences, reproducibility, shapes, splits, resuming."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from core.skeleton import FPS
from model.features import AUDIO_DIM
from model.training.corpus import FORTUNE_DIR, CorpusError, build_corpus, load_corpus, load_manifest, load_sentences

sys.path.insert(0, str(Path(__file__).parent))
from synthetic import write_fortunes  # noqa: E402

HOURS_TWO_SHARDS = 150 / FPS / 3600  # 150 frames: more than one shard of two clips


@pytest.fixture()
def fortunes(tmp_path):
    return write_fortunes(tmp_path / "fortunes")


def test_sentences_cleaned(fortunes):
    s = load_sentences(fortunes)
    assert "Look over there, the big red house is where I grew up." in s
    assert not any("Twain" in x or "ascii" in x or "--" in x for x in s)
    assert not any(x.startswith(("Q:", "A:")) for x in s)
    assert "Ok" not in s  # under 3 words
    assert len(s) == len(set(s)) and s == sorted(s)


def test_missing_fortunes_is_a_clear_error(tmp_path):
    with pytest.raises(CorpusError, match="apt-get install fortunes"):
        load_sentences(tmp_path / "nothing")


@pytest.mark.skipif(not FORTUNE_DIR.is_dir(), reason="fortunes not installed")
def test_real_fortunes():
    from dsl.parser import WORD_RE

    s = load_sentences()
    assert len(s) > 1000
    for x in s[:: max(1, len(s) // 300)]:
        assert 3 <= len(WORD_RE.findall(x)) <= 25, x


def build(out, fortunes, hours=HOURS_TWO_SHARDS):
    return build_corpus(out, hours=hours, seed=5, clips_per_shard=2, fortune_dir=fortunes)


def test_tiny_corpus_reproducible_shapes_splits_resume(tmp_path, fortunes):
    a, b = tmp_path / "a", tmp_path / "b"
    ma = build(a, fortunes)
    mb = build(b, fortunes)
    assert ma["total_frames"] >= 150 and len(ma["shards"]) >= 2
    assert ma["clips"] == mb["clips"] and ma["total_frames"] == mb["total_frames"]

    ca, cb = load_corpus(a, None), load_corpus(b, None)
    assert len(ca) == len(ma["clips"]) == 2 * len(ma["shards"])
    for x, y in zip(ca, cb):
        for key in ("audio", "audio_clean", "word_ids", "onsets", "poses", "accent"):
            assert np.array_equal(x[key], y[key]), key
        T = len(x["poses"])
        assert T == x["meta"]["n_frames"]
        assert x["audio"].shape == (T, AUDIO_DIM) and x["audio_clean"].shape == (T, AUDIO_DIM)
        assert x["word_ids"].shape == (T,) and x["onsets"].shape == (T,) and x["poses"].shape == (T, 27)
        assert np.isfinite(x["audio"]).all() and np.isfinite(x["poses"]).all()
        assert np.allclose(np.linalg.norm(x["poses"].reshape(T, 9, 3), axis=-1), 1, atol=1e-4)
        assert x["onsets"].sum() == len(x["meta"]["words"]) > 0
        assert (x["word_ids"] > 0).any()
        m = x["meta"]
        assert {"text", "voice", "engine", "style", "mirror", "augmentation", "words", "gaps"} <= set(m)
        if m["engine"] == "espeak-ng":
            assert 120 <= m["rate"] <= 220 and 30 <= m["pitch"] <= 70
        else:
            assert m["engine"] == "festival" and all(0.8 <= s <= 1.3 for s in m["stretch"])
        assert x["accent"].shape == (T,) and 0 <= x["accent"].min() and x["accent"].max() <= 1

    # splits: disjoint and covering
    ids = {s: {c["id"] for c in load_corpus(a, s)} for s in ("train", "val", "test")}
    assert sum(len(v) for v in ids.values()) == len(ca)
    assert not (ids["train"] & ids["val"]) and not (ids["train"] & ids["test"]) and not (ids["val"] & ids["test"])
    assert sum(ma["split_counts"].values()) == len(ca)

    # the same arrays give the same bytes, whenever a shard is built
    assert [(a / f["file"]).read_bytes() for f in ma["shards"]] == [(b / f["file"]).read_bytes() for f in mb["shards"]]

    # resume: finished shards are kept, a missing or damaged one is rebuilt identically
    shard0, shard1 = a / ma["shards"][0]["file"], a / ma["shards"][1]["file"]
    stamp = shard0.stat().st_mtime_ns
    before = shard1.read_bytes()
    for damage in (shard1.unlink, lambda: shard1.write_bytes(before[: len(before) // 2])):
        damage()
        (a / "manifest.json").unlink()
        mc = build(a, fortunes)
        assert shard0.stat().st_mtime_ns == stamp
        assert shard1.read_bytes() == before
        assert mc == ma
        assert load_manifest(a)["total_frames"] == ma["total_frames"]


def test_jobs_build_the_same_corpus(tmp_path, fortunes):
    """--jobs 2 (worker processes) gives the manifest and byte-identical shards of --jobs 1."""
    one = build_corpus(tmp_path / "one", hours=2 * HOURS_TWO_SHARDS, seed=5, clips_per_shard=2, fortune_dir=fortunes)
    calls = []
    two = build_corpus(tmp_path / "two", hours=2 * HOURS_TWO_SHARDS, seed=5, clips_per_shard=2, fortune_dir=fortunes,
                       jobs=2, progress=lambda done, total, what: calls.append(what))
    assert len(one["shards"]) >= 3 and two == one
    for shard in one["shards"]:
        assert (tmp_path / "one" / shard["file"]).read_bytes() == (tmp_path / "two" / shard["file"]).read_bytes()
    assert {f"shard {k}" for k in range(len(one["shards"]))} <= set(calls)
    # a resumed --jobs 2 run keeps every shard and writes the same manifest
    (tmp_path / "two" / "manifest.json").unlink()
    assert build_corpus(tmp_path / "two", hours=2 * HOURS_TWO_SHARDS, seed=5, clips_per_shard=2, fortune_dir=fortunes,
                        jobs=2) == one


def test_different_seed_differs(tmp_path, fortunes):
    m1 = build_corpus(tmp_path / "s1", hours=1e-4, seed=1, clips_per_shard=2, fortune_dir=fortunes)
    m2 = build_corpus(tmp_path / "s2", hours=1e-4, seed=2, clips_per_shard=2, fortune_dir=fortunes)
    key = lambda m: [(c["text"], c["voice"], c.get("rate")) for c in m["clips"]]
    assert key(m1) != key(m2)


def test_cli(tmp_path, fortunes, monkeypatch, capsys):
    import model.training.corpus as corpus
    from sgt_tui.cli import main

    monkeypatch.setattr(corpus, "FORTUNE_DIR", fortunes)
    monkeypatch.setattr(corpus.build_corpus, "__kwdefaults__", {**corpus.build_corpus.__kwdefaults__, "fortune_dir": fortunes})
    rc = main(["corpus", "-o", str(tmp_path / "c"), "--hours", "0.0001", "--seed", "1", "--clips-per-shard", "2"])
    assert rc == 0
    assert "clips" in capsys.readouterr().out
    assert json.loads((tmp_path / "c" / "manifest.json").read_text())["seed"] == 1
    assert main(["corpus", "-o", str(tmp_path / "d"), "--hours", "0"]) == 2
    # a missing corpus is a message with the fix, not a traceback
    capsys.readouterr()
    for command in ("train", "eval"):
        assert main([command, "--corpus", str(tmp_path / "none")]) == 1
        assert f"sgt corpus -o {tmp_path / 'none'}" in capsys.readouterr().err


def test_gap_clips_rest_in_their_silences(tmp_path, fortunes):
    """A clip of several sentences has silent gaps: the clean audio sits on the silence floor
    there, and the teacher's hands move far less inside a long gap than while speaking."""
    from core.skeleton import JOINTS
    from model.features import silence_features
    from model.training.corpus import make_clip
    from model.training.metrics import joint_speeds

    texts = ["Look over there, the big red house is where I grew up.", "We never went back after that summer."]
    clip = make_clip(texts, 3, 11, ["en-us"], tmp_path)
    (gap,) = clip["meta"]["gaps"]
    assert 2.0 <= gap <= 4.0  # drawn from 0.8-4 s; this seed's is long enough to rest in
    words = clip["meta"]["words"]
    first_end = max(w["end"] for w in words[:12])
    second_start = min(w["start"] for w in words[12:])
    assert second_start - first_end == pytest.approx(gap, abs=0.3)
    inside = slice(int((first_end + 0.7) * FPS), int((second_start - 0.5) * FPS))
    assert np.allclose(clip["audio_clean"][inside], silence_features(1), atol=1e-2)
    wrists = [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]
    speed = joint_speeds(clip["poses"])[:, wrists].mean(axis=1)
    talking = slice(int(words[0]["start"] * FPS), int(first_end * FPS))
    assert speed[inside].mean() < 0.5 * speed[talking].mean()


@pytest.mark.skipif(not __import__("model.training.voices", fromlist=["x"]).festival_voices(), reason="festival not installed")
def test_festival_voices_give_timed_words(tmp_path):
    from model.training.voices import festival_voices, speak

    for voice in festival_voices():
        wav, words, drawn = speak("Look over there, 12 people!", voice, tmp_path, np.random.default_rng(0))
        assert [w for w, _, _ in words][:3] == ["Look", "over", "there"] and len(words) == 5  # "twelve" expanded
        assert all(a <= b for _, a, b in words) and all(b1 <= a2 + 1e-6 for (_, _, b1), (_, a2, _) in zip(words, words[1:]))
        import soundfile as sf

        assert sf.info(str(wav)).duration >= words[-1][2] - 0.05

