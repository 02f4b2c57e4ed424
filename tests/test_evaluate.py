"""sgt eval (model/training/evaluate.py), the code behind the model card, on a tiny corpus
built here: every condition is what docs/model.md says it is, and the table rows are the
metrics of those motions."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from core.controls import ControlArrays  # noqa: E402
from core.skeleton import mirror_pose, normalize_pose  # noqa: E402
from core.words import TimedWord  # noqa: E402
from model import keyframe, neural, postprocess  # noqa: E402
from model.style import style  # noqa: E402
from model.teacher import teach  # noqa: E402
from model.training import evaluate as E  # noqa: E402
from model.training import metrics as M  # noqa: E402
from model.training.corpus import build_corpus, load_corpus  # noqa: E402
from model import take_posture  # noqa: E402
from model.weights import load_weights  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from synthetic import write_fortunes  # noqa: E402

NAMES = ["model", "model+pose raw", "model+pose", "model+style", "mean pose", "rules", "keyframe"]
SEED = 13  # this seed's tiny corpus (corpus v2: Festival voices, clips with gaps) has 3 train clips (mirrored and not), 1 val and 2 test clips


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    root = tmp_path_factory.mktemp("eval")
    build_corpus(root / "corpus", hours=0.006, seed=SEED, clips_per_shard=2, fortune_dir=write_fortunes(root / "fortunes"))
    return root / "corpus"


@pytest.fixture(scope="module")
def clips(corpus):
    out = load_corpus(corpus, "train")
    assert len(out) == 3 and {c["meta"]["mirror"] for c in out} == {True, False}
    return out


@pytest.fixture(scope="module")
def model():
    """The shipped network with its training takes, as evaluate_corpus runs it."""
    from model.runtime import TorchRunner
    from model.weights import DEFAULT_WEIGHTS, takes_of

    net, info = load_weights()
    return TorchRunner(net, takes_of(DEFAULT_WEIGHTS, info))


@pytest.fixture(scope="module")
def motions(clips, model):
    return E.condition_motions(clips, model, E.mean_pose(clips), seed=3)


def test_pose_control_is_the_one_sgt_eval_used(clips):
    """metrics.pose_control replaced evaluate.pose_controls (the code behind docs/eval.json):
    the same frames and poses on motions of every length."""

    def old(ref):  # model/training/evaluate.py before the merge, verbatim
        a = ControlArrays.empty(len(ref))
        mid = len(ref) // 2
        a.set_pose(mid - 5 // 2, ref[mid - 5 // 2 : mid - 5 // 2 + 5])
        return a

    rng = np.random.default_rng(0)
    for n in list(range(5, 40)) + [len(c["poses"]) for c in clips]:
        ref = rng.normal(size=(n, 27)).astype(np.float32)
        a, b = old(ref), M.pose_control(ref)
        for key, value in a.as_dict().items():
            assert np.array_equal(value, b.as_dict()[key]), (n, key)


def test_every_condition_is_what_the_model_card_says(clips, model, motions):
    refs = [c["poses"] for c in clips]
    assert list(motions) == NAMES
    for name, entry in motions.items():
        assert all(r is c for r, c in zip(entry[0], refs)), name
        assert [g.shape for g in entry[1]] == [r.shape for r in refs], name
    # the mean pose of the training split, held still
    mean = normalize_pose(np.concatenate(refs).mean(axis=0))
    assert all(np.allclose(g, mean[None], atol=1e-6) for g in motions["mean pose"][1])
    for i, (clip, ref) in enumerate(zip(clips, refs)):
        frames = M.pcs_frames(len(ref))
        pose_ctl = motions["model+pose"][2][i]
        assert np.flatnonzero(pose_ctl.pose_mask).tolist() == list(range(frames.start, frames.stop))
        assert np.array_equal(pose_ctl.pose[frames], ref[frames])
        # the blend makes the controlled frames exact; the raw network only comes close
        assert np.abs(motions["model+pose"][1][i][frames] - ref[frames]).max() < 1e-6
        raw = motions["model+pose raw"][1][i]
        assert 0 < np.abs(raw[frames] - ref[frames]).mean() < np.abs(mean - ref[frames]).mean()
        # the style control is the reference's own style on every frame (not its mean)
        style_ctl = motions["model+style"][2][i]
        assert np.allclose(style_ctl.style, style(ref), atol=1e-6) and style_ctl.style_mask.all()
        assert style_ctl.style.std(axis=0).max() > 0.05
        # the free model: the neural engine with no controls, clip i's seed (3 + i) and the
        # posture and drift (from frame 0) of the training take that seed draws
        empty = ControlArrays.empty(len(ref))
        raw_free = neural.run_windows(model, clip["audio"], clip["word_ids"], clip["onsets"], empty, 3 + i)
        raw_free = take_posture.with_posture(raw_free, take_posture.draw(model.takes, 3 + i))
        assert np.array_equal(motions["model"][1][i], postprocess.finish(raw_free, empty.pose, empty.pose_mask))
        # keyframe: splines through the same pose control, the mean pose at the ends
        key = motions["keyframe"][1][i]
        assert np.abs(key[frames] - ref[frames]).max() < 1e-6 and np.allclose(key[[0, -1]], mean, atol=1e-6)
        # rules: the teacher on the clip's words, style, side and audio accents, with another seed
        meta = clip["meta"]
        teacher = teach([TimedWord.from_dict(w) for w in meta["words"]], len(ref), style=meta["teacher_style"],
                        strength=clip["accent"], rng=np.random.default_rng(10_000 + 3 + i))
        assert np.array_equal(motions["rules"][1][i], mirror_pose(teacher) if meta["mirror"] else teacher)
    # the mean-pose row is scored against both controls
    both = motions["mean pose"][2][0]
    assert both["pose_mask"].sum() == M.PCS_LENGTH and both["style_mask"].all()


def test_smoothing_option_reaches_the_model_rows_only(clips, model, motions):
    plain = E.condition_motions(clips[:1], model, E.mean_pose(clips), seed=3, smoothing="none")
    for name in ("model", "model+pose", "model+style"):
        assert not np.array_equal(plain[name][1][0], motions[name][1][0]), name
    for name in ("model+pose raw", "mean pose", "rules", "keyframe"):
        assert np.array_equal(plain[name][1][0], motions[name][1][0]), name


def test_table_rows_are_the_metrics_of_the_conditions(corpus, clips, model):
    rows = E.evaluate_corpus(corpus, split="train", seed=3, limit=3, engine="neural")
    assert [r["name"] for r in rows] == NAMES + ["shuffled audio", "rules, shuffled"] and all(r["n_clips"] == 3 for r in rows)
    conditions = E.condition_motions(clips[:3], model, E.mean_pose(clips), seed=3)
    audio = [c["audio_clean"] for c in clips[:3]]
    expected = M.report(conditions, audio=audio)
    for got, want in zip(rows, expected):
        for key in M.ROW_KEYS:
            assert got[key] == pytest.approx(want[key], rel=1e-6, nan_ok=True), (got["name"], key)
    # beat alignment: each row's motion against its own clip's onsets; the shuffled rows, the
    # model's and the teacher's motion against clip i + 1's onsets cut or repeated to clip i's length
    by = {r["name"]: r for r in rows}
    assert rows[0]["beat_align"] == pytest.approx(M.clips_beat_alignment(conditions["model"][1], audio))
    other = [audio[(i + 1) % 3][np.arange(len(audio[i])) % len(audio[(i + 1) % 3])] for i in range(3)]
    for row, name in (("shuffled audio", "model"), ("rules, shuffled", "rules")):
        assert by[row]["beat_align"] == pytest.approx(M.clips_beat_alignment(conditions[name][1], other))
        assert np.isnan(by[row]["fgd"]) and np.isnan(by[row]["hellinger"])
    assert by["model+pose"]["pcs"] < 1e-6 and by["keyframe"]["pcs"] < 1e-6 < by["model+pose raw"]["pcs"]
    assert by["model+pose raw"]["pcs"] < by["mean pose"]["pcs"]
    # --no-take-posture: the network alone; the style row requests space and handedness on
    # every frame, so it holds no posture either way
    plain = {r["name"]: r for r in E.evaluate_corpus(corpus, split="train", seed=3, limit=3, takes=False, engine="neural")}
    assert plain["model"]["fgd"] != pytest.approx(by["model"]["fgd"], rel=1e-3)
    assert plain["model+style"]["fgd"] == pytest.approx(by["model+style"]["fgd"], rel=1e-9)
    for name in ("model", "rules"):
        assert np.isnan(by[name]["pcs"]) and np.isnan(by[name]["scs"])
    assert np.isnan(by["model+style"]["pcs"]) and by["model+style"]["scs"] < by["mean pose"]["scs"]
    # the mean pose is that of the training split, whatever split is evaluated
    test_clips = [c["poses"] for c in load_corpus(corpus, "test")]
    mean = E.mean_pose(clips)
    row = {r["name"]: r for r in E.evaluate_corpus(corpus, split="test", extractor=None)}["mean pose"]
    assert np.isnan(row["beat_align"])  # a still pose has no motion beats
    # PCS over every test clip's controlled frames (the same number in each clip)
    want = np.concatenate([np.abs(p[M.pcs_frames(len(p))] - mean) for p in test_clips]).mean()
    assert len(test_clips) == 2 and row["pcs"] == pytest.approx(want, rel=1e-6)


def test_sgt_eval_writes_the_rows(corpus, tmp_path, capsys):
    from sgt_tui.cli import main

    out = tmp_path / "eval.json"
    assert main(["eval", "--corpus", str(corpus), "--split", "train", "--limit", "2", "--seed", "3", "-o", str(out)]) == 0
    table = capsys.readouterr().out
    written = json.loads(out.read_text())
    rows = written["conditions"]
    assert [r["name"] for r in rows] == NAMES + ["shuffled audio", "rules, shuffled"] and rows[0]["n_clips"] == 2
    assert rows[2]["pcs"] == pytest.approx(0.0, abs=1e-6) and rows[1]["pcs"] > 0
    assert rows[0]["pcs"] is None  # NaN (not applicable) is written as null
    assert table.splitlines()[2].startswith("model ") and "FGD" in table and " BA" in table.splitlines()[0]
    style = written["style_following"]
    assert list(style) == ["speed", "space", "handedness"] and "slope" in table
    for r in style.values():
        assert r["requested"] == [-2.0, -1.0, 1.0, 2.0] and len(r["achieved"]) == 4
        assert r["slope"] == pytest.approx(np.polyfit(r["requested"], r["achieved"], 1)[0])


def test_split_all_evaluates_every_clip_of_the_corpus(corpus, capsys):
    """--split all: a held-out corpus built with another seed is evaluated whole (its train,
    val and test clips alike), with the same rows as one split."""
    from sgt_tui.cli import main

    every = load_corpus(corpus, None)
    assert len({c["split"] for c in every}) == 3
    rows = {r["name"]: r for r in E.evaluate_corpus(corpus, split="all", extractor=None)}
    assert rows["model"]["n_clips"] == len(every) and rows["model"]["n_frames"] == sum(len(c["poses"]) for c in every)
    assert rows["rules"]["n_clips"] == len(every)
    assert main(["eval", "--corpus", str(corpus), "--split", "all", "--limit", "1", "--no-style"]) == 0
    assert capsys.readouterr().out.splitlines()[2].startswith("model ")


def test_style_following_is_the_style_of_the_requested_motion(clips, model):
    """Achieved style: the style statistics of the neural engine's output (with its speed
    correction) with only that dimension requested, at that value, on every frame, averaged
    over the speaking frames."""
    got = E.style_following(clips[:2], model, seed=3, levels=(-1.0, 2.0))
    for k, name in enumerate(("speed", "space", "handedness")):
        for value, achieved in zip((-1.0, 2.0), got[name]["achieved"]):
            per_clip = []
            for i, clip in enumerate(clips[:2]):
                arrays = ControlArrays.empty(len(clip["poses"]))
                arrays.set_style(0, len(clip["poses"]), {name: value})
                raw = neural.run_windows(model, clip["audio"], clip["word_ids"], clip["onsets"], arrays, 3 + i)
                if name == "speed":  # a speed request leaves the take's posture on, and its drift if faster
                    raw = take_posture.with_posture(raw, take_posture.draw(model.takes, 3 + i),
                                                    drift_weight=np.full(len(raw), float(value > 0), np.float32))
                words = clip["word_ids"] > 0
                engine = postprocess.finish(raw, arrays.pose, arrays.pose_mask, style=arrays.style, style_mask=arrays.style_mask)
                per_clip.append(style(engine)[words, k])
            assert achieved == pytest.approx(float(np.concatenate(per_clip).mean()), rel=1e-6)
        assert got[name]["slope"] == pytest.approx((got[name]["achieved"][1] - got[name]["achieved"][0]) / 3.0)


def test_train_default_extractor_on_a_corpus(corpus, tmp_path):
    """The documented way to retrain the shipped FGD extractor (fgd.load's fix message)."""
    from model.training import fgd

    out = tmp_path / "fgd.pt"
    ext = fgd.train_default_extractor(corpus, out, epochs=2, seed=1)
    assert fgd.load(out).config == ext.config and ext.meta["epochs"] == 2
    assert ext.meta["n_motions"] == 3 and ext.meta["n_val_motions"] == 1 and np.isfinite(ext.meta["corpus_val_mae"])
    train = [c["poses"] for c in load_corpus(corpus, "train")]
    again = fgd.train_extractor(train, epochs=2, seed=1)  # the same training, on the train split
    assert np.array_equal(again.features(train), ext.features(train))


def test_hellinger_bound_own_style_is_the_rules_row(corpus):
    """scripts/hellinger_bound.py's "own style" row is sgt eval's re-seeded teacher (the rules
    row) to the digit, so its neutral and other-style rows measure that teacher without the
    clip's hidden style, as docs/model.md says; without the style it is further away."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    import hellinger_bound  # lazy: a script, found on the path added above

    every = load_corpus(corpus, None)
    rows = {r["name"]: r for r in E.evaluate_corpus(corpus, split="all", seed=4, extractor=None)}
    got = hellinger_bound.distances(every, 4)
    assert got["own style"] == pytest.approx(rows["rules"]["hellinger"], rel=1e-9)
    assert got["neutral style"] != pytest.approx(got["own style"], rel=1e-3)
    assert np.isfinite(got["another clip's style"])


def test_sgt_eval_engine_flow_measures_the_flow_weights(corpus, tmp_path, capsys):
    """`sgt eval --engine flow --weights FILE`: the model rows are the flow network's of that file
    (two networks, two sets of figures; the pose controls exact with the blend), and weights of
    the other network are refused in one line."""
    import torch

    from model.flow_net import FlowNet
    from model.net import GestureNet
    from model.weights import save_weights
    from sgt_tui.cli import main

    tiny = {"hidden": 16, "word_dim": 8, "enc_layers": 1, "layers": 1, "time_dim": 8}
    rows = []
    for seed in (0, 1):
        torch.manual_seed(seed)
        net = FlowNet(tiny)
        with torch.no_grad():  # (its last layer starts at zero: every fresh network samples alike)
            for w in net.parameters():
                w.normal_(0.0, 0.1)
        save_weights(tmp_path / f"flow{seed}.pt", net)
        out = tmp_path / f"eval{seed}.json"
        assert main(["eval", "--engine", "flow", "--weights", str(tmp_path / f"flow{seed}.pt"), "--corpus", str(corpus),
                     "--split", "all", "--limit", "2", "--no-style", "-o", str(out)]) == 0
        rows.append({r["name"]: r for r in json.loads(out.read_text())["conditions"]})
    assert rows[0]["model"]["fgd"] != pytest.approx(rows[1]["model"]["fgd"], rel=1e-6)
    assert rows[0]["rules"]["fgd"] == pytest.approx(rows[1]["rules"]["fgd"], rel=1e-9)  # the teacher's row: the same
    assert rows[0]["model+pose"]["pcs"] == pytest.approx(0.0, abs=1e-6) and rows[0]["model+pose raw"]["pcs"] > 0
    capsys.readouterr()
    save_weights(tmp_path / "generator.pt", GestureNet({"hidden": 16, "word_dim": 8, "layers": 1, "gru": False}))
    assert main(["eval", "--engine", "flow", "--weights", str(tmp_path / "generator.pt"), "--corpus", str(corpus),
                 "--split", "all", "--limit", "1", "--no-style"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and len([x for x in err.splitlines() if "error" in x]) == 1, err
    assert "not the flow engine's" in err, err


def test_wrist_speed_check_measures_the_motions_of_sgt_evals_rows(corpus, capsys):
    """scripts/wrist_speed_check.py's rows are the wrist speeds of the motions behind sgt eval's
    rows of the same seed: its matching row those of the ``model`` row (clip i with seed + i),
    its rules row the re-seeded teacher's, its reference row the clips'."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    import wrist_speed_check as W  # lazy: a script, found on the path added above
    from core.skeleton import JOINTS
    from model import matching

    every = load_corpus(corpus, None)
    motions = E.condition_motions(every, E.MatchingModel(matching.load(None)), E.mean_pose(every), seed=4, smoothing=None)
    assert W.main(["--corpus", str(corpus), "--seed", "4", "--engine", "matching"]) == 0
    printed = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines()[1:]}
    for name, clips in (("matching", motions["model"][1]), ("rules", motions["rules"][1]), ("reference", motions["model"][0])):
        want = W.summary(clips)
        speeds = np.concatenate([M.joint_speeds(m)[:, [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]] for m in clips])
        assert want["mean"] == pytest.approx(speeds.mean()) and want["p95"] == pytest.approx(np.percentile(speeds, 95))
        assert printed[name][1:5] == ["mean", f"{want['mean']:.3f}", "p95", f"{want['p95']:.3f}"]
