"""The regular-expression scanner (dsl.scan) against Lark with the grammar (dsl/sgt.lark).

Whatever the scanner accepts, Lark must accept with the very same items; what it rejects
goes to Lark anyway, so rejecting is always safe (but it should be rare for valid input).
"""

from hypothesis import given, settings
from hypothesis import strategies as st
from lark.exceptions import UnexpectedInput

from dsl.body import lark_parser
from dsl.scan import scan_body, scan_items

PIECES = [
    "[", "]", "<", ">", "</", "</>", "\\", "#", ":", "=", " ", "\t", "\n", "\r", "\x0b", "\xa0", "pose", "pause",
    "wave", "x2", "flip", "hold", "5ms", "-1", "+0.5", ".", "+", "-", "_", "a", "Z", "9", "speed", "space", "happy",
    "é", "don't", "/", "'", "1.5s", "ab-c", "a.b", "[pose:", "[pause ", "<speed:", "</speed>", "hold=",
    "[look:", "José", "Σωκράτης", "<face:", "smile", "\u0301", "٣", "_x",
]
VALID = [
    "Hello [pose:wave] there.", "[pose:point_right x2 flip hold=500ms] <speed:-1 space:+0.5>over</speed> </>",
    "[ pose : wave\n x2 ]", "[pose:wave.5]", "[pose:wave hold = 1s]", "<calm speed:-2>a</calm>", "<a b:1>x</a>",
    "it \\[laughs\\] \\: \\\\ \\q", "[pause 300ms] [pause\t1.2s]", "</ >", "[pose]", "<happy>[pose:big] yes</>",
    "[look:José] hola [look:left hold=1s]", "<face:smile happy>x</face>", "[look:Σωκράτης]",
]
body_text = st.lists(st.one_of(st.sampled_from(PIECES), st.text(max_size=4)), max_size=16).map("".join)


def _lark_items(body):
    try:
        return lark_parser().parse(body)
    except UnexpectedInput:
        return None


def _check(body):
    items = scan_body(body)
    if items is not None:
        assert _lark_items(body) == items, body
    return items


def test_valid_bodies_take_the_fast_path():
    for body in VALID:
        assert _check(body) is not None, body
        assert _lark_items(body) is not None


@settings(max_examples=3000, deadline=None)
@given(body=body_text)
def test_scanner_agrees_with_lark(body):
    _check(body)


@settings(max_examples=1000, deadline=None)
@given(body=body_text)
def test_what_lark_accepts_the_scanner_accepts(body):
    if _lark_items(body) is not None:
        assert scan_body(body) is not None, body


@settings(max_examples=1000, deadline=None)
@given(body=body_text)
def test_the_scanner_stops_where_the_grammar_fails(body):
    # The analyser reports syntax errors where scan_items stops: the prefix before it is
    # well-formed (Lark gives the same items) and the body, cut just after, is not.
    items, stop = scan_items(body)
    if stop is None:
        assert _lark_items(body) == items
        return
    assert body[stop] in "[]<>\\#"  # '#' only here: the line splitter strips comments before
    assert body[stop] != "\\" or stop == len(body) - 1  # an escape fails only at the very end
    assert _lark_items(body[:stop]) == items
    assert _lark_items(body) is None
