"""A fake of NAOqi's Python 3 ``qi`` module for tests/test_naoqi_play.py: a session whose
services record every call (service, method, arguments, whether asynchronous, the monotonic
time it was made and returned) to the JSON file named by $FAKE_QI_LOG. A blocking
``angleInterpolation`` takes as long as its last key time, as on the robot; the robot stands
with every joint at 0."""

import json
import os
import time

CALLS = []


def _save():
    with open(os.environ["FAKE_QI_LOG"], "w") as f:
        json.dump(CALLS, f)


class Session:
    def connect(self, url):
        if not url.startswith("tcp://"):
            raise RuntimeError("Failed to connect: bad URL")
        CALLS.append({"service": "Session", "method": "connect", "args": [url], "async": False,
                      "at": time.monotonic(), "done": time.monotonic()})
        _save()

    def service(self, name):
        return _Service(name)


class _Future:
    def __init__(self, result):
        self.result = result

    def value(self):
        return self.result


class _Service:
    def __init__(self, name):
        self.name = name

    def __getattr__(self, method):
        def call(*args, _async=False):
            at = time.monotonic()
            result = None
            if method == "getAngles":
                result = [0.0] * len(args[0])
            elif method == "loadFile":
                result = 7
            elif method == "angleInterpolation" and not _async:
                time.sleep(max(max(t) if isinstance(t, list) else t for t in args[2]))
            CALLS.append({"service": self.name, "method": method, "args": list(args), "async": _async,
                          "at": at, "done": time.monotonic()})
            _save()
            return _Future(result) if _async else result
        return call
