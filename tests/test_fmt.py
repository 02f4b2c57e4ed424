"""`sgt fmt` (dsl/fmt.py): one canonical layout, idempotent, and never a change to what is
spoken or gestured.

Every example and 300 generated scripts (random spacing inside and around tags, options in
any order, directives in every accepted form, comments, escapes, continuation lines, CRLF)
are compiled before and after formatting (estimated timing): the plans, less the line and
column numbers, are equal, the spoken text is equal up to whitespace, the diagnostics are
the same rules, and a second formatting changes nothing. And a line's layout never depends on
another line: for scripts built by hypothesis from the language's pieces, adding or removing
one line changes only that line of the output.
"""

from __future__ import annotations

import random
import subprocess
import sys
from collections import Counter
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dsl import compile_text
from dsl.fmt import FormatError, format_source
from library import load_library

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.sgt"))
LIB = load_library(use_config=False)
GESTURES = ["wave", "nod", "point_right", "point_left", "open_arms", "count_one", "count_two", "shrug", "beat_both", "nope_gesture"]
WORDS = ["hello", "there", "we", "can", "see", "the", "river", "now", "don't", "left-hand", "Σωκράτης", "José", "1999"]


def _sgt(*args: str, stdin: str | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], check=False, input=stdin, capture_output=True, text=True,
                          cwd=cwd or ROOT, timeout=60)


# -- what a script means -------------------------------------------------------------------------

def _without_places(value):
    if isinstance(value, dict):
        return {k: _without_places(v) for k, v in value.items() if k not in ("line", "col", "source")}
    if isinstance(value, list):
        return [_without_places(v) for v in value]
    return value


def _meaning(text: str, arrays: bool = False) -> dict:
    """What a script says and gestures: the plan without places, the spoken text up to
    whitespace, speakers and voices, and the rules its diagnostics come from."""
    result = compile_text(text, "fmt_case.sgt", timing="estimate", library=LIB)
    out = {
        "codes": Counter((d.code, d.severity) for d in result.diagnostics),
        "spoken": [(u.speaker, " ".join(u.text.split()), u.voice, u.gap) for u in result.script.utterances],
        "plan": _without_places(result.plan.to_dict()) if result.plan is not None else None,
    }
    if arrays and result.plan is not None:
        out["arrays"] = [{k: v.tolist() for k, v in u.arrays.as_dict().items()} for u in result.plan.utterances]
    return out


# -- a generator of messy scripts ------------------------------------------------------------------

def _ws(rng: random.Random, empty: bool = True) -> str:
    return rng.choice(([""] if empty else []) + [" ", "  ", "\t", " \t "])


def _pose(rng: random.Random) -> str:
    options = []
    if rng.random() < 0.5:
        options.append(rng.choice(["x1", "x2", "x3"]))
    if rng.random() < 0.3:
        options.append("flip")
    if rng.random() < 0.3:
        options.append(f"hold{_ws(rng)}={_ws(rng)}{rng.choice(['300ms', '0.5s', '1s'])}")
    if rng.random() < 0.1:
        options.append(rng.choice(["x2", "flip", "hold=200ms"]))  # given twice: the last one wins
    if rng.random() < 0.05:
        options.append(rng.choice(["fast", "hold 300ms", "x2=1"]))  # errors, kept in their order
    rng.shuffle(options)
    inner = f"{_ws(rng)}pose{_ws(rng)}:{_ws(rng)}{rng.choice(GESTURES)}"
    for o in options:
        inner += _ws(rng, empty=False) + o
    return f"[{inner}{_ws(rng)}]"


def _style(rng: random.Random, presets: list[str]) -> tuple[str, str]:
    items = []
    if presets and rng.random() < 0.4:
        items.append(rng.choice(presets))
    for name in rng.sample(["speed", "space", "handedness"], rng.randint(0 if items else 1, 2)):
        items.append(f"{name}{_ws(rng)}:{_ws(rng)}{rng.choice(['-1', '+0.5', '2', '-2.5'])}")
    opening = "<" + _ws(rng) + _ws(rng, empty=False).join(items) + _ws(rng) + ">"
    first = items[0].split(":")[0].strip()
    closing = rng.choice([f"</{_ws(rng)}{first}{_ws(rng)}>", "</>", ""])
    return opening, closing


