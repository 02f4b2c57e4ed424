"""What ``sgt view`` shows: the takes of a script, a motion file or a build folder, loaded when
the page asks for them and loaded again when their files change.

A script is generated (:func:`model.generate.generate`, the path every command takes) and its
speech mixed on the performance clock; a motion file is read, and its speech taken from the
script it names (compiled again, as ``sgt render -o x.mp4`` does) when that script is still
there and is a ``.sgt`` script (:func:`sgt_tui.commands.render.script_of`); a build folder
(``sgt build -o OUT``) offers every motion file its manifest lists, with the speech of
``--wav`` builds. Everything a build folder's files name must be inside the folder once links
are resolved (:func:`core.fileio.resolved_inside`): a manifest path that leads out (``..``, an
absolute path, a link) is a take that shows that error, and a motion file's script or WAV
outside the folder is not read (the take shows without speech, and says why). :class:`Viewer` polls the files each take was made from (a
script, the recordings it names; a motion file; the manifest) and loads a take again, in its
own thread, once its files have changed and then stood still for a moment (an editor's save
may take several writes). A take that fails to load again keeps what it showed, with the error.
:meth:`Viewer.close` (ctrl+c) cancels the load under way (:mod:`core.cancel`: generation stops at
its next loop point) and stops the watching.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from core import cancel
from core.diagnostics import format_text, summary
from core.fileio import LinkRefused, resolved_inside
from core.motion import MotionFile, MotionFileError, load_motion_file
from core.reading import InputFileError, loads_json, read_bytes
from model.generate import GenerateError, generate
from renders.audio_mix import mix
from sgt_tui.commands.common import inputs_of
from sgt_tui.commands.render import _audio
from sgt_tui.errors import InputError
from sgt_tui.view.page import page_take, vrma_bytes, wav_of

log = logging.getLogger("sgt.view")
MANIFEST = "manifest.json"
#: Seconds between looks at the files, and how long they must stand still before a reload.
POLL_S = 0.25
SETTLE_S = 0.3
#: Why a load is cancelled when sgt view stops.
STOPPING = "sgt view is stopping"


class ViewError(Exception):
    """A take that cannot be shown: ``str()`` is one line, ``details`` the diagnostics (or "")."""

    def __init__(self, message: str, details: str = "") -> None:
        super().__init__(message)
        self.details = details


@dataclass
class Loaded:
    """A take ready for the page: its document, its speech (a WAV, or None and why not)."""

    motion: MotionFile
    doc: dict
    audio: bytes | None
    note: str = ""
    warnings: str = ""
    vrma: dict = field(default_factory=dict)  # speaker number -> VRM Animation bytes, made when asked

    def vrma_of(self, speaker: int) -> bytes:
        if speaker not in self.vrma:
            self.vrma[speaker] = vrma_bytes(self.motion, speaker)
        return self.vrma[speaker]


class Source:
    """One take the page can show."""

    name: str

    def load(self) -> Loaded:
        raise NotImplementedError

    def watched(self) -> list[Path]:
        raise NotImplementedError


class ScriptSource(Source):
    def __init__(self, path: Path, engine: str | None = None, seed: int | None = None) -> None:
        self.path, self.engine, self.seed = Path(path), engine, seed
        self.name = self.path.name

    def watched(self) -> list[Path]:
        return inputs_of(self.path)  # the script and the recordings and timings files it names

    def load(self) -> Loaded:
        try:
            take = generate(self.path, engine=self.engine, seed=self.seed)
        except GenerateError as exc:
            details = format_text(exc.diagnostics, {str(self.path): exc.source}) if exc.diagnostics else ""
            raise ViewError(f"{self.path}: {summary(exc.diagnostics)}" if exc.diagnostics else str(exc), details) from None
        except InputFileError as exc:
            raise ViewError(f"{self.path}: {exc.reason}") from None
        if not take.clips:
            raise ViewError(f"{self.path}: no utterances (a script with only a header makes no motion)")
        motion = MotionFile(take.clips, take.tracks, str(self.path), engine=take.engine)
        plan = take.plan
        samples, rate = mix([(u.audio_path, u.start + u.audio_offset) for u in plan.utterances], plan.n_frames)
        warnings = format_text(take.diagnostics, {str(self.path): take.source}) if take.diagnostics else ""
        return Loaded(motion, page_take(motion, self.name), wav_of(samples, rate), warnings=warnings)


class MotionSource(Source):
    """A motion file; ``folder``: the build folder it is in, which everything it names must be in."""

    def __init__(self, path: Path, name: str | None = None, folder: Path | None = None) -> None:
        self.path = Path(path)
        self.name = name or self.path.name
        self.folder = folder

    def watched(self) -> list[Path]:
        return [self.path]

    def load(self) -> Loaded:
        try:
            motion = load_motion_file(self.path)
        except MotionFileError as exc:
            raise ViewError(str(exc)) from None
        if not motion.clips:
            raise ViewError(f"{self.path}: no utterances")
        audio, note = self._speech(motion)
        return Loaded(motion, page_take(motion, self.name), audio, note)

    def _speech(self, motion: MotionFile) -> tuple[bytes | None, str]:
        """The speech of the take: from the WAVs of ``sgt build --wav`` beside it, else from
        its script (compiled again); (None, why) when neither is there."""
        clips = motion.clips
        if any(c.audio_offset is None for c in clips):
            return None, "a motion file from before the performance clock has no speech (generate it again)"
        wavs = {c.index: self.path.with_name(f"{self.path.stem}_{c.index:03d}.wav") for c in clips if c.index is not None}
        if self.folder is not None:
            wavs = {i: p for i, p in wavs.items() if _inside(self.folder, p)}
        if motion.tracks and len(wavs) == len(clips) and all(p.is_file() for p in wavs.values()):
            samples, rate = mix([(wavs[c.index], c.start + c.audio_offset) for c in clips], motion.tracks[0].n_frames)
            return wav_of(samples, rate), ""
        if not motion.source:
            return None, "the take does not name its script, so its speech is unknown"
        try:
            samples, rate = _audio(motion, str(self.path), within=self.folder)  # as sgt render -o x.mp4: the script compiled again
        except InputError as exc:
            return None, str(exc)
        return wav_of(samples, rate), ""


class RefusedSource(Source):
    """A take a build manifest lists at a path that leads out of the folder: its error, shown on the page."""

    def __init__(self, name: str, reason: str) -> None:
        self.name, self.reason = name, reason

    def watched(self) -> list[Path]:
        return []

    def load(self) -> Loaded:
        raise ViewError(self.reason)


def build_sources(folder: Path) -> list[Source]:
    """The motion files of a build folder, as its manifest lists them (every motion file under
    it, without a manifest); a listed path outside the folder is a :class:`RefusedSource`."""
    manifest = folder / MANIFEST
    listed: list[str] = []
    if manifest.is_file():
        try:
            doc = loads_json(read_bytes(manifest, "configuration"))
            for script in doc.get("scripts", []):
                listed += [o["path"] for o in script.get("outputs", []) if str(o.get("path", "")).endswith(".json")]
        except (OSError, ValueError, TypeError, AttributeError, KeyError) as exc:
            raise ViewError(f"{manifest}: not a build manifest ({exc})") from None
    else:
        listed = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.json")
                        if not p.name.endswith(".timeline.json") and p.name != MANIFEST)
    sources: list[Source] = []
    for rel in listed:
        rel = str(rel)
        try:
            resolved_inside(folder, rel)
        except LinkRefused as exc:
            sources.append(RefusedSource(rel, f"{manifest if manifest.is_file() else folder}: {exc}"))
            continue
        path = folder / rel
        if path.is_file():
            sources.append(MotionSource(path, rel, folder))
    return sorted(sources, key=lambda s: isinstance(s, RefusedSource))  # a take to show first, if there is one


def _inside(folder: Path, path: Path) -> bool:
    try:
        resolved_inside(folder, path)
    except LinkRefused:
        return False
    return True


def sources_of(path: Path, engine: str | None = None, seed: int | None = None) -> list[Source]:
    """The takes of what ``sgt view`` was given."""
    if path.is_dir():
        return build_sources(path)
    if path.suffix.lower() == ".sgt":
        return [ScriptSource(path, engine, seed)]
    return [MotionSource(path)]


def _stamp(paths) -> tuple:
    out = []
    for p in paths:
        try:
            st = os.stat(p)
            out.append((str(p), st.st_mtime_ns, st.st_size, st.st_ino))
        except OSError:
            out.append((str(p), None))
    return tuple(out)


@dataclass
class Slot:
    """A take's state: what it shows (``loaded``, and ``id``, counted up at every load), the
    error of its last load, whether it is loading now, and the stamp of its files."""

    source: Source
    loaded: Loaded | None = None
    id: int = 0
    error: str = ""
    details: str = ""
    busy: bool = False
    stamp: tuple = ()

    def status(self) -> dict:
        return {"name": self.source.name, "id": self.id if self.loaded is not None else None, "busy": self.busy,
                "error": self.error, "details": self.details,
                "note": self.loaded.note if self.loaded else "", "warnings": self.loaded.warnings if self.loaded else ""}


class Viewer:
    """The takes ``sgt view`` serves, and the thread that loads them again when they change.

    ``version`` counts every change the page should see (a take loaded, an error, a reload
    begun, the list of takes changed); :meth:`status` says it all. ``closing`` is set once
    sgt view stops (:meth:`close`)."""

    def __init__(self, path: Path, engine: str | None = None, seed: int | None = None) -> None:
        self.path, self.engine, self.seed = Path(path), engine, seed
        self.folder = self.path.is_dir()
        self._lock = threading.RLock()  # the slots and the version
        self._loading = threading.Lock()  # one load at a time (generation uses the CPUs)
        self.version = 1
        self._manifest = _stamp([self.path / MANIFEST]) if self.folder else ()
        self.slots = [Slot(s) for s in sources_of(self.path, engine, seed)]
        self.closing = threading.Event()
        self._token: cancel.Token | None = None  # the load under way's
        self._thread: threading.Thread | None = None

    # -- the page's questions ---------------------------------------------------------------

    def status(self) -> dict:
        with self._lock:
            return {"version": self.version, "takes": [s.status() for s in self.slots]}

    def take(self, index: int) -> tuple[Loaded, int]:
        """Take ``index``, loaded now if it never was; raises IndexError or :class:`ViewError`."""
        with self._lock:
            slot = self.slots[index]
            if slot.loaded is not None:
                return slot.loaded, slot.id
        self._load(slot)
        with self._lock:
            if slot.loaded is None:
                if self.closing.is_set():
                    raise ViewError(STOPPING)
                raise ViewError(slot.error, slot.details)
            return slot.loaded, slot.id

    def _load(self, slot: Slot) -> None:
        with self._loading:
            if self.closing.is_set():
                return
            self._token = token = cancel.Token()
            if self.closing.is_set():  # closed before the token was there to cancel
                token.cancel(STOPPING)
            with self._lock:
                slot.busy = True
                self.version += 1
            stamp = _stamp(slot.source.watched())
            try:
                with cancel.scope(token):
                    loaded, error, details = slot.source.load(), "", ""
            except cancel.Cancelled:  # sgt view is stopping: the slot shows what it showed
                with self._lock:
                    slot.busy = False
                    self.version += 1
                return
            except ViewError as exc:
                loaded, error, details = None, str(exc), exc.details
            except Exception as exc:  # a bug: say so on the page and in the terminal, and go on watching
                log.exception("sgt view: loading %s failed", slot.source.name)
                loaded, error, details = None, f"{slot.source.name}: internal error ({type(exc).__name__}); the terminal has the details", ""
            finally:
                self._token = None
            with self._lock:
                slot.stamp, slot.busy, slot.error, slot.details = stamp, False, error, details
                if loaded is not None:
                    slot.loaded, slot.id = loaded, slot.id + 1
                self.version += 1

    # -- watching ---------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self._watch, name="sgt-view-watch", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop: cancel the load under way, end the watching; ``closing`` is set. It takes no
        lock, so that uvicorn's signal handler may call it (ctrl+c) whatever the thread it
        interrupts holds."""
        self.closing.set()
        token = self._token
        if token is not None:
            token.cancel(STOPPING)

    def stop(self) -> None:
        """:meth:`close`, then wait (a few seconds at most) for the watching thread to end."""
        self.close()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def _watch(self) -> None:
        while not self.closing.wait(POLL_S):
            self.poll()

    def poll(self) -> None:
        """Load again every take whose files changed (and stood still for :data:`SETTLE_S`)."""
        if self.folder:
            self._poll_manifest()
        with self._lock:
            watched = [s for s in self.slots if s.loaded is not None or s.error]
        for slot in watched:
            now = _stamp(slot.source.watched())
            if now == slot.stamp:
                continue
            while not self.closing.wait(SETTLE_S):  # until the save is over
                later = _stamp(slot.source.watched())
                if later == now:
                    break
                now = later
            if not self.closing.is_set():
                self._load(slot)

    def _poll_manifest(self) -> None:
        stamp = _stamp([self.path / MANIFEST])
        if stamp == self._manifest:
            return
        time.sleep(SETTLE_S)
        self._manifest = _stamp([self.path / MANIFEST])
        try:
            sources = build_sources(self.path)
        except ViewError:
            return  # a manifest being written: the next look reads it
        with self._lock:
            old = {s.source.name: s for s in self.slots}
            self.slots = [old.get(s.name) or Slot(s) for s in sources]
            self.version += 1
