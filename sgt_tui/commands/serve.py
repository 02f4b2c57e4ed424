"""sgt serve: generation as an HTTP and WebSocket service (docs/serve.md)."""

from __future__ import annotations

import argparse

HELP = "run a generation service for agents (HTTP + WebSocket streaming)"
DESCRIPTION = """\
Serve generation over HTTP for running agents: POST /v1/generate (a script or plain
text -> motion JSON, optionally BVH, glb, WAV), POST /v1/generate/upload (a recording
and its transcript), POST /v1/check, GET /v1/library, GET /healthz, and the WebSocket
/v1/stream (text or timed words in, motion frames out with a fixed 0.47 s lookahead).
OpenAPI documentation at /docs. The model stays loaded; requests run in worker
threads behind a bounded queue (503 with Retry-After when it is full).

Secure by default: it listens on 127.0.0.1 only. --host exposes it, and then a token
is required (--token, or the SGT_SERVE_TOKEN environment variable); clients send
'Authorization: Bearer TOKEN'. Scripts in requests may not name server files with
@audio or @library unless they lie in a folder given with --allow. Web pages cannot use
it: a request must name it as its Host (a loopback name or --host, with its port, or a
name given with --allow-host; else 421), one with an Origin must come from it (else
403), and form bodies are refused (an upload needs 'X-Requested-With: sgt' or the token)."""


def register(sub) -> None:
    from sgt_tui.commands.common import add_database_option, non_negative_int, positive_float, positive_int
    from sgt_tui.commands.view import add_allow_host_option

    p = sub.add_parser("serve", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=non_negative_int, default=8765, help="port (default 8765; 0 picks a free one)")
    p.add_argument("--token", help="require 'Authorization: Bearer TOKEN' (default: $SGT_SERVE_TOKEN; required with --host)")
    add_allow_host_option(p)
    p.add_argument("--allow", action="append", default=[], metavar="FOLDER",
                   help="a folder that @audio/@library paths in requests may name (repeatable; relative paths resolve in the first)")
    p.add_argument("--workers", type=positive_int, default=2, help="generation threads (default 2)")
    p.add_argument("--queue", type=non_negative_int, default=8, help="requests that may wait for a thread; more get 503 (default 8)")
    p.add_argument("--max-body", type=positive_int, default=2_000_000, metavar="BYTES",
                   help="largest request body, an upload included (default 2000000; larger: 413)")
    p.add_argument("--max-text", type=positive_int, default=20_000, metavar="CHARS", help="longest script or text (default 20000)")
    p.add_argument("--timeout", type=positive_float, default=30.0, metavar="SECONDS",
                   help="longest a request may take, its body included (default 30; then 408)")
    p.add_argument("--max-seconds", type=positive_float, default=600.0, metavar="SECONDS",
                   help="the longest performance a request may make, pauses and gaps included (default 600, at most "
                        "3600; longer: 422 with the error at the mark that passes it)")
    p.add_argument("--header-timeout", type=positive_float, default=10.0, metavar="SECONDS",
                   help="a client must send a request's headers within this time of connecting or of its "
                        "previous answer, or it is disconnected (default 10)")
    p.add_argument("--max-streams", type=positive_int, default=32, metavar="N",
                   help="WebSocket streams open at once; one more is refused with 503 (default 32)")
    p.add_argument("--max-client-streams", type=positive_int, default=8, metavar="N",
                   help="streams open at once from one client address (default 8)")
    p.add_argument("--weights", metavar="PATH", help="generator weights (default: the shipped model/weights/generator.pt)")
    add_database_option(p)
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    from pathlib import Path

    from model.runtime import load_runner
    from model.weights import WeightsError
    from sgt_tui.commands.common import database_option, existing_file
    from sgt_tui.errors import InputError, UsageError
    from sgt_tui.serve.config import ConfigError, ServeConfig, checked

    weights = str(existing_file(args.weights)) if args.weights else None
    database = database_option(args.database, "matching")  # for the requests and streams that ask for the matching engine
    try:
        config = checked(ServeConfig(host=args.host, port=args.port, token=args.token, allow=tuple(Path(a) for a in args.allow),
                                     workers=args.workers, queue=args.queue, max_body=args.max_body, max_text=args.max_text,
                                     timeout=args.timeout, header_timeout=args.header_timeout, weights=weights,
                                     database=database, allow_hosts=tuple(args.allow_host), max_streams=args.max_streams,
                                     max_client_streams=args.max_client_streams, max_seconds=args.max_seconds))
    except ConfigError as exc:
        raise UsageError(str(exc)) from None
    try:
        runner = load_runner(weights)  # fail before listening when the weights cannot run
    except WeightsError as exc:
        raise InputError(str(exc)) from None
    from sgt_tui.build.work import one_thread
    from sgt_tui.serve.app import create_app
    from sgt_tui.serve.listen import ListenError, bind
    from sgt_tui.serve.server import Server
    from sgt_tui.serve.server import config as server_config

    try:
        sock = bind(config.host, config.port)
    except ListenError as exc:
        raise InputError(str(exc)) from None
    port = sock.getsockname()[1]
    host = f"[{config.host}]" if ":" in config.host else config.host
    print(f"sgt serve: http://{host}:{port} (model on {runner.kind}; OpenAPI at /docs; "
          f"{'token required' if config.token else 'no token: this machine only'})", file=sys.stderr)
    # Requests run side by side in the pool's threads, each on a core: OpenBLAS's own threads on
    # top of them only spun waiting for a core (measured at 8 clients on 2 cores: 57 ms of CPU a
    # request with them, 21 ms with one thread each, the throughput doubled).
    one_thread()
    server = Server(server_config(create_app(config), config.header_timeout, ws_max_size=1 << 20,
                                  timeout_graceful_shutdown=5))
    try:
        server.run(sockets=[sock])
    except KeyboardInterrupt:  # uvicorn re-raises the ctrl+c it shut down on: a clean stop, as uvicorn.run has it
        pass
    finally:
        sock.close()
    return 0