def _utterance(rng: random.Random, presets: list[str], speakers: list[str]) -> list[str]:
    parts = []
    open_spans: list[str] = []
    for _ in range(rng.randint(1, 9)):
        r = rng.random()
        if r < 0.5:
            parts.append(rng.choice(WORDS) + rng.choice(["", "", ",", ".", "!", "?"]))
        elif r < 0.7:
            parts.append(_pose(rng))
        elif r < 0.8:
            opening, closing = _style(rng, presets)
            parts.append(opening)
            if closing:
                open_spans.append(closing)
        elif r < 0.85 and open_spans:
            parts.append(open_spans.pop())
        elif r < 0.9:
            parts.append(f"[{_ws(rng)}pause{_ws(rng, empty=False)}{rng.choice(['300ms', '0.2s'])}{_ws(rng)}]")
        else:
            parts.append(rng.choice(["\\[", "\\]", "\\#", "\\:", "\\<", "\\\\"]))
    parts += reversed(open_spans)
    words = [rng.choice(WORDS)] + parts
    seps = [rng.choice([" ", " ", "  ", "\t", ""]) for _ in words]
    # a separator of "" glues a tag to a word (a mark in a word, a warning that must stay)
    body = "".join(s + w for s, w in zip(seps, words))
    speaker = rng.choice(speakers + [None])
    head = f"{speaker}{rng.choice(['', ' ', chr(9)])}:{rng.choice([' ', '   ', chr(9)])}" if speaker else ""
    lines = [head + body.lstrip()]
    if head and rng.random() < 0.1:  # the speaker alone on its line, the words on the next
        lines = [head.rstrip(), rng.choice(["  ", "\t"]) + body.lstrip()]
    # continuation lines, cut where a word or a tag ends
    while rng.random() < 0.3:
        more = " ".join(rng.choice(WORDS + [_pose(rng)]) for _ in range(rng.randint(1, 4)))
        lines.append(rng.choice([" ", "  ", "\t", "        ", " \t"]) + more)
    return [line + rng.choice(["", "", " ", "\t", "  # note", "# tight", "\t#  spaced comment  "]) for line in lines]


def _script(seed: int) -> str:
    rng = random.Random(seed)
    speakers = rng.sample(["guide", "knight", "merchant", "Robot_2"], rng.randint(1, 3))
    presets = []
    lines = []
    if rng.random() < 0.5:
        lines.append("# a generated script " + str(seed))
    for _ in range(rng.randint(0, 7)):
        kind = rng.choice(["voice", "voice_for", "rate", "rate_for", "pitch", "seed", "preset", "gap"])
        sp = _ws(rng, empty=False)
        if kind == "voice":
            lines.append(f"@voice{sp}{rng.choice(['en-us', 'en-gb'])}")
        elif kind == "voice_for":
            lines.append(f"@voice{sp}{rng.choice(speakers)}{rng.choice([':', ' :', '  :'])}{sp}{rng.choice(['en-us+m3', 'en-gb', 'en-us+f2'])}")
        elif kind in ("rate", "rate_for", "pitch"):
            name = "pitch" if kind == "pitch" else "rate"
            who = f"{rng.choice(speakers)}:{sp}" if kind == "rate_for" else ""
            lines.append(f"@{name}{sp}{who}{rng.randint(100, 200) if name == 'rate' else rng.randint(20, 80)}")
        elif kind == "seed":
            lines.append(f"@seed{sp}{rng.randint(0, 99)}")
        elif kind == "preset":
            name = rng.choice(["shy", "bold", "very_calm", "fast2"])
            presets.append(name)
            items = " ".join(f"{e}:{rng.choice(['+1', '-2', '0.5'])}" for e in rng.sample(["speed", "space", "handedness"], rng.randint(1, 3)))
            eq = rng.choice([" = ", "=", " =", "= ", "   =   "])
            lines.append(f"@preset{sp}{name}{eq}{items}")
        else:
            lines.append(f"@gap{sp}{rng.choice(['0.3s', '600ms'])}")
        if rng.random() < 0.2:
            lines[-1] += rng.choice(["   # why", "# tight"])
    for n in range(rng.randint(1, 5)):
        if rng.random() < 0.3:
            lines += [""] * rng.randint(1, 3)
        if rng.random() < 0.1:
            lines.append(rng.choice(["# a comment line", "  # an indented comment"]))
        if n and rng.random() < 0.1:
            lines.append(f"@gap {rng.choice(['-200ms', '1s'])}")
        lines += _utterance(rng, presets, speakers)
    end = rng.choice(["\n", "\n", "", "\n\n\n"])
    newline = "\r\n" if rng.random() < 0.1 else "\n"
    return newline.join(lines).replace("\n", newline) + end.replace("\n", newline)


