"""The streaming protocol of ``/v1/stream``: messages in, motion frames out (docs/serve.md).

A :class:`StreamSession` holds one stream's state; :meth:`StreamSession.handle` takes one
client message (a dict) and returns the messages to send back. The WebSocket endpoint of
:mod:`sgt_tui.serve.app` only moves JSON between the socket and the session, so the protocol is
tested without a network.

Client messages (``type``): ``start`` (first; optional ``seed``, ``style``, ``rate``,
``smoothing``, ``engine``: ``neural`` or ``matching``), ``words`` (timed words on the stream's clock, seconds), ``text`` (text as an LLM
produces it: complete words are timed by the language's estimate at ``rate``), ``audio`` (the
next chunk of the speech audio, base64 16-bit PCM, with the timed words it holds), ``time`` (the
speech is known up to ``t``: silence after the last word), ``end``.
Server messages: ``ready`` (engine, fps, lookahead, joints, bones), ``timed`` (the times given to words
that came as text), ``frames`` (``start`` frame index, ``poses`` (n, 27), ``positions``
(n, 10, 3)), ``error`` (what is wrong; the stream goes on), ``done``.
"""

from __future__ import annotations

import base64
import binascii
import logging
import re

import numpy as np

from core.skeleton import BONES, FPS, JOINTS, POSE_DIM, positions_from_pose
from core.words import TimedWord
from dsl.compiler import compile_text
from dsl.plain import plain_script
from dsl.speech.audio import StreamResampler
from model import matching
from model.features import SAMPLE_RATE
from model.engines import DEFAULT_ENGINE
from model.matching_stream import MatchingStreamGenerator
from model.streaming import LOOKAHEAD_S, StreamBase, StreamError, StreamGenerator

log = logging.getLogger("sgt.serve")

#: The longest stream, in seconds of motion: a word or time past it is refused.
MAX_SECONDS = 600.0
#: The most text a stream holds back waiting for the end of a word (characters).
MAX_PENDING = 2000
#: The most text one ``text`` message may hold (characters; a /v1/generate text holds 20,000 too):
#: more would keep a worker for longer than a request may take.
MAX_TEXT_MESSAGE = 20_000
#: The largest audio chunk, in characters of base64 (about 23 s of 16 kHz speech).
MAX_AUDIO_CHUNK = 1_000_000
#: The sample rates an audio chunk may have (resampled to the model's).
AUDIO_RATES = (8000, 11025, 16000, 22050, 24000, 32000, 44100, 48000)
#: The engines a stream may run (``engine`` in ``start``; the first is the default, as everywhere).
ENGINES = (DEFAULT_ENGINE, *(e for e in ("matching", "neural") if e != DEFAULT_ENGINE))
_DUMMY = "sgtnextword"


