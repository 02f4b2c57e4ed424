"""Minimal ctypes binding to the espeak-ng C library (``libespeak-ng.so.1``).

The library is process-global state, so every call goes through :data:`_LOCK`, and it is
loaded and initialised lazily on first use (importing this module loads nothing).

Determinism: espeak-ng keeps generator state (pitch flutter phase...) between synthesis calls
in one process, so the same text synthesized twice in one process gives slightly different
audio, while the *first* synthesis after loading the library is identical in every process.
``espeak_Terminate`` followed by a new ``espeak_Initialize`` hangs in 1.51, so every synthesis
runs in a process of its own that synthesizes once: :func:`run_synth` asks a fork server (this
file run as a script with ``--serve``, stdlib only), which has loaded and initialised the
library and forks a child per request (about 15 ms a request, where starting a fresh process
took 100 ms). The in-process engine is only used to list and check voices.

Facts verified by experiment against espeak-ng 1.51 (see tests/test_speech_synth.py):
* ``espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, ...)`` returns the sample rate, 22050 Hz.
* ``espeak_EVENT`` is ``{int type; unsigned uid; int text_position; int length;
  int audio_position; int sample; void *user_data; union{int; char*; char[8]} id}``.
* With ``espeakCHARS_UTF8`` and ``POS_CHARACTER``, ``text_position`` of a word event is the
  1-based *character* (code point) index in the input, not a byte offset ("café" counts 4).
* ``sample`` is the sample index of the event in the output stream (``audio_position`` is the
  same in ms), so word times are exact to the sample.
* Phoneme events (``espeakEVENT_PHONEME`` = 7, enabled by ``espeakINITIALIZE_PHONEME_EVENTS``
  = 0x0001 at ``espeak_Initialize``; ``espeakINITIALIZE_PHONEME_IPA`` = 0x0002 names them in
  IPA, UTF-8 in ``id``, at most 8 bytes) come through the same callback, one per phoneme at
  the sample where it starts; ``text_position`` is the start of the word it belongs to.
  Enabling them leaves the audio as it was, to the bit. Pauses are phonemes too (an empty
  name in IPA). The events carry no stress: :func:`_stress_marks` takes it from
  ``espeak_TextToPhonemes`` on the same text (IPA, ``|`` between phonemes, ``ˈ``/``ˌ`` on the
  stressed vowel), matched to the events' phonemes in order.
"""

from __future__ import annotations

import ctypes
import glob
import json
import os
import threading
from dataclasses import dataclass


