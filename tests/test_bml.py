"""BML out and in, SSML in (dsl/bml.py, dsl/ssml.py, dsl/xmlread.py; sgt export --format bml,
sgt import, sgt serve's 'ssml'): run as users run them, the files checked on disk."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from dsl.compiler import load_script

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = """\
@voice en-us
guide: [pose:wave] Hello, and welcome! <happy>I can help you find anything.</>
visitor: [look:guide hold=800ms] Where is [pose:point_right x2 flip] the <face:surprised>cinema</face>?
guide: [look:left] Look at the shelf [pose:point_right hold=500ms] <face:smile>over there</face>, on your right [pose:nod]
"""


def sgt(*args, cwd=None, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *map(str, args)], check=False, capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=timeout)


def marks(path) -> list:
    """Every mark of a script: (utterance, speaker, kind, name, options, the word it stands before)."""
    script, _, diags = load_script(path)
    assert not [d for d in diags if d.is_error], diags
    out = []
    for u in script.utterances:
        for m in u.poses:
            out.append((u.index, u.speaker, "pose", m.name, tuple(sorted(m.options.items())), m.word_index, m.after_word))
        for m in u.looks:
            out.append((u.index, u.speaker, "look", m.target, m.hold, m.word_index, m.after_word))
        for s in u.styles:
            if s.face is not None:
                out.append((u.index, u.speaker, "face", s.face, s.first_word, s.last_word))
    return sorted(out, key=repr)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bml")
    (folder / "take.sgt").write_text(SCRIPT)
    r = sgt("export", "take.sgt", "-o", "take.bml", cwd=folder)
    assert r.returncode == 0, r.stderr
    return folder, r.stderr


def test_bml_round_trip_keeps_every_mark(exported):
    folder, stderr = exported
    # <happy>'s style: said, not dropped silently
    assert "3 BML blocks" in stderr and "left out: 1 style span (BML has no element for it)" in stderr
    r = sgt("import", "take.bml", "-o", "back.sgt", cwd=folder)
    assert r.returncode == 0, r.stderr
    assert marks(folder / "back.sgt") == marks(folder / "take.sgt")
    assert sgt("check", "back.sgt", cwd=folder).returncode == 0


def test_bml_is_valid_against_the_schema_and_the_rules(exported):
    etree = pytest.importorskip("lxml.etree")
    folder, _ = exported
    schema = etree.XMLSchema(etree.parse(str(ROOT / "dsl" / "bml_sgt.xsd")))
    doc = etree.parse(str(folder / "take.bml"))
    assert schema.validate(doc), schema.error_log
    from dsl.bml import check_bml
    from dsl.xmlread import parse_xml

    assert check_bml(parse_xml((folder / "take.bml").read_bytes())) == []
    bml = doc.getroot()[1]
    gesture = bml.find("{http://www.bml-initiative.org/bml/bml-1.0}gesture")
    assert gesture.get("lexeme") == "deictic=point_right" and gesture.get("stroke") == "s1:tm2"
    assert gesture.get("{urn:sgt:bml}speed") == "2" and gesture.get("{urn:sgt:bml}flip") == "true"
    start, end = float(gesture.get("start")), float(gesture.get("end"))
    assert 0 <= start < end


def test_the_rules_catch_a_broken_block():
    from dsl.bml import check_bml
    from dsl.xmlread import parse_xml

    broken = parse_xml('<bml xmlns="http://www.bml-initiative.org/bml/bml-1.0" id="b">\n<speech id="s0"><text>'
                       '<sync id="a"/>hi <sync id="b"/>there</text></speech>\n'
                       '<gesture id="g" lexeme="beat=beat_right" start="s0:b" stroke="s0:a"/>\n'
                       '<gesture id="g" start="s0:zz"/>\n<gaze id="z" start="-1"/></bml>')
    found = [(p.line, p.message) for p in check_bml(broken)]
    assert (3, "<gesture> start comes after its stroke") in found
    assert (4, "<gesture> without an id, or with one used before") in found
    assert (4, "<gesture> without lexeme") in found
    assert (4, "start='s0:zz' names no sync point of this block's speech") in found
    assert (5, "start='-1' is neither a sync reference nor seconds") in found
    assert (5, "<gaze> without target") in found


SSML = """\
<speak version="1.1" xmlns="http://www.w3.org/2001/10/synthesis">
  <mark name="wave"/>Hello! <break time="300ms"/> The <prosody rate="slow">cinema</prosody> is
  <mark name="there"/> over there, <mark name="look:left"/>past the <mark name="pose:count_two x2"/> two shops.
