"""The timeline of one utterance, laid out in character cells.

Rows, each starting with its lane name so nothing depends on colour::

    time  0s        1s        2s      ▼ 3s
    words Hello, and welcome ‥pause‥ to Riverside
    pose  [wave=======]           [point_right x2]
    style       <helpful speed:+0.5 space:+1~~~~~~~>

Pose-control spans are ``[name ...]`` filled with ``=``, style spans ``<name ...>`` filled
with ``~``, pauses ``‥pause‥`` in the words row. A pose span marks where its stroke lands with
``*`` (``[wave=*===]``), or ``!`` when the stroke lands two frames or more after its word (a
late stroke, which ``sgt check`` warns about with SGT401); the label goes before the mark where
it fits, else after it. A label too long for its span is cut where
one of its items ends (or before a value's colon) and ends with ``…``: ``<speed…~>``, never
``speed:+0`` for +0.5. Overlapping spans go to extra rows; when there is no room for them (at
80x24 there is one row a kind) each hidden span is marked ``+`` where it starts (just after a
shown span's label when it starts on one), in the last row of its kind, and that row's name ends
with ``+`` (``pose+``). The playhead column is reported
separately so the view can draw it (reverse video) on every row.
Data comes from an estimated plan (:class:`dsl.plan.UtterancePlan`) or from a generated
motion clip (:class:`core.motion.MotionClip`, which carries the real speech timing).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from core.skeleton import FPS
from core.words import TimedWord

LANE_WIDTH = 6  # "words " etc.


@dataclass(frozen=True)
class Span:
    kind: str  # "pose", "style" or "pause"
    name: str
    start: int  # frame
    end: int  # frame, exclusive
    label: str
    stroke: int | None = None  # a pose control's stroke frame
    late: bool = False  # its stroke lands two frames or more after its word

#: A stroke this many frames or more after its word is marked late (as dsl.realize.LATE_WARN warns).
LATE = 2


@dataclass
class TimelineData:
    words: list[TimedWord]
    spans: list[Span]
    n_frames: int
    timing: str = "estimate"  # where the word times come from

    @property
    def duration(self) -> float:
        return self.n_frames / FPS

    def word_at(self, frame: int) -> int | None:
        t = frame / FPS
        for i, (_, a, b) in enumerate(self.words):
            if a <= t < b:
                return i
        return None


@dataclass
class Row:
    lane: str
    text: str
    marks: list[tuple[int, int, str]] = field(default_factory=list)  # (start, end, class) in text


def _label(kind: str, name: str, options: dict) -> str:
    if kind == "pose":
        extra = []
        if options.get("speed", 1) not in (1, None):
            extra.append(f"x{options['speed']}")
        if options.get("flip"):
            extra.append("flip")
        if options.get("hold"):
            extra.append(f"hold={options['hold']:g}s")
        return " ".join([name] + extra)
    if kind == "style":
        values = " ".join(f"{k}:{v:+g}" for k, v in sorted(options.items()) if isinstance(v, (int, float)))
        return f"{name} {values}".strip() if values and values.split(":")[0] != name else (values or name)
    if kind == "pause":
        return f"pause {options.get('seconds', 0):g}s"
    return name


def from_plan(plan) -> TimelineData:
    """From an :class:`~dsl.plan.UtterancePlan`."""
    return _data(plan.words, plan.controls, plan.n_frames, plan.speech.get("engine", "estimate"))


def from_clip(clip, timing: str = "speech") -> TimelineData:
    """From a generated :class:`~core.motion.MotionClip` (it carries the real speech timing)."""
    return _data(clip.words, clip.controls, clip.n_frames, timing)


def _data(words, controls, n_frames: int, timing: str) -> TimelineData:
    spans = [Span(c.kind, c.name, c.start_frame, c.end_frame, _label(c.kind, c.name, c.options), c.stroke_frame,
                  c.stroke_frame is not None and c.word_frame is not None and c.stroke_frame - c.word_frame >= LATE)
             for c in controls]
    return TimelineData(list(words), spans, n_frames, timing)


def _put(buf: list[str], col: int, text: str) -> None:
    for i, ch in enumerate(text):
        if 0 <= col + i < len(buf):
            buf[col + i] = ch


def fit_label(label: str, width: int) -> str:
    """``label`` in at most ``width`` cells: whole, or cut where an item ends (at a space, or
    before the colon of ``name:value``) followed by ``…``; a lone first name is shortened."""
    if len(label) <= width:
        return label
    if width <= 1:
        return "…"[:width]
    cuts = [i for i, c in enumerate(label) if c in " :" and 0 < i <= width - 1]
    if cuts:
        return label[: cuts[-1]].rstrip() + "…"
    return label[: width - 1] + "…"


def _span_text(label: str, width: int, kind: str, mark: tuple[int, str] | None = None) -> str:
    """The span's cells; ``mark``: (cell within the span, character) of its stroke, drawn there
    with the label before it when it fits there, else after it when it fits there, else on
    the side with more room (cut where an item ends)."""
    open_, close, fill = {"pose": ("[", "]", "="), "style": ("<", ">", "~")}.get(kind, ("‥", "‥", "‥"))
    if width <= 1:
        return open_[:width] if mark is None else mark[1]
    inner = width - 2
    cells = list(open_ + fit_label(label, inner).ljust(inner, fill) + close)
    if mark is None:
        return "".join(cells)
    at, char = min(max(mark[0], 0), width - 1), mark[1]
    cells[1:-1] = [fill] * inner
    before, after = at - 1, width - 2 - at  # free cells inside the brackets on each side of the mark
    if len(label) <= before or (len(label) > after and before >= after):
        text = fit_label(label, max(0, before))
        cells[1 : 1 + len(text)] = text
    else:
        text = fit_label(label, max(0, after))
        cells[at + 1 : at + 1 + len(text)] = text
    cells[at] = char
    return "".join(cells)


def layout(data: TimelineData | None, width: int, playhead: int | None = None, max_lanes: int = 2) -> tuple[list[Row], int | None]:
    """Rows of text ``width`` cells wide, and the playhead's column (or None)."""
    lane_w = LANE_WIDTH if width >= 30 else 0
    w = max(1, width - lane_w)
    if data is None or data.n_frames <= 0:
        return [], None
    n = data.n_frames

    def col(frame: float) -> int:
        return min(w - 1, max(0, int(frame * w / n)))

    rows: list[Row] = []
    # time ruler
    ruler = [" "] * w
    step = 1
    while step * FPS * w / n < 4 and step < 600:  # at least 4 cells between labels
        step *= 2
    for s in range(0, int(data.duration) + 1, step):
        _put(ruler, col(s * FPS), f"{s}s" if s else "0")
    rows.append(Row("time", "".join(ruler)))
    # words and pauses
    words = [" "] * w
    marks: list[tuple[int, int, str]] = []
    for sp in data.spans:
        if sp.kind == "pause":
            a, b = col(sp.start), max(col(sp.start) + 1, col(sp.end))
            _put(words, a, _span_text("pause", b - a, "pause"))
            marks.append((a, b, "pause"))
    current = data.word_at(playhead) if playhead is not None else None
    placed = sorted(((col(a * FPS), i, word) for i, (word, a, _) in enumerate(data.words)))
    for k, (c, i, word) in enumerate(placed):
        room = (placed[k + 1][0] if k + 1 < len(placed) else w) - c
        if room <= 0:
            continue
        text = word if len(word) < room else (word[: max(1, room - 1)] + ("…" if room > 1 else ""))
        _put(words, c, text)
        marks.append((c, c + len(text), "word-current" if i == current else "word"))
    rows.append(Row("words", "".join(words), marks))
    # control lanes, overlapping spans on extra rows
    for kind in ("pose", "style"):
        lanes: list[list[Span]] = []
        for sp in sorted((s for s in data.spans if s.kind == kind), key=lambda s: (s.start, s.end)):
            for lane in lanes:
                if all(sp.start >= o.end or sp.end <= o.start for o in lane):
                    lane.append(sp)
                    break
            else:
                lanes.append([sp])
        shown, hidden = lanes[:max_lanes] or [[]], [sp for lane in lanes[max_lanes:] for sp in lane]
        for li, lane in enumerate(shown):
            buf = [" "] * w
            lm = []
            for sp in lane:
                a = col(sp.start)
                b = max(a + 1, min(w, int(round(sp.end * w / n))))
                mark = None
                if kind == "pose" and sp.stroke is not None:
                    mark = (col(sp.stroke) - a, "!" if sp.late else "*")
                _put(buf, a, _span_text(sp.label, b - a, kind, mark))
                lm.append((a, b, kind))
                if mark is not None:
                    at = a + min(max(mark[0], 0), b - a - 1)
                    lm.append((at, at + 1, "stroke-late" if sp.late else "stroke"))
            name = kind if li == 0 else ""
            if hidden and li == len(shown) - 1:  # no room for their rows: a marker where each starts
                for sp in hidden:
                    a = col(sp.start)
                    while a + 1 < w and buf[a] not in "=~ ":  # not over a shown span's label
                        a += 1
                    _put(buf, a, "+")
                    lm.append((a, a + 1, "overlap"))
                name = (name or kind) + "+"
            rows.append(Row(name, "".join(buf), lm))
    if lane_w:
        for r in rows:
            r.text = f"{r.lane:<{lane_w - 1}.{lane_w - 1}} " + r.text
            r.marks = [(a + lane_w, b + lane_w, c) for a, b, c in r.marks]
    head = None
    if playhead is not None:
        head = lane_w + col(playhead)
        t = rows[0].text
        rows[0].text = t[:head] + "▼" + t[head + 1 :]
    return rows, head