class EngineError(Exception):
    """Engine failure; ``kind`` is "missing-lib", "init", "voice", "synth" or "crash" (the
    process synthesizing died: a signal, a crash inside the library)."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message

_LOCK = threading.RLock()

LIBRARY_NAME = "libespeak-ng.so.1"
_LIB_DIRS = (
    "/usr/lib/x86_64-linux-gnu",
    "/usr/lib/aarch64-linux-gnu",
    "/usr/lib64",
    "/usr/lib",
    "/usr/local/lib",
)

AUDIO_OUTPUT_SYNCHRONOUS = 2
espeakINITIALIZE_PHONEME_EVENTS = 0x0001
espeakINITIALIZE_PHONEME_IPA = 0x0002
espeakINITIALIZE_DONT_EXIT = 0x8000
espeakCHARS_UTF8 = 1
POS_CHARACTER = 1
espeakRATE = 1
espeakPITCH = 3

EVENT_LIST_TERMINATED = 0
EVENT_WORD = 1
EVENT_SENTENCE = 2
EVENT_END = 5
EVENT_MSG_TERMINATED = 6
EVENT_PHONEME = 7
EVENT_SAMPLERATE = 8
#: espeak_TextToPhonemes' phonememode: IPA names (bit 1), a separator character in bits 8-23.
PHONEMES_IPA = 0x02
PHONEME_SEPARATOR = "|"
#: IPA stress marks espeak-ng puts on a stressed vowel: primary, secondary.
STRESS_MARKS = {"\u02c8": 2, "\u02cc": 1}

#: How espeak-ng's voice list names a variant (``!v/m3``); the name after ``+`` is the rest.
VARIANT_PREFIX = "!v/"


class _Event(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("unique_identifier", ctypes.c_uint),
        ("text_position", ctypes.c_int),
        ("length", ctypes.c_int),
        ("audio_position", ctypes.c_int),
        ("sample", ctypes.c_int),
        ("user_data", ctypes.c_void_p),
        ("id", ctypes.c_char * 8),
    ]


class _Voice(ctypes.Structure):
    _fields_ = [
        ("name", ctypes.c_char_p),
        ("languages", ctypes.c_void_p),
        ("identifier", ctypes.c_char_p),
        ("gender", ctypes.c_ubyte),
        ("age", ctypes.c_ubyte),
        ("variant", ctypes.c_ubyte),
        ("xx1", ctypes.c_ubyte),
        ("score", ctypes.c_int),
        ("spare", ctypes.c_void_p),
    ]


_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(_Event))


@dataclass(frozen=True)
class WordEvent:
    char_index: int  # 0-based code-point index into the synthesized text
    length: int  # characters, as reported by the engine
    sample: int  # sample index of the word's start


@dataclass(frozen=True)
class PhonemeEvent:
    char_index: int  # 0-based code-point index of the start of the word it belongs to
    sample: int  # sample index of the phoneme's start
    name: str  # IPA; "" for a pause
    stress: int = 0  # 2 primary, 1 secondary (from :func:`_stress_marks`), 0 none


@dataclass(frozen=True)
class VoiceInfo:
    name: str
    identifier: str
    languages: tuple[str, ...]


def find_library() -> str | None:
    """Path of libespeak-ng without loading it (used for the cache key and error messages)."""
    env_dirs = [d for d in os.environ.get("LD_LIBRARY_PATH", "").split(":") if d]
    for d in (*env_dirs, *_LIB_DIRS):
        p = os.path.join(d, LIBRARY_NAME)
        if os.path.exists(p):
            return p
    for d in _LIB_DIRS:
        hits = sorted(glob.glob(os.path.join(d, "*", LIBRARY_NAME)))
        if hits:
            return hits[0]
    return None


def engine_fingerprint() -> str:
    """Identifies the installed engine build (resolved library file name and size) without loading it."""
    p = find_library()
    if p is None:
        return "missing"
    real = os.path.realpath(p)
    try:
        size = os.path.getsize(real)
    except OSError:
        size = -1
    return f"{os.path.basename(real)}:{size}"


class _Engine:
    def __init__(self) -> None:
        path = find_library() or LIBRARY_NAME
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            raise EngineError(
                "missing-lib",
                f"the espeak-ng speech library ({LIBRARY_NAME}) could not be loaded ({e}); "
                "install it with `apt-get install espeak-ng` (or use a recorded voice)",
            ) from None
        lib.espeak_Initialize.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_char_p, ctypes.c_int]
        lib.espeak_Initialize.restype = ctypes.c_int
        lib.espeak_SetSynthCallback.argtypes = [_CALLBACK]
        lib.espeak_SetSynthCallback.restype = None
        lib.espeak_SetVoiceByName.argtypes = [ctypes.c_char_p]
        lib.espeak_SetVoiceByName.restype = ctypes.c_int
        lib.espeak_SetParameter.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int]
        lib.espeak_SetParameter.restype = ctypes.c_int
        lib.espeak_Synth.argtypes = [
            ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int,
            ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p, ctypes.c_void_p,
        ]
        lib.espeak_Synth.restype = ctypes.c_int
        lib.espeak_ListVoices.argtypes = [ctypes.c_void_p]
        lib.espeak_ListVoices.restype = ctypes.POINTER(ctypes.POINTER(_Voice))
        lib.espeak_Info.argtypes = [ctypes.c_void_p]
        lib.espeak_Info.restype = ctypes.c_char_p
        lib.espeak_TextToPhonemes.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_int, ctypes.c_int]
        lib.espeak_TextToPhonemes.restype = ctypes.c_char_p
        options = espeakINITIALIZE_DONT_EXIT | espeakINITIALIZE_PHONEME_EVENTS | espeakINITIALIZE_PHONEME_IPA
        rate = lib.espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 0, None, options)
        if rate <= 0:
            raise EngineError(
                "init",
                "espeak-ng could not be initialised (its data folder is missing?); "
                "reinstall it with `apt-get install --reinstall espeak-ng espeak-ng-data`",
            )
        self.lib = lib
        self.sample_rate = int(rate)
        self.version = (lib.espeak_Info(None) or b"?").decode("ascii", "replace")
        self._chunks: list[bytes] = []
        self._events: list[WordEvent] = []
        self._phonemes: list[PhonemeEvent] = []
        self._callback = _CALLBACK(self._on_audio)  # keep a reference: C holds a raw pointer
        lib.espeak_SetSynthCallback(self._callback)
        self._voices: list[VoiceInfo] | None = None
        self._variants: dict[str, str] | None = None

    def _on_audio(self, wav, n, events) -> int:
        if wav and n > 0:
            self._chunks.append(ctypes.string_at(wav, n * 2))
        i = 0
        while events[i].type != EVENT_LIST_TERMINATED:
            ev = events[i]
            if ev.type == EVENT_WORD:
                self._events.append(WordEvent(ev.text_position - 1, ev.length, ev.sample))
            elif ev.type == EVENT_PHONEME:  # id: the IPA name, NUL-terminated unless it fills 8 bytes
                name = bytes(ev.id).split(b"\0", 1)[0].decode("utf-8", "replace")
                self._phonemes.append(PhonemeEvent(ev.text_position - 1, ev.sample, name))
            i += 1
        return 0

    def voices(self) -> list[VoiceInfo]:
        if self._voices is None:
            arr = self.lib.espeak_ListVoices(None)
            out = []
            i = 0
            while arr[i]:
                v = arr[i].contents
                langs = []
                p = v.languages
                while p:
                    priority = ctypes.c_ubyte.from_address(p).value
                    if priority == 0:
                        break
                    s = ctypes.string_at(p + 1)
                    langs.append(s.decode("utf-8", "replace"))
                    p += 2 + len(s)
                out.append(VoiceInfo((v.name or b"").decode("utf-8", "replace"),
                                     (v.identifier or b"").decode("utf-8", "replace"), tuple(langs)))
                i += 1
            self._voices = out
        return self._voices

    def variants(self) -> dict[str, str]:
        """The installed voice variants, name after ``+`` (``m3``, ``f2``, ``aunty``...) -> its
        description (``Auntie``): the files of espeak-ng's ``voices/!v`` folder, as its voice
        list gives them, sorted case-insensitively."""
        if self._variants is None:
            spec = _Voice()
            spec.languages = ctypes.cast(ctypes.c_char_p(b"variant"), ctypes.c_void_p)
            arr = self.lib.espeak_ListVoices(ctypes.byref(spec))
            found = {}
            i = 0
            while arr[i]:
                v = arr[i].contents
                ident = (v.identifier or b"").decode("utf-8", "replace")
                if ident.startswith(VARIANT_PREFIX):
                    found[ident[len(VARIANT_PREFIX):]] = (v.name or b"").decode("utf-8", "replace")
                i += 1
            self._variants = dict(sorted(found.items(), key=lambda kv: kv[0].lower()))
        return self._variants

    def _voice_keys(self) -> set[str]:
        """Every way the voice list names a voice (identifier, name, language), lower case."""
        return {k.lower() for v in self.voices() for k in (v.identifier, v.name, *v.languages)}

    def set_voice(self, name: str) -> bool:
        """Select voice ``name`` (``IDENTIFIER`` or ``IDENTIFIER+VARIANT``). Only installed voices
        and variants reach the library: espeak-ng opens whatever file a variant names (a path
        reads any file and prints it line by line on stderr) and overflows a buffer on a long
        one (glibc aborts the process), so anything else is refused here, without a call."""
        base, plus, variant = name.partition("+")
        if base.lower() not in self._voice_keys() or (plus and variant not in self.variants()):
            return False
        return self.lib.espeak_SetVoiceByName(name.encode("utf-8")) == 0

    def synth(self, text: str, voice: str, rate: int, pitch: int) -> tuple[bytes, list[WordEvent], list[PhonemeEvent]]:
        """The audio, the word events and the phoneme events (with their stress) of ``text``."""
        if not self.set_voice(voice):
            raise EngineError("voice", f"espeak-ng rejected the voice {voice!r}")
        self.lib.espeak_SetParameter(espeakRATE, int(rate), 0)
        self.lib.espeak_SetParameter(espeakPITCH, int(pitch), 0)
        data = text.encode("utf-8") + b"\0"
        buf = ctypes.create_string_buffer(data, len(data))
        self._chunks, self._events, self._phonemes = [], [], []
        try:
            err = self.lib.espeak_Synth(buf, len(data), 0, POS_CHARACTER, 0, espeakCHARS_UTF8, None, None)
            if err != 0:
                raise EngineError("synth", f"espeak-ng failed to synthesize the text (error {err})")
            audio, words, phonemes = b"".join(self._chunks), list(self._events), list(self._phonemes)
        finally:
            self._chunks, self._events, self._phonemes = [], [], []
        # after the synthesis (it never changes what was synthesized): the stress of each phoneme
        return audio, words, _stress_marks(phonemes, self.text_to_phonemes(text))

    def text_to_phonemes(self, text: str) -> list[str]:
        """espeak-ng's phonemes of ``text`` for the selected voice (``espeak_TextToPhonemes``):
        IPA names, a stressed vowel with its mark in front (``ˈoʊ``), words separated by "" (an
        empty name). Translation only: nothing is synthesized."""
        data = text.replace("\0", " ").encode("utf-8") + b"\0"
        buf = ctypes.create_string_buffer(data, len(data))
        ptr = ctypes.c_void_p(ctypes.addressof(buf))
        mode = PHONEMES_IPA | (ord(PHONEME_SEPARATOR) << 8)
        out: list[str] = []
        for _ in range(len(data) + 1):  # each call translates one clause and moves the pointer on
            if not ptr.value:
                break
            got = self.lib.espeak_TextToPhonemes(ctypes.byref(ptr), espeakCHARS_UTF8, mode)
            for word in (got or b"").decode("utf-8", "replace").split():
                out += [p for p in word.split(PHONEME_SEPARATOR) if p] + [""]
        return out


def split_stress(name: str) -> tuple[str, int]:
    """A phoneme name of :meth:`_Engine.text_to_phonemes` without its stress marks, and its
    stress: 2 primary, 1 secondary, 0 none."""
    stress = max((STRESS_MARKS.get(c, 0) for c in name), default=0)
    return "".join(c for c in name if c not in STRESS_MARKS), stress


def _stress_marks(phonemes: list[PhonemeEvent], translated: list[str]) -> list[PhonemeEvent]:
    """``phonemes`` with the stress that ``translated`` (:meth:`_Engine.text_to_phonemes` of the
    same text) marks on their vowels: the two sequences of names are matched in order (the
    events also hold pauses, and synthesis may merge or change a phoneme here and there; an
    unmatched phoneme keeps stress 0)."""
    import difflib

    marks = [split_stress(t) for t in translated if t]
    names = [p.name for p in phonemes]
    out = list(phonemes)
    matcher = difflib.SequenceMatcher(None, names, [m[0] for m in marks], autojunk=False)
    for a, b, n in matcher.get_matching_blocks():
        for k in range(n):
            if marks[b + k][1] and names[a + k]:
                p = phonemes[a + k]
                out[a + k] = PhonemeEvent(p.char_index, p.sample, p.name, marks[b + k][1])
    return out


_engine: _Engine | None = None


def engine() -> _Engine:
    """The process-wide engine, loaded on first use. Call with :data:`_LOCK` held."""
    global _engine
    if _engine is None:
        _engine = _Engine()
    return _engine


def run_synth(text: str, voice: str, rate: int, pitch: int,
              timeout: float = 120.0) -> tuple[int, bytes, list[WordEvent], list[PhonemeEvent]]:
    """Synthesize as the first synthesis of a freshly initialised engine (deterministic);
    returns (sample_rate, s16le bytes, word events, phoneme events).

    The work is done by a child forked from this process's :class:`_ForkServer` (the library
    loaded and initialised, nothing synthesized yet: the state of a fresh process, for about
    15 ms instead of the 100 ms of starting one); by a fresh process of its own when the fork
    server is busy with another thread's request or cannot run."""
    request = json.dumps({"text": text, "voice": voice, "rate": rate, "pitch": pitch}).encode("utf-8")
    return _parse_answer(_ask(request, timeout), "")