# -- tests ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_mean_the_same_after_formatting_and_a_second_run_changes_nothing(path):
    text = path.read_text(encoding="utf-8")
    once = format_source(text, str(path))
    assert format_source(once, str(path)) == once
    assert _meaning(once, arrays=True) == _meaning(text, arrays=True)


def test_generated_scripts_mean_the_same_after_formatting():
    tried = changed = planned = 0
    for seed in range(300):
        text = _script(seed)
        try:
            once = format_source(text, "fmt_case.sgt")
        except FormatError:
            continue
        tried += 1
        changed += once != text
        assert format_source(once, "fmt_case.sgt") == once, f"seed {seed}: not idempotent"
        before, after = _meaning(text), _meaning(once)
        assert after == before, f"seed {seed}: the meaning changed\n{text!r}\n{once!r}"
        planned += before["plan"] is not None
    # most scripts are tried, most change, and many compile to a plan (the rest have errors, also compared)
    assert tried >= 280 and changed >= 250 and planned >= 100, (tried, changed, planned)


@pytest.mark.slow
def test_real_speech_is_the_same_after_formatting():
    """With espeak-ng's timing too (the text it speaks differs only in whitespace)."""
    compared = 0
    for seed in range(12):
        text = _script(seed)
        before = compile_text(text, "fmt_case.sgt", timing="speech", library=LIB)
        if before.plan is None:
            continue
        after = compile_text(format_source(text), "fmt_case.sgt", timing="speech", library=LIB)
        assert _without_places(after.plan.to_dict()) == _without_places(before.plan.to_dict()), f"seed {seed}"
        compared += 1
    assert compared >= 5


def test_the_canonical_layout():
    messy = ("\n\n# header   \n@voice   en-us    # default\n@voice knight :  en-gb+m3\n@voice   merchant: en-us+f2\n"
             "@rate merchant:\t175\n@preset shy=space:-2   handedness:-1\n@preset   bold =speed:+2\n\n\n\n"
             "knight :   [ pose : wave  hold = 1s  flip x2 ]   Hello,\tthere!   <  calm  speed : -1 >slowly</ calm >  # c1\n"
             "        and on [pause   300ms] it goes. \\[x\\] \\# not a comment\n"
             "  # inside the utterance\n"
             "\t[pose:nod x3 flip x2] end#tight\n"
             "merchant:    [pose:shrug hold=200ms x2 hold=300ms] Hm.   \n\n")
    assert format_source(messy) == (
        "# header\n@voice en-us  # default\n@voice knight: en-gb+m3\n@voice merchant: en-us+f2\n"
        "@rate merchant: 175\n@preset shy = space:-2 handedness:-1\n@preset bold = speed:+2\n\n"
        "knight: [pose:wave x2 flip hold=1s] Hello, there! <calm speed:-1>slowly</calm>  # c1\n"
        "    and on [pause 300ms] it goes. \\[x\\] \\# not a comment\n"
        "    # inside the utterance\n"
        "    [pose:nod x3 x2 flip] end  #tight\n"
        "merchant: [pose:shrug x2 hold=200ms hold=300ms] Hm.\n")


def test_a_speaker_alone_on_its_first_line():
    assert format_source("guide :\n\t  [ pose:wave ] Hello.\n") == "guide:\n    [pose:wave] Hello.\n"


