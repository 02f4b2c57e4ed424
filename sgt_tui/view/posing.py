"""The pose editor's side of the server: what the page's "Pose" panel asks for (docs/view.md).

The page poses a gesture itself (``viewer/src/ik.js``, the same inverse kinematics as
:mod:`core.ik`) and asks the server only for what sgt computes: the hands of a pose
(:func:`frame_answer`), the gesture played as the library plays it with its spec file's text
(:func:`preview_answer`), the gesture mirrored (:func:`mirror_answer`), the gestures it may start
from (:func:`gesture_answer`), and under ``sgt view`` the take generated with the gesture at a
word without writing anything (:meth:`Poser.context`).

``sgt view`` alone writes (:class:`Poser`), and only with the per-run **edit token** it prints in
the page's address (``#edit=...``; the page sends it as ``X-SGT-Edit``), on top of the Host and
Origin checks every route has: a gesture into one of the script's ``@library`` folders, or into
a new folder beside the script that it adds to the script's header (:meth:`Poser.save`); a
``[pose:NAME]`` mark before a word of the script (:meth:`Poser.use`). Every write goes through
:class:`core.fileio.Inside` (inside its folder, no link followed, atomic) and compares the file's
SHA-256 with the one the page read: a file changed on disk since is never written over (409).
"""

from __future__ import annotations

import hashlib
import hmac
import re
import threading
from pathlib import Path

import numpy as np
from fastapi import Request
from fastapi.responses import JSONResponse

from core.fileio import Inside, LinkRefused, OutputError
from core.hands import PALMS, SHAPES, hand_positions
from core.ik import elbow_flexion, head_angles, shoulder_angles, swivel
from core.reading import LIMITS, InputFileError, loads_json, read_bytes
from core.skeleton import POSE_DIM, positions_from_pose
from dsl.lines import decode_source
from dsl.marks import MarkError, add_library, insert_mark, word_position
from dsl.parser import analyse
from library import Gesture, Library, load_library
from library.posing import (
    HAND_ORDER,
    LABELS,
    Draft,
    DraftError,
    FileChanged,
    GestureExists,
    joints_of,
    new_draft,
    rest_pose,
    save,
    sha256_of,
)
from library.spec import LIMBS, NAME_RE
from sgt_tui.view.page import data_url, vrma_bytes
from sgt_tui.view.takes import ViewError, script_take

#: The largest request body the pose routes read (a gesture of 150 keyframes is about 100 kB).
MAX_BODY = 1 << 20
#: A new gesture folder's name: a plain name beside the script.
FOLDER_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}\Z")
#: The name of a new gesture (the page's field changes it).
NEW_NAME = "my_gesture"
#: The header that carries the edit token.
EDIT_HEADER = "x-sgt-edit"


class PoseError(Exception):
    """A refusal: ``status`` and a one-line ``str()``; ``extra`` goes into the JSON answer."""

    def __init__(self, status: int, message: str, **extra) -> None:
        super().__init__(message)
        self.status = status
        self.extra = extra


def _flat(array) -> list[float]:
    return np.round(np.asarray(array, np.float64), 6).reshape(-1).tolist()


def vocabulary(names: list[str], **more) -> dict:
    """What the page needs to pose: the rest pose (exactly as a spec's ``"rest"``), a new gesture
    (:func:`library.posing.new_draft`), the hand shapes and palms, the labels, the limbs and their
    bones, the gestures to start from."""
    return {"rest": [float(x) for x in rest_pose()], "new": new_draft(NEW_NAME).to_dict(), "shapes": list(SHAPES),
            "palms": list(PALMS), "labels": list(LABELS),
            "limbs": {limb: list(bones) for limb, bones in LIMBS.items()}, "gestures": names, **more}


def _pose_of(value) -> list[float]:
    if not isinstance(value, list) or len(value) != POSE_DIM or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in value):
        raise PoseError(422, f"a pose is {POSE_DIM} numbers")
    return [float(x) for x in value]


def frame_answer(body: dict) -> dict:
    """The joints, hand joints and angles of one pose with its hands by name (``pose``, ``hands``)."""
    pose = np.array(_pose_of(body.get("pose")))
    if not np.all(np.isfinite(pose)) or np.any(np.linalg.norm(pose.reshape(-1, 3), axis=1) < 1e-6):
        raise PoseError(422, "a pose's bones must be finite directions, none of zero length")
    pose = (pose.reshape(-1, 3) / np.linalg.norm(pose.reshape(-1, 3), axis=1, keepdims=True)).reshape(-1)
    hands = body.get("hands")
    if not isinstance(hands, dict) or any(not isinstance(hands.get(k), str) or hands[k] not in (SHAPES if k.endswith("_hand") else PALMS)
                                          for k in HAND_ORDER):
        raise PoseError(422, f"hands must name {', '.join(HAND_ORDER)} (shapes: {', '.join(SHAPES)}; palms: {', '.join(PALMS)})")
    positions, joints = joints_of(pose, hands)
    angles = {side: {"flexion": elbow_flexion(pose, side), "swivel": swivel(pose, side),
                     "shoulder": list(shoulder_angles(pose, side))} for side in ("left", "right")}
    return {"positions": _flat(positions), "hands": _flat(joints), "angles": {**angles, "head": list(head_angles(pose))}}


