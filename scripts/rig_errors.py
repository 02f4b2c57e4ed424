"""Error figures of every rig export as read back by independent readers (docs/formats.md).

    python scripts/rig_errors.py            # the whole gesture library as one take

Readers: pygltflib (our own forward kinematics of the file's nodes and samplers), bvhio,
Blender's glTF and BVH importers (when `blender` is installed), scipy rotvecs for SMPL-X, and a
URDF-style forward kinematics of the robots' solved angles. Prints one line per reader and rig.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from rig_readers import BLENDER, check, read_bvh_bvhio, read_glb_pygltflib, read_with_blender, robot_figures, sgt_position_error_mm

from core.hands import concat
from core.motion import MotionClip
from library import load_library
from renders.export import write_bvh
from renders.gltf import write_glb
from renders.rigs import SKELETAL_RIGS


def main() -> None:
    lib = load_library(use_config=False)
    clips = [lib.get(n).clip() for n in lib.names()]
    clip = MotionClip(poses=np.concatenate([c.poses for c in clips]), hands=concat([c.hands for c in clips]))
    print(f"take: the {len(lib.names())} library gestures, {clip.n_frames} frames\n")
    print(f"{'reader':<10} {'rig':<7} {'file':<5} {'aim deg':>9} {'chain mm':>9} {'orient deg':>10} "
          f"{'follow deg':>10} {'roll deg':>9} {'root mm':>8} {'sgt mm':>8}")
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for name, rig in SKELETAL_RIGS.items():
            for suffix, write, read, reader in ((".glb", write_glb, read_glb_pygltflib, "pygltflib"),
                                                (".bvh", write_bvh, read_bvh_bvhio, "bvhio")):
                path = Path(tmp) / f"{name}{suffix}"
                write(path, clip, rig)
                paths.append((name, path))
                _row(reader, name, suffix, rig, clip, read(path))
        if BLENDER:
            result = read_with_blender([p for _, p in paths], Path(tmp) / "blender.json")
            for name, path in paths:
                _row("blender", name, path.suffix, SKELETAL_RIGS[name], clip, result[str(path)])
        else:
            print("blender: not installed, skipped")
    print(f"\n{'robot':<7} {'IK error deg (median / p95 / max)':<36} {'with limits (median / p95 / max)':<36} "
          f"{'range-clamped':>13} {'speed-clamped':>13}")
    for robot in ("nao", "pepper"):
        f = robot_figures(clip, robot)
        raw, lim = f["raw"], f["limited"]
        print(f"{robot:<7} {raw['median']:.3f} / {raw['p95']:.3f} / {raw['max']:.2f}{'':<16} "
              f"{lim['median']:.3f} / {lim['p95']:.2f} / {lim['max']:.1f}{'':<17} "
              f"{100 * f['position_clamped']:12.2f}% {100 * f['velocity_clamped']:12.2f}%")


def _row(reader, name, suffix, rig, clip, r) -> None:
    f = check(rig, clip, r)
    sgt = f"{sgt_position_error_mm(clip, r):8.4f}" if name == "sgt" else f"{'':>8}"
    print(f"{reader:<10} {name:<7} {suffix:<5} {f['aim_deg']:9.5f} {f['chain_mm']:9.5f} {f['orient_deg']:10.5f} "
          f"{f['follow_deg']:10.5f} {f['roll_deg']:9.5f} {f['root_mm']:8.5f} {sgt}")


if __name__ == "__main__":
    main()
