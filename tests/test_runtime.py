"""The generator runs in onnxruntime from the shipped export, the same as in PyTorch.

The export (model/weights/generator.onnx, made by scripts/export_onnx.py) must hold exactly
the shipped weights: the first test fails while it is stale, so new weights cannot ship
without their export. Stale or damaged exports are never used: PyTorch runs instead.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core.controls import ControlArrays
from model import features, neural
from model.runtime import OnnxRunner, TorchRunner, export_onnx, load_runner, onnx_path, random_window, read_export
from model.weights import DEFAULT_WEIGHTS, WeightsError, file_hash, load_weights, save_weights

ROOT = Path(__file__).resolve().parent.parent
SHIPPED_ONNX = onnx_path(DEFAULT_WEIGHTS)
TOLERANCE = 1e-4  # issue 12: outputs equal within 1e-4


def test_shipped_export_is_made_from_the_shipped_weights():
    assert SHIPPED_ONNX.exists(), f"{SHIPPED_ONNX} is missing: run 'python scripts/export_onnx.py'"
    _, meta = read_export(SHIPPED_ONNX)
    assert meta["weights_sha256"] == file_hash(DEFAULT_WEIGHTS), (
        f"{SHIPPED_ONNX} is stale: it was exported from other weights than {DEFAULT_WEIGHTS}; "
        "run 'python scripts/export_onnx.py' and commit the new export")
    _, info = load_weights(DEFAULT_WEIGHTS)
    for key in ("format", "version", "layout", "config", "style_stats"):
        assert meta["weights_info"][key] == info[key]


def _runners(weights=DEFAULT_WEIGHTS, export=SHIPPED_ONNX):
    session, meta = read_export(export)
    return TorchRunner(load_weights(weights)[0]), OnnxRunner(session, meta["weights_info"])


@pytest.mark.parametrize("n_frames", [1, 2, 5, 31, 60])
def test_onnx_equals_torch_on_one_window(n_frames):
    torch_runner, onnx_runner = _runners()
    rng = np.random.default_rng(n_frames)
    for _ in range(3):
        inputs = random_window(n_frames, torch_runner.noise_dim, rng)
        a, b = torch_runner.run_window(*inputs), onnx_runner.run_window(*inputs)
        assert a.shape == b.shape == (n_frames, 27)
        assert np.abs(a - b).max() < TOLERANCE


def test_onnx_equals_torch_over_sliding_windows_of_a_real_script():
    from dsl import compile_file

    plan = compile_file(ROOT / "examples" / "mall_guide.sgt", timing="estimate").plan
    torch_runner, onnx_runner = _runners()
    for u in plan.utterances:
        audio, ids, onsets = features.speech_inputs(neural_inputs(u), u.n_frames)
        a = neural.run_windows(torch_runner, audio, ids, onsets, u.arrays, 5)
        b = neural.run_windows(onnx_runner, audio, ids, onsets, u.arrays, 5)
        assert np.abs(a - b).max() < TOLERANCE


def neural_inputs(u):
    from model.generate import EngineInputs

    return EngineInputs.from_plan(u)


def test_the_shipped_weights_run_in_onnxruntime():
    assert load_runner(None).kind == "onnx"


def test_stale_damaged_or_missing_exports_are_never_used(tmp_path):
    net, info = load_weights(DEFAULT_WEIGHTS)
    with_new_weights = tmp_path / "generator.pt"
    import torch

    with torch.no_grad():
        net.head.bias += 0.05  # other weights: the shipped export no longer describes them
    save_weights(with_new_weights, net, info.get("meta"))
    assert load_runner(str(with_new_weights)).kind == "torch"  # no export beside it
    shutil.copy(SHIPPED_ONNX, onnx_path(with_new_weights))
    assert load_runner.__wrapped__(str(with_new_weights)).kind == "torch"  # stale export
    onnx_path(with_new_weights).write_bytes(b"not an onnx file")
    assert load_runner.__wrapped__(str(with_new_weights)).kind == "torch"  # damaged export
    export_onnx(with_new_weights)  # a fresh export for them is used, and follows them
    runner = load_runner.__wrapped__(str(with_new_weights))
    assert runner.kind == "onnx"
    torch_runner = TorchRunner(net.eval())
    inputs = random_window(40, torch_runner.noise_dim, np.random.default_rng(1))
    assert np.abs(runner.run_window(*inputs) - torch_runner.run_window(*inputs)).max() < TOLERANCE
    shipped_torch, _ = _runners()
    assert np.abs(runner.run_window(*inputs) - shipped_torch.run_window(*inputs)).max() > 0.01  # really other weights


def test_an_export_recorded_for_another_data_layout_is_refused(tmp_path):
    import json

    import onnx

    weights = tmp_path / "generator.pt"
    shutil.copy(DEFAULT_WEIGHTS, weights)
    proto = onnx.load(str(SHIPPED_ONNX))
    for entry in proto.metadata_props:
        if entry.key == "weights_info":
            info = json.loads(entry.value)
            info["layout"]["fps"] = 30
            entry.value = json.dumps(info)
    onnx.save(proto, str(onnx_path(weights)))
    with pytest.raises(WeightsError, match="different data layout"):
        load_runner.__wrapped__(str(weights))


def test_missing_weights_are_reported_as_before(tmp_path):
    with pytest.raises(WeightsError, match="not found"):
        load_runner.__wrapped__(str(tmp_path / "none.pt"))


def test_generate_imports_neither_torch_nor_scipy_signal(tmp_path):
    """The fast cold start (benchmarks/bench_cold_start.py): a one-utterance `sgt generate`
    resamples without scipy and loads no torch; the default (matching) engine loads no
    network runtime at all, the neural engine onnxruntime."""
    script = tmp_path / "one.sgt"
    script.write_text("guide: Welcome to the mall! [pose:point_right] The shops are over there.\n")
    code = ("import sys; from sgt_tui.cli import main; rc = main(sys.argv[1:]); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'torch', 'onnxruntime', 'librosa'}), "
            "'scipy.signal' in sys.modules, rc)")
    for extra, runtimes in (((), "[]"), (("--engine", "neural"), "['onnxruntime']")):
        r = subprocess.run([sys.executable, "-c", code, "generate", str(script), "-o", str(tmp_path / "m.json"), *extra],
                           capture_output=True, text=True, cwd=ROOT, timeout=300)
        assert r.stdout.strip().splitlines()[-1] == f"{runtimes} False 0", r.stderr
