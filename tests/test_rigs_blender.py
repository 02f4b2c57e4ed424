"""Blender's own glTF and BVH importers (Debian's ``blender``, run headless) read the rig exports:
joint positions and bone turns against sgt's motion (tests/rig_readers.py). Skipped without
Blender (scripts/install.sh installs it)."""

from __future__ import annotations

import pytest
from rig_readers import BLENDER, check, read_with_blender, sgt_position_error_mm
from test_export import _library_clip

pytestmark = [pytest.mark.slow, pytest.mark.skipif(BLENDER is None, reason="blender is not installed (apt-get install blender)")]

# Blender keeps rotations as float32 matrices: arccos near 1 turns that into ~0.05 degrees.
AIM_DEG, CHAIN_MM, ORIENT_DEG, ROOT_MM, SGT_MM = 0.01, 0.01, 0.2, 0.01, 0.01


def test_blender_imports_gltf_and_bvh_of_every_rig(tmp_path):
    from core.motion import MotionClip
    from renders.export import write_bvh
    from renders.gltf import write_glb
    from renders.rigs import SKELETAL_RIGS

    c = _library_clip(("wave", "point_right", "shrug", "nod", "thumbs_up", "count_three", "small"))
    clip = MotionClip(poses=c.poses, positions=c.positions + [0.05, 0.0, 0.1], hands=c.hands)  # the root moves too
    paths = []
    for name, rig in SKELETAL_RIGS.items():
        for suffix, write in ((".glb", write_glb), (".bvh", write_bvh)):
            path = tmp_path / f"{name}{suffix}"
            write(path, clip, rig)
            paths.append((name, path))
    result = read_with_blender([p for _, p in paths], tmp_path / "blender.json")
    for name, path in paths:
        r = result[str(path)]
        what = f"{path.name} in Blender"
        assert abs(r["fps"] - 15.0) < 1e-3, f"{what}: scene at {r['fps']} fps"
        assert all(len(v) == clip.n_frames for v in r["heads"].values()), what
        fig = check(SKELETAL_RIGS[name], clip, r)
        assert fig["aim_deg"] < AIM_DEG, f"{what}: {fig}"
        assert fig["chain_mm"] < CHAIN_MM, f"{what}: {fig}"
        assert fig["orient_deg"] < ORIENT_DEG, f"{what}: {fig}"
        assert fig["follow_deg"] < ORIENT_DEG, f"{what}: {fig}"
        assert fig["root_mm"] < ROOT_MM, f"{what}: {fig}"
        assert fig["roll_deg"] < ORIENT_DEG, f"{what}: {fig}"
        if name == "sgt":
            assert sgt_position_error_mm(clip, r) < SGT_MM, what