def _draft(body: dict) -> Draft:
    try:
        return Draft.from_dict(body.get("gesture"))
    except DraftError as exc:
        raise PoseError(422, str(exc)) from None


def preview_answer(body: dict) -> dict:
    """The gesture as the library plays it (speed 1): its frames' joints and hand joints, the
    stroke's frame and each keyframe's, and its spec file's text (as :meth:`Draft.canonical`)."""
    try:
        draft = _draft(body).canonical()
        gesture = Gesture(draft.spec(), "the page")
    except DraftError as exc:
        raise PoseError(422, str(exc)) from None
    clip = gesture.clip()
    positions = positions_from_pose(clip.poses)
    return {"gesture": draft.to_dict(), "text": draft.spec_text(), "frames": clip.n_frames, "positions": _flat(positions),
            "hands": _flat(hand_positions(positions, clip.hands)), "stroke_frame": clip.stroke_frame,
            "key_frames": [int(f) for f in gesture.key_frames()]}


def mirror_answer(body: dict) -> dict:
    """The gesture mirrored, left and right swapped (the library's ``flip``)."""
    return {"gesture": _draft(body).mirrored().to_dict()}


def gesture_answer(library: Library, name: str, folders: list[Path] = ()) -> dict:
    """Gesture ``name`` of ``library`` as a draft to start from, with its file's path and SHA-256
    (a replacement compares it) and the folder it is in when that is one the page may write."""
    g = library.get(name)
    if g is None:
        hint = library.suggest(name)
        raise PoseError(404, f"no gesture named '{name}'" + (f"; did you mean '{hint}'?" if hint else ""))
    try:
        sha = sha256_of(read_bytes(g.path, "gesture spec"))
    except OSError:
        sha = None
    folder = next((str(f) for f in folders if _same_folder(Path(g.path).parent, f)), None)
    return {"gesture": Draft.from_spec(g.spec).canonical().to_dict(), "path": str(g.path), "sha256": sha, "folder": folder,
            "origin": g.origin}


def _same_folder(a: Path, b: Path) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except OSError:
        return False


