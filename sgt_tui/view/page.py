"""What the page of ``sgt view`` shows, as data (JSON for the page's code in ``viewer/src``).

A take becomes one document: per speaker its joint positions (frames x 10 x 3) and hand joint
positions (frames x 2 x 20 x 3, :func:`core.hands.hand_positions`) on the performance clock,
flattened and rounded to 0.1 mm; every utterance's words (their times as ``sgt render`` has them,
for the page to caption each frame with the word sgt does) and controls on that clock (a pose
control's ``stroke`` is the second its stroke keyframe plays, where a click on it jumps); and
sgt's own cameras, lights and colours (:mod:`renders.mannequin`), so that the page's mannequin,
seen from one of sgt's views, is the picture ``sgt render`` draws of that frame. A speaker with a
face (:class:`core.face.FaceTrack`) has ``face``: the blendshape weights that
:mod:`renders.face_rig` draws and that this take moves (``channels``; the ``eyeLook*`` ones are
left out: the gaze turns the pupils) and the gaze per eye, for the page's copy of that face
(``viewer/src/face.js``). The speech is one WAV on the same clock (sample 0 = frame 0,
:mod:`renders.audio_mix`); a speaker's motion for a user's VRM character is VRM Animation
(:func:`renders.gltf.glb_bytes` on the vrm rig).
"""

from __future__ import annotations

import numpy as np

from core.face import ARKIT_INDEX, ARKIT_NAMES, FaceTrack
from core.hands import hand_positions
from core.motion import MotionFile
from core.skeleton import FPS, JOINTS
from core.words import shift_words
from dsl.speech.audio import wav_bytes
from renders.clips import concat_clips, speaker_name, track_clip
from renders.gltf import glb_bytes
from renders.mannequin import AMBIENT, BACKGROUND, DISTANCE, TARGET, VIEWS, YFOV, _lights, camera_pose, speaker_tint
from renders.rigs import get_rig
from sgt_tui.editor.timeline import _label

FORMAT = "sgt-view"
VERSION = 1
#: Decimals of the positions sent to the page (0.1 mm).
DECIMALS = 4
#: The blendshapes the mannequin's face draws (renders.face_rig.part_transforms): all but the
#: ``eyeLook*`` ones, which say the gaze again.
FACE_CHANNELS: tuple[str, ...] = tuple(n for n in ARKIT_NAMES if not n.startswith("eyeLook"))


def _flat(array) -> list[float]:
    return np.round(np.asarray(array, np.float64), DECIMALS).reshape(-1).tolist()


def face_of(face: FaceTrack | None) -> dict | None:
    """A speaker's face for the page (None without one): ``channels``, the names of the
    :data:`FACE_CHANNELS` that are not 0 anywhere in the take (as rounded), ``weights``
    (frames x channels, flattened, rounded as the motion file rounds them) and ``gaze`` (frames x 2
    eyes (left, right) x (yaw, pitch) in degrees, flattened). A channel left out is 0 throughout."""
    if face is None:
        return None
    weights = np.round(face.weights.astype(np.float64), FaceTrack.DECIMALS["weights"])
    used = [n for n in FACE_CHANNELS if np.any(weights[:, ARKIT_INDEX[n]] != 0)]
    rows = weights[:, [ARKIT_INDEX[n] for n in used]]
    return {"channels": used, "weights": rows.reshape(-1).tolist(),
            "gaze": np.round(face.gaze.astype(np.float64), FaceTrack.DECIMALS["gaze"]).reshape(-1).tolist()}


def figures(motion: MotionFile) -> list:
    """The clips the page draws, one per speaker on the performance clock (a motion file from
    before the clock: its utterances one after another, one figure)."""
    if motion.tracks:
        return [track_clip(t, motion.clips) for t in motion.tracks]
    return [concat_clips(list(motion.clips))]


