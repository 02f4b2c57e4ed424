"""What the language server says about the language's names: gestures (with a braille figure
of their stroke), style elements, presets, directives, pose options and the diagnostics' long
explanations (the pages ``codeDescription`` links to)."""

from __future__ import annotations

from pathlib import Path

from core import rules
from core.controls import STYLE_LIMIT
from core.fileio import atomic_write
from core.paths import cache_dir
from core.reading import read_bytes
from core.skeleton import FPS, positions_from_pose
from dsl import presets as presets_module
from renders.terminal import figure_points, stick_figure

STYLES = {
    "speed": "mean speed of all joints: negative is slower, positive faster",
    "space": "distance between the hands: negative is smaller and closer, positive larger and wider",
    "handedness": "relative speed of the hands: negative, the right hand moves more; positive, the left",
}
STYLE_RANGE = (f"values from -{STYLE_LIMIT:g} to {STYLE_LIMIT:g}; 0 is the average of the training motion, "
               "1 one standard deviation")

DIRECTIVES = {
    "voice": ("@voice NAME  |  @voice SPEAKER: NAME", ("the espeak-ng voice (default en-us), for everyone or one "
                                                       "speaker; NAME+VARIANT picks a timbre ('sgt voices', "
                                                       "'sgt voices --variants')")),
    "rate": ("@rate WPM  |  @rate SPEAKER: WPM", "speaking rate in words per minute, 80..450 (default 165)"),
    "pitch": ("@pitch N  |  @pitch SPEAKER: N", "pitch, 0..100 (default 50)"),
    "seed": ("@seed N", "the generator's random seed (default 0)"),
    "library": ("@library PATH", ("an extra gesture folder, relative to the script; its gestures override "
                                  "built-ins of the same name")),
    "preset": ("@preset NAME = ITEMS", "a style preset of this script: @preset shy = space:-2 handedness:-1"),
    "audio": ("@audio FILE [timings=FILE]", ("a recording (WAV, FLAC, MP3) for the next utterance, with its word "
                                             "timings (TextGrid or JSON) or aligned offline")),
    "gap": ("@gap DURATION", ("in the header: the silence between lines (default 0.5s); between two lines: the "
                              "silence before the next one only; negative there: the next line interrupts")),
}
HEADER_ONLY = ("voice", "rate", "pitch", "seed", "library", "preset")

OPTIONS = {
    "x1": "play at normal speed (the default)",
    "x2": "play at twice the speed: the gesture takes half the time",
    "x3": "play at three times the speed",
    "flip": "mirror left and right (point_right flip points left)",
    "hold": "keep the key pose this long before the gesture retracts: hold=500ms, hold=1.5s (at most 10 s)",
}
TAGS = {
    "pose": "[pose:NAME x2 flip hold=500ms]: a library gesture whose stroke lands on the next word's onset",
    "pause": "[pause DURATION]: silence inserted into the speech, e.g. [pause 300ms] (at most 10 s)",
    "look": "[look:TARGET hold=800ms]: the eyes look at a speaker of the script or a direction (left, right, up, "
            "down, ahead) from the next word to the end of its clause, or for hold=",
}


def preset_text(values: dict[str, float]) -> str:
    return " ".join(f"{k}:{v:+g}" for k, v in values.items())


#: Where the built-in presets are defined (go to definition of ``<calm>``).
BUILTIN_PRESETS_FILE = Path(presets_module.__file__)


def builtin_preset_line(name: str) -> int:
    """The 0-based line of a built-in preset's definition in dsl/presets.py (0 when not found)."""
    try:
        text = read_bytes(BUILTIN_PRESETS_FILE, "configuration").decode("utf-8", errors="replace")
    except OSError:
        return 0
    for n, line in enumerate(text.splitlines()):
        if line.strip().startswith(f'"{name}":'):
            return n
    return 0


# -- gestures ---------------------------------------------------------------------------------

_FIGURES: dict[int, tuple[object, list[str]]] = {}


def stroke_figure(gesture, cols: int = 20, rows: int = 10) -> list[str]:
    """A braille stick figure of the gesture's stroke pose (its last pose when it marks none),
    hands included; cached while its spec is unchanged."""
    hit = _FIGURES.get(id(gesture.spec))
    if hit is not None and hit[0] is gesture.spec:
        return hit[1]
    clip = gesture.clip()
    s = clip.stroke_frame if clip.stroke_frame is not None else clip.n_frames - 1
    points = figure_points(positions_from_pose(clip.poses[s : s + 1]), clip.hands.take(slice(s, s + 1)))
    figure = [line.rstrip("\u2800") for line in stick_figure(points[0], cols, rows)]
    while figure and not figure[0]:
        figure.pop(0)
    while figure and not figure[-1]:
        figure.pop()
    _FIGURES[id(gesture.spec)] = (gesture.spec, figure)
    return figure


def gesture_detail(gesture) -> str:
    where = "" if gesture.origin == "built-in" else f" · {Path(gesture.origin).name}/"
    return f"{gesture.duration:g} s · {', '.join(gesture.tags)}{where}"


def gesture_markdown(gesture) -> str:
    """A gesture's description, tags, durations, origin and the figure of its stroke (seen from the front, turned a little to show depth)."""
    stroke = gesture.stroke_frame(1)
    timing = f"{gesture.duration:g} s (x2 {gesture.n_frames(2) / FPS:.2f} s, x3 {gesture.n_frames(3) / FPS:.2f} s)"
    origin = "built-in" if gesture.origin == "built-in" else f"from {gesture.origin}"
    lines = [f"**{gesture.name}**: {gesture.description}", "",
             f"*tags* {', '.join(gesture.tags)} · *duration* {timing}"
             + (f" · *stroke* at {stroke / FPS:.2f} s" if stroke is not None else " · no stroke marked (the last pose is held)"),
             f"*{origin}*: `{gesture.path}`", "", "```text", *stroke_figure(gesture), "```"]
    return "\n".join(lines)


# -- diagnostics ------------------------------------------------------------------------------

_PAGES: dict[str, Path | None] = {}


def explanation_page(code: str) -> Path | None:
    """A Markdown page of what ``sgt explain CODE`` prints (without running the example),
    written into the sgt cache once per server; None for an unknown code."""
    if code in _PAGES:
        return _PAGES[code]
    rule = rules.lookup(code)
    path = cache_dir("lsp") / "explain" / f"{rule.code}.md" if rule is not None else None
    if rule is not None:
        text = "\n".join([
            f"# {rule.code} {rule.name} ({rule.severity})", "", f"message: {rule.template}",
            *([f"hint: {rule.hint}"] if rule.hint else []), "", rule.explanation, "",
            *(["Example:", "", "```sgt", rule.example.rstrip("\n"), "```", ""] if rule.example else []),
            f"`sgt explain {rule.code}` prints this and what `sgt check` says about the example.", ""])
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(path, text.encode("utf-8"), durable=False)
        except OSError:
            path = None
    _PAGES[code] = path
    return path