</speak>
"""


def test_ssml_with_marks_becomes_a_script_that_check_passes(tmp_path):
    (tmp_path / "a.ssml").write_text(SSML)
    (tmp_path / "map.toml").write_text('there = "pose:point_right flip"\n')
    r = sgt("import", "a.ssml", "--map", "map.toml", "--speaker", "guide", "-o", "a.sgt", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines()[0] == ("a.ssml:2:55: warning: <prosody> is not kept, its text is "
                                        "(sgt's @voice, @rate and @pitch set the voice)")
    text = (tmp_path / "a.sgt").read_text()
    assert text == ("guide: [pose:wave] Hello! [pause 300ms] The cinema is [pose:point_right flip] over there, "
                    "[look:left] past the [pose:count_two x2] two shops.\n")
    assert sgt("check", "a.sgt", cwd=tmp_path).returncode == 0


def test_what_cannot_be_mapped_is_reported_by_line_and_nothing_is_written(tmp_path):
    (tmp_path / "a.ssml").write_text('<speak>\n  Hi <mark name="salute"/>\n  there <foo/> <break time="2 weeks"/>\n</speak>\n')
    r = sgt("import", "a.ssml", "-o", "a.sgt", cwd=tmp_path)
    assert r.returncode == 1 and not (tmp_path / "a.sgt").exists()
    lines = r.stderr.splitlines()
    assert lines[0].startswith("a.ssml:2:6: error: <mark name='salute'> names no sgt gesture")
    assert lines[1].startswith("a.ssml:3:9: error: <foo> is not SSML that sgt reads")
    assert lines[2] == "a.ssml:3:16: error: <break time='2 weeks'>: write a time as 300ms or 1.2s"
    (tmp_path / "b.bml").write_text('<bml xmlns="http://www.bml-initiative.org/bml/bml-1.0" id="x">\n'
                                    '<speech id="s"><text><sync id="t"/>Yes.</text></speech>\n'
                                    '<gesture id="g" lexeme="BEAT=unknown_thing" stroke="s:t"/>\n'
                                    '<head id="h" lexeme="NOD" start="1.5"/>\n<faceLexeme id="f" lexeme="BLUSH" start="s:t" end="s:t"/>\n'
                                    '<pointing id="p" target="x"/></bml>\n')
    r = sgt("import", "b.bml", "-o", "b.sgt", cwd=tmp_path)
    assert r.returncode == 1 and not (tmp_path / "b.sgt").exists()
    assert [line.split(": error: ")[0] for line in r.stderr.splitlines()[:4]] == ["b.bml:3:1", "b.bml:4:1", "b.bml:5:1", "b.bml:6:1"]
    assert "lexeme 'BEAT=unknown_thing' names no sgt gesture" in r.stderr
    assert "start='1.5' is no sync point" in r.stderr


HOSTILE = {
    "xxe": '<?xml version="1.0"?>\n<!DOCTYPE speak [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n<speak>&x;</speak>\n',
    "laughs": '<?xml version="1.0"?>\n<!DOCTYPE l [<!ENTITY a "aaaaaaaaaa">' + "".join(
        f'<!ENTITY {chr(98 + i)} "' + f"&{chr(97 + i)};" * 10 + '">' for i in range(8)) + ']>\n<speak>&i;</speak>\n',
    "external": '<!DOCTYPE speak SYSTEM "http://127.0.0.1:9/x.dtd">\n<speak>hi</speak>\n',
    "broken": "<speak>\n  hi <mark name='wave'>\n</speak>\n",
}


@pytest.mark.parametrize("kind", sorted(HOSTILE))
def test_hostile_xml_is_one_line_and_reads_nothing(tmp_path, kind):
    from test_hostile_files import PEAK_MIB
    from test_hostile_files import sgt as measured  # its peak memory its own, not the suite's children's

    (tmp_path / "h.ssml").write_text(HOSTILE[kind])
    r = measured("import", "h.ssml", "-o", "h.sgt", cwd=tmp_path, timeout=60)
    assert r.rc == 1 and not (tmp_path / "h.sgt").exists()
    assert len(r.err.splitlines()) == 1, r.err
    assert "Traceback" not in r.err and "root:" not in r.err  # nothing of /etc/passwd
    line = r.err.strip()
    if kind == "broken":
        assert line == "sgt import: error: h.ssml:3:3: not well-formed XML: mismatched tag"
    else:
        assert line.startswith("sgt import: error: h.ssml:") and ("document type" in line)
    assert 0 < r.peak_mib < PEAK_MIB


def test_export_bml_refuses_a_motion_file(tmp_path):
    (tmp_path / "m.json").write_text("{}")
    r = sgt("export", "m.json", "-o", "m.bml", cwd=tmp_path)
    assert r.returncode == 2 and "BML is written from a script (.sgt)" in r.stderr


def test_serve_takes_ssml(tmp_path):
    from fastapi.testclient import TestClient

    from sgt_tui.serve.app import create_app
    from sgt_tui.serve.config import ServeConfig, checked

    with TestClient(create_app(checked(ServeConfig())), raise_server_exceptions=False) as api:
        body = {"ssml": '<speak><mark name="wave"/>Hello <break time="200ms"/> there.</speak>', "speaker": "robot",
                "timing": "estimate", "engine": "keyframe"}
        answer = api.post("/v1/generate", json=body)
        assert answer.status_code == 200, answer.text
        u = answer.json()["motion"]["utterances"][0]
        assert u["speaker"] == "robot" and u["text"] == "Hello there."
        assert sorted(c["kind"] for c in u["controls"]) == ["pause", "pose"]
        bad = api.post("/v1/generate", json={"ssml": HOSTILE["xxe"], "timing": "estimate"})
        assert bad.status_code == 422 and "ssml:2:" in bad.json()["error"] and "document type" in bad.json()["error"]
        unknown = api.post("/v1/generate", json={"ssml": '<speak>Hi <mark name="salute"/></speak>', "timing": "estimate"})
        assert unknown.status_code == 422 and "ssml:1:11: error: <mark name='salute'>" in unknown.json()["error"]
