"""Nothing a user types may produce a Python traceback: only diagnostics come out.

Hypothesis feeds random text built from the language's own pieces, and mutations (deleted,
duplicated, swapped and inserted characters) of the shipped examples, through the whole
static front end, the compiler with estimated timing, and the `sgt check` and
`sgt compile --estimate` commands (exit status 0 or 1, JSON diagnostics, a plan only when clean).
"""

import contextlib
import io
import json
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.diagnostics import Diagnostic
from dsl.compiler import compile_file
from dsl.parser import analyse
from sgt_tui import cli

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = [p.read_text(encoding="utf-8") for p in sorted((ROOT / "examples").glob("*.sgt"))]

PIECES = [
    "[", "]", "<", ">", "</", "</>", "\\", "#", ":", "=", "@", "\n", "\n  ", "\r\n", " ", "\t",
    "[pose:", "[pose:wave", "[pose:point_right x2]", "[pose:open_arms flip hold=1s]", "[pause 300ms]",
    "[pause", "<speed:-1>", "<speed:9>", "<happy>", "</speed>", "<space:+0.5 handedness:1>", "hold=", "x3",
    "guide: ", "@voice en-us\n", "@preset p = speed:1\n", "@seed 3\n", "@rate 999\n", "@library ..\n",
    "@audio x.wav\n", "hello", "world", "é", "日本", "🙂", "\x00", "\ufeff", "1999", "don't", "-", "+", ".",
]

script_text = st.lists(st.one_of(st.sampled_from(PIECES), st.text(max_size=6)), max_size=40).map("".join)


def _mutate(data: st.DataObject, text: str) -> str:
    chars = list(text)
    for _ in range(data.draw(st.integers(1, 8))):
        if not chars:
            chars = list(data.draw(st.sampled_from(PIECES)))
        op = data.draw(st.sampled_from(["delete", "insert", "duplicate", "swap"]))
        i = data.draw(st.integers(0, len(chars) - 1))
        if op == "delete":
            del chars[i]
        elif op == "insert":
            chars[i:i] = list(data.draw(st.sampled_from(PIECES)))
        elif op == "duplicate":
            j = data.draw(st.integers(i, min(len(chars), i + 30)))
            chars[i:i] = chars[i:j]
        else:
            j = data.draw(st.integers(0, len(chars) - 1))
            chars[i], chars[j] = chars[j], chars[i]
    return "".join(chars)


def _only_diagnostics(text: str, tmp: Path) -> None:
    script = analyse(text, "fuzz.sgt", gesture_names=["wave", "point_right", "open_arms"], base_dir=tmp)
    assert all(isinstance(d, Diagnostic) for d in script.diagnostics)
    for d in script.diagnostics:
        assert d.line >= 0 and d.col >= 0 and d.message
    path = tmp / "fuzz.sgt"
    path.write_bytes(text.encode("utf-8", errors="surrogatepass"))
    result = compile_file(path, timing="estimate")
    assert all(isinstance(d, Diagnostic) for d in result.diagnostics)
    if result.plan is not None:
        for u in result.plan.utterances:
            assert u.arrays.pose.shape == (u.n_frames, 27)
            for c in u.controls:
                assert 0 <= c.start_frame <= c.end_frame <= u.n_frames
            _no_bone_played_twice(u)  # overlaps are resolved per bone (a nod layers on a point)
    _commands(path, tmp, result)


def _no_bone_played_twice(u) -> None:
    """No two pose controls of a planned utterance drive one bone on one frame."""
    owner = np.full((u.n_frames, 9), -1)
    for i, p in enumerate(u.requests.poses):
        lengths = p.lengths()[0]
        taken = p.approach[1] if p.approach is not None else np.zeros(9, bool)
        for b in np.flatnonzero(np.asarray(p.clip().bones, bool)):
            first = p.approach[0] if taken[b] else p.start
            frames = slice(max(0, first), max(0, min(u.n_frames, p.start + lengths[b])))
            assert (owner[frames, b] == -1).all(), (p.mark.name, b, owner[frames, b])
            owner[frames, b] = i


def _commands(path: Path, tmp: Path, result) -> None:
    """`sgt compile --estimate` and `sgt check`: diagnostics and an exit status, never a traceback."""
    plan = tmp / "plan.json"
    plan.unlink(missing_ok=True)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["compile", str(path), "--estimate", "--format", "json", "-o", str(plan)])
        check = cli.main(["check", str(path)])
    assert code == check == (0 if result.ok else 1), err.getvalue()
    data, _ = json.JSONDecoder().raw_decode(out.getvalue())
    assert data["errors"] == sum(d.is_error for d in result.diagnostics)
    assert plan.exists() == (code == 0)
    if code == 0:
        assert len(json.loads(plan.read_text(encoding="utf-8"))["utterances"]) == len(result.plan.utterances)
    assert "Traceback" not in err.getvalue()


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=script_text)
def test_random_scripts_only_give_diagnostics(text, tmp_path):
    _only_diagnostics(text, tmp_path)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_examples_only_give_diagnostics(data, tmp_path):
    text = _mutate(data, data.draw(st.sampled_from(EXAMPLES)))
    _only_diagnostics(text, tmp_path)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(raw=st.binary(max_size=200))
def test_arbitrary_bytes_only_give_diagnostics(raw, tmp_path):
    path = tmp_path / "bytes.sgt"
    path.write_bytes(raw)
    result = compile_file(path, timing="estimate")
    assert all(isinstance(d, Diagnostic) for d in result.diagnostics)
    _commands(path, tmp_path, result)