def run_text_to_phonemes(words: list[str], voice: str, timeout: float = 60.0) -> list[list[str]]:
    """espeak-ng's phonemes of each of ``words`` on its own, for ``voice``
    (:meth:`_Engine.text_to_phonemes`), translated in a worker process as :func:`run_synth`
    synthesizes: text from a script never reaches the C library in this process. Raises
    :class:`EngineError` (the voice rejected, the worker died or took too long)."""
    answer = _ask(json.dumps({"phonemes": list(words), "voice": voice}).encode("utf-8"), timeout)
    info, _ = _split_answer(answer)
    if info is None:
        raise EngineError("synth", "the espeak-ng worker failed")
    if not info.get("ok"):
        raise EngineError(info.get("kind", "synth"), info.get("message", "espeak-ng failed"))
    return [[str(n) for n in names] for names in info["phonemes"]]


def _ask(request: bytes, timeout: float) -> bytes:
    """The whole answer to ``request``, from a child of the fork server, else a fresh process."""
    server = _fork_server()
    if server is not None and server.lock.acquire(blocking=False):
        try:
            answer = server.ask(request, timeout)
        finally:
            server.lock.release()
        if answer is not None:
            return answer
    return _run_fresh(request, timeout)


def _run_fresh(request: bytes, timeout: float) -> bytes:
    """The answer to ``request`` from a new process (this file run as a script)."""
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-I", "-S", os.path.abspath(__file__)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + timeout
    given = request
    try:
        while True:  # looking every _POLL seconds whether the work was cancelled (core.cancel)
            _check_cancelled()
            try:
                out, _ = proc.communicate(given, timeout=max(0.0, min(_POLL, deadline - time.monotonic())))
                break
            except subprocess.TimeoutExpired:
                given = None  # sent already: communicate goes on where it was
                if time.monotonic() >= deadline:
                    raise _too_long(timeout) from None
    except BaseException:  # too long, cancelled or interrupted: the process is not needed any more
        proc.kill()
        proc.communicate()
        raise
    # what the engine printed on stderr is not passed on: it can quote files (see _Engine.set_voice)
    if proc.returncode != 0 or not _whole(out):
        raise EngineError("crash", _died(-proc.returncode if proc.returncode < 0 else proc.returncode << 8))
    return out