def _starts(motion: MotionFile) -> list[int]:
    """Each utterance's first frame on the page's clock."""
    if motion.tracks:
        return [c.start_frame for c in motion.clips]
    out, at = [], 0
    for c in motion.clips:
        out.append(at)
        at += c.n_frames
    return out


def page_take(motion: MotionFile, name: str) -> dict:
    """The page's document for ``motion`` (its audio and VRM Animation are fetched apart)."""
    shown = figures(motion)
    n_frames = shown[0].n_frames
    names = [speaker_name(c.speaker) for c in shown]
    speakers = []
    for i, clip in enumerate(shown):
        hands = hand_positions(clip.positions, clip.hands)
        speaker = {"name": names[i], "tint": list(speaker_tint(i)), "positions": _flat(clip.positions), "hands": _flat(hands)}
        face = face_of(clip.face)
        if face is not None:
            speaker["face"] = face
        speakers.append(speaker)
    utterances, words, controls = [], [], []
    for c, first in zip(motion.clips, _starts(motion)):
        who = speaker_name(c.speaker)
        index = c.index if c.index is not None else len(utterances)
        start = first / FPS
        utterances.append({"index": index, "speaker": who, "text": c.text or "", "start": round(start, 6),
                           "frames": c.n_frames,
                           "audio_offset": None if c.audio_offset is None else round(c.audio_offset, 6)})
        # the words' times as sgt render captions them (renders.clips), not rounded: the page's
        # caption rule (viewer/src/caption.js) then picks the word sgt render does at every frame
        words += [{"word": w.word, "start": w.start, "end": w.end, "speaker": who, "utterance": index}
                  for w in shift_words(c.words, c.start if motion.tracks else start)]
        for k in c.controls:
            stroke = None if k.stroke_frame is None else first + k.stroke_frame
            controls.append({"kind": k.kind, "name": k.name, "label": _label(k.kind, k.name, k.options or {}),
                             "speaker": who, "utterance": index, "line": k.line, "col": k.col,
                             "start": round((first + k.start_frame) / FPS, 6), "end": round((first + k.end_frame) / FPS, 6),
                             "stroke_frame": stroke, "stroke": None if stroke is None else round(stroke / FPS, 6),
                             "word": None if k.word_frame is None else round((first + k.word_frame) / FPS, 6)})
    return {"format": FORMAT, "version": VERSION, "name": name, "fps": FPS, "frames": n_frames,
            "duration": round(n_frames / FPS, 6), "joints": list(JOINTS), "speakers": speakers,
            "utterances": utterances, "words": words, "controls": controls, "scene": scene()}


def scene() -> dict:
    """sgt's cameras, lights and colours (renders.mannequin), for the page to see what sgt renders:
    each view's angles, its distance and whether it looks at the head (``on_head``: the face's
    close-up, which follows the head; the others look at ``target``).

    Each light is given in the camera's own frame (x right, y up, looking along -z): the
    direction towards the light and its radiance (linear RGB); the lights move with the camera,
    as in sgt's renders."""
    cam = camera_pose("front")[:3, :3]
    lights = [{"towards": [round(float(x), 6) for x in cam.T @ -shine], "radiance": [round(float(x), 6) for x in radiance]}
              for shine, radiance in _lights(VIEWS["front"])]
    return {"target": [float(x) for x in TARGET], "distance": DISTANCE, "fov": YFOV,
            "views": {name: {"azimuth": v.azimuth, "elevation": v.elevation, "distance": v.distance, "on_head": v.on_head}
                      for name, v in VIEWS.items()},
            "lights": lights, "ambient": list(AMBIENT), "background": list(BACKGROUND)}


def wav_of(samples, rate) -> bytes | None:
    """The speech as a WAV file's bytes (None without speech)."""
    return None if samples is None else wav_bytes(samples, rate)


def vrma_bytes(motion: MotionFile, speaker: int) -> bytes:
    """VRM Animation of the ``speaker``-th figure (:func:`figures`), as ``sgt export -o x.vrma`` writes it."""
    return glb_bytes(figures(motion)[speaker], get_rig("vrm"))
