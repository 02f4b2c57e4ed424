"""The uvicorn server of `sgt serve` and `sgt view`: ctrl+c stops it once, quietly.

A second ctrl+c while the first stop is under way changes nothing: that stop ends within the
graceful timeout anyway (in-flight work is cancelled, core/cancel.py), while uvicorn's forced
exit would skip the application's shutdown and leave its lifespan task to be cancelled when
the loop closes, printing a CancelledError traceback.
"""

from __future__ import annotations

import uvicorn


class Server(uvicorn.Server):
    """uvicorn's server on which a repeated ctrl+c (or SIGTERM) is ignored."""

    def handle_exit(self, sig, frame) -> None:
        if self.should_exit:
            return
        super().handle_exit(sig, frame)