#: How often a synthesis that is waited for looks whether its work was cancelled, seconds.
_POLL = 0.1


def _check_cancelled() -> None:
    """:func:`core.cancel.check` (imported here: this file also runs alone, as a stdlib-only script)."""
    from core import cancel  # lazy: this file also runs as a script without the project on its path

    cancel.check()


def _died(status: int) -> str:
    """How a synthesizing process ended, from its wait status (the signal in the low 7 bits)."""
    import signal

    if status & 0x7F:
        try:
            name = signal.Signals(status & 0x7F).name
        except ValueError:
            name = f"signal {status & 0x7F}"
        return f"espeak-ng was killed by {name}"
    return f"espeak-ng exited with status {status >> 8 or status}"


def _too_long(timeout: float) -> EngineError:
    return EngineError("synth", f"espeak-ng took longer than {timeout:.0f} s to synthesize the text")


def _split_answer(data: bytes) -> tuple[dict | None, bytes]:
    """(the JSON header of an answer, the bytes after it); None for a header that is not one."""
    header, sep, body = data.partition(b"\n")
    try:
        info = json.loads(header.decode("utf-8")) if sep else None
    except ValueError:
        info = None
    return (info if isinstance(info, dict) else None), body


def _parse_answer(data: bytes, why: str) -> tuple[int, bytes, list[WordEvent], list[PhonemeEvent]]:
    info, body = _split_answer(data)
    if info is None:
        raise EngineError("synth", "the espeak-ng worker failed" + why)
    if not info.get("ok"):
        raise EngineError(info.get("kind", "synth"), info.get("message", "espeak-ng failed"))
    if len(body) != info["nbytes"]:
        raise EngineError("synth", "the espeak-ng worker returned truncated audio")
    events = [WordEvent(int(c), int(n), int(s)) for c, n, s in info["events"]]
    phonemes = [PhonemeEvent(int(c), int(s), str(name), int(stress)) for c, s, name, stress in info.get("phonemes", [])]
    return int(info["sample_rate"]), body, events, phonemes