class StreamSession:
    """One stream; ``library`` is the loaded motion library the text is compiled with,
    ``database`` the matching engine's (None: the shipped one; ``sgt serve --database``)."""

    def __init__(self, runner, library, database: str | None = None) -> None:
        self.runner = runner
        self.library = library
        self.database = database
        self.generator: StreamBase | None = None
        self.rate: int | None = None
        self.pending = ""  # text not yet timed (the last word may be incomplete)
        self.clock: float | None = None  # where the next timed text word starts
        self.sent = 0
        self.closed = False
        self.resampler = None  # a StreamResampler, from the first audio chunk on
        self.audio_rate: int | None = None
        self.audio_samples = 0  # samples received, at audio_rate

    def handle(self, message) -> list[dict]:
        """The replies to one client message; protocol errors become ``error`` replies."""
        try:
            return self._handle(message)
        except StreamError as exc:
            return [{"type": "error", "message": str(exc)}]

    def _handle(self, message) -> list[dict]:
        if not isinstance(message, dict) or not isinstance(message.get("type"), str):
            raise StreamError('each message is a JSON object with a "type": start, words, text, audio, time or end')
        kind = message["type"]
        if self.closed:
            raise StreamError("the stream has ended")
        if kind == "start":
            return self._start(message)
        if self.generator is None:
            raise StreamError('send {"type": "start"} first')
        if kind == "words":
            return self._frames(self.generator.add_words(self._words(message.get("words"))))
        if kind == "text":
            return self._text(message.get("text"))
        if kind == "audio":
            return self._audio(message)
        if kind == "time":
            t = message.get("t")
            if not isinstance(t, (int, float)) or isinstance(t, bool) or not 0 <= t <= MAX_SECONDS:
                raise StreamError(f'"t" must be a number of seconds from 0 to {MAX_SECONDS:g}')
            return self._frames(self.generator.known_until(float(t)))
        if kind == "end":
            out = self._text(None, final=True) if self.pending.strip() else []
            if self.resampler is not None:
                out += self._frames(self.generator.add_audio(self.resampler.flush()))
            out += self._frames(self.generator.finish())
            self.closed = True
            return out + [{"type": "done", "frames": self.sent}]
        raise StreamError(f"unknown message type '{kind}': use start, words, text, audio, time or end")

    def _start(self, message: dict) -> list[dict]:
        if self.generator is not None:
            raise StreamError("the stream has already started")
        unknown = set(message) - {"type", "seed", "style", "rate", "smoothing", "engine"}
        if unknown:
            raise StreamError(f"unknown start field(s): {', '.join(sorted(unknown))} "
                              "(use seed, style, rate, smoothing, engine)")
        seed, style, rate = message.get("seed", 0), message.get("style") or {}, message.get("rate")
        if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**31:
            raise StreamError('"seed" must be a whole number from 0')
        if not isinstance(style, dict):
            raise StreamError('"style" must be an object like {"speed": 1.5}')
        if rate is not None and (not isinstance(rate, int) or isinstance(rate, bool) or not 80 <= rate <= 450):
            raise StreamError('"rate" must be words per minute, 80 to 450')
        smoothing = message.get("smoothing", True)
        if not isinstance(smoothing, bool):
            raise StreamError('"smoothing" must be true or false')
        engine = message.get("engine", ENGINES[0])
        if engine not in ENGINES:
            raise StreamError(f'"engine" must be one of {", ".join(ENGINES)}')
        if engine == "matching":
            try:
                db = matching.load(self.database)
            except matching.DatabaseError as exc:  # (the server's file: its path goes to the log, not the client)
                log.error("stream: the matching database cannot be read: %s", exc)
                raise StreamError("the matching engine cannot run: the server's matching database cannot be read "
                                  "(the server's log says why)") from None
            self.generator = MatchingStreamGenerator(db, seed=seed, style=style, smoothing=smoothing)
        else:
            self.generator = StreamGenerator(self.runner, seed=seed, style=style, smoothing=smoothing)
        self.rate = rate
        return [{"type": "ready", "engine": engine, "fps": FPS, "lookahead_s": round(LOOKAHEAD_S, 4), "joints": list(JOINTS),
                 "bones": [list(b) for b in BONES]}]

    def _audio(self, message: dict) -> list[dict]:
        """The next chunk of the speech audio (and the timed words it holds): afterwards the
        speech is known up to the chunk's end."""
        unknown = set(message) - {"type", "pcm16", "sample_rate", "words"}
        if unknown:
            raise StreamError(f"unknown audio field(s): {', '.join(sorted(unknown))} (use pcm16, sample_rate, words)")
        data, rate = message.get("pcm16"), message.get("sample_rate", 16000)
        if not isinstance(data, str) or len(data) > MAX_AUDIO_CHUNK:
            raise StreamError(f'"pcm16" must be base64 text of at most {MAX_AUDIO_CHUNK} characters '
                              "(16-bit little-endian mono samples)")
        if not isinstance(rate, int) or isinstance(rate, bool) or rate not in AUDIO_RATES:
            raise StreamError(f'"sample_rate" must be one of {", ".join(map(str, AUDIO_RATES))}')
        if self.audio_rate is not None and rate != self.audio_rate:
            raise StreamError(f"this stream's audio is at {self.audio_rate} Hz: send every chunk at that rate")
        try:
            raw = base64.b64decode(data, validate=True)
        except (binascii.Error, ValueError):
            raise StreamError('"pcm16" is not valid base64') from None
        if len(raw) % 2:
            raise StreamError('"pcm16" must hold whole 16-bit samples (an even number of bytes)')
        if (self.audio_samples + len(raw) // 2) / rate > MAX_SECONDS:
            raise StreamError(f"the stream is longer than {MAX_SECONDS:g} s")
        words = self._words(message["words"]) if message.get("words") else []
        if self.resampler is None:
            self.resampler, self.audio_rate = StreamResampler(rate, SAMPLE_RATE), rate
            self.generator.add_audio(np.zeros(0, np.float32))  # from now on frames wait for the audio
        self.audio_samples += len(raw) // 2
        out = self.generator.add_words(words) if words else np.zeros((0, POSE_DIM), np.float32)
        samples = np.frombuffer(raw, "<i2").astype(np.float32) / 32768.0
        more = self.generator.add_audio(self.resampler.push(samples))
        end = self.audio_samples / rate
        last = self.generator.known_until(max(end, self.generator.known))
        return self._frames(np.concatenate([out, more, last]))

    def _words(self, words) -> list[TimedWord]:
        if not isinstance(words, list) or not words or len(words) > 1000:
            raise StreamError('"words" must be a list of 1 to 1000 {"word", "start", "end"} objects')
        out = []
        for w in words:
            if not isinstance(w, dict) or set(w) != {"word", "start", "end"}:
                raise StreamError('each word is {"word": TEXT, "start": SECONDS, "end": SECONDS}')
            text, start, end = w["word"], w["start"], w["end"]
            if not isinstance(text, str) or len(text) > 200:
                raise StreamError('"word" must be text of at most 200 characters')
            for value in (start, end):
                if not isinstance(value, (int, float)) or isinstance(value, bool) or not 0 <= value <= MAX_SECONDS:
                    raise StreamError(f"word times must be seconds from 0 to {MAX_SECONDS:g}")
            out.append(TimedWord(text, float(start), float(end)))
        return out

    def _text(self, text, final: bool = False) -> list[dict]:
        if not final:
            if not isinstance(text, str):
                raise StreamError('"text" must be a string')
            if len(text) > MAX_TEXT_MESSAGE:
                raise StreamError(f"a text message may hold at most {MAX_TEXT_MESSAGE} characters (this one has "
                                  f"{len(text)}): send long text in several messages; nothing of this one was used")
            self.pending += text
        cut = len(self.pending) if final else _last_break(self.pending)
        ready, self.pending = self.pending[:cut], self.pending[cut:]
        if len(self.pending) > MAX_PENDING:  # what waits for its word's end: one word, not a book
            self.pending = ""
            raise StreamError(f"more than {MAX_PENDING} characters without a space: that text was dropped")
        if not ready.strip():
            return []
        words, next_start = self._time_text(ready)
        self.clock = next_start
        return [{"type": "timed", "words": [w.to_dict(4) for w in words]}] + self._frames(self.generator.add_words(words))

    def _time_text(self, text: str) -> tuple[list[TimedWord], float]:
        """Times for the words of ``text`` by the language's estimate, placed at the stream's
        clock; and where the next word would start (a dummy word gives the estimate's pause)."""
        result = compile_text(plain_script(f"{text} {_DUMMY}", rate=self.rate), timing="estimate", library=self.library)
        if result.plan is None:  # plain text always compiles; say so if it ever does not
            raise StreamError(f"cannot time this text: {next(d.message for d in result.diagnostics if d.is_error)}")
        timed = list(result.plan.utterances[0].words)
        *words, dummy = timed
        start = timed[0].start if self.clock is None else self.clock
        shift = max(start, self.generator.known) - timed[0].start
        words = [TimedWord(w.word, w.start + shift, w.end + shift) for w in words]
        if words and words[-1].end > MAX_SECONDS:
            raise StreamError(f"the stream is longer than {MAX_SECONDS:g} s")
        return words, dummy.start + shift

    def _frames(self, poses: np.ndarray) -> list[dict]:
        if not len(poses):
            return []
        start, self.sent = self.sent, self.sent + len(poses)
        positions = positions_from_pose(poses)
        return [{"type": "frames", "start": start, "known_until": round(self.generator.known, 4),
                 "poses": np.round(poses.astype(np.float64), 5).tolist(),
                 "positions": np.round(positions, 5).tolist()}]


def _last_break(text: str) -> int:
    """Where the complete words of ``text`` end: after its last whitespace (0 if none)."""
    m = None
    for m in re.finditer(r"\s+", text):
        pass
    return m.end() if m else 0


class StreamSlots:
    """The streams open now: at most ``total`` at once, at most ``per_client`` of them from one
    client address (``sgt serve --max-streams``, ``--max-client-streams``)."""

    def __init__(self, total: int, per_client: int) -> None:
        self.total = total
        self.per_client = per_client
        self.open: dict[str, int] = {}

    def take(self, client: str) -> str | None:
        """Count a stream of ``client`` as open; or the reason it may not open (counted as nothing)."""
        if sum(self.open.values()) >= self.total:
            return f"this service has {self.total} streams open, its most (--max-streams): retry later"
        if self.open.get(client, 0) >= self.per_client:
            return f"this client has {self.per_client} streams open, the most one client may (--max-client-streams): close one"
        self.open[client] = self.open.get(client, 0) + 1
        return None

    def give_back(self, client: str) -> None:
        self.open[client] -= 1
        if not self.open[client]:
            del self.open[client]

    def stats(self) -> dict:
        return {"open": sum(self.open.values()), "max": self.total, "max_per_client": self.per_client}
