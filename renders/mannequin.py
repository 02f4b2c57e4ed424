"""An offscreen shaded mannequin: one pyrender scene, node poses updated per frame.

The meshes (trimesh primitives) are built once; :meth:`Mannequin.render` only moves the
nodes. Hands are a palm (a flattened box) and the thumb and four fingers, three capsules each,
placed on the hand joints of :mod:`core.hands` (drawn a little thicker than life so that a
pointing index or a thumbs up reads at 240x240). The camera is fixed at a three-quarter view from the front-right of the character
(who faces +z), so its right hand is on the left of the picture.
"""

from __future__ import annotations

import numpy as np

from core.hands import DIGITS, HAND_JOINTS, SIDES, HandTrack, hand_positions, local_hand_joints
from core.interrupts import interrupts_deferred
from core.skeleton import BONE_LENGTHS
from core.skeleton import JOINT_INDEX as J
from renders import gl
from renders.rotations import align_z, frame_from, transform

BACKGROUND = (236, 239, 243)
BODY = (0.25, 0.36, 0.55)
SKIN = (0.80, 0.62, 0.48)
JOINT_COLOR = (0.17, 0.24, 0.37)

#: Camera: looks at TARGET from AZIMUTH degrees off the character's front (towards its
#: right, -x), slightly from above; vertical field of view in degrees.
TARGET = np.array([0.0, 1.39, 0.0])
AZIMUTH = 30.0
ELEVATION = 6.0
DISTANCE = 2.95
YFOV = 30.0

# (name, parent joint, child joint, radius): capsules drawn along bones.
_LIMBS = (
    ("l_clav", "neck", "left_shoulder", 0.045),
    ("l_upper", "left_shoulder", "left_elbow", 0.045),
    ("l_fore", "left_elbow", "left_wrist", 0.037),
    ("r_clav", "neck", "right_shoulder", 0.045),
    ("r_upper", "right_shoulder", "right_elbow", 0.045),
    ("r_fore", "right_elbow", "right_wrist", 0.037),
)
_BALLS = (("left_shoulder", 0.058), ("right_shoulder", 0.058), ("left_elbow", 0.047),
          ("right_elbow", 0.047))
#: Finger capsule radius (metres) per digit; the palm's half thickness.
_FINGER_RADIUS = {"thumb": 0.0125, "index": 0.0115, "middle": 0.0115, "ring": 0.011, "little": 0.010}
_PALM_HALF_THICKNESS = 0.015


#: The hand joints of a relaxed hand at the origin (segment lengths of the finger capsules).
_REST_HAND = local_hand_joints(HandTrack.rest(1).fingers[0, 0])


def camera_pose() -> np.ndarray:
    az = np.radians(AZIMUTH)
    el = np.radians(ELEVATION)
    # Front is +z; the character's right is -x.
    eye = TARGET + DISTANCE * np.array([-np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])
    return transform(_look_frame(eye - TARGET), eye)  # the camera looks along its own -z


