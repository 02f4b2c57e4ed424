"""sgt align (issue 27): the aligner's word times of a script's recordings, written as timings
files whatever the check's verdict, so that a user whose correct transcript is rejected has a
way forward that is not hand-writing the file: review the times, name them with timings=."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest
import soundfile as sf

from dsl.speech import _espeak, synthesize
from dsl.speech.recording import load_recording, parse_json_timings, parse_textgrid
from sgt_tui.cli import main

pytestmark = pytest.mark.skipif(_espeak.find_library() is None, reason="libespeak-ng not installed")

SAID = "Well, hello there my friend. How are you today?"
WRONG = "Well, hello there my dear friend. How are you today?"  # 'dear' is not in the recording


def spans_of(text: str) -> list[tuple[int, int]]:
    return [m.span() for m in re.finditer(r"[\w']+", text)]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """SAID spoken by espeak-ng with 0.3 s of faint noise around it, as a recording."""
    folder = tmp_path_factory.mktemp("align")
    s = synthesize(SAID, spans_of(SAID), cache_dir=folder / "syn")
    x, sr = sf.read(str(s.audio_path))
    pad = np.zeros(int(0.3 * sr))
    y = np.concatenate([pad, x, pad])
    y = y + np.random.default_rng(0).normal(0, 1e-3 * np.abs(x).max(), len(y))
    sf.write(str(folder / "rec.wav"), y, sr)
    return folder / "rec.wav"


def script(tmp_path, recording, text, timings=None):
    (tmp_path / "rec.wav").write_bytes(recording.read_bytes())
    directive = "@audio rec.wav" + (f" timings={timings}" if timings else "")
    path = tmp_path / "talk.sgt"
    path.write_text(f"{directive}\nbot: {text}\n")
    return path


def test_a_rejected_transcript_gets_its_times_written_and_they_then_pass(tmp_path, recording, capsys):
    path = script(tmp_path, recording, WRONG)
    assert main(["check", str(path)]) == 1
    said = capsys.readouterr()
    err = said.out + said.err
    assert "SGT407" in err and "'sgt align' writes" in err  # the error points the way
    assert main(["align", str(path)]) == 0
    out = capsys.readouterr().out
    written = tmp_path / "rec.timings.json"
    assert "REJECTS" in out and "'dear'" in out and "@audio rec.wav timings=rec.timings.json" in out
    words = [w for w, _, _ in parse_json_timings(written)]
    assert words == re.findall(r"[\w']+", WRONG)
    # the way forward: the file named on the directive, and the script checks and compiles
    path.write_text(f"@audio rec.wav timings=rec.timings.json\nbot: {WRONG}\n")
    assert main(["check", str(path)]) == 0
    timed = parse_json_timings(written)
    speech = load_recording(tmp_path / "rec.wav", WRONG, spans_of(WRONG), timings_path=written, cache_dir=tmp_path / "c")
    assert [round(w.start, 4) for w in speech.words] == [a for _, a, _ in timed]


def test_an_accepted_transcript_gets_the_aligners_times_as_a_textgrid(tmp_path, recording, capsys):
    path = script(tmp_path, recording, SAID)
    out_dir = tmp_path / "times"
    assert main(["align", str(path), "--format", "textgrid", "-o", str(out_dir)]) == 0
    assert "the check accepts this transcript" in capsys.readouterr().out
    grid = out_dir / "rec.TextGrid"
    timed = parse_textgrid(grid)
    aligned = load_recording(tmp_path / "rec.wav", SAID, spans_of(SAID), cache_dir=tmp_path / "c").words
    assert [w for w, _, _ in timed] == [w.word for w in aligned]
    assert np.allclose([a for _, a, _ in timed], [w.start for w in aligned], atol=1e-4)
    # a TextGrid Praat opens: one interval tier whose intervals tile [0, xmax], none empty
    text = grid.read_text()
    bounds = [float(v) for v in re.findall(r"^ {12}xm(?:in|ax) = (\S+)", text, re.M)]
    starts, ends = bounds[0::2], bounds[1::2]
    assert starts[0] == 0 and all(a == b for a, b in zip(ends, starts[1:])) and all(b > a for a, b in zip(starts, ends))
    assert ends[-1] == pytest.approx(float(re.search(r"^xmax = (\S+)", text, re.M).group(1)))
    assert ends[-1] == pytest.approx(sf.info(str(tmp_path / "rec.wav")).duration, abs=1e-3)


def test_a_timings_file_that_exists_is_kept_without_force(tmp_path, recording, capsys):
    path = script(tmp_path, recording, SAID)
    mine = tmp_path / "rec.timings.json"
    mine.write_text('[{"word": "corrected", "start": 0, "end": 1}]')
    assert main(["align", str(path)]) == 2
    assert "exists" in capsys.readouterr().err and "corrected" in mine.read_text()
    assert main(["align", str(path), "--force"]) == 0
    assert json.loads(mine.read_text())[0]["word"] == "Well"


def test_recordings_with_timings_are_skipped_and_a_script_without_any_says_so(tmp_path, recording, capsys):
    (tmp_path / "given.json").write_text(json.dumps([{"word": w, "start": i, "end": i + 0.5}
                                                      for i, w in enumerate(re.findall(r"[\w']+", SAID))]))
    path = script(tmp_path, recording, SAID, timings="given.json")
    assert main(["align", str(path)]) == 0
    assert "skipped" in capsys.readouterr().err and not (tmp_path / "rec.timings.json").exists()
    assert main(["align", str(path), "--utterance", "1"]) == 2  # the first: timed already, nothing to align
    assert "no utterance of 1 is spoken from a recording without timings=" in capsys.readouterr().err
    spoken = tmp_path / "tts.sgt"
    spoken.write_text("bot: Hello there.\n")
    assert main(["align", str(spoken)]) == 0
    assert "no recording" in capsys.readouterr().err


def test_a_script_with_syntax_errors_is_not_aligned(tmp_path, recording, capsys):
    path = script(tmp_path, recording, SAID + " [pose:")
    assert main(["align", str(path)]) == 1
    assert "fix these first" in capsys.readouterr().err and not (tmp_path / "rec.timings.json").exists()


PRAAT_SCRIPT = """form Read
    sentence path
