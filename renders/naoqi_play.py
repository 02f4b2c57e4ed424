"""Playing a NAO or Pepper take (the ``angleInterpolation`` file of :mod:`renders.naoqi`) on the
robot with its speech, through NAOqi's Python 3 ``qi`` API.

The file's frame *i* is reached at ``(i + 1) / 15`` s from the call, so a take started as it is
makes the robot snap from wherever it stands to the first key in 1/15 s, and its speech runs
1/15 s ahead. The player:

1. wakes the motion up (``ALMotion.wakeUp``: stiffness on) and loads the WAV on the robot
   (``ALAudioPlayer.loadFile``), so that starting it later costs no file read;
2. moves to the first key in :func:`settle_seconds` (at most :data:`SETTLE_SPEED` rad/s,
   at least :data:`MIN_SETTLE` s) with a blocking ``angleInterpolation``: it returns there;
3. starts the audio (``ALAudioPlayer.play``) and the rest of the take (``angleInterpolation``
   of frames 1.. at ``i / 15`` s, so frame *i* lands with audio sample ``i / 15 * rate``, the
   clock of ``sgt say --mix``) as two asynchronous calls, one right after the other, and waits
   for both.

``qi`` (the libqi Python 3 SDK) is imported only when a robot is played; a dry run prints the
calls instead and needs no robot.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from core.skeleton import FPS

#: The fastest the move to the first key turns a joint (rad/s): a calm start.
SETTLE_SPEED = 1.0
#: The shortest move to the first key (s).
MIN_SETTLE = 1.0
INSTALL = ("NAOqi's Python 3 SDK (the 'qi' module) is not installed: 'pip install qi' (LibQi's Python bindings, "
           "on PyPI), or add the SDK's folder to PYTHONPATH; --dry-run prints the calls without it")


class TakeError(ValueError):
    """A take file that is not an ``angleInterpolation`` file of ``sgt export --rig nao|pepper``."""


@dataclass
class Take:
    names: list[str]
    frames: list[list[float]]  # per frame, the angle of each name (radians)

    @property
    def n_frames(self) -> int:
        return len(self.frames)


def read_take(doc) -> Take:
    """The take of a parsed ``.nao.json`` (``names``, ``angleLists``, ``timeLists``)."""
    if not isinstance(doc, dict) or not {"names", "angleLists"} <= set(doc):
        raise TakeError("not an angleInterpolation file (names, angleLists, timeLists): "
                        "write one with 'sgt export --rig nao -o take.nao.json'")
    names, lists = doc["names"], doc["angleLists"]
    if (not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names)
            or not isinstance(lists, list) or len(lists) != len(names)):
        raise TakeError("'names' and 'angleLists' must be lists of the same length, one list of angles per joint")
    n = len(lists[0]) if isinstance(lists[0], list) else -1
    for name, angles in zip(names, lists):
        if (not isinstance(angles, list) or len(angles) != n or n < 1
                or not all(isinstance(a, (int, float)) and not isinstance(a, bool) and abs(a) < 10 for a in angles)):
            raise TakeError(f"angleLists of {name}: every joint needs the same number (at least 1) of angles in radians")
    return Take(list(names), [[float(lists[j][i]) for j in range(len(names))] for i in range(n)])


def settle_seconds(current: list[float], first: list[float]) -> float:
    """How long the move to the first key takes: the largest turn at :data:`SETTLE_SPEED`, at
    least :data:`MIN_SETTLE` s."""
    turn = max((abs(a - b) for a, b in zip(current, first)), default=0.0)
    return max(MIN_SETTLE, turn / SETTLE_SPEED)


def play(session, take: Take, audio: str | None, *, wake: bool = True) -> dict:
    """Play ``take`` on the robot of ``session`` (a ``qi.Session``, or :class:`DrySession`),
    with the WAV at ``audio`` on the robot's file system (None: motion only). Returns when both
    are done: the seconds between the two starting calls (``skew``) and the settle time."""
    motion = session.service("ALMotion")
    player = session.service("ALAudioPlayer") if audio is not None else None
    if wake:
        motion.wakeUp()
    sound = player.loadFile(audio) if player is not None else None
    names, first = take.names, take.frames[0]
    settle = settle_seconds(list(motion.getAngles(names, True)), first)
    motion.angleInterpolation(names, first, [settle] * len(names), True)  # blocking: returns at the first key
    rest = take.frames[1:]
    angles = [[f[j] for f in rest] for j in range(len(names))]
    times = [round((i + 1) / FPS, 6) for i in range(len(rest))]  # frame i + 1 at (i + 1) / 15 s
    started = time.monotonic()
    playing = player.play(sound, _async=True) if player is not None else None
    audio_at = time.monotonic()
    moving = motion.angleInterpolation(names, angles, [times] * len(names), True, _async=True) if rest else None
    motion_at = time.monotonic()
    for future in (moving, playing):
        if future is not None:
            future.value()
    return {"skew": (motion_at - audio_at) if playing is not None else 0.0, "settle": settle,
            "started": started}


def connect(url: str):
    """A ``qi.Session`` connected to ``url`` (``tcp://IP:9559``). Raises ImportError with
    :data:`INSTALL` when the SDK is missing, RuntimeError when the robot cannot be reached."""
    try:
        import qi  # lazy: NAOqi's SDK, only to play on a robot
    except ImportError:
        raise ImportError(INSTALL) from None
    session = qi.Session()
    try:
        session.connect(url)
    except RuntimeError as exc:
        raise RuntimeError(f"cannot reach the robot at {url}: {exc}") from None
    return session


class DrySession:
    """A session that prints every call (``--dry-run``) on the robot's clock and answers as a
    robot at rest would: every joint at 0; a blocking ``angleInterpolation`` moves the clock on
    by its duration, an asynchronous call returns at once."""

    def __init__(self, out) -> None:
        self.out = out
        self.clock = 0.0

    def service(self, name: str) -> _DryService:
        return _DryService(name, self)


class _DryService:
    def __init__(self, name: str, session: DrySession) -> None:
        self.name, self.session = name, session

    def __getattr__(self, method: str):
        def call(*args, _async: bool = False):
            shown = ", ".join(_short(a) for a in args)
            print(f"{self.session.clock:8.3f} s  {self.name}.{method}({shown})" + ("  [async]" if _async else ""),
                  file=self.session.out)
            if method == "angleInterpolation" and not _async:
                self.session.clock += max(args[2])
            result = [0.0] * len(args[0]) if method == "getAngles" else (1 if method == "loadFile" else None)
            return _Done(result) if _async else result
        return call


class _Done:
    def __init__(self, result) -> None:
        self.result = result

    def value(self):
        return self.result


def _short(value) -> str:
    """A call's argument as the dry run prints it: lists of lists by their shape and ends."""
    if isinstance(value, list) and value and isinstance(value[0], list):
        inner = value[0]
        return f"[{len(value)} lists of {len(inner)}: {_short(inner)}...]"
    if isinstance(value, list) and len(value) > 4:
        return "[" + ", ".join(_short(v) for v in value[:2]) + f", ... {_short(value[-1])}] ({len(value)})"
    if isinstance(value, list):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.4g}"
    return repr(value)