class Poser:
    """The pose editor of one ``sgt view``: the script it may edit (``script``, a ``.sgt``, or
    None), its gesture folders, the edit token, the gesture the page starts from."""

    def __init__(self, script: Path | None, edit_token: str | None, *, start: str | None = None, engine=None, seed=None,
                 changed=None) -> None:
        self.script = Path(script) if script is not None else None
        self.edit_token = edit_token
        self.start = start
        self.engine, self.seed = engine, seed
        self.changed = changed or (lambda: None)  # called after a write (the take loads again)
        self._lock = threading.Lock()  # one write at a time

    # -- reading ------------------------------------------------------------------------------

    def may_write(self, sent: str | None) -> bool:
        return bool(self.edit_token) and sent is not None and hmac.compare_digest(sent.encode(), self.edit_token.encode())

    def _read_script(self) -> tuple[bytes, str, list[Path]]:
        """The script's bytes, text (no byte-order mark) and gesture folders, as it is on disk now."""
        if self.script is None:
            raise PoseError(409, "sgt view shows no script here: only a script's take can be edited")
        try:
            data = read_bytes(self.script, "script")
        except (InputFileError, OSError) as exc:
            raise PoseError(409, f"cannot read {self.script}: {getattr(exc, 'reason', None) or exc.strerror or exc}") from None
        text, bad = decode_source(data)
        if bad is not None:
            raise PoseError(409, f"{self.script} is not UTF-8 text: sgt view does not edit it")
        header = analyse(text, str(self.script), gesture_names=None, base_dir=self.script.parent).header
        return data, text, list(header.library_dirs)

    def folders(self) -> list[Path]:
        try:
            return self._read_script()[2]
        except PoseError:
            return []

    def library(self, folders: list[Path] | None = None) -> Library:
        return load_library(extra_dirs=self.folders() if folders is None else folders)

    def info(self) -> dict:
        folders = self.folders()
        shown = [{"path": str(f), "label": _shown(f, self.script)} for f in folders]
        return vocabulary(self.library(folders).names(), folders=shown, script=self.script.name if self.script else None,
                          can_write=self.script is not None and bool(self.edit_token), start=self.start,
                          new_folder=None if self.script is None else "gestures")

    def gesture(self, name: str) -> dict:
        folders = self.folders()
        return gesture_answer(self.library(folders), name, folders)

    # -- writing ------------------------------------------------------------------------------

    def save(self, body: dict) -> dict:
        """Write the gesture ``body["gesture"]`` into ``body["folder"]`` (one of the script's
        gesture folders) or into a new folder ``body["new_folder"]`` beside the script (added to
        the script's header; ``body["script_sha256"]``: the script the page read)."""
        draft = _draft(body)
        replace = body.get("replace", False) is True
        expected = body.get("sha256")
        expected = expected if isinstance(expected, str) else None
        with self._lock:
            data, text, folders = self._read_script()
            new_folder = body.get("new_folder")
            if new_folder is not None:
                if not isinstance(new_folder, str) or not FOLDER_RE.match(new_folder) or new_folder in (".", ".."):
                    raise PoseError(403, f"a new gesture folder is a plain name beside the script (letters, digits, '_', '-', '.'), "
                                         f"not {new_folder!r}")
                self._same_script(data, body.get("script_sha256"))
                base, sub = self.script.parent, new_folder
                target = self.script.parent / new_folder
            else:
                target = next((f for f in folders if str(f) == body.get("folder")), None)
                if target is None:
                    raise PoseError(403, f"{body.get('folder')!r} is not a gesture folder of {self.script.name} "
                                         f"(its @library folders: {', '.join(map(str, folders)) or 'none'}); nothing was written")
                base, sub = target, ""
            lib = self.library(folders + ([target] if new_folder is not None else []))
            known = lib.get(draft.name)
            elsewhere = None
            if known is not None and not _same_folder(Path(known.path).parent, target):
                elsewhere = "built in" if known.origin == "built-in" else f"in {Path(known.path).parent}"
            try:
                saved = save(draft, base, subfolder=sub, replace=replace, expected_sha256=expected, elsewhere=elsewhere)
            except GestureExists as exc:
                raise PoseError(409, str(exc), exists=True, sha256=exc.sha256) from None
            except FileChanged as exc:
                raise PoseError(409, str(exc), changed=True) from None
            except DraftError as exc:
                raise PoseError(422, str(exc)) from None
            except LinkRefused as exc:
                raise PoseError(403, f"{exc}; nothing was written") from None
            except OutputError as exc:
                raise PoseError(403, str(exc)) from None
            answer = {"path": str(saved.path), "sha256": saved.sha256, "text": saved.text, "gesture": saved.draft.to_dict(),
                      "folder": str(target)}
            if new_folder is not None and target not in folders:
                answer["script_sha256"] = self._write_script(data, add_library(text, new_folder))
        self.changed()
        return answer

    def use(self, body: dict) -> dict:
        """Put ``[pose:NAME]`` before word ``body["word"]`` of utterance ``body["utterance"]`` of the
        script the page read (``body["sha256"]``): written only while the file is still that one."""
        name = body.get("name")
        if not isinstance(name, str) or not NAME_RE.match(name):
            raise PoseError(422, f"{name!r} is not a gesture name")
        with self._lock:
            data, text, folders = self._read_script()
            self._same_script(data, body.get("sha256"))
            if name not in self.library(folders):
                raise PoseError(422, f"no gesture named '{name}' in the script's library: save it into one of its gesture folders first")
            line, col = self._word(text, body)
            sha = self._write_script(data, insert_mark(text, line, col, name))
        self.changed()
        return {"sha256": sha, "line": line, "col": col}

    def context(self, body: dict) -> tuple[object, dict]:
        """The take of the script with the page's gesture before a word (``utterance``, ``word``),
        generated without writing anything: (the loaded take, where the mark went)."""
        draft = _draft(body)
        try:
            spec = draft.canonical().spec()
        except DraftError as exc:
            raise PoseError(422, str(exc)) from None
        data, text, folders = self._read_script()
        self._same_script(data, body.get("sha256"))
        line, col = self._word(text, body)
        lib = self.library(folders)
        lib.gestures[spec.name] = Gesture(spec, "the page")
        loaded = script_take(self.script, f"{self.script.name} with [pose:{spec.name}]", insert_mark(text, line, col, spec.name),
                             self.engine, self.seed, library=lib)
        return loaded, {"line": line, "col": col}

    def _word(self, text: str, body: dict) -> tuple[int, int]:
        utterance, word = body.get("utterance"), body.get("word")
        if not all(isinstance(v, int) and not isinstance(v, bool) for v in (utterance, word)):
            raise PoseError(422, "name the word by its utterance and its number in it (numbers from 0)")
        try:
            return word_position(text, utterance, word)
        except MarkError as exc:
            raise PoseError(422, str(exc)) from None

    def _same_script(self, data: bytes, sha) -> None:
        if not isinstance(sha, str) or not hmac.compare_digest(sha.encode(), hashlib.sha256(data).hexdigest().encode()):
            raise PoseError(409, f"{self.script.name} changed on disk since the page read it: nothing was written; "
                                 "the page shows it again once it is generated, then try again", changed=True)

    def _write_script(self, old: bytes, text: str) -> str:
        bom = old[:3] if old.startswith(b"\xef\xbb\xbf") else b""
        data = bom + text.encode("utf-8")
        try:
            with Inside(self.script.parent) as d:
                now = d.read(self.script.name, LIMITS["script"])
                if now != old:  # changed while this request was answered
                    raise PoseError(409, f"{self.script.name} changed on disk since the page read it: nothing was written",
                                    changed=True)
                d.write(self.script.name, data)
        except LinkRefused as exc:
            raise PoseError(403, f"{exc}; nothing was written") from None
        except OutputError as exc:
            raise PoseError(403, str(exc)) from None
        return hashlib.sha256(data).hexdigest()


