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


# -- speakers, words and marks (issue 13: decided, documented in docs/language.md) --------------


def _names(s):
    return [(d.name, d.line, d.col) for d in s.diagnostics]


def test_a_speaker_is_one_word_of_any_alphabet():
    s = analyse("José: hola\nΣωκράτης: γεια\n_bot-2: hi\n", "t.sgt")
    assert [u.speaker for u in s.utterances] == ["José", "Σωκράτης", "_bot-2"]
    assert [w.text for w in s.utterances[0].words] == ["hola"] and not s.diagnostics


def test_lines_that_look_like_a_speaker_are_spoken_with_a_warning():
    s = analyse("mall guide: Hello\ng:hello\nmall guide\\: Hello\ng\\:hello\nhttps://example.com now\n", "t.sgt")
    assert _names(s) == [("speaker-space", 1, 1), ("speaker-colon", 2, 1)]
    first, second, escaped, escaped2, _url = s.utterances
    assert first.speaker is None and [w.text for w in first.words] == ["mall", "guide", "Hello"]
    assert second.speaker is None and [w.text for w in second.words] == ["g", "hello"]
    assert escaped.speaker is None and escaped2.speaker is None  # an escaped colon: text, no warning
    fix = s.diagnostics[0].fixes[0]
    assert fix.edits[0].text == "mall_guide" and analyse("mall_guide: Hello\n").utterances[0].speaker == "mall_guide"


def test_a_tag_inside_a_word_splits_it_in_speech_and_display_alike():
    s = analyse("guide: Lo[pose:nod]ok here\n", "t.sgt", gesture_names=NAMES)
    (u,) = s.utterances
    assert [w.text for w in u.words] == ["Lo", "ok", "here"]
    assert u.display == "Lo ok here"  # the plan shows what is spoken
    (d,) = s.diagnostics
    assert (d.name, d.severity, d.col) == ("mark-in-word", "warning", 10) and "'Lo' and 'ok'" in d.message
    (fix,) = d.fixes  # move the pose control before the word
    assert [(e.col, e.length, e.text) for e in fix.edits] == [(8, 0, "[pose:nod]"), (10, 10, "")]
    assert analyse("guide: [pose:nod]Look here\n", "t.sgt", gesture_names=NAMES).utterances[0].display == "Look here"
    glued = analyse("a Lo[pose:nod][pause 1s]ok b\n", "t.sgt", gesture_names=NAMES)
    assert _names(glued) == [("mark-in-word", 1, 5)]  # a run of marks: one warning


def test_duplicates_warn_and_the_last_one_wins():
    s = analyse("@seed 1\n@seed 2\n@rate 100\n@rate 200\n@voice bot: en-us\n@voice bot: en-gb\n"
                "@preset p = speed:1\n@preset p = space:2\n"
                "bot: <speed:1 speed:-2>a</> [pose:wave x2 x3 flip flip hold=1s hold=2s] b\n", "t.sgt", gesture_names=NAMES)
    assert all(d.name == "duplicate" and d.severity == "warning" for d in s.diagnostics)
    assert len(s.diagnostics) == 8  # seed, rate, voice, preset, speed item, x2/x3, flip, hold
    assert s.header.seed == 2 and s.header.voice.rate == 200 and s.header.presets == {"p": {"space": 2.0}}
    (u,) = s.utterances
    assert u.voice.name == "en-gb"
    assert u.styles[0].values == {"speed": -2.0}
    (p,) = u.poses
    assert (p.speed, p.flip, p.hold) == (3, True, 2.0)
    seed = s.diagnostics[0]
    assert (seed.line, seed.related[0].line) == (2, 1)  # the note points at the earlier one


def test_a_mismatched_closing_tag_is_one_error():
    s = analyse("a <speed:1><space:1>x</speed> y </space> z\n", "t.sgt")
    assert _names(s) == [("mismatched-close", 1, 22)]
    _speed, space = s.utterances[0].styles
    assert [w.text for w in s.utterances[0].words][space.first_word : space.last_word + 1] == ["x", "y"]
    s = analyse("a <speed:1>x</space> y </speed> z\n", "t.sgt")
    assert _names(s) == [("mismatched-close", 1, 13)]  # closes nothing: </speed> still matches


def test_a_broken_preset_is_reported_once_not_at_its_uses():
    s = analyse("@preset Loud = speed:2\n@preset soft = sped:-1\n@preset quiet\n"
                "a <Loud>b</Loud> <soft>c</soft> <quiet>d</quiet> <nope>e</nope>\n", "t.sgt")
    assert _names(s) == [("bad-name", 1, 9), ("unknown-style", 2, 16), ("missing-value", 3, 9), ("unknown-style", 4, 51)]


def test_syntax_errors_are_found_by_the_scanner_at_the_grammar_s_failure_point():
    s = analyse("a [pose:wave b <speed:1> c\nx [pose:wave, x2] y <> z </sp eed> w\n", "t.sgt", gesture_names=NAMES)
    assert _names(s) == [("unclosed", 1, 3), ("bad-tag", 2, 3), ("bad-tag", 2, 21), ("bad-tag", 2, 26)]
    assert [w.text for w in s.utterances[1].words] == ["x", "y", "z", "w"]
