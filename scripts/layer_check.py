"""Layered gestures: how should the generator be fed a gesture that drives only some limbs?

The network takes one pose-mask bit per frame, so a one-handed gesture can reach it in two
ways. This script compares them on real speech (espeak-ng) with the given weights:

- ``free`` (what sgt does, :func:`core.controls.network_pose_controls`): frames that control
  only some bones are fed as uncontrolled; the blend then puts the controlled bones exactly
  where they were asked for, bone by bone;
- ``whole``: the gesture's whole pose is fed with the mask bit set (the bones it leaves free
  at their spec values, the rest pose), then the same per-bone blend;
- ``old``: as before layering, the whole pose fed and blended on every bone.

For each it prints the free arm's wrist speed (m/s, mean and 95th percentile) while the
one-handed gesture plays, the same for the generator with no gesture at all (the reference),
the pose error on the controlled bones (PCS on those bones; 0 = exact), the largest turn of a
controlled bone at the mask's edges (degrees per frame), and the same for a nod (the arms free).

    python scripts/layer_check.py [--weights FILE] [--seeds 4]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

from core.controls import ControlArrays  # noqa: E402
from core.skeleton import FPS, JOINT_INDEX, N_BONES, positions_from_pose  # noqa: E402

SCRIPTS = {
    "point_right": "guide: The harbour is [pose:point_right hold=2s] over there, behind the old boats, where the ferries come in every morning.\n",
    "nod": "guide: Yes, that is right, [pose:nod] we open every day at nine and close late in the evening for the summer.\n",
}


def _whole_arrays(u) -> ControlArrays:
    """The plan's controls with every gesture's whole pose requested (no per-bone mask)."""
    arrays = ControlArrays.empty(u.n_frames)
    arrays.style[:], arrays.style_mask[:] = u.arrays.style, u.arrays.style_mask
    for p in u.requests.poses:
        arrays.set_pose(p.start, p.clip().poses[: p.length])
    return arrays


def _speed(poses, joint) -> np.ndarray:
    p = positions_from_pose(poses)[:, JOINT_INDEX[joint]]
    return np.linalg.norm(np.diff(p, axis=0), axis=-1) * FPS


def _edge_turn(out, bones) -> float:
    """The largest per-frame turn (degrees) of a controlled bone within 8 frames of its mask's edges."""
    d = out.reshape(len(out), N_BONES, 3).astype(np.float64)
    turn = np.degrees(np.arccos(np.clip(np.sum(d[1:] * d[:-1], -1), -1, 1)))
    worst = 0.0
    for b in np.flatnonzero(bones.any(0)):
        edges = np.flatnonzero(np.diff(bones[:, b].astype(int)))
        for e in edges:
            lo, hi = max(0, e - 8), min(len(turn), e + 8)
            worst = max(worst, float(turn[lo:hi, b].max()))
    return worst


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default=None)
    ap.add_argument("--seeds", type=int, default=4)
    args = ap.parse_args(argv)

    from dsl import compile_file
    from model import features, neural, postprocess
    from model.generate import EngineInputs

    model = neural._model(args.weights)
    for name, text in SCRIPTS.items():
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / f"{name}.sgt"
            path.write_text(text)
            u = compile_file(path).plan.utterances[0]
            inputs = EngineInputs.from_plan(u)
            audio, ids, onsets = features.speech_inputs(inputs, u.n_frames)
        layered = u.arrays
        bones = layered.bones() > 0.5
        span = np.flatnonzero(bones.any(1))
        free_joint = "left_wrist" if name == "point_right" else "right_wrist"
        free_bone = np.array([not bones[:, b].any() for b in range(N_BONES)])
        rows = {k: [] for k in ("none", "free", "whole", "old")}
        for seed in range(args.seeds):
            empty = ControlArrays.empty(u.n_frames)
            empty.style[:], empty.style_mask[:] = layered.style, layered.style_mask
            outs = {
                "none": postprocess.finish(neural.run_windows(model, audio, ids, onsets, empty, seed), empty.pose, empty.pose_mask),
                "free": neural.generate(inputs, seed=seed, options=neural.Options(weights=args.weights)),
            }
            whole = _whole_arrays(u)
            raw_whole = neural.run_windows(model, audio, ids, onsets, whole, seed)
            outs["whole"] = postprocess.finish(raw_whole, layered.pose, layered.pose_mask, bones=layered.bone_mask)
            outs["old"] = postprocess.finish(raw_whole, whole.pose, whole.pose_mask)
            for k, out in outs.items():
                v = _speed(out, free_joint)[span[0] : span[-1]]
                req = layered.pose.reshape(-1, N_BONES, 3)[bones]
                got = out.reshape(-1, N_BONES, 3)[bones]
                pcs = float(np.abs(req - got).mean()) if k != "none" else float("nan")
                rows[k].append((v.mean(), np.percentile(v, 95), pcs, _edge_turn(out, bones) if k != "none" else float("nan")))
        print(f"\n{name}: {len(span)} controlled frames, free {free_joint.replace('_', ' ')}; "
              f"free bones: {', '.join(b for b, f in zip(('neck', 'nose', 'head_top', 'l_shoulder', 'l_elbow', 'l_wrist', 'r_shoulder', 'r_elbow', 'r_wrist'), free_bone) if f)}")
        print(f"  {'feeding':<8} {'wrist m/s mean':>15} {'p95':>6} {'PCS ctrl':>9} {'edge deg/frame':>15}")
        for k, r in rows.items():
            a = np.array(r)
            print(f"  {k:<8} {a[:, 0].mean():15.3f} {a[:, 1].mean():6.3f} {np.nanmean(a[:, 2]) if k != 'none' else float('nan'):9.4f} "
                  f"{np.nanmean(a[:, 3]) if k != 'none' else float('nan'):15.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
