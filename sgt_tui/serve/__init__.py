"""``sgt serve``: generation as an HTTP and WebSocket service for running agents (docs/serve.md).

- :mod:`.config`: the service's settings and their checks (bind address, token, limits, allow-list);
- :mod:`.requests`: request bodies, and turning one into a script with its paths checked;
- :mod:`.pool`: the worker threads and the bounded queue (503 with Retry-After when full);
- :mod:`.jobs`: the work a request does (check, generate) and its answer;
- :mod:`.app`: the ASGI application (endpoints, errors as JSON, the size/token guard);
- :mod:`.stream`: the WebSocket streaming protocol over :mod:`model.streaming`.
"""
