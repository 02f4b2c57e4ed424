"""Benchmark: generation speed of the flow engine (model/flow.py) and of its stream.

    python benchmarks/bench_flow.py [--weights PATH] [--repeat 21]

Prints
1. the time for 20 s of speech after loading, with the sampler steps the weights ship with:
   the sliding windows (:func:`model.flow.run_windows`) and the post-processing
   (:func:`model.postprocess.finish`), in onnxruntime on one thread (what ``sgt generate``
   runs while the export beside the weights is fresh) and in PyTorch on one thread (training,
   ``sgt eval`` of weights without an export); the budget is 100 ms;
2. the stream (:class:`model.flow_stream.FlowStreamGenerator`): the time to decide one frame
   (one sampler call), against the 67 ms a frame lasts at 15 fps.

Medians over ``--repeat`` runs (the machine is shared: quote medians). Uses the shipped flow
weights (model/weights/flow.pt) unless ``--weights`` names others.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default=str(ROOT / "model" / "weights" / "flow.pt"))
    ap.add_argument("--repeat", type=int, default=21)
    args = ap.parse_args()

    import torch

    from bench_generate import random_inputs  # benchmarks/ is the script's folder
    from core.skeleton import FPS
    from model import flow, postprocess
    from model.flow_stream import FlowStreamGenerator
    from model.runtime import TorchRunner, fresh_export
    from model.weights import load_weights

    torch.set_num_threads(1)
    net, _ = load_weights(args.weights, "flow")
    steps = len(net.config["times"])
    print(f"weights {args.weights}: {sum(p.numel() for p in net.parameters()):,} parameters, {steps} sampler steps "
          f"(times {net.config['times']}), guidance {net.config['guidance']}")
    n = 20 * FPS
    arrays, audio, ids, onsets = random_inputs(n)
    runners = [("PyTorch, 1 thread", TorchRunner(net))]
    export = fresh_export(args.weights)
    if export is not None:
        runners.insert(0, ("onnxruntime, 1 thread (what sgt generate runs)", export))
    else:
        print("no fresh ONNX export beside the weights: python scripts/export_onnx.py --weights", args.weights)
    for name, runner in runners:
        flow.run_windows(runner, audio, ids, onsets, arrays, 0)  # warm-up
        net_t, post_t = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            raw = flow.run_windows(runner, audio, ids, onsets, arrays, 0)
            t1 = time.perf_counter()
            postprocess.finish(raw, arrays.pose, arrays.pose_mask, style=arrays.style, style_mask=arrays.style_mask)
            post_t.append(time.perf_counter() - t1)
            net_t.append(t1 - t0)
        total = [a + b for a, b in zip(net_t, post_t)]
        print(f"20 s of speech ({n} frames), {name}: median {statistics.median(total) * 1000:.1f} ms (min "
              f"{min(total) * 1000:.1f}): sampler {statistics.median(net_t) * 1000:.1f} ms, post-processing "
              f"{statistics.median(post_t) * 1000:.1f} ms (n={args.repeat})")
    runner = runners[0][1]
    words = [(f"w{i}", i / FPS, (i + 5) / FPS) for i in range(0, n, 7)]
    gen = FlowStreamGenerator(runner, seed=0)
    gen.add_words(words[:3])
    per_frame = []
    for w in words[3:40]:
        t0 = time.perf_counter()
        got = gen.add_words([w])
        if len(got):
            per_frame.append((time.perf_counter() - t0) / len(got))
    print(f"stream ({runners[0][0]}): median {statistics.median(per_frame) * 1000:.1f} ms a frame "
          f"(max {max(per_frame) * 1000:.1f}; a frame lasts {1000 / FPS:.0f} ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
