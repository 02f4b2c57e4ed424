"""Who may talk to sgt's web servers (``sgt serve``, ``sgt view``): the Host and Origin checks.

A web page the user opens anywhere can reach a server on this machine's loopback: by DNS
rebinding (a name of the page's that resolves to 127.0.0.1: the browser then reads the answers,
sending that name as Host), or cross-origin (a form posted, a WebSocket opened, an ``<img>``
or ``<script>`` loaded from another site). :class:`SameOrigin`, the outermost ASGI middleware of
both applications, answers such requests before any route, page or static file does:

- **Host** must name this server: a loopback name (``localhost``, ``127.x.x.x``, ``[::1]``) or
  the address the connection reached, or the ``--host`` name, each with the port the connection
  reached; or a name given with ``--allow-host NAME[:PORT]`` (a reverse proxy's; any port when
  none is given). Anything else, or no Host: 421 (Misdirected Request).
- **Origin**, when a request has one (browsers send it with every WebSocket handshake and every
  cross-origin or non-GET request; curl and Python clients send none), must be ``http://`` and
  such a host and port, or ``http(s)://`` and an ``--allow-host`` name; ``null`` and anything
  else: 403.
- **Sec-Fetch-Site** ``cross-site`` or ``same-site`` (a page of another site, or of another port
  of this machine, made the request): 403, except a GET navigation to a page (a link followed).
- **Forms**: a request body of a type an HTML form (or a cross-origin fetch without a
  preflight) can send, ``application/x-www-form-urlencoded``, ``multipart/form-data`` or
  ``text/plain``: 415, except multipart on an upload route, which needs a header no form of
  another origin can send: ``Authorization``, ``X-Requested-With``, or this server's own
  Origin (a page of its own, such as ``/docs``); else 403.

Refusals are one-line JSON errors (``{"error": ...}``). A WebSocket handshake is refused with
the same answer (the ASGI denial response, which uvicorn supports) or, on a server without that
extension, closed before it is accepted (the server answers 403).
"""

from __future__ import annotations

import ipaddress

from starlette.responses import JSONResponse

from sgt_tui.serve.config import ServeConfig, is_loopback, split_host

#: The body types an HTML form can send (the CORS-safelisted ones: no preflight from another origin).
FORM_TYPES = frozenset({"application/x-www-form-urlencoded", "multipart/form-data", "text/plain"})
#: Headers a form of another origin cannot send (a page of another origin only after a preflight
#: this server never grants; Origin, when it got this far, is this server's own).
NON_FORM_HEADERS = ("authorization", "x-requested-with", "origin")
DEFAULT_PORTS = {"http": 80, "https": 443}


async def refuse(scope, receive, send, status: int, message: str, headers: dict | None = None) -> None:
    """Answer ``{"error": message}`` with ``status``: an HTTP answer, or a WebSocket handshake
    refused with it (closed before it is accepted where the server cannot send an answer)."""
    if scope["type"] == "websocket" and "websocket.http.response" not in scope.get("extensions", {}):
        await send({"type": "websocket.close", "code": 1013 if status == 503 else 1008, "reason": message[:120]})
        return
    await JSONResponse({"error": message}, status_code=status, headers=headers)(scope, receive, send)


class SameOrigin:
    """ASGI middleware: the Host, Origin, Sec-Fetch-Site and form checks of the module's
    docstring on every HTTP request and WebSocket handshake; ``uploads`` are the paths that
    take multipart bodies."""

    def __init__(self, app, config: ServeConfig, uploads: tuple[str, ...] = ()) -> None:
        self.app = app
        self.uploads = uploads
        self.port = config.port
        self.proxies = {split_host(name) for name in config.allow_hosts}
        host = split_host(config.host)
        self.host = host[0] if host is not None and not _unspecified(host[0]) else None

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        headers: dict[str, list[str]] = {}
        for key, value in scope.get("headers", ()):
            headers.setdefault(key.decode("latin-1").lower(), []).append(value.decode("latin-1"))
        refusal = self._refusal(scope, headers)
        if refusal is not None:
            return await refuse(scope, receive, send, *refusal)
        return await self.app(scope, receive, send)

    def _refusal(self, scope, headers: dict[str, list[str]]) -> tuple[int, str] | None:
        server = scope.get("server") or (None, self.port)
        hosts = headers.get("host", [])
        host = split_host(hosts[0]) if len(hosts) == 1 else None
        if host is None or not self._names_us(host[0], 80 if host[1] is None else host[1], server):
            return 421, (f"this server does not answer to that Host (a web page's own name, DNS rebinding?): open it as "
                         f"http://127.0.0.1:{server[1]}/, or start it with --allow-host NAME for a proxy's name")
        origins = headers.get("origin")
        if origins is not None and (len(origins) != 1 or not self._our_origin(origins[0], server)):
            return 403, "a page of another origin may not use this server (its Origin is not this server's)"
        method = scope.get("method", "GET")
        fetch = {k: (headers.get(f"sec-fetch-{k}") or [""])[0] for k in ("site", "mode", "dest")}
        if fetch["site"] in ("cross-site", "same-site") and not (
                method in ("GET", "HEAD") and fetch["mode"] == "navigate" and fetch["dest"] == "document"):
            return 403, "a page of another site may not use this server (Sec-Fetch-Site: " + fetch["site"] + ")"
        if scope["type"] == "http" and method not in ("GET", "HEAD"):
            kind = (headers.get("content-type") or [""])[0].split(";")[0].strip().lower()
            if kind not in FORM_TYPES:
                return None
            if kind == "multipart/form-data" and scope["path"] in self.uploads:
                if any(name in headers for name in NON_FORM_HEADERS):
                    return None
                return 403, ("an upload needs a header an HTML form cannot send: 'X-Requested-With: sgt' "
                             "(or the token, 'Authorization: Bearer TOKEN')")
            return 415, (f"{method} {scope['path']} does not take form bodies ({kind}: any web page can send them): "
                         "send JSON with 'Content-Type: application/json'"
                         + (", or an upload as multipart/form-data" if scope["path"] in self.uploads else ""))
        return None

    def _names_us(self, name: str, port: int | None, server) -> bool:
        """Whether ``name:port`` (a Host's, an origin's) names this server, reached at ``server``."""
        if port == server[1] and (is_loopback(name) or name in (self.host, server[0])):
            return True
        return (name, None) in self.proxies or (name, port) in self.proxies

    def _our_origin(self, origin: str, server) -> bool:
        scheme, sep, rest = origin.partition("://")
        host = split_host(rest) if sep else None
        if host is None or scheme.lower() not in DEFAULT_PORTS:
            return False  # "null" (a sandboxed frame, a file), a path, another scheme
        port = DEFAULT_PORTS[scheme.lower()] if host[1] is None else host[1]
        if scheme.lower() == "https":  # this server speaks http: https is a proxy's (--allow-host)
            return (host[0], None) in self.proxies or (host[0], port) in self.proxies
        return self._names_us(host[0], port, server)


def _unspecified(name: str) -> bool:
    """0.0.0.0 and :: (every address) name no server."""
    try:
        return ipaddress.ip_address(name).is_unspecified
    except ValueError:
        return False
