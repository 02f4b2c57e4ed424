"""Grammar and analyser: what each construct of the language turns into."""

from dsl.parser import analyse, parse_duration
from dsl.presets import BUILTIN_PRESETS

NAMES = ["open_arms", "point_right", "point_left", "wave", "nod"]


def ok(src, **kw):
    s = analyse(src, "t.sgt", gesture_names=NAMES, **kw)
    errors = [d for d in s.diagnostics if d.is_error]
    assert not errors, errors
    return s


def test_issue_example_parses_into_words_poses_and_styles():
    s = ok("guide: Welcome! [pose:open_arms] Look at the shelf [pose:point_right x2] <speed:-1>over there</speed>.\n")
    (u,) = s.utterances
    assert u.speaker == "guide"
    assert [w.text for w in u.words] == ["Welcome", "Look", "at", "the", "shelf", "over", "there"]
    assert u.display == "Welcome! Look at the shelf over there."
    a, b = u.poses
    assert (a.name, a.speed, a.word_index) == ("open_arms", 1, 1)  # anchored to "Look"
    assert (b.name, b.speed, b.word_index) == ("point_right", 2, 5)  # anchored to "over"
    (st,) = u.styles
    assert st.values == {"speed": -1.0} and (st.first_word, st.last_word) == (5, 6)


def test_word_offsets_point_into_spoken_text():
    s = ok("Hello [pose:wave] big <speed:1>world</>!\n")
    u = s.utterances[0]
    for w in u.words:
        assert u.text[w.start : w.end] == w.text
    assert "[" not in u.text and "<" not in u.text


def test_speaker_prefix_is_optional_and_columns_are_exact():
    s = ok("no speaker here\nbob:  hi [pose:nod] there\n")
    assert s.utterances[0].speaker is None
    u = s.utterances[1]
    assert u.speaker == "bob"
    assert (u.poses[0].where.line, u.poses[0].where.col) == (2, 10)
    assert (u.words[0].where.line, u.words[0].where.col) == (2, 7)


def test_continuation_lines_comments_blank_lines_and_crlf():
    src = "# header comment\r\n\r\nguide: first part # a comment\r\n    second [pose:nod] part\r\n\r\nnext: one\r\n"
    s = ok(src)
    assert len(s.utterances) == 2
    u = s.utterances[0]
    assert [w.text for w in u.words] == ["first", "part", "second", "part"]
    assert (u.poses[0].where.line, u.poses[0].where.col) == (4, 12)
    assert u.words[2].where.line == 4


def test_pose_options_flip_hold_and_anchor_to_previous_word_at_end():
    s = ok("Look there [pose:point_left x3 flip hold=1.5s]\n")
    (p,) = s.utterances[0].poses
    assert (p.speed, p.flip, p.hold) == (3, True, 1.5)
    assert p.word_index is None and p.after_word == 1


def test_style_presets_nesting_and_open_span_to_end():
    s = ok("a <happy>b <speed:-1>c</speed> d <space:0.5>e f\n")
    u = s.utterances[0]
    happy, inner, open_span = u.styles
    assert happy.values == BUILTIN_PRESETS["happy"]
    assert inner.values == {**BUILTIN_PRESETS["happy"], "speed": -1.0}  # inner wins, the rest inherited
    assert (inner.first_word, inner.last_word) == (2, 2)
    assert open_span.last_word == 5  # left open: lasts to the end of the utterance
    assert happy.last_word == 5


def test_close_with_bare_tag_and_multi_values():
    s = ok("x <speed:+1 space:-0.5 handedness:2>y z</> w\n")
    (st,) = s.utterances[0].styles
    assert st.values == {"speed": 1.0, "space": -0.5, "handedness": 2.0}
    assert (st.first_word, st.last_word) == (1, 2)


def test_pauses_and_durations():
    s = ok("one [pause 300ms] two [pause 1.2s]\n")
    p1, p2 = s.utterances[0].pauses
    assert (p1.seconds, p1.word_index) == (0.3, 1)
    assert (p2.seconds, p2.word_index) == (1.2, 2)
    assert parse_duration("2s") == 2.0 and parse_duration("5") is None and parse_duration("1.5m") is None


def test_escapes_give_literal_characters():
    s = ok("a \\[b\\] \\<c\\> \\\\ \\# \\: d\n")
    u = s.utterances[0]
    assert u.display == "a [b] <c> \\ # : d"
    assert not u.poses and not u.styles


def test_header_directives():
    src = (
        "@voice en-gb\n@voice bot: en-us+m3\n@rate 140\n@rate bot: 200\n@pitch 40\n@seed 9\n"
        "@preset shy = space:-2 handedness:-1\n"
        "bot: hi <shy>there</>\nme: hello\n"
    )
    s = ok(src)
    h = s.header
    assert h.seed == 9 and h.presets == {"shy": {"space": -2.0, "handedness": -1.0}}
    bot, me = s.utterances
    assert (bot.voice.name, bot.voice.rate, bot.voice.pitch) == ("en-us+m3", 200, 40)
    assert (me.voice.name, me.voice.rate, me.voice.pitch) == ("en-gb", 140, 40)
    assert bot.styles[0].values == {"space": -2.0, "handedness": -1.0}


def test_library_and_audio_directives_resolve_relative_to_script(tmp_path):
    (tmp_path / "moves").mkdir()
    (tmp_path / "a.wav").write_bytes(b"RIFF")
    (tmp_path / "a.json").write_text("[]")
    src = "@library moves\n@audio a.wav timings=a.json\nhi there\nno audio here\n"
    s = analyse(src, str(tmp_path / "s.sgt"), gesture_names=NAMES)
    assert not s.diagnostics
    assert s.header.library_dirs == [tmp_path / "moves"]
    first, second = s.utterances
    assert first.audio.path == tmp_path / "a.wav" and first.audio.timings == tmp_path / "a.json"
    assert second.audio is None


def test_gesture_names_can_depend_on_the_header():
    seen = {}

    def names(header):
        seen["dirs"] = list(header.library_dirs)
        return ["custom"]

    s = analyse("x [pose:custom] y\n", "t.sgt", gesture_names=names)
    assert not s.diagnostics and seen == {"dirs": []}


def test_empty_and_comment_only_files():
    assert analyse("", "t.sgt").utterances == []
    s = analyse("# nothing\n\n   \n", "t.sgt")
    assert s.utterances == [] and not s.diagnostics
