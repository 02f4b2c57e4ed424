"""Real clients read the face's glTF exports:

- three.js with @pixiv/three-vrm-animation (node; tests/node/read_face.mjs) loads the ``.vrma``'s
  expression tracks and plays them through createVRMAnimationClip onto a VRM's expression
  manager; three's GLTFLoader makes the ``.glb``'s face meshes with ARKit-named morph targets and
  plays their influences;
- the Khronos glTF validator (npm ``gltf-validator``; tests/node/validate.mjs) reports no error;
- Blender's own glTF importer (``blender -b``) makes shape keys named after the 52 blendshapes,
  keyed frame by frame with the face's weights.

The node packages are tests/node's (``cd tests/node && npm ci``; scripts/install.sh does it);
without them, or without Blender, these tests are skipped and say why.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_face_export import face_clip

from core.face import ARKIT_NAMES
from core.skeleton import FPS

HERE = Path(__file__).resolve().parent
NODE_DIR = HERE / "node"
NODE = shutil.which("node")
BLENDER = shutil.which("blender")
needs_node = pytest.mark.skipif(
    NODE is None or not (NODE_DIR / "node_modules" / "@pixiv" / "three-vrm-animation").is_dir()
    or not (NODE_DIR / "node_modules" / "gltf-validator").is_dir(),
    reason="tests/node's packages are not installed (cd tests/node && npm ci; scripts/install.sh does it)")
needs_blender = pytest.mark.skipif(BLENDER is None, reason="blender is not installed (apt-get install blender)")


def _node(script: str, *args) -> dict:
    proc = subprocess.run([NODE, str(NODE_DIR / script), *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=NODE_DIR, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    """The .vrma and the --rig sgt .glb of a talking face (45 frames, the head turning at 20)."""
    from renders.gltf import write_glb
    from renders.rigs import get_rig

    d = tmp_path_factory.mktemp("face-gltf")
    clip = face_clip()
    write_glb(d / "take.vrma", clip, get_rig("vrm"))
    write_glb(d / "take.glb", clip, get_rig("sgt"))
    return clip, d / "take.vrma", d / "take.glb"


FRAMES = (0, 7, 11, 20, 30, 44)


@needs_node
def test_three_vrm_animation_loads_and_plays_the_vrma_expression_tracks(exports):
    from renders.face_export import VRM_EXPRESSIONS, vrm_expressions

    clip, vrma, _ = exports
    got = _node("read_face.mjs", "vrma", vrma, *(f / FPS for f in FRAMES))
    want = vrm_expressions(clip.face)
    assert list(got["presetTracks"]) == list(VRM_EXPRESSIONS) and got["customTracks"] == []
    for name, track in got["presetTracks"].items():
        assert track["trackName"] == f"{name}.weight"
        np.testing.assert_allclose(track["times"], np.arange(clip.n_frames) / FPS, atol=1e-6)
        np.testing.assert_allclose(track["values"], want[name], atol=1e-6, err_msg=name)
    # Played on a VRM's expression manager at the frames' times: the weights the frames have.
    for frame, played in zip(FRAMES, got["played"]):
        for name, value in played["weights"].items():
            assert value == pytest.approx(float(want[name][frame]), abs=1e-5), (frame, name)
    blinks = [p["weights"]["blink"] for p in got["played"]]
    assert blinks[2] == pytest.approx(1.0, abs=1e-3) and blinks[0] < 0.1  # frame 11 blinks, frame 0 does not
    assert got["played"][4]["weights"]["blinkLeft"] > 0.9  # frame 30: the left eye alone
    assert got["played"][0]["weights"]["lookRight"] > 0.8 and got["played"][-1]["weights"]["lookLeft"] > 0.8


@needs_node
def test_three_gltf_loader_makes_the_glb_face_with_arkit_morph_targets_that_play(exports):
    clip, _, glb = exports
    got = _node("read_face.mjs", "glb", glb, *(f / FPS for f in FRAMES))
    assert len(got["meshes"]) >= 8
    assert all(m["targets"] == list(ARKIT_NAMES) for m in got["meshes"])
    assert len(got["weightTracks"]) == len(got["meshes"])
    for frame, played in zip(FRAMES, got["played"]):
        for influences in played["influences"]:
            np.testing.assert_allclose(influences, clip.face.weights[frame], atol=1e-6, err_msg=str(frame))


@needs_node
def test_the_khronos_validator_finds_no_error_in_the_glb_and_the_vrma(exports, tmp_path):
    from renders.gltf import write_glb
    from renders.rigs import get_rig

    _, vrma, glb = exports
    plain = tmp_path / "mixamo.glb"
    write_glb(plain, face_clip(10), get_rig("mixamo"))
    report = _node("validate.mjs", glb, vrma, plain)
    for path, r in report.items():
        assert r["errors"] == 0, (path, r["messages"])
        assert r["warnings"] == 0, (path, r["messages"])
    # The only notes: the VRM extension the validator does not know, and the expression nodes
    # (nodes with nothing but a translation, which is what the extension asks for).
    notes = {m.split(" ")[1] for m in report[str(vrma)]["messages"]}
    assert notes <= {"UNSUPPORTED_EXTENSION", "NODE_EMPTY"}, report[str(vrma)]["messages"]


BLENDER_SCRIPT = r'''
import json, sys
import bpy
try:  # Debian 12's Blender 3.4 glTF mesh importer uses np.bool, removed in numpy 1.24
    import numpy
    if not hasattr(numpy, "bool"):
        numpy.bool = bool
except ImportError:
    pass
out_path, path = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps, scene.render.fps_base = 15, 1.0  # glTF keys are seconds: one key per frame
bpy.ops.import_scene.gltf(filepath=path)
out = {}
for o in scene.objects:
    if o.type != "MESH" or o.data.shape_keys is None:
        continue
    keys = o.data.shape_keys
    action = keys.animation_data.action if keys.animation_data else None
    f0, f1 = (int(round(x)) for x in action.frame_range)
    frames = []
    for f in range(f0, f1 + 1):
        scene.frame_set(f)
        frames.append({"frame": f, "values": {k.name: k.value for k in keys.key_blocks[1:]},
                       "location": list(o.matrix_world.translation)})
    out[o.name] = {"keys": [k.name for k in keys.key_blocks], "curves": sorted(c.data_path for c in action.fcurves),
                   "frames": frames}
json.dump(out, open(out_path, "w"))
'''


@needs_blender
@pytest.mark.slow
def test_blender_imports_the_glb_with_its_shape_keys_animated(exports, tmp_path):
    clip, _, glb = exports
    script = tmp_path / "shape_keys.py"
    script.write_text(BLENDER_SCRIPT)
    out = tmp_path / "blender.json"
    env = dict(os.environ)
    env["PATH"] = "/usr/local/bin:/usr/bin:/bin"  # Debian's Python for Blender (tests/rig_readers.py)
    proc = subprocess.run([BLENDER, "-b", "--factory-startup", "--python", str(script), "--", str(out), str(glb)],
                          capture_output=True, text=True, timeout=600, env=env, check=False)
    assert proc.returncode == 0 and out.exists(), proc.stdout[-3000:] + proc.stderr[-3000:]
    result = json.loads(out.read_text())
    assert list(result) == ["face"], list(result)
    face = result["face"]
    assert face["keys"] == ["Basis", *ARKIT_NAMES]
    assert face["curves"] == sorted(f'key_blocks["{n}"].value' for n in ARKIT_NAMES)
    assert [f["frame"] for f in face["frames"]] == list(range(clip.n_frames))
    for f in face["frames"]:
        got = np.array([f["values"][n] for n in ARKIT_NAMES])
        np.testing.assert_allclose(got, clip.face.weights[f["frame"]], atol=1e-5, err_msg=str(f["frame"]))
    # The face rides on the head: its object moves when the head turns (frame 20 on).
    loc = np.array([f["location"] for f in face["frames"]])
    assert np.ptp(loc[:20], axis=0).max() < 1e-6 and np.linalg.norm(loc[25] - loc[0]) > 0.01
