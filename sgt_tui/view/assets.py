"""The page's files, shipped in ``sgt_tui/view/static`` (package data): the HTML, its style sheet,
the vendored bundle (three.js, three-vrm, three-vrm-animation and the page's code, built from
``viewer/`` by ``npm run build``) and the bundled libraries' licences. Nothing is fetched from
elsewhere: the page works offline."""

from __future__ import annotations

from pathlib import Path

STATIC = Path(__file__).resolve().parent / "static"
#: The files the page may ask for, and their media types.
FILES = {
    "viewer.js": "text/javascript; charset=utf-8",
    "viewer.css": "text/css; charset=utf-8",
    "viewer.LICENSES.txt": "text/plain; charset=utf-8",
}
#: How the page learns where it runs: ``sgt view`` (a take of its own) or ``sgt serve`` (a script typed in).
MODES = ("file", "service")


def index_html(mode: str) -> str:
    """The page, for ``mode`` (:data:`MODES`)."""
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}")
    return (STATIC / "index.html").read_text(encoding="utf-8").replace('data-mode="file"', f'data-mode="{mode}"', 1)


def asset(name: str) -> tuple[bytes, str] | None:
    """(contents, media type) of a static file of the page, or None when it is not one."""
    if name not in FILES:
        return None
    return (STATIC / name).read_bytes(), FILES[name]
