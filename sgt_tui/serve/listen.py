"""Listening: the socket the service binds before it starts, and the timeouts of a connection.

The socket is bound here, before uvicorn runs, so that a port in use or a host that does not
resolve is one clear line and exit status 1 (uvicorn exits 3), and ``--port 0`` can print the
port it got. Connections get three timeouts (docs/serve.md):

- **header read** (``--header-timeout``, default 10 s): a client must send a request's whole
  headers within this time of connecting or of its previous answer; a client that trickles
  them (or sends nothing) is disconnected, so slow clients cannot hold connections open;
- **keep-alive** (5 s): an idle connection between requests is closed (uvicorn's);
- **request** (``--timeout``): the body and the work (:class:`sgt_tui.serve.app.Guard`).

Connections are kept below the process's descriptor limit (``ulimit -n``): every open
connection holds a descriptor, and a process out of them can neither accept (asyncio then stops
accepting for a second at a time, logging a traceback) nor open a file, so one client holding
idle connections would stop the service answering anyone. Two bounds:

- at most :func:`connection_limit` connections (half the descriptors left after
  :data:`RESERVED_FDS`) are open at once: one more closes the connection that has waited
  longest for a request's headers (an idle one), or, when every connection is busy (a request,
  a stream), is answered 503 and closed;
- the listening socket (:class:`Listener`) never lets a connection take one of the top
  :data:`RESERVED_FDS` descriptors: such a connection is answered 503 and closed at once. This
  bound holds while connections come faster than the first can act (asyncio accepts a batch of
  them in one go, each a descriptor, and closes the ones it drops a few turns of the loop later).

asyncio accepts at most :data:`ACCEPT_BATCH` connections a turn (the ``backlog`` handed to
uvicorn; the kernel's queue stays :data:`BACKLOG` long), so that a flood waiting in the queue
is let in a few at a time, each batch's idle connections closed before the next: a request
that comes after a thousand idle connections is answered, not refused for want of a
descriptor.

uvicorn's ``limit_concurrency`` cannot do either: it answers 503 to a request on a connection
it has already accepted (its descriptor held until the client goes), and never to a WebSocket
upgrade. WebSocket streams have a cap of their own (``--max-streams``, in the application).
"""

from __future__ import annotations

import resource
import socket

from uvicorn.protocols.http.h11_impl import H11Protocol

#: Seconds an idle keep-alive connection stays open between requests.
KEEP_ALIVE = 5.0
#: Descriptors kept for what is not a connection: the model's files, logs, the speech worker's
#: pipes, a request's temporary files (an idle service holds 12).
RESERVED_FDS = 64
#: How many connections the kernel queues for the listening socket.
BACKLOG = 2048
#: How many connections asyncio accepts in one turn of the loop (uvicorn's ``backlog``, which
#: asyncio also hands to ``listen``: :meth:`Listener.listen` keeps the queue at :data:`BACKLOG`).
ACCEPT_BATCH = 16
BUSY = (b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\nretry-after: 1\r\n"
        b"connection: close\r\ncontent-length: 72\r\n\r\n"
        b'{"error": "every connection this service can hold is busy: retry later"}')


class ListenError(OSError):
    """The service cannot listen where it was asked to (one line for users)."""


class Listener(socket.socket):
    """A listening socket whose connections never take a descriptor from ``ceiling`` up: one
    that would is answered 503 and closed before the server sees it."""

    ceiling = 1 << 30

    def listen(self, backlog: int = BACKLOG) -> None:
        super().listen(max(backlog, BACKLOG))

    def accept(self):
        conn, address = super().accept()
        if conn.fileno() < self.ceiling:
            return conn, address
        try:
            conn.setblocking(False)
            conn.send(BUSY)
        except OSError:
            pass
        conn.close()
        # "none waiting" to asyncio's accept loop: it tries again on the loop's next turn, after
        # the connections it closes have given their descriptors back (one refused a turn)
        raise BlockingIOError(11, "every descriptor for connections is taken")


def descriptor_limit() -> int:
    """The process's descriptor limit (``ulimit -n``)."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    return 1 << 16 if soft == resource.RLIM_INFINITY else soft


def bind(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (0: a free port); raises :class:`ListenError`."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        raise ListenError(f"--host {host}: no such address ({exc.strerror})") from None
    family, kind, proto, _, address = infos[0]
    sock = Listener(family, kind, proto)
    sock.ceiling = descriptor_limit() - RESERVED_FDS
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(BACKLOG)
    except OSError as exc:
        sock.close()
        if exc.errno == 98:  # EADDRINUSE
            raise ListenError(f"port {port} on {host} is in use (another sgt serve?): choose another with --port, "
                              "or --port 0 for a free one") from None
        raise ListenError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    sock.set_inheritable(True)
    return sock


def connection_limit() -> int:
    """How many connections may be open at once: half the descriptors the rest does not need
    (the other half for connections on their way in or out)."""
    return max(8, (descriptor_limit() - RESERVED_FDS) // 2)


def protocol(header_timeout: float, max_connections: int) -> type:
    """uvicorn's HTTP protocol with a header-read timeout of ``header_timeout`` seconds and at
    most ``max_connections`` connections open at once (WebSockets included)."""
    waiting: dict = {}  # the connections waiting for a request's headers, the longest first

    class HeaderTimeoutProtocol(H11Protocol):
        """Disconnects a client that has not sent a request's whole headers ``header_timeout``
        seconds after connecting or after its previous answer, and the one that has waited
        longest when a connection beyond ``max_connections`` comes."""

        _header_timer = None

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            if len(self.connections) > max_connections:
                if not waiting:  # every connection is busy: this one is refused
                    transport.write(BUSY)
                    transport.close()
                    return
                oldest = next(iter(waiting))
                oldest._stop_waiting()
                oldest.transport.close()
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
            waiting[self] = None

        def _stop_waiting(self) -> None:
            waiting.pop(self, None)
            if self._header_timer is not None:
                self._header_timer.cancel()
                self._header_timer = None

        def _headers_too_slow(self) -> None:
            self._header_timer = None
            waiting.pop(self, None)
            if not self.transport.is_closing() and (self.cycle is None or self.cycle.response_complete):
                self.transport.close()

    return HeaderTimeoutProtocol
