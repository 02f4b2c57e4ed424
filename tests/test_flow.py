"""The flow engine (model/flow_net.py, model/flow.py, model/training/train_flow.py): a tiny network
trained here on synthetic clips, then checked end to end: shapes, one take per seed, pose
controls exact, windows that join on their seed poses, ONNX equal to PyTorch, weights of the
other network refused, and a stopped training run that resumes onto the same weights."""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

sys.path.insert(0, str(Path(__file__).parent))
from synthetic import synthetic_clips

from core.controls import ControlArrays
from core.skeleton import FPS, POSE_DIM, normalize_pose
from core.words import TimedWord
from model import flow, neural
from model.features import speech_inputs
from model.flow_net import FlowNet
from model.generate import EngineInputs, GenerateError, engine_function
from model.runtime import OnnxRunner, TorchRunner, export_onnx, largest_difference, load_runner, onnx_path
from model.training.train_flow import FlowConfig, train_flow
from model.weights import WeightsError, load_weights, save_weights

TINY = {"hidden": 32, "word_dim": 8, "enc_layers": 2, "layers": 2, "time_dim": 16}


def tiny_config(**kw) -> FlowConfig:
    return FlowConfig(**{"epochs": 6, "steps_per_epoch": 25, "batch": 16, "lr": 2e-3, "ema": 0.9, "threads": 1,
                         "net": TINY, **kw})


@pytest.fixture(scope="module")
def weights(tmp_path_factory):
    out = tmp_path_factory.mktemp("flow")
    clips = synthetic_clips(20, frames=150, seed=0)
    train_flow(clips[:16], clips[16:], out, tiny_config(), resume=False, log=lambda s: None, extractor=None)
    return out / "flow.pt"


def words_every(n_frames, every=6):
    return [TimedWord(f"w{i}", i / FPS, (i + every - 1) / FPS) for i in range(0, n_frames, every)]


def inputs_for(n_frames, arrays=None, every=6):
    return EngineInputs(arrays or ControlArrays.empty(n_frames), words_every(n_frames, every), None, 0.0)


def gen(weights, inputs, seed=0, **opts):
    return flow.generate(inputs, seed=seed, options=neural.Options(weights=str(weights), **opts))


@pytest.mark.parametrize("frames", [7, neural.WINDOW, 2 * neural.WINDOW + 11])
def test_shapes_units_and_one_take_per_seed(weights, frames):
    inp = inputs_for(frames)
    a = gen(weights, inp, seed=3)
    assert a.shape == (frames, POSE_DIM) and a.dtype == np.float32 and np.isfinite(a).all()
    assert np.allclose(np.linalg.norm(a.reshape(frames, 9, 3), axis=-1), 1, atol=1e-4)
    assert np.array_equal(a, gen(weights, inp, seed=3))  # a seed is one take
    assert np.abs(a - gen(weights, inp, seed=4)).max() > 1e-3  # another seed another


def test_the_network_keeps_whole_pose_controls_exactly(weights):
    """Controlled frames are put into every prediction of the sampler, so its windows already
    end on them; the blend keeps them exact after the re-timing and the smoothing."""
    n = 80
    ref = normalize_pose(synthetic_clips(1, frames=n, seed=9)[0]["poses"])  # requests are unit bones
    arrays = ControlArrays.empty(n)
    arrays.set_pose(30, ref[30:40])
    inp = inputs_for(n, arrays)
    audio, ids, onsets = speech_inputs(inp, n)
    raw = flow.run_windows(flow.load(str(weights)), audio, ids, onsets, arrays, 0)
    assert np.abs(raw[30:40] - ref[30:40]).max() < 1e-4
    out = gen(weights, inputs_for(n, arrays))
    assert np.abs(out[30:40] - ref[30:40]).max() < 1e-5
    # a per-bone control (one arm) reaches the network as free, and the blend makes that arm exact
    arm = np.zeros(9, bool)
    arm[6:] = True
    arrays = ControlArrays.empty(n)
    arrays.set_pose(30, ref[30:40], bones=arm)
    out = gen(weights, inputs_for(n, arrays))
    cols = np.repeat(arm, 3)
    assert np.abs(out[30:40][:, cols] - ref[30:40][:, cols]).max() < 1e-5


