"""`sgt fmt` (dsl/fmt.py): one canonical layout, idempotent, and never a change to what is
spoken or gestured.

Every example and 300 generated scripts (random spacing inside and around tags, options in
any order, directives in every accepted form, comments, escapes, continuation lines, CRLF)
are compiled before and after formatting (estimated timing): the plans, less the line and
column numbers, are equal, the spoken text is equal up to whitespace, the diagnostics are
the same rules, and a second formatting changes nothing.
"""

from __future__ import annotations

import random
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

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
        "# header\n@voice en-us  # default\n@voice knight:   en-gb+m3\n@voice merchant: en-us+f2\n"
        "@rate merchant: 175\n@preset shy  = space:-2 handedness:-1\n@preset bold = speed:+2\n\n"
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
