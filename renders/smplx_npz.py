"""SMPL-X joint rotations as an ``.npz`` in the layout SMPL-X tools read.

Keys (T frames; float32 arrays unless said; axis-angle vectors in radians, each joint's rotation
relative to its parent, against SMPL-X's rest T-pose):

- the ``smplx`` package's forward-pass arguments: ``global_orient`` (T, 3) = joint 0 (pelvis),
  ``body_pose`` (T, 63) = joints 1..21 in SMPL-X order, ``transl`` (T, 3), ``betas`` (10,),
  ``jaw_pose``, ``leye_pose``, ``reye_pose`` (T, 3), ``expression`` (T, 10) (zeros), and
  ``left_hand_pose``, ``right_hand_pose`` (T, 45): the 15 finger joints of each hand in SMPL-X
  order (index1..3, middle1..3, pinky1..3, ring1..3, thumb1..3), full axis-angle (not PCA),
  relative to a flat hand: build the model with ``use_pca=False, flat_hand_mean=True``;
- AMASS's names for the same numbers: ``poses`` (T, 165) = root, body, jaw, left eye, right eye,
  left hand, right hand (55 joints x 3), ``root_orient``, ``pose_body``, ``pose_jaw``,
  ``pose_eye`` (T, 6), ``pose_hand`` (T, 90), ``trans``, ``num_betas`` (10),
  ``mocap_frame_rate`` (15.0), ``mocap_time_length`` (seconds), ``gender`` ("neutral"),
  ``surface_model_type`` ("smplx");
- ``joint_names`` (the 22 body joints), ``hand_joint_names`` (the 15 of each hand),
  ``flat_hand_mean`` (True: the hand poses are relative to a flat hand) and ``coordinates``.

Coordinates: the SMPL-X model's own frame (y up, facing +z, metres), which is also sgt's; AMASS's
captured takes are z-up, so code that turns AMASS takes upright must skip that turn for these.
``transl`` is the movement of sgt's root from its rest position times the rig's scale: zero for
a still root, the pelvis then stays where the SMPL-X template puts it.
"""

from __future__ import annotations

import io

import numpy as np

from core.fileio import atomic_write
from core.motion import MotionClip
from core.skeleton import FPS
from renders.rigs import SMPLX
from renders.rigs.retarget import retarget_clip
from renders.rigs.smplx import HAND_JOINT_NAMES, JOINT_NAMES
from renders.rotations import continuous_axis_angle

COORDINATES = "y-up, right-handed, metres, body facing +z (the SMPL-X model frame; not AMASS's z-up)"


def smplx_arrays(clip: MotionClip) -> dict[str, np.ndarray]:
    motion = retarget_clip(SMPLX, clip)
    T = motion.n_frames
    aa = continuous_axis_angle(motion.local).astype(np.float32)  # (T, bones, 3), no jumps between frames
    f = np.float32
    global_orient, body_pose = aa[:, 0], aa[:, 1:22].reshape(T, 63)
    hand = {side: aa[:, [SMPLX.index[f"{side}_{n}"] for n in HAND_JOINT_NAMES]].reshape(T, 45)
            for side in ("left", "right")}
    transl = (motion.root_translation - SMPLX.heads()[0]).astype(f)
    z3 = np.zeros((T, 3), f)
    poses = np.concatenate([global_orient, body_pose, z3, z3, z3, hand["left"], hand["right"]], axis=1)
    return {
        "global_orient": global_orient, "body_pose": body_pose, "transl": transl, "betas": np.zeros(10, f),
        "jaw_pose": z3, "leye_pose": z3, "reye_pose": z3, "left_hand_pose": hand["left"],
        "right_hand_pose": hand["right"], "expression": np.zeros((T, 10), f),
        "poses": poses, "root_orient": global_orient, "pose_body": body_pose, "pose_jaw": z3,
        "pose_eye": np.zeros((T, 6), f), "pose_hand": np.concatenate([hand["left"], hand["right"]], axis=1),
        "trans": transl, "flat_hand_mean": np.array(True),
        "num_betas": np.array(10), "mocap_frame_rate": np.array(float(FPS)),
        "mocap_time_length": np.array(T / FPS), "gender": np.array("neutral"),
        "surface_model_type": np.array("smplx"), "joint_names": np.array(JOINT_NAMES),
        "hand_joint_names": np.array(HAND_JOINT_NAMES),
        "coordinates": np.array(COORDINATES),
    }


def write_smplx_npz(path, clip: MotionClip) -> None:
    buf = io.BytesIO()
    np.savez_compressed(buf, **smplx_arrays(clip))
    atomic_write(path, buf.getvalue())