def test_windows_start_from_the_previous_windows_last_frames():
    """Each window after the first gets SEED frames of the previous window's as whole-pose
    controls, ending EDGE frames before its end, and its output is used from right after them
    (so it samples the previous window's last EDGE frames again), its first free frame
    continuing the seed (model.flow.join): no frame is skipped, and a user's control in the
    seed span stays the user's."""
    calls = []

    class Spy:
        noise_dim = POSE_DIM

        def run_window(self, audio, ids, onsets, pose, pose_mask, style, style_mask, z):
            calls.append((pose.copy(), pose_mask.copy(), z.copy()))
            out = np.zeros((len(pose), POSE_DIM), np.float32)
            out[:, 1] = 1.0
            out[:, 0] = len(calls)  # which window made the frame
            out[pose_mask > 0.5] = pose[pose_mask > 0.5]
            return out

    hop, seed, join = flow.HOP, neural.SEED, flow.JOIN
    assert hop == neural.WINDOW - seed - flow.EDGE and flow.EDGE > 0
    n = 2 * hop + neural.WINDOW
    arrays = ControlArrays.empty(n)
    user = np.full((2, POSE_DIM), 0.5, np.float32)
    arrays.set_pose(hop + 3, user)  # inside the second window's seed span
    out = flow.run_windows(Spy(), np.zeros((n, 33), np.float32), np.zeros(n, np.int64), np.zeros(n, np.float32), arrays, 0)
    assert len(calls) == 3
    for k, (pose, mask, z) in enumerate(calls[1:], start=1):
        start = k * hop
        assert (mask[:seed] == 1).all() and (mask[seed:] == 0).all()
        assert np.array_equal(pose[:seed], out[start : start + seed])
        assert z.shape == (min(neural.WINDOW, n - start), POSE_DIM)
        # the first free frame continues the seed's last two (here still: the same pose again)
        assert np.abs(out[start + seed] - normalize_pose(2 * out[start + seed - 1] - out[start + seed - 2])).max() < 1e-6
    made = out[:, 0].copy()
    made[hop + 3 : hop + 5] = 1  # the user's frames, kept through the windows
    assert (made[: hop + seed] == 1).all()
    assert (made[hop + seed + join : 2 * hop + seed] == 2).all()
    assert (made[2 * hop + seed + join :] == 3).all()
    assert np.array_equal(out[hop + 3 : hop + 5], user)  # the request, not the first window's frames


def test_onnx_export_runs_the_same_sampler(weights, tmp_path):
    export = export_onnx(weights, tmp_path / "flow.onnx")
    assert largest_difference(weights, export) < 1e-4
    # beside the weights, the export is what load_runner picks (while its hash matches)
    copy = tmp_path / "w" / "flow.pt"
    copy.parent.mkdir()
    copy.write_bytes(Path(weights).read_bytes())
    export_onnx(copy)
    load_runner.cache_clear()
    runner = load_runner(str(copy), "flow")
    assert isinstance(runner, OnnxRunner) and runner.noise_dim == POSE_DIM
    inp = inputs_for(100)
    on_onnx = flow.generate(inp, seed=2, options=neural.Options(weights=str(copy)))
    load_runner.cache_clear()
    onnx_path(copy).unlink()
    assert isinstance(load_runner(str(copy), "flow"), TorchRunner)
    assert np.abs(on_onnx - flow.generate(inp, seed=2, options=neural.Options(weights=str(copy)))).max() < 1e-3
    load_runner.cache_clear()


def test_weights_of_the_other_network_are_refused(weights, tmp_path):
    from model.net import GestureNet

    regressor = tmp_path / "generator.pt"
    save_weights(regressor, GestureNet({"hidden": 16, "word_dim": 8, "layers": 1, "gru": False}))
    with pytest.raises(WeightsError, match="neural engine's network, not the flow engine's") as err:
        load_weights(regressor, "flow")
    assert "--engine neural" in str(err.value)
    with pytest.raises(WeightsError, match="flow engine's network, not the neural engine's"):
        load_weights(weights)
    with pytest.raises(GenerateError, match="--engine flow"):
        engine_function("neural", neural.Options(weights=str(weights)))
    with pytest.raises(GenerateError, match="--engine neural"):
        engine_function("flow", neural.Options(weights=str(regressor)))
    # and its export too: an export records the kind of the weights it was made from
    export_onnx(weights)
    load_runner.cache_clear()
    with pytest.raises(WeightsError, match="not the neural engine's"):
        load_runner(str(weights), "neural")
    onnx_path(weights).unlink()
    load_runner.cache_clear()
    blob = torch.load(str(weights), weights_only=True)
    for change, pattern in [({"layout": {**blob["layout"], "pose_dim": 30}}, "pose_dim"),
                            ({"kind": "diffusion"}, "kind 'diffusion'"), ({"version": 7}, "version 7")]:
        path = tmp_path / "changed.pt"
        buf = io.BytesIO()
        torch.save({**blob, **change}, buf)
        path.write_bytes(buf.getvalue())
        with pytest.raises(WeightsError, match=pattern) as err:
            load_weights(path, "flow")
        assert "sgt train --engine flow" in str(err.value)