def test_options_with_an_error_keep_their_order_and_style_items_are_never_reordered():
    assert format_source("g: [pose:wave hold 300ms x2] <space:1 speed:-1>hi</space>\n") == \
        "g: [pose:wave hold 300ms x2] <space:1 speed:-1>hi</space>\n"


def test_crlf_and_a_byte_order_mark_are_kept():
    assert format_source("\ufeffg:  hi\r\n\r\n\r\ng: [ pose:nod ]there\r\n") == "\ufeffg: hi\r\n\r\ng: [pose:nod]there\r\n"


@pytest.mark.parametrize("text", ["g: hello [pose:wave\n", "g: a ] b\n", "  indented\n", "@ voice en-us\ng: hi\n",
                                  "g: hi [pose:]\n", "g: trailing \\"])
def test_a_script_with_a_syntax_error_is_refused(text):
    with pytest.raises(FormatError) as info:
        format_source(text)
    assert info.value.diagnostics and all(d.is_error for d in info.value.diagnostics)


def test_sgt_fmt_rewrites_then_check_passes(tmp_path):
    for p in EXAMPLES:
        (tmp_path / p.name).write_bytes(p.read_bytes())
    messy = tmp_path / "messy.sgt"
    messy.write_text("g :  [pose:wave  x2]  hi\n")
    r = _sgt("fmt", "--check", str(tmp_path))
    assert r.returncode == 1
    assert f"--- a/{messy}" in r.stdout and "-g :  [pose:wave  x2]  hi\n+g: [pose:wave x2] hi\n" in r.stdout
    assert messy.read_text() == "g :  [pose:wave  x2]  hi\n"  # --check writes nothing
    assert _sgt("fmt", str(tmp_path)).returncode == 0
    assert messy.read_text() == "g: [pose:wave x2] hi\n"
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    r = _sgt("fmt", "--check", str(tmp_path))
    assert (r.returncode, r.stdout) == (0, "")
    assert _sgt("fmt", str(tmp_path)).returncode == 0
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # a no-op after one run


def test_sgt_fmt_refuses_a_file_with_syntax_errors_and_leaves_it(tmp_path):
    bad = tmp_path / "bad.sgt"
    bad.write_text("g:  hello [pose:wave\n")
    good = tmp_path / "good.sgt"
    good.write_text("g:  hello\n")
    r = _sgt("fmt", str(bad), str(good))
    assert r.returncode == 1
    assert "SGT104" in r.stderr and "not formatted" in r.stderr
    assert bad.read_text() == "g:  hello [pose:wave\n" and good.read_text() == "g: hello\n"


def test_sgt_fmt_stdin():
    r = _sgt("fmt", "--stdin", stdin="g:  hi   [ pose:wave ]there\n")
    assert (r.returncode, r.stdout) == (0, "g: hi [pose:wave]there\n")
    r = _sgt("fmt", "--stdin", "--check", "--stdin-filename", "x.sgt", stdin="g:  hi\n")
    assert r.returncode == 1 and "+++ b/x.sgt" in r.stdout
    r = _sgt("fmt", "--stdin", "--stdin-filename", "x.sgt", stdin="g: [pose:wave\n")
    assert r.returncode == 1 and r.stdout == "" and "x.sgt:1:4" in r.stderr
    assert _sgt("fmt").returncode == 2


def test_the_generator_makes_what_it_should():
    """The generated scripts cover the forms the formatter rewrites."""
    texts = "".join(_script(seed) for seed in range(300))
    for form in ("\t", "hold =", " :", "@preset", "\r\n", "</>", "\\#", "# tight", "\n ", "[ pause", "x2=1"):
        assert form in texts, form
    assert np.mean([bool(_meaning(_script(s))["plan"]) for s in range(40)]) > 0.3


def test_the_documented_layout_is_canonical():
    doc = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    block = doc.split("## Canonical layout", 1)[1].split("```sgt\n", 1)[1].split("```", 1)[0]
    assert format_source(block) == block


# -- one line's change is one line's change ------------------------------------------------------------
# Scripts built from the language's pieces, each line of one kind: header directives (several
# @voice/@rate/@pitch/@preset lines, written with messy spacing), comment lines, utterances with
# marks and their continuation lines, single blank lines between statements.

