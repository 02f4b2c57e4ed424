"""Jobs of `sgt edit` in the worker subprocess: results, errors as messages, cancel."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest

from core.motion import load_motion
from sgt_tui.editor.jobs import CANCELLED, DONE, FAILED, JobRunner
from sgt_tui.editor.protocol import JobRequest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "examples" / "mall_guide.sgt"


class Events:
    def __init__(self) -> None:
        self.seen = []
        self.finished = threading.Event()

    def __call__(self, job) -> None:
        self.seen.append((job.id, job.state, job.phase))
        if job.finished_state:
            self.finished.set()

    def wait(self, timeout: float = 120.0) -> None:
        assert self.finished.wait(timeout), f"no job finished in {timeout} s: {self.seen[-5:]}"
        self.finished.clear()


@pytest.fixture
def runner(tmp_path):
    events = Events()
    r = JobRunner(events, log_path=tmp_path / "worker.log")
    r.events = events
    yield r
    r.shutdown()


def test_generate_one_utterance_then_reuse_the_warm_worker(runner, tmp_path):
    src = SCRIPT.read_text()
    out = tmp_path / "take.npz"
    job = runner.submit(JobRequest("generate", str(SCRIPT), src, engine="rules", utterances=(1,), out=str(out)), "gen")
    runner.events.wait()
    assert job.state == DONE, job.message
    assert job.result.utterances == (1,) and job.result.motion == str(out)
    clips = load_motion(out)
    assert len(clips) == 1 and clips[0].n_frames == job.result.frames > 15
    assert "shelf" in [w.word for w in clips[0].words]
    pid = runner.worker_pid
    again = runner.submit(JobRequest("generate", str(SCRIPT), src + "\nguide: one more [pose:nod] line",
                                     engine="keyframe", utterances=(4,), out=str(out)), "gen")
    runner.events.wait()
    assert again.state == DONE and runner.worker_pid == pid  # same process: models stay loaded
    assert [p for _, _, p in runner.events.seen if p] and again.fraction == 1.0


def test_errors_come_back_as_messages(runner, tmp_path):
    job = runner.submit(JobRequest("generate", str(SCRIPT), "guide: [pose:nope] hi\n", engine="rules",
                                   out=str(tmp_path / "x.npz")), "gen")
    runner.events.wait()
    assert job.state == FAILED and "error" in job.message and "nope" in job.message
    assert job.diagnostics and job.diagnostics[0].line == 1 and job.diagnostics[0].message == "unknown gesture 'nope'"
    job = runner.submit(JobRequest("generate", str(SCRIPT), "guide: hello\n", engine="neural",
                                   weights=str(tmp_path / "missing.pt"), out=str(tmp_path / "x.npz")), "gen")
    runner.events.wait()
    assert job.state == FAILED and "weights not found" in job.message and "sgt train" in job.message


def test_cancel_kills_the_running_job_and_the_next_one_still_runs(runner, tmp_path):
    long = "\n".join(f"guide: line {i} with [pose:wave] words to say and more words to say." for i in range(40))
    job = runner.submit(JobRequest("generate", str(SCRIPT), long, engine="rules", timing="estimate",
                                   out=str(tmp_path / "long.npz")), "long")
    queued = runner.submit(JobRequest("generate", str(SCRIPT), "guide: hi\n", engine="rules",
                                      out=str(tmp_path / "q.npz")), "queued")
    deadline = time.monotonic() + 60
    while runner.worker_pid is None and time.monotonic() < deadline:
        time.sleep(0.02)
    pid = runner.worker_pid
    assert runner.cancel() is queued and queued.state == CANCELLED  # ctrl+t: the job asked for last
    runner.events.finished.clear()
    runner.cancel(job)
    runner.events.wait(60)
    assert job.state == CANCELLED
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.05)
    else:
        pytest.fail("the cancelled worker is still alive")
    after = runner.submit(JobRequest("generate", str(SCRIPT), "guide: hi there\n", engine="rules",
                                     out=str(tmp_path / "a.npz")), "after")
    runner.events.wait()
    assert after.state == DONE and runner.worker_pid != pid


def test_worker_errors_are_told_apart_by_type_not_by_class_name():
    from model.generate import GenerateError
    from sgt_tui.editor.protocol import Failed, decode_event, encode_event
    from sgt_tui.editor.worker import error_event

    class ValueError(Exception):  # noqa: A001 - named like a user error, but a bug: not one of them
        pass

    assert error_event("1", FileNotFoundError(2, "No such file", "x.wav")).message.startswith("[Errno 2]")
    assert error_event("1", GenerateError("weights not found")).message == "weights not found"
    assert error_event("1", ValueError("boom")).message == "ValueError: boom"
    assert error_event("1", KeyError("k")).message == "KeyError: 'k'"
    from core.diagnostics import Diagnostic, Fix, TextEdit

    d = Diagnostic("error", "unknown gesture 'wavee'", "a.sgt", 1, 8, 5, code="SGT201",
                   fixes=(Fix("replace with 'wave'", (TextEdit(1, 8, 5, "wave"),)),))
    back = decode_event(encode_event(Failed("7", "the script has 1 error", (d,))))
    assert back == Failed("7", "the script has 1 error", (d,))


def test_an_unreadable_answer_fails_its_job_instead_of_leaving_it_running():
    from sgt_tui.editor.protocol import Failed, decode_event

    assert decode_event("not json at all") is None  # not an event: ignored
    assert decode_event('{"something": "else"}') is None
    bad = decode_event('{"event": "error", "id": "3", "diagnostics": [{"message": "no severity"}]}')
    assert isinstance(bad, Failed) and bad.id == "3" and "could not be read" in bad.message
    bad = decode_event('{"event": "done", "id": "4", "result": {"utterances": "many"}}')
    assert isinstance(bad, Failed) and bad.id == "4" and "could not be read" in bad.message


def test_gif_names_count_utterances_from_one_like_the_status_line(tmp_path):
    from sgt_tui.editor.analysis import Analyser
    from sgt_tui.editor.jobs import JobRefused, plan_job

    path = tmp_path / "lobby.sgt"
    text = "guide: one [pose:wave]\nguide: two\nguide: three [pose:nope]\n"
    a = Analyser(path).run(text)
    plan = plan_job("render", a, 1, path=path, source=text, engine="rules", cache=tmp_path / "c")
    assert plan.request.gif == str(tmp_path / "lobby.u2.gif") and plan.request.utterances == (1,)
    assert plan.label == "gif utterance 2 (rules)" and len(plan.keys) == 3
    whole = plan_job("generate", Analyser(path).run(text.replace("nope", "nod")), 0, path=path, source=text,
                     engine="rules", whole=True, cache=tmp_path / "c")
    assert whole.request.utterances is None and whole.request.gif is None
    with pytest.raises(JobRefused, match="utterance 3 has errors"):
        plan_job("render", a, 2, path=path, source=text, engine="rules", cache=tmp_path / "c")
