"""Malformed bodies never make sgt serve fail: random bytes, random JSON, valid requests with
one field broken, odd content types and multipart forms. Every answer is JSON; anything but
200 is a 4xx (or 503/408 for load) with an ``error`` line, never a 500 or a traceback."""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sgt_tui.serve.app import create_app
from sgt_tui.serve.config import ServeConfig, checked

VALID = {"text": "Hello there.", "timing": "estimate", "engine": "keyframe", "seed": 1}
FIELDS = ["script", "text", "speaker", "voice", "rate", "pitch", "style", "seed", "engine", "timing", "utterances", "outputs",
          "words", "extra"]
json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=40),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=10), inner, max_size=4), max_leaves=12)
scripts = st.sampled_from(["guide: hi", "@audio /etc/passwd\nbot: hi", "@library ..\nb: c", "guide: [pose:", "@seed x\na: b",
                           "\x00", "a: b\n" * 50, "<speed:9>x</speed>", "@voice zz\na: b", ""])


@pytest.fixture(scope="module")
def api():
    with TestClient(create_app(checked(ServeConfig(max_body=20_000, max_text=2000))), raise_server_exceptions=False) as c:
        yield c


def answered_well(r) -> None:
    assert r.status_code < 500 or r.status_code == 503, (r.status_code, r.text[:300])
    assert "Traceback" not in r.text and 'File "' not in r.text
    body = r.json()  # always JSON
    if r.status_code != 200:
        assert isinstance(body.get("error"), str) and body["error"]


@settings(max_examples=40, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(raw=st.binary(max_size=300), endpoint=st.sampled_from(["/v1/generate", "/v1/check", "/v1/generate/upload"]),
       content_type=st.sampled_from(["application/json", "text/plain", "multipart/form-data; boundary=x",
                                     "multipart/form-data", "application/x-www-form-urlencoded", ""]))
def test_random_bytes(api, raw, endpoint, content_type):
    answered_well(api.post(endpoint, content=raw, headers={"Content-Type": content_type} if content_type else {}))


@pytest.mark.parametrize("raw", [b'{"text": "hi", "seed": NaN}', b'{"text": "hi", "style": {"speed": Infinity}}',
                                 b'{"text": "hi", "words": [{"word": "a", "start": -Infinity, "end": 1}]}', b'{"text": "\\ud800"}',
                                 b'{"text": "hi", "rate": 1e999}', b'[' * 5000, b'{"script": "a: b", "utterances": [1e300]}'])
def test_json_that_python_reads_but_is_not_json(api, raw):
    answered_well(api.post("/v1/generate", content=raw, headers={"Content-Type": "application/json"}))


@settings(max_examples=40, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(value=json_values, endpoint=st.sampled_from(["/v1/generate", "/v1/check"]))
def test_random_json(api, value, endpoint):
    answered_well(api.post(endpoint, json=value))


@settings(max_examples=50, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(field=st.sampled_from(FIELDS), value=json_values | scripts, drop_text=st.booleans())
def test_valid_requests_with_one_field_broken(api, field, value, drop_text):
    body = dict(VALID)
    if drop_text:
        body.pop("text")
    body[field] = value
    answered_well(api.post("/v1/generate", json=body))
    if field == "script":
        answered_well(api.post("/v1/check", json={"script": value}))


@settings(max_examples=25, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(request=json_values.map(json.dumps) | st.text(max_size=50), name=st.text(max_size=20),
       data=st.binary(max_size=200), timings=st.none() | st.tuples(st.text(max_size=12), st.binary(max_size=100)))
def test_random_uploads(api, request, name, data, timings):
    files = {"audio": (name or "a.wav", data)}
    if timings is not None:
        files["timings"] = timings
    answered_well(api.post("/v1/generate/upload", headers={"X-Requested-With": "sgt"}, data={"request": request}, files=files))