def test_a_stopped_training_resumes_onto_the_same_weights(tmp_path):
    clips = synthetic_clips(10, frames=100, seed=1)
    cfg = tiny_config(epochs=3, steps_per_epoch=4, batch=8)
    kw = {"log": lambda s: None, "extractor": None}
    train_flow(clips[:8], clips[8:], tmp_path / "whole", cfg, **kw)
    train_flow(clips[:8], clips[8:], tmp_path / "parts", tiny_config(epochs=3, steps_per_epoch=4, batch=8, minutes=1e-9), **kw)
    rows = [json.loads(line) for line in (tmp_path / "parts" / "metrics.jsonl").read_text().splitlines()]
    assert [r["epoch"] for r in rows] == [1]  # stopped after its first epoch
    state = torch.load(str(tmp_path / "parts" / "checkpoint.pt"), weights_only=True)  # no pickled objects
    assert state["epoch"] == 1
    train_flow(clips[:8], clips[8:], tmp_path / "parts", cfg, **kw)
    for name in ("last.pt", "flow.pt"):
        a = load_weights(tmp_path / "whole" / name, "flow")[0].state_dict()
        b = load_weights(tmp_path / "parts" / name, "flow")[0].state_dict()
        assert all(torch.equal(a[k], b[k]) for k in a)
    # a checkpoint made with other settings is refused, not replaced
    with pytest.raises(ValueError, match="batch 8 \\(now 4\\)"):
        train_flow(clips[:8], clips[8:], tmp_path / "parts", tiny_config(epochs=3, steps_per_epoch=4, batch=4), **kw)


def test_training_learns_and_keeps_the_best_epoch(weights):
    rows = [json.loads(line) for line in (Path(weights).parent / "metrics.jsonl").read_text().splitlines()]
    assert len(rows) == 6 and rows[-1]["loss"] < 0.85 * rows[0]["loss"] and rows[-1]["val_loss"] < rows[0]["val_loss"]
    kept = min(rows, key=lambda r: r["score"])
    assert load_weights(weights, "flow")[1]["meta"]["epochs_done"] == kept["epoch"]


def test_sampler_times_are_checked():
    with pytest.raises(ValueError, match="sampler times"):
        FlowNet({**TINY, "times": [0.2, 0.5]})
    with pytest.raises(ValueError, match="sampler times"):
        FlowNet({**TINY, "times": [0.0, 0.5, 0.5]})


def test_the_stream_decides_each_frame_half_a_second_ahead_and_keeps_its_take(weights):
    """The flow stream decides a frame once the speech is known LOOKAHEAD_S (under 0.5 s) past
    it, continues the frames it decided, and gives the same take however the words arrive."""
    from model.flow_stream import FlowStreamGenerator
    from model.streaming import LOOKAHEAD, LOOKAHEAD_S, STEP

    assert LOOKAHEAD_S == (STEP + LOOKAHEAD) / FPS <= 0.5
    runner = flow.load(str(weights))
    words = [(w.word, w.start, w.end) for w in words_every(90, every=7)]

    def stream(chunks):
        gen = FlowStreamGenerator(runner, seed=5)
        out = []
        for piece in np.array_split(np.arange(len(words)), chunks):
            got = gen.add_words([words[i] for i in piece])
            known = words[piece[-1]][2]
            # frame a is decided once frames up to a + LOOKAHEAD are known, and not before
            assert gen.done == max(0, int(np.floor(known * FPS + 1e-6)) - LOOKAHEAD)
            out.append(got)
        out.append(gen.finish())
        return np.concatenate(out)

    whole, pieces = stream(1), stream(9)
    assert whole.shape[1] == POSE_DIM and len(whole) >= 90 and np.isfinite(whole).all()
    assert np.array_equal(whole, pieces)
    assert np.abs(whole - stream_with_seed(runner, words, 6)).max() > 1e-3  # another seed, another take


def stream_with_seed(runner, words, seed):
    from model.flow_stream import FlowStreamGenerator

    gen = FlowStreamGenerator(runner, seed=seed)
    return np.concatenate([gen.add_words(words), gen.finish()])


