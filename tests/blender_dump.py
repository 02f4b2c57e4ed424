"""Run inside Blender: import glTF/BVH files with Blender's own importers, write world poses.

    blender -b --factory-startup --python tests/blender_dump.py -- OUT.json FILE.glb FILE.bvh ...

For every file: the scene's frame rate after the import, the action's frames, and per frame and
bone the bone head's world position and the bone's world rotation relative to its rest
(3x3), all in Blender's z-up world (tests/test_rig_readers.py converts back to y-up).
Standard library and bpy only: Blender's Python need not have numpy.
"""

import json
import sys

import bpy

try:  # Debian 12's Blender 3.4 glTF mesh importer uses np.bool, removed in numpy 1.24
    import numpy

    if not hasattr(numpy, "bool"):
        numpy.bool = bool
except ImportError:
    pass

if sys.version_info >= (3, 11):  # Blender 3.4's BVH importer opens files with mode "rU", gone in 3.11
    import builtins

    _open = builtins.open

    def _open_without_u(file, mode="r", *args, **kwargs):
        return _open(file, mode.replace("U", "") if isinstance(mode, str) else mode, *args, **kwargs)

    builtins.open = _open_without_u


def dump(path: str) -> dict:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    if path.endswith(".bvh"):
        bpy.ops.import_anim.bvh(filepath=path, update_scene_fps=True, update_scene_duration=True)
    else:
        # glTF keys are in seconds; Blender places them at seconds * scene fps.
        scene.render.fps, scene.render.fps_base = 15, 1.0
        bpy.ops.import_scene.gltf(filepath=path)
    arm = next(o for o in scene.objects if o.type == "ARMATURE")
    f0, f1 = arm.animation_data.action.frame_range
    frames = list(range(int(round(f0)), int(round(f1)) + 1))
    out = {"fps": scene.render.fps / scene.render.fps_base, "frames": frames, "heads": {}, "rotations": {}}
    rest = {pb.name: (arm.matrix_world @ pb.bone.matrix_local).to_3x3().inverted() for pb in arm.pose.bones}
    for pb in arm.pose.bones:
        out["heads"][pb.name] = []
        out["rotations"][pb.name] = []
    for f in frames:
        scene.frame_set(f)
        for pb in arm.pose.bones:
            out["heads"][pb.name].append(list(arm.matrix_world @ pb.head))
            m = (arm.matrix_world @ pb.matrix).to_3x3() @ rest[pb.name]
            out["rotations"][pb.name].append([list(row) for row in m])
    return out


def main() -> None:
    argv = sys.argv[sys.argv.index("--") + 1:]
    result = {path: dump(path) for path in argv[1:]}
    with open(argv[0], "w") as f:
        json.dump(result, f)


main()