SPEAKER_NAMES = ["guide", "knight", "merchant", "Robot_2", "a_very_long_speaker_name", "x"]
_space = st.sampled_from([" ", "  ", "\t", " \t "])
_colon = st.sampled_from([":", " :", "  :", ":  ", ": ", " : "])
_tail = st.sampled_from(["", "", "", " ", "\t", "  # note", "# tight", "\t#  a spaced comment  ", " # a much longer note"])
_word = st.sampled_from(WORDS + ["a", "supercalifragilistic", "there,", "now."])
_value = st.sampled_from(["en-us", "en-gb+m3", "en-us+f2", "'en gb'", "en"])


@st.composite
def _directive(draw) -> str:
    kind = draw(st.sampled_from(["voice_for", "rate_for", "pitch_for", "preset", "voice", "rate", "pitch", "seed", "gap"]))
    sp, who = draw(_space), draw(st.sampled_from(SPEAKER_NAMES))
    if kind == "voice_for":
        line = f"@voice{sp}{who}{draw(_colon)}{draw(_space)}{draw(_value)}"
    elif kind in ("rate_for", "pitch_for"):
        line = f"@{kind[:-4]}{sp}{who}{draw(_colon)}{draw(_space)}{draw(st.integers(20, 300))}"
    elif kind == "preset":
        name = draw(st.sampled_from(["shy", "bold", "a_much_longer_preset_name", "p2"]))
        items = draw(st.lists(st.sampled_from(["speed:+1", "space:-2", "handedness:0.5", "speed:-0.5"]), min_size=1, max_size=3))
        line = f"@preset{sp}{name}{draw(st.sampled_from([' = ', '=', ' =', '= ', '   =   ']))}{draw(_space).join(items)}"
    elif kind == "voice":
        line = f"@voice{sp}{draw(_value)}"
    elif kind in ("rate", "pitch"):
        line = f"@{kind}{sp}{draw(st.integers(20, 300))}"
    elif kind == "seed":
        line = f"@seed{sp}{draw(st.integers(0, 99))}"
    else:
        line = f"@gap{sp}{draw(st.sampled_from(['0.3s', '600ms']))}"
    return line + draw(_tail)


@st.composite
def _marks(draw) -> str:
    parts = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["word", "word", "pose", "pause", "style"]))
        if kind == "pose":
            options = draw(st.lists(st.sampled_from(["x2", "flip", "hold = 300ms", "x3"]), max_size=2, unique=True))
            parts.append("[" + draw(_space).join([f"pose{draw(_colon)}{draw(st.sampled_from(GESTURES))}"] + options) + "]")
        elif kind == "pause":
            parts.append(f"[ pause{draw(_space)}{draw(st.sampled_from(['300ms', '0.2s']))}]")
        elif kind == "style":
            parts.append(f"< speed :{draw(st.sampled_from(['-1', '+0.5']))}>{draw(_word)}</ speed >")
        else:
            parts.append(draw(_word))
    return draw(_space).join(parts)


@st.composite
def _utterance_line(draw) -> str:
    speaker = draw(st.sampled_from(SPEAKER_NAMES + [None]))
    head = f"{speaker}{draw(_colon)}{draw(_space)}" if speaker else ""
    return head + draw(_word) + " " + draw(_marks()) + draw(_tail)


@st.composite
def _continuation(draw) -> str:
    return draw(st.sampled_from([" ", "  ", "\t", "        ", " \t"])) + draw(_marks()) + draw(_tail)


_comment_line = st.sampled_from(["# a comment line", "#tight", "  # an indented comment", "#", "# " + "long " * 12])


@st.composite
def _statement(draw) -> list[str]:
    """Body lines: an utterance (perhaps continued), a comment line, a @gap, a blank line."""
    kind = draw(st.sampled_from(["utterance", "utterance", "utterance", "comment", "gap", "blank"]))
    if kind == "utterance":
        return [draw(_utterance_line())] + draw(st.lists(_continuation(), max_size=2))
    if kind == "comment":
        return [draw(_comment_line)]
    if kind == "gap":
        return [f"@gap{draw(_space)}{draw(st.sampled_from(['-200ms', '1s']))}{draw(_tail)}"]
    return [""]