def test_sgt_train_engine_flow_then_distil_then_generate(tmp_path, capsys):
    """The commands users run: `sgt train --engine flow` on their own takes, then distilled
    (`--teacher`), then `sgt generate --engine flow --weights`; the regressor's options, the
    other network's weights and a teacher that is not flow weights are one line each."""
    from sgt_tui.cli import main
    from tests.test_train_matching import _one_error_line, write_takes

    write_takes(tmp_path / "data", n_takes=3, frames=160)
    small = ["--epochs", "1", "--steps", "2", "--batch", "4", "--window", "40", "--hidden", "16", "--threads", "1"]
    assert main(["train", "--engine", "flow", "--data", str(tmp_path / "data"), "-o", str(tmp_path / "flow"), *small]) == 0
    weights = tmp_path / "flow" / "flow.pt"
    assert load_weights(weights, "flow")[0].config["hidden"] == 16
    capsys.readouterr()
    assert main(["train", "--engine", "flow", "--data", str(tmp_path / "data"), "-o", str(tmp_path / "student"),
                 "--teacher", str(weights), "--times", "0,0.6", "--substeps", "2", *small[:-4], "--threads", "1"]) == 0
    student, card = load_weights(tmp_path / "student" / "flow.pt", "flow")
    assert student.config["times"] == [0.0, 0.6] and student.config["hidden"] == 16
    # distillation's own defaults (the shipped student's), training's where it has none
    from model.training.train_config import DISTIL_DEFAULTS

    made = card["meta"]["train_config"]
    assert {k: made[k] for k in ("lr", "ema")} == {"lr": DISTIL_DEFAULTS["lr"], "ema": DISTIL_DEFAULTS["ema"]}
    assert made["teacher"] == str(weights) and made["substeps"] == 2 and made["p_pose"] == FlowConfig.p_pose
    assert load_weights(weights, "flow")[1]["meta"]["train_config"]["lr"] == FlowConfig.lr != DISTIL_DEFAULTS["lr"]
    script = tmp_path / "one.sgt"
    script.write_text("guide: Well here is the thing you asked about.\n")
    out = tmp_path / "m.json"
    assert main(["generate", str(script), "-o", str(out), "--engine", "flow", "--weights", str(tmp_path / "student" / "flow.pt")]) == 0
    assert len(json.loads(out.read_text())["utterances"][0]["poses"]) > 10
    capsys.readouterr()
    assert main(["generate", str(script), "-o", str(out), "--engine", "neural", "--weights", str(weights)]) == 1
    _one_error_line(capsys.readouterr().err, "flow engine's network, not the neural engine's", "--engine flow")
    assert main(["train", "--engine", "flow", "--data", str(tmp_path / "data"), "-o", str(tmp_path / "x"), "--gan-weight", "2"]) == 2
    _one_error_line(capsys.readouterr().err, "--gan-weight", "--engine flow")
    assert main(["train", "--data", str(tmp_path / "data"), "-o", str(tmp_path / "x"), "--times", "0,0.5"]) == 2
    _one_error_line(capsys.readouterr().err, "--times", "--engine neural")
    regressor = tmp_path / "generator.pt"
    from model.net import GestureNet

    save_weights(regressor, GestureNet({"hidden": 16, "word_dim": 8, "layers": 1, "gru": False}))
    assert main(["train", "--engine", "flow", "--data", str(tmp_path / "data"), "-o", str(tmp_path / "y"),
                 "--teacher", str(regressor), *small]) == 1
    _one_error_line(capsys.readouterr().err, "neural engine's network, not the flow engine's")


def test_sgt_build_engine_flow_keys_its_cache_on_the_flow_weights(weights, tmp_path, monkeypatch, capsys):
    """`sgt build --engine flow --weights FILE`: the manifest records the flow weights' hash and
    their settings, and other flow weights regenerate every line (a cached line is never another
    network's; other weights at the same path are the next process's: hashes and runners are
    kept per process)."""
    import shutil

    from model.weights import file_hash
    from sgt_tui.cli import main

    monkeypatch.setenv("SGT_CACHE_DIR", str(tmp_path / "cache"))
    (tmp_path / "game").mkdir()
    (tmp_path / "game" / "a.sgt").write_text("guide: Welcome to the mall!\nguide: The shops are over there.\n")
    mine = tmp_path / "flow.pt"
    shutil.copy(weights, mine)
    out = tmp_path / "out"

    def build() -> dict:
        assert main(["build", str(tmp_path / "game"), "-o", str(out), "--engine", "flow", "--weights", str(mine), "-j", "1"]) == 0
        return json.loads((out / "manifest.json").read_text())

    doc = build()
    assert doc["settings"]["engine"] == "flow" and doc["settings"]["weights_sha256"] == file_hash(mine)
    assert {"smoothing", "blend"} <= set(doc["settings"])
    first = (out / "a.json").read_bytes()
    assert [u["cached"] for u in build()["scripts"][0]["utterances"]] == [True, True]
    net, _ = load_weights(mine, "flow")
    with torch.no_grad():
        for w in net.parameters():
            w.add_(0.05 * torch.randn_like(w))
    mine = tmp_path / "other.pt"
    save_weights(mine, net)
    doc = build()
    assert [u["cached"] for u in doc["scripts"][0]["utterances"]] == [False, False]
    assert doc["settings"]["weights_sha256"] == file_hash(mine) and (out / "a.json").read_bytes() != first
