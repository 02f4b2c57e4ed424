"""What a request does in a worker thread: check or generate a script, and the answer's body."""

from __future__ import annotations

import base64
import io
import json
import logging
import tempfile
from pathlib import Path

from core import cancel, limits, rules
from core.diagnostics import sort_key
from core.fileio import OutputError
from core.motion import save_motion
from dsl.compiler import compile_file
from dsl.plain import file_references
from model.generate import GenerateError, NoSuchUtterance, check_motion_size, generate
from model.neural import Options
from sgt_tui.serve.config import ServeConfig
from sgt_tui.serve.requests import REQUEST_FILE, GenerateRequest, RequestError, refused_paths, text_script

log = logging.getLogger("sgt.serve")


def script_path(config: ServeConfig, folder: Path | None = None) -> Path:
    """The path a request's script is compiled as: in ``folder`` (an upload's), else in the first
    allowed folder (relative paths resolve there), else the current folder (no path is allowed)."""
    return (folder or config.base_dir or Path(".")) / REQUEST_FILE


def diagnostics_json(diags, path: Path) -> list[dict]:
    """Diagnostics as JSON, the request's script named ``<request>`` (not the server's folder)."""
    out = []
    for d in sorted(diags, key=sort_key):
        item = d.to_dict()
        if item.get("file") == str(path):
            item["file"] = REQUEST_FILE
        out.append(item)
    return out


def service_limits(config: ServeConfig) -> limits.Limits:
    """What one request may ask for (:mod:`core.limits`): the service's ``--max-seconds`` of
    performance, and no recording longer than that."""
    most = limits.current()
    return limits.Limits(seconds=config.max_seconds, recording_seconds=min(most.recording_seconds, config.max_seconds),
                         setting="the service's --max-seconds")


def check(config: ServeConfig, source: str, library) -> dict:
    with limits.using(service_limits(config)):
        return _check(config, source, library)


def _check(config: ServeConfig, source: str, library) -> dict:
    refused = refused_paths(source, config.allow)
    if refused:
        raise RequestError(403, "the script names files this service does not read", diagnostics_json(refused, Path(REQUEST_FILE)))
    path = script_path(config)
    result = compile_file(path, source=source, timing="estimate", library=_library_for(source, library))  # as 'sgt check'
    diags = result.diagnostics
    return {"ok": not any(d.is_error for d in diags), "utterances": len(result.script.utterances),
            "diagnostics": diagnostics_json(diags, path)}


def generate_request(config: ServeConfig, req: GenerateRequest, library, upload: dict | None = None) -> dict:
    """Compile and generate a request; ``upload`` holds a recording (``audio``: (suffix, bytes))
    and its timings (``timings``: (suffix, bytes)). Raises :class:`RequestError` for a bad request."""
    with limits.using(service_limits(config)):
        return _generate_request(config, req, library, upload)


def _generate_request(config: ServeConfig, req: GenerateRequest, library, upload: dict | None) -> dict:
    if upload is None:
        source = req.script if req.script is not None else text_script(req, req.text)
        if req.script is not None:
            refused = refused_paths(source, config.allow)
            if refused:
                raise RequestError(403, "the script names files this service does not read", diagnostics_json(refused, Path(REQUEST_FILE)))
        return _generate(config, req, source, script_path(config), library)
    with tempfile.TemporaryDirectory(prefix="sgt-serve-") as tmp:  # the compiler reads recordings from files
        folder = Path(tmp)
        audio_suffix, audio_bytes = upload["audio"]
        (folder / f"audio{audio_suffix}").write_bytes(audio_bytes)
        timings = None
        if "timings" in upload:
            suffix, data = upload["timings"]
            timings = f"timings{suffix}"
            (folder / timings).write_bytes(data)
        elif req.words is not None:
            timings = "timings.json"
            (folder / timings).write_text(json.dumps([w.model_dump() for w in req.words]))
        source = text_script(req, req.text, f"audio{audio_suffix}", timings)
        return _generate(config, req, source, script_path(config, folder), library)


def _generate(config: ServeConfig, req: GenerateRequest, source: str, path: Path, library) -> dict:
    options = Options(weights=config.weights, database=config.database)
    try:
        take = generate(path, source=source, engine=req.engine, utterances=req.utterances, seed=req.seed,
                        timing=req.timing, options=options, library=_library_for(source, library))
    except NoSuchUtterance as exc:
        raise RequestError(422, str(exc)) from None
    except GenerateError as exc:
        crashed = [d for d in exc.diagnostics if d.code == rules.SPEECH_CRASH.code]
        if crashed:  # the server's fault, not the request's: 500, and the log says what happened
            log.error("the speech worker died on a request (%s); a new one serves the next", crashed[0].message)
            raise RequestError(500, "the speech engine failed on this request (the server's log has the details); "
                                    "the service goes on") from None
        if exc.diagnostics:
            raise RequestError(422, str(exc).replace(str(path), REQUEST_FILE), diagnostics_json(exc.diagnostics, path)) from None
        log.error("the generator cannot run: %s", exc)  # (names the server's files: for its log, not the client)
        raise RequestError(503, "the generator cannot run on the server (the server's log says why)") from None
    try:
        check_motion_size(take.clips, take.tracks)
    except OutputError as exc:
        raise RequestError(422, str(exc)) from None
    cancel.check()  # (encoding the motion has no check points of its own)
    buf = io.BytesIO()
    save_motion(buf, take.clips, format="json", tracks=take.tracks, engine=take.engine)  # as sgt generate writes it, less the server's path
    rest = {"timing": take.timing, "diagnostics": diagnostics_json(take.diagnostics, path)}
    if req.outputs:
        rest["outputs"] = _outputs(req.outputs, take)
    # the motion file's JSON goes into the answer as it is: parsing it back and encoding it again
    # cost more than the network's own work
    return Encoded(b'{"motion": ' + buf.getvalue().rstrip() + b", " + json.dumps(rest)[1:].encode("utf-8"))


class Encoded(bytes):
    """An answer already encoded as JSON (the endpoint sends it as it is)."""


def _library_for(source: str, library):
    """The preloaded library, or None (loaded by the compiler) when the script adds folders."""
    return None if any(r.kind == "library" for r in file_references(source)) else library


def _outputs(kinds, take) -> dict:
    out: dict = {}
    if "bvh" in kinds:
        from renders.export import bvh_text  # lazy: the BVH writer (only when a request asks for BVH)

        out["bvh"] = [bvh_text(c) for c in take.clips]
    if "glb" in kinds:
        from renders.gltf import glb_bytes  # lazy: the glTF writer
        from renders.rigs import get_rig  # lazy: the rigs

        out["glb"] = [base64.b64encode(glb_bytes(c, get_rig("sgt"))).decode("ascii") for c in take.clips]
    if "wav" in kinds:
        out["wav"] = [{"lead_in": u.lead_in, "data": base64.b64encode(Path(u.audio_path).read_bytes()).decode("ascii")}
                      if u.audio_path is not None and Path(u.audio_path).is_file() else None for u in take.plan.utterances]
    return out