def _look_frame(back: np.ndarray) -> np.ndarray:
    """Rotation whose -z looks against ``back`` with +y as close to world up as possible."""
    z = back / np.linalg.norm(back)
    x = np.cross(np.array([0.0, 1.0, 0.0]), z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


class Mannequin:
    """Offscreen renderer of skeleton positions (10, 3) to RGB images (H, W, 3) uint8."""

    def __init__(self, width: int = 320, height: int = 320) -> None:
        self.width, self.height = int(width), int(height)
        self.pyrender, self.renderer, self.platform = gl.start(self.width, self.height)
        # trimesh computes the meshes' vertex normals inside ``except BaseException`` (it falls
        # back from scipy.sparse on any error): a Ctrl-C landing there was logged as a warning and
        # the render ran on to the end (seen in CI). Hold it while the scene is built.
        try:
            with interrupts_deferred():
                self._build_scene()
        except BaseException:
            self.close()  # the GL context is released even when the build is interrupted
            raise

    def _build_scene(self) -> None:
        import trimesh

        pr = self.pyrender
        self.scene = pr.Scene(bg_color=[c / 255 for c in BACKGROUND] + [1.0], ambient_light=[0.18, 0.18, 0.2])
        self._nodes: dict[str, object] = {}

        def mat(rgb, rough=0.75):
            return pr.MetallicRoughnessMaterial(baseColorFactor=list(rgb) + [1.0], metallicFactor=0.0,
                                                roughnessFactor=rough)

        def add(name, tm, material):
            mesh = pr.Mesh.from_trimesh(tm, material=material, smooth=True)
            self._nodes[name] = self.scene.add(mesh, name=name)

        # Torso: a capsule widened across the shoulders, built along +y, about 0.42 m tall.
        torso = trimesh.creation.capsule(height=0.30, radius=0.1, count=[16, 16])
        torso.apply_transform(transform(np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]), [0, 0, 0]))  # z -> y
        torso.apply_scale([1.55, 1.0, 0.95])
        add("torso", torso, mat(BODY))
        hips = trimesh.creation.capsule(height=0.06, radius=0.1, count=[16, 16])
        hips.apply_transform(transform(np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]), [0, 0, 0]))
        hips.apply_scale([1.45, 1.0, 0.95])
        add("hips", hips, mat(JOINT_COLOR))
        neck = trimesh.creation.capsule(height=0.07, radius=0.042, count=[12, 12])
        add("neckpiece", neck, mat(SKIN))
        head = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        head.apply_scale([0.092, 0.112, 0.102])
        add("head", head, mat(SKIN, 0.6))
        nose = trimesh.creation.cone(radius=0.022, height=0.05, sections=12)  # along +z
        add("nose", nose, mat(SKIN, 0.6))
        for eye in ("eye_l", "eye_r"):
            add(eye, trimesh.creation.icosphere(subdivisions=1, radius=0.014), mat((0.15, 0.17, 0.2), 0.4))
        for name, a, b, r in _LIMBS:
            cap = trimesh.creation.capsule(height=BONE_LENGTHS[b], radius=r, count=[12, 12])
            add(name, cap, mat(BODY))
        for j, r in _BALLS:
            add("ball_" + j, trimesh.creation.icosphere(subdivisions=2, radius=r), mat(JOINT_COLOR))
        self._segments = []  # (node name, parent hand joint index or -1 for the wrist, child index)
        for side in SIDES:
            palm = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
            add(side + "_palm", palm, mat(SKIN, 0.6))
            wrist = trimesh.creation.icosphere(subdivisions=2, radius=0.026)
            add(side + "_wristball", wrist, mat(SKIN, 0.6))
            for d, digit in enumerate(DIGITS):
                for k in range(3):
                    a, b = 4 * d + k, 4 * d + k + 1
                    length = float(np.linalg.norm(_REST_HAND[b] - _REST_HAND[a]))
                    cap = trimesh.creation.capsule(height=length, radius=_FINGER_RADIUS[digit], count=[8, 8])
                    name = f"{side}_{HAND_JOINTS[b]}"
                    add(name, cap, mat(SKIN, 0.6))
                    self._segments.append((name, SIDES.index(side), a, b))

        cam = pr.PerspectiveCamera(yfov=np.radians(YFOV), aspectRatio=self.width / self.height, znear=0.5, zfar=10.0)
        self.scene.add(cam, pose=camera_pose())
        key = pr.DirectionalLight(color=[1.0, 0.97, 0.92], intensity=2.4)
        fill = pr.DirectionalLight(color=[0.85, 0.9, 1.0], intensity=0.9)
        rim = pr.DirectionalLight(color=[1.0, 1.0, 1.0], intensity=0.8)
        self.scene.add(key, pose=transform(_look_frame(np.array([-0.6, 0.9, 0.9])), [0, 0, 0]))
        self.scene.add(fill, pose=transform(_look_frame(np.array([0.9, 0.2, 0.7])), [0, 0, 0]))
        self.scene.add(rim, pose=transform(_look_frame(np.array([0.2, 0.6, -1.0])), [0, 0, 0]))

    # -- per frame ---------------------------------------------------------------------

    def _set(self, name: str, matrix: np.ndarray) -> None:
        self.scene.set_pose(self._nodes[name], matrix)

    def pose(self, positions: np.ndarray, hands: np.ndarray | None = None) -> None:
        """Move the nodes to joint ``positions`` (10, 3) in metres and the hands to hand
        joints ``hands`` (2, 20, 3) (:func:`core.hands.hand_positions`; relaxed when None)."""
        p = np.asarray(positions, dtype=np.float64)
        if hands is None:
            hands = hand_positions(p[None], HandTrack.rest(1))[0]
        spine, neck, nose, top = p[J["spine"]], p[J["neck"]], p[J["nose"]], p[J["head_top"]]
        ls, rs = p[J["left_shoulder"]], p[J["right_shoulder"]]
        # Torso frame: y along the spine, x across the shoulders (to the character's left).
        across = ls - rs
        up = neck - spine
        fwd = np.cross(across, up)
        torso = frame_from(up, fwd)
        self._set("torso", transform(torso, spine + 0.48 * up))
        self._set("hips", transform(torso, spine - 0.02 * up / max(np.linalg.norm(up), 1e-9)))
        # Head frame: y from the neck to the head top, z towards the nose.
        head_up = top - neck
        head = frame_from(head_up, nose - neck)
        hu = head[:, 1]
        hz = head[:, 2]
        center = top - 0.105 * hu - 0.01 * hz
        self._set("head", transform(head, center))
        neck_dir = center - neck
        self._set("neckpiece", transform(align_z(neck_dir), neck + 0.45 * neck_dir))
        self._set("nose", transform(head, center + 0.092 * hz - 0.012 * hu))
        for eye, sx in (("eye_l", 1.0), ("eye_r", -1.0)):
            pos = center + head @ np.array([0.036 * sx, 0.02, 0.084])
            self._set(eye, transform(head, pos))
        for name, a, b, _ in _LIMBS:
            pa, pb = p[J[a]], p[J[b]]
            self._set(name, transform(align_z(pb - pa), 0.5 * (pa + pb)))
        for j, _ in _BALLS:
            self._set("ball_" + j, transform(np.eye(3), p[J[j]]))
        self._pose_hands(p, np.asarray(hands, dtype=np.float64))

    def _pose_hands(self, p: np.ndarray, hands: np.ndarray) -> None:
        index, little = HAND_JOINTS.index("index_mcp"), HAND_JOINTS.index("little_mcp")
        for s, side in enumerate(SIDES):
            wrist = p[J[side + "_wrist"]]
            h = hands[s]
            knuckles = 0.5 * (h[index] + h[little])
            along = knuckles - wrist
            across = h[index] - h[little]
            frame = frame_from(along, np.cross(across, along))  # y to the knuckles, z out of one face
            width = float(np.linalg.norm(across)) + 0.022
            length = float(np.linalg.norm(along))
            m = transform(frame @ np.diag([width, length, 2 * _PALM_HALF_THICKNESS]), wrist + 0.5 * along)
            self._set(side + "_palm", m)
            self._set(side + "_wristball", transform(np.eye(3), wrist))
        for name, s, a, b in self._segments:
            pa = hands[s, a]
            pb = hands[s, b]
            self._set(name, transform(align_z(pb - pa), 0.5 * (pa + pb)))

    def render(self, positions: np.ndarray, hands: np.ndarray | None = None) -> np.ndarray:
        """An image of joint ``positions`` (10, 3) and hand joints ``hands`` (2, 20, 3)."""
        self.pose(positions, hands)
        # PyOpenGL drops exceptions raised inside its argument conversion, KeyboardInterrupt
        # included (a Ctrl-C landing there was lost and the render ran on): hold it for the frame.
        with interrupts_deferred():
            color, _ = self.renderer.render(self.scene)
        return np.ascontiguousarray(color[:, :, :3])

    def close(self) -> None:
        try:
            self.renderer.delete()
        except Exception:  # noqa: BLE001 - releasing the GL context is best effort: a broken GL stack raises
            pass  # anything here (TypeError from PyOpenGL's EGL import on this machine), and it must not hide the render's own result or error

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