def _shown(folder: Path, script: Path | None) -> str:
    if script is not None:
        try:
            return str(Path(folder).relative_to(script.parent))
        except ValueError:
            pass
    return str(folder)


def take_extras(loaded) -> dict:
    """The speech and VRM Animation of a take made for one answer, inside it as ``data:`` URLs."""
    n = len(loaded.doc["speakers"])
    return {"audio": None if loaded.audio is None else data_url("audio/wav", loaded.audio), "audio_note": loaded.note,
            "vrma": [data_url("model/gltf-binary", vrma_bytes(loaded.motion, s)) for s in range(n)]}


# -- the routes -----------------------------------------------------------------------------------


async def json_body(request) -> dict:
    """The request's JSON object, read up to :data:`MAX_BODY` bytes (:class:`PoseError` otherwise)."""
    kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if kind != "application/json":
        raise PoseError(415, "send the request as JSON (Content-Type: application/json)")
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > MAX_BODY:
            raise PoseError(413, f"the request is larger than the pose editor takes ({MAX_BODY} bytes)")
        chunks.append(chunk)
    try:
        body = loads_json(b"".join(chunks))
    except ValueError as exc:
        raise PoseError(400, f"the request is not JSON: {exc}") from None
    if not isinstance(body, dict):
        raise PoseError(400, "the request must be a JSON object")
    return body


def refusal(exc: PoseError) -> JSONResponse:
    return JSONResponse({"error": str(exc), **exc.extra}, status_code=exc.status)


def add_view_routes(app, poser: Poser, run) -> None:
    """The pose editor's routes on ``sgt view``'s ``app`` (under ``/api/pose/``); ``run(work, *args)``
    runs work in a thread and answers 503 once sgt view stops."""

    def answer(work, *args):
        try:
            return JSONResponse(work(*args))
        except PoseError as exc:
            return refusal(exc)

    def writing(request) -> JSONResponse | None:
        if poser.may_write(request.headers.get(EDIT_HEADER)):
            return None
        return JSONResponse({"error": "saving needs this page's edit token: open the address sgt view printed "
                                      "(it ends with #edit=...); nothing was written"}, status_code=403)

    async def compute(request, work):
        try:
            body = await json_body(request)
        except PoseError as exc:
            return refusal(exc)
        return await run(answer, work, body)

    @app.get("/api/pose/info")
    async def pose_info():
        return await run(answer, poser.info)

    @app.get("/api/pose/gesture")
    async def pose_gesture(name: str):
        return await run(answer, poser.gesture, name)

    @app.post("/api/pose/frame")
    async def pose_frame(request: Request):
        return await compute(request, frame_answer)

    @app.post("/api/pose/preview")
    async def pose_preview(request: Request):
        return await compute(request, preview_answer)

    @app.post("/api/pose/mirror")
    async def pose_mirror(request: Request):
        return await compute(request, mirror_answer)

    @app.post("/api/pose/context")
    async def pose_context(request: Request):
        def work(body):
            try:
                loaded, where = poser.context(body)
            except ViewError as exc:
                raise PoseError(422, str(exc), details=exc.details) from None
            return {**loaded.doc, "id": None, "take": None, "preview": where, **take_extras(loaded)}

        return await compute(request, work)

    @app.post("/api/pose/save")
    async def pose_save(request: Request):
        return writing(request) or await compute(request, poser.save)

    @app.post("/api/pose/use")
    async def pose_use(request: Request):
        return writing(request) or await compute(request, poser.use)
