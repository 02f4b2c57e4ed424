"""Listening: the socket the service binds before it starts, and the timeouts of a connection.

The socket is bound here, before uvicorn runs, so that a port in use or a host that does not
resolve is one clear line and exit status 1 (uvicorn exits 3), and ``--port 0`` can print the
port it got. Connections get three timeouts (docs/serve.md):

- **header read** (``--header-timeout``, default 10 s): a client must send a request's whole
  headers within this time of connecting or of its previous answer; a client that trickles
  them (or sends nothing) is disconnected, so slow clients cannot hold connections open;
- **keep-alive** (5 s): an idle connection between requests is closed (uvicorn's);
- **request** (``--timeout``): the body and the work (:class:`sgt_tui.serve.app.Guard`).
"""

from __future__ import annotations

import socket

from uvicorn.protocols.http.h11_impl import H11Protocol

#: Seconds an idle keep-alive connection stays open between requests.
KEEP_ALIVE = 5.0


class ListenError(OSError):
    """The service cannot listen where it was asked to (one line for users)."""


def bind(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (0: a free port); raises :class:`ListenError`."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        raise ListenError(f"--host {host}: no such address ({exc.strerror})") from None
    family, kind, proto, _, address = infos[0]
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(2048)
    except OSError as exc:
        sock.close()
        if exc.errno == 98:  # EADDRINUSE
            raise ListenError(f"port {port} on {host} is in use (another sgt serve?): choose another with --port, "
                              "or --port 0 for a free one") from None
        raise ListenError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    sock.set_inheritable(True)
    return sock


def protocol(header_timeout: float) -> type:
    """uvicorn's HTTP protocol with a header-read timeout of ``header_timeout`` seconds."""

    class HeaderTimeoutProtocol(H11Protocol):
        """Disconnects a client that has not sent a request's whole headers ``header_timeout``
        seconds after connecting or after its previous answer."""

        _header_timer = None

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            self._wait_for_headers()

        def handle_events(self) -> None:
            before = self.scope
            super().handle_events()
            if self.scope is not before:  # a request's headers arrived (a WebSocket upgrade too)
                self._stop_waiting()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._wait_for_headers()

        def connection_lost(self, exc) -> None:
            self._stop_waiting()
            super().connection_lost(exc)

        def _wait_for_headers(self) -> None:
            self._stop_waiting()
            self._header_timer = self.loop.call_later(header_timeout, self._headers_too_slow)

        def _stop_waiting(self) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()
                self._header_timer = None

        def _headers_too_slow(self) -> None:
            self._header_timer = None
            if not self.transport.is_closing() and (self.cycle is None or self.cycle.response_complete):
                self.transport.close()

    return HeaderTimeoutProtocol