class _ForkServer:
    """A process (this file run with ``--serve``) holding an initialised engine that has never
    synthesized; it forks a child per request, so each synthesis starts from the state of a
    fresh process. One request at a time (:attr:`lock`); it exits when this process closes its
    input (this process ended, killed or not). ``argv`` runs another server speaking the same
    protocol (one JSON request a line; a JSON header line and ``nbytes`` bytes an answer): the
    piper worker, :mod:`dsl.speech._piper`."""

    def __init__(self, argv: list[str] | None = None) -> None:
        import subprocess
        import sys

        self.lock = threading.Lock()
        self.proc = subprocess.Popen(argv or [sys.executable, "-I", "-S", os.path.abspath(__file__), "--serve"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                     start_new_session=True)
        self._pending = b""

    def ask(self, request: bytes, timeout: float) -> bytes | None:
        """The answer (header line and audio), or None when the server failed (then it is
        stopped and the caller asks a fresh process). Raises :class:`EngineError` on timeout."""
        import time

        deadline = time.monotonic() + timeout
        try:
            self.proc.stdin.write(request.replace(b"\n", b" ") + b"\n")
            self.proc.stdin.flush()
            while b"\n" not in self._pending:
                self._fill(deadline)
            header = self._pending[: self._pending.index(b"\n") + 1]
            info = json.loads(header)
            size = len(header) + (int(info.get("nbytes", 0)) if isinstance(info, dict) else 0)
            while len(self._pending) < size:
                self._fill(deadline)
            answer, self._pending = self._pending[:size], self._pending[size:]
            return answer
        except TimeoutError:
            self.stop()
            raise _too_long(timeout) from None
        except (OSError, ValueError, EOFError):
            self.stop()
            return None
        except BaseException:  # the work was cancelled (core.cancel) or interrupted: the answer is not wanted
            self.stop()
            raise

    def _fill(self, deadline: float) -> None:
        """More bytes from the server into the buffer, waiting at most until ``deadline``, and
        looking every :data:`_POLL` seconds whether the work was cancelled (:mod:`core.cancel`)."""
        import select
        import time

        fd = self.proc.stdout.fileno()
        while True:
            _check_cancelled()
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError
            if select.select([fd], [], [], min(left, _POLL))[0]:
                break
        chunk = os.read(fd, 1 << 20)
        if not chunk:
            raise EOFError
        self._pending += chunk

    def stop(self) -> None:
        import signal

        global _server
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)  # the server and a child synthesizing
        except OSError:
            pass
        self.proc.wait()
        if _server is self:
            _server = None


