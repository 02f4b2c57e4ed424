"""sgt view: a take in 3D in a web page on this machine, reloaded when its script is saved (docs/view.md)."""

from __future__ import annotations

import argparse

from core.counting import plural

HELP = "watch a take in 3D in a web browser (three.js), with its speech; reloads when the script is saved"
DESCRIPTION = """\
Serve a web page that shows a take in 3D: every speaker, orbit and zoom, front, side,
top and three-quarter cameras (sgt render's), play and pause, scrubbing with the speech
in sync, playback speed, a timeline of the words and the pose and style controls (click
one to jump to its stroke), the word being spoken, and sgt's mannequin or your own VRM
character (a .vrm file chosen in the page). FILE is a script (.sgt, generated first),
a motion file (.json/.npz; its speech comes from the script it names) or a build
folder (sgt build -o OUT: every take its manifest lists). When the script (or the
motion file, or the build) changes on disk, it is generated again in the background
and the page reloads: edit in any editor and watch.

The page needs nothing from the internet (three.js is shipped with sgt). It listens on
127.0.0.1 and a free port, printed with its address; from another machine, forward
the port over SSH (ssh -L 8700:127.0.0.1:8700 HOST, then sgt view FILE --port 8700 on
HOST and open http://127.0.0.1:8700/ here). --host exposes it, and then a token is
required (--token or SGT_SERVE_TOKEN, as sgt serve): open http://HOST:PORT/#token=TOKEN
(the page keeps the token; the part after # never leaves the browser). Other web pages
cannot use it: a request must name it as its Host (a loopback name or --host, with its
port, or a name given with --allow-host; else 421) and come from no other origin (403).

The page's Pose panel makes a gesture by hand: drag a wrist (the arm follows at its
bone lengths), an elbow, a shoulder or the neck; turn the head and the forearm with
their rings; pick hand shapes and palms; keyframes on a small timeline; play it alone or
in the take at a word. Save writes the gesture (the TOML of library/gestures) into the
script's @library folder (or a new one it adds), and Use at this word puts [pose:NAME]
before the word in the script. Writes need this run's edit token, in the address
printed (#edit=...)."""


def register(sub) -> None:
    from sgt_tui.commands.common import non_negative_int

    p = sub.add_parser("view", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="FILE", help="script (.sgt), motion file (.json/.npz) or build folder")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=non_negative_int, default=0, help="port (default 0: a free one, printed)")
    p.add_argument("--token", help="require this token (default: $SGT_SERVE_TOKEN; required with --host)")
    p.add_argument("--gesture", metavar="NAME", help="open the pose editor on this gesture (of the library the script sees)")
    add_allow_host_option(p)
    from sgt_tui.commands.render import add_script_options

    add_script_options(p)
    p.set_defaults(run=run)


def add_allow_host_option(p) -> None:
    """``--allow-host``, for ``sgt view`` and ``sgt serve`` (sgt_tui/serve/origin.py)."""
    p.add_argument("--allow-host", action="append", default=[], metavar="NAME[:PORT]",
                   help="another name requests may give as their Host and Origin, e.g. a reverse proxy's "
                        "(repeatable; any port without :PORT; http and https origins). Without it only "
                        "loopback names and --host, with the port served, are answered (others: 421)")


def run(args) -> int:
    import os
    import signal
    import sys
    from pathlib import Path

    from sgt_tui.errors import InputError, UsageError
    from sgt_tui.serve.config import ConfigError, ServeConfig, checked

    try:
        config = checked(ServeConfig(host=args.host, port=args.port, token=args.token, allow_hosts=tuple(args.allow_host)))
    except ConfigError as exc:
        raise UsageError(str(exc)) from None
    path = Path(args.input)
    if not os.path.exists(path):
        raise InputError(f"no such file or folder: {args.input}")
    if not path.is_dir() and path.suffix.lower() not in (".sgt", ".json", ".npz"):
        raise UsageError(f"{path}: unknown input type '{path.suffix or '(none)'}' (use .sgt, .json, .npz or a build folder)")

    import secrets

    from sgt_tui.view.posing import Poser
    from sgt_tui.view.takes import Viewer, ViewError

    try:
        viewer = Viewer(path, engine=args.engine, seed=args.seed)
    except ViewError as exc:
        raise InputError(str(exc)) from None
    if not viewer.slots:
        raise InputError(f"{path}: no motion files in this folder (sgt build -o {path} makes them)")
    script = path if not path.is_dir() and path.suffix.lower() == ".sgt" else None
    edit = secrets.token_urlsafe(18)  # this run's: the page's writes (a gesture, a mark in the script) need it
    poser = Poser(script, edit, start=args.gesture, engine=args.engine, seed=args.seed, changed=viewer.touch)
    if args.gesture is not None and args.gesture not in poser.library():
        hint = poser.library().suggest(args.gesture)
        raise UsageError(f"--gesture {args.gesture}: no such gesture" + (f"; did you mean '{hint}'?" if hint else ""))
    try:
        viewer.take(0)  # the first take before listening: a script with errors stops here
    except ViewError as exc:
        if exc.details:
            sys.stderr.write(exc.details + "\n")
        raise InputError(str(exc), printed=False) from None

    from sgt_tui.serve.listen import ListenError, bind
    from sgt_tui.serve.server import config as server_config
    from sgt_tui.view.server import ViewServer, create_view_app

    try:
        sock = bind(config.host, config.port)
    except ListenError as exc:
        raise InputError(str(exc)) from None
    port = sock.getsockname()[1]
    host = f"[{config.host}]" if ":" in config.host else config.host
    address = f"http://{host}:{port}/"
    server = ViewServer(server_config(create_view_app(viewer, config, poser), config.header_timeout,
                                     timeout_graceful_shutdown=1), viewer)
    # From here ctrl+c stops the server and raises nothing: before uvicorn runs too, where a
    # KeyboardInterrupt could land in an import (and CPython then ends by SIGINT, whatever caught it).
    previous = signal.signal(signal.SIGINT, server.handle_exit)
    try:
        print(f"sgt view: {address}#edit={edit}" + (f" (token required: open {address}#edit={edit}&token=TOKEN)"
                                                    if config.token else ""), file=sys.stderr)
        print(f"  {plural(len(viewer.slots), 'take')} of {path}; reloads when "
              f"{'its files change' if viewer.folder or path.suffix.lower() != '.sgt' else 'the script is saved'}; ctrl+c "
              f"stops. Over SSH: ssh -L {port}:127.0.0.1:{port} THIS_HOST, then open the address on your machine.",
              file=sys.stderr)
        sys.stderr.flush()
        viewer.start()
        server.run(sockets=[sock])  # its own handler while it runs, ours again after (it re-raises the signal to it)
    finally:
        signal.signal(signal.SIGINT, previous)
        viewer.stop()
        sock.close()
    return 0