def _is_code(line: str) -> bool:
    return bool(line.strip()) and not line.lstrip().startswith("#")


def _is_continuation(line: str) -> bool:
    return line[:1] in (" ", "\t") and _is_code(line)


@st.composite
def _script_and_edit(draw):
    """(the script's lines, the lines after the edit, the index of the line added or removed;
    None when no line could be removed)."""
    header = draw(st.lists(st.one_of(_directive(), _directive(), _comment_line), min_size=1, max_size=8))
    body: list[str] = []
    for statement in draw(st.lists(_statement(), min_size=1, max_size=8)):
        if statement != [""] or (body and body[-1]):  # blank lines: single, between statements
            body += statement
    while body and not body[-1]:
        body.pop()
    lines = header + ([""] if body and draw(st.booleans()) else []) + body
    if draw(st.booleans()):  # add a line
        at = draw(st.integers(0, len(lines)))
        before, following = (lines[at - 1] if at else ""), (lines[at] if at < len(lines) else "")
        kinds = ["comment"] + (["directive"] * 3 if at <= len(header) else ["utterance"] * 2)
        if at > len(header) and _is_code(before) and not before.startswith("@"):
            kinds.append("continuation")  # after a line of an utterance
        if before and following and not _is_continuation(following):
            kinds.append("blank")
        line = {"comment": _comment_line, "directive": _directive(), "utterance": _utterance_line(),
                "continuation": _continuation(), "blank": st.just("")}[draw(st.sampled_from(kinds))]
        return lines, lines[:at] + [draw(line)] + lines[at:], at

    # remove a line, but not one whose removal makes blank lines meet (or begin or end the
    # script), nor the first line of an utterance with continuation lines
    def removable(i: int) -> bool:
        rest = lines[:i] + lines[i + 1:]
        if not rest or not rest[0] or not rest[-1] or any(not a and not b for a, b in pairwise(rest)):
            return False
        following = next((x for x in lines[i + 1:] if _is_code(x)), "")
        return _is_continuation(lines[i]) or not _is_continuation(following)

    candidates = [i for i in range(len(lines)) if removable(i)]
    if not candidates:
        return lines, lines, None
    at = draw(st.sampled_from(candidates))
    return lines, lines[:at] + lines[at + 1:], at


@settings(max_examples=400, deadline=None)
@given(case=_script_and_edit())
def test_adding_or_removing_one_line_changes_only_that_line(case):
    lines, edited, at = case
    before = format_source("\n".join(lines) + "\n").splitlines()
    after = format_source("\n".join(edited) + "\n").splitlines()
    assert len(before) == len(lines) and len(after) == len(edited)  # no blank lines collapse here
    if at is None:
        return
    if len(edited) > len(lines):  # added at `at`: every other line as it was
        assert after[:at] + after[at + 1:] == before, (lines, edited)
    else:
        assert before[:at] + before[at + 1:] == after, (lines, edited)


def test_one_speakers_new_voice_is_a_one_line_diff():
    """The case users met: a script typed by hand is canonical, and a @voice line added to it
    is the only line of the diff `sgt fmt --check` would show."""
    typed = "@voice en-us\n@voice knight: en-gb+m3\n@rate knight: 150  # slow\n\nknight: Halt!  # loud\nx: [pose:nod] Yes.\n"
    assert format_source(typed) == typed
    grown = typed.replace("@voice knight:", "@voice a_very_long_speaker_name: en-us+f2\n@voice knight:")
    assert format_source(grown) == grown


def test_the_shipped_scripts_are_canonical():
    """`sgt fmt --check` on the examples and the scripts in docs/ (what CI runs on a project's
    scripts): nothing to change."""
    r = _sgt("fmt", "--check", "examples", "docs")
    assert (r.returncode, r.stdout) == (0, ""), r.stdout
    assert r.stderr.startswith("0 of ") and int(r.stderr.split()[2]) >= 4  # the three examples and docs/*.sgt