_server: _ForkServer | None = None
_server_pid: int | None = None  # the process that started it (a forked copy of this process starts its own)


def _fork_server() -> _ForkServer | None:
    global _server, _server_pid
    with _LOCK:
        if _server is None or _server_pid != os.getpid() or _server.proc.poll() is not None:
            try:
                _server, _server_pid = _ForkServer(), os.getpid()
            except OSError:
                _server = None
            else:
                import atexit

                atexit.register(_close_server, _server)
        return _server


def _close_server(server: _ForkServer) -> None:
    """At exit: close the server's input (it ends at once) and reap it."""
    import subprocess

    if server.proc.poll() is None and _server_pid == os.getpid():
        try:
            server.proc.stdin.close()
            server.proc.wait(timeout=2)
        except OSError:
            pass
        except subprocess.TimeoutExpired:
            server.stop()


def _answer(eng_or_error, request: bytes) -> bytes:
    """The answer to one request: a JSON header line, then the audio."""
    try:
        if isinstance(eng_or_error, EngineError):
            raise eng_or_error
        req = json.loads(request.decode("utf-8"))
        if "phonemes" in req:  # run_text_to_phonemes: translation only
            if not eng_or_error.set_voice(req["voice"]):
                raise EngineError("voice", f"espeak-ng rejected the voice {req['voice']!r}")
            raw = b""
            header = {"ok": True, "nbytes": 0,
                      "phonemes": [eng_or_error.text_to_phonemes(str(w)) for w in req["phonemes"]]}
        else:
            raw, events, phonemes = eng_or_error.synth(req["text"], req["voice"], req["rate"], req["pitch"])
            header = {"ok": True, "sample_rate": eng_or_error.sample_rate, "nbytes": len(raw),
                      "events": [[e.char_index, e.length, e.sample] for e in events],
                      "phonemes": [[p.char_index, p.sample, p.name, p.stress] for p in phonemes]}
    except EngineError as e:
        raw, header = b"", {"ok": False, "kind": e.kind, "message": e.message, "nbytes": 0}
    return json.dumps(header).encode("utf-8") + b"\n" + raw


