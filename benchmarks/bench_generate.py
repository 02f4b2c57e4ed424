"""Benchmark: generation speed and memory of the neural engine.

    python benchmarks/bench_generate.py [--weights PATH] [--repeat 7]

Prints
1. model time for 20 s of speech after loading (sliding windows + post-processing; budget 50 ms),
   for each way the network runs: onnxruntime on one thread (what `sgt generate`, `sgt build`
   and the service run when the shipped export is fresh) and PyTorch on one and two threads
   (training, evaluation, weights without an export),
2. where the wall time of a whole `sgt generate` of one utterance goes: interpreter and
   imports, speech synthesis (cold cache), audio features, model, post-processing, writing,
3. peak memory (RSS) of generating 1, 5 and 10 minutes of speech, to show it does not grow with
   the length beyond the output itself.

Uses the shipped weights (model/weights/generator.pt) when present; otherwise a freshly
initialised network of the default size (same speed, meaningless motion) and says so.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

CHILD = r"""
import json, resource, sys, time
import numpy as np
sys.path.insert(0, {root!r})
from core.controls import ControlArrays
from core.skeleton import FPS
from model import neural
from model.net import GestureNet
from model.features import AUDIO_DIM
import torch
torch.set_num_threads(2)
minutes = float(sys.argv[1])
n = int(minutes * 60 * FPS)
model = GestureNet()
model.eval()
arrays = ControlArrays.empty(n)
audio = np.random.default_rng(0).normal(size=(n, AUDIO_DIM)).astype(np.float32)
ids = np.zeros(n, np.int64); onsets = np.zeros(n, np.float32)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out = neural.run_windows(model, audio, ids, onsets, arrays, 0)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"frames": n, "rss_before_mb": before / 1024, "rss_after_mb": after / 1024, "output_mb": out.nbytes / 2**20}}))
"""


def random_inputs(n: int, seed: int = 0):
    """A network's inputs for ``n`` frames of made-up speech and no controls: (controls, audio
    features, word ids, onset flags); the timing does not depend on what they say."""
    import numpy as np

    from core.controls import ControlArrays
    from model.features import AUDIO_DIM

    rng = np.random.default_rng(seed)
    audio = rng.normal(size=(n, AUDIO_DIM)).astype(np.float32)
    ids = rng.integers(1, 4096, n)
    onsets = (rng.random(n) < 0.1).astype(np.float32)
    return ControlArrays.empty(n), audio, ids, onsets


def model_time(weights, repeat: int) -> None:

    from core.skeleton import FPS
    from model import neural, postprocess

    if weights and Path(weights).exists():
        from model.weights import load_weights

        model, _ = load_weights(weights)
        what = f"weights {weights}"
    else:
        import torch

        from model.net import GestureNet

        torch.manual_seed(0)
        model = GestureNet().eval()
        what = "untrained default-size network (no weights file)"
    import torch

    from model.runtime import TorchRunner, fresh_export

    n = 20 * FPS
    arrays, audio, ids, onsets = random_inputs(n)
    print(f"model: {what}; {sum(p.numel() for p in model.parameters()):,} parameters")
    runners = [(f"PyTorch, {t} thread{'s' if t > 1 else ''}", TorchRunner(model), t) for t in (1, 2)]
    export = fresh_export(weights) if weights and Path(weights).exists() else None
    if export is not None:  # what `sgt generate` and the service run
        runners.insert(0, ("onnxruntime (what sgt generate runs), 1 thread", export, 1))
    for name, runner, threads in runners:
        torch.set_num_threads(threads)
        neural.run_windows(runner, audio, ids, onsets, arrays, 0)  # warm-up
        times, post = [], []
        for _ in range(repeat):
            t = time.perf_counter()
            raw = neural.run_windows(runner, audio, ids, onsets, arrays, 0)
            t1 = time.perf_counter()
            postprocess.finish(raw, arrays.pose, arrays.pose_mask, style=arrays.style, style_mask=arrays.style_mask)
            t2 = time.perf_counter()
            times.append(t1 - t)
            post.append(t2 - t1)
        print(f"20 s of speech ({n} frames), {name}: network median {statistics.median(times) * 1000:.1f} ms "
              f"(min {min(times) * 1000:.1f}), post-processing median {statistics.median(post) * 1000:.1f} ms (n={repeat})")


def generate_breakdown(weights) -> None:
    from core.skeleton import FPS
    from model.features import audio_features, load_audio

    text = "guide: Welcome to the mall! [pose:point_right] The shops are over there, and the food court is upstairs."
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "one.sgt"
        script.write_text(text + "\n")
        env_cache = {"SGT_CACHE_DIR": str(Path(tmp) / "cache")}
        import os

        env = {**os.environ, **env_cache}
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import sgt_tui.cli"], check=True, env=env)
        t_start = time.perf_counter() - t
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import torch"], check=True, env=env)
        t_imports = time.perf_counter() - t - t_start
        t = time.perf_counter()
        os.environ.update(env_cache)
        from dsl.compiler import compile_file

        result = compile_file(script, timing="speech")
        t_tts = time.perf_counter() - t
        u = result.plan.utterances[0]
        t = time.perf_counter()
        audio = load_audio(u.audio_path)
        t_load = time.perf_counter() - t
        t = time.perf_counter()
        audio_features(audio, u.n_frames, int(round(u.lead_in * FPS)))
        t_feat = time.perf_counter() - t
        args = [sys.executable, "-m", "sgt_tui.cli", "generate", str(script), "-o", str(Path(tmp) / "m.json")]
        if weights:
            args += ["--weights", str(weights)]
        times = []
        for _ in range(3):
            t = time.perf_counter()
            r = subprocess.run(args, env=env, capture_output=True, text=True)
            times.append(time.perf_counter() - t)
        if r.returncode != 0:
            print(f"sgt generate failed: {r.stderr.strip()}")
            return
    print(f"`sgt generate` of one {u.duration:.1f} s utterance, warm speech cache: median {statistics.median(times):.2f} s")
    print(f"  interpreter + sgt imports {t_start:.2f} s; torch import {t_imports:.2f} s; "
          f"speech synthesis (cold) {t_tts:.2f} s; reading and resampling the audio {t_load:.3f} s; "
          f"audio features {t_feat:.3f} s")


def memory() -> None:
    for minutes in (1, 5, 10):
        r = subprocess.run([sys.executable, "-c", CHILD.format(root=str(ROOT)), str(minutes)], capture_output=True, text=True, check=True)
        d = json.loads(r.stdout.strip().splitlines()[-1])
        print(f"{minutes:>2} min of speech ({d['frames']} frames): peak RSS {d['rss_after_mb']:.0f} MiB "
              f"(before generating {d['rss_before_mb']:.0f} MiB; the output itself {d['output_mb']:.1f} MiB)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default=str(ROOT / "model" / "weights" / "generator.pt"))
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    weights = args.weights if Path(args.weights).exists() else None
    model_time(weights, args.repeat)
    generate_breakdown(weights)
    memory()
    return 0


if __name__ == "__main__":
    sys.exit(main())
