"""The uvicorn server of `sgt serve` and `sgt view`: ctrl+c stops it once, quietly.

A second ctrl+c while the first stop is under way changes nothing: that stop ends within the
graceful timeout anyway (in-flight work is cancelled, core/cancel.py), while uvicorn's forced
exit would skip the application's shutdown and leave its lifespan task to be cancelled when
the loop closes, printing a CancelledError traceback.
"""

from __future__ import annotations

import uvicorn

from sgt_tui.serve.listen import ACCEPT_BATCH, KEEP_ALIVE, connection_limit, protocol


def config(app, header_timeout: float, **options) -> uvicorn.Config:
    """uvicorn's settings for ``app`` on a socket of :func:`sgt_tui.serve.listen.bind`: the
    header timeout and connection cap of :func:`~sgt_tui.serve.listen.protocol`, the idle
    keep-alive, connections let in :data:`~sgt_tui.serve.listen.ACCEPT_BATCH` a turn, and the
    asyncio loop (its accept loop calls the Listener's accept); ``options``: the rest."""
    return uvicorn.Config(app, log_level="warning", http=protocol(header_timeout, connection_limit()),
                          timeout_keep_alive=KEEP_ALIVE, backlog=ACCEPT_BATCH, loop="asyncio", **options)


class Server(uvicorn.Server):
    """uvicorn's server on which a repeated ctrl+c (or SIGTERM) is ignored."""

    def handle_exit(self, sig, frame) -> None:
        if self.should_exit:
            return
        super().handle_exit(sig, frame)