def _whole(data: bytes) -> bool:
    """Whether ``data`` is a whole answer: a JSON header line and as many bytes as it says."""
    info, body = _split_answer(data)
    return info is not None and len(body) == info.get("nbytes", -1)


def _new_engine():
    try:
        return _Engine()
    except EngineError as e:
        return e


def _worker_main() -> int:
    import sys

    out = sys.stdout.buffer
    out.write(_answer(_new_engine(), sys.stdin.buffer.read()))
    out.flush()
    return 0


def _serve_main() -> int:
    """The fork server: one request per input line; each answered by a forked child."""
    import sys

    eng = _new_engine()  # loaded and initialised once, never used here to synthesize
    if not isinstance(eng, EngineError):  # listed once here, not in every child (listing leaves synthesis as it was)
        eng.voices()
        eng.variants()
    out = sys.stdout.buffer
    for request in sys.stdin.buffer:
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: the engine as a fresh process has it
            os.close(read)
            try:
                data = _answer(eng, request)
                view = memoryview(data)
                while view:
                    view = view[os.write(write, view):]
            finally:
                os._exit(0)
        os.close(write)
        chunks = []
        while chunk := os.read(read, 1 << 20):
            chunks.append(chunk)
        os.close(read)
        _, status = os.waitpid(pid, 0)
        data = b"".join(chunks)
        if status != 0 or not _whole(data):  # the child died, or answered half
            data = _answer(EngineError("crash", _died(status)), b"")
        out.write(data)
        out.flush()
    return 0


if __name__ == "__main__":
    import sys as _sys

    raise SystemExit(_serve_main() if _sys.argv[1:] == ["--serve"] else _worker_main())