endform
Read from file: path$
n = Get number of intervals: 1
name$ = Get tier name: 1
writeInfoLine: name$
for i to n
    label$ = Get label of interval: 1, i
    a = Get start time of interval: 1, i
    b = Get end time of interval: 1, i
    appendInfoLine: fixed$(a, 4), tab$, fixed$(b, 4), tab$, label$
endfor
"""


@pytest.mark.skipif(shutil.which("praat") is None, reason="praat is not installed (apt-get install praat)")
def test_praat_reads_the_textgrid_as_written(tmp_path, recording, capsys):
    """Praat itself (the program users review timings in) opens the TextGrid: one tier named
    words, the same words at the same times as sgt reads back, silences between them."""
    path = script(tmp_path, recording, WRONG)
    assert main(["align", str(path), "--format", "textgrid"]) == 0
    (tmp_path / "read.praat").write_text(PRAAT_SCRIPT)
    run = subprocess.run(["praat", "--run", str(tmp_path / "read.praat"), str(tmp_path / "rec.TextGrid")],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "words"
    rows = [line.split("\t") for line in lines[1:]]
    said = [(label, float(a), float(b)) for a, b, label in rows if label]
    ours = parse_textgrid(tmp_path / "rec.TextGrid")
    assert [w for w, _, _ in said] == [w for w, _, _ in ours] == re.findall(r"[\w']+", WRONG)
    assert np.allclose([a for _, a, _ in said], [a for _, a, _ in ours], atol=1e-4)
    assert float(rows[0][0]) == 0 and all(float(r[1]) == float(s[0]) for r, s in zip(rows, rows[1:]))
