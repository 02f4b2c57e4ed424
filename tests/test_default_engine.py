"""One default engine everywhere, and what ships is what was previewed.

Every path that names no engine runs ``model.engines.DEFAULT_ENGINE`` (each test below names
none and reads which engine ran from what the user gets: the motion file's ``engine``, the
service's answer, the stream's ``ready``, the editor's and the language server's job), and
``sgt build`` writes byte-identical motion to ``sgt generate`` for the same script and settings:
each utterance is generated from its own inputs alone, the same way on both paths.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from model.engines import DEFAULT_ENGINE, ENGINES

ROOT = Path(__file__).resolve().parent.parent

#: Two and three speakers, pauses, gaps, an interruption, pose and style marks, a recorded-free
#: script (espeak-ng speaks it).
SCRIPTS = {
    "shop.sgt": (
        "@voice ann: en-us\n@voice bob: en-gb\n"
        "ann: Welcome to the shop! [pose:open_arms] Look at the shelf [pose:point_right x2] over there. [pause 1s] It is new.\n"
        "bob: That is <speed:-1>really</speed> nice, [pose:nod] thank you.\n"
        "ann: You are welcome. [pause 0.5s] Anything else?\n"
    ),
    "tavern.sgt": (
        "@seed 7\n@voice cook: en-gb\n"
        "cook: Soup of the day is <space:1>enormous</space>, friend. [pose:big]\n"
        "guard: No soup for me. [pose:head_shake] I am on duty.\n"
        "@gap 1.5s\n"
        "bard: A song then! [pose:celebrate] [pause 2s] Or two.\n"
        "cook: <handedness:-1>Fine</handedness>, [pose:shrug] as you like.\n"
    ),
}


def sgt(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], cwd=cwd, capture_output=True, text=True,
                       timeout=timeout, check=False, env={**os.environ, "PYTHONPATH": str(ROOT),
                                                          "SGT_CACHE_DIR": str(cwd / ".cache")})
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture(scope="module")
def game(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("default_engine")
    (root / "game").mkdir()
    for name, text in SCRIPTS.items():
        (root / "game" / name).write_text(text)
    return root


def test_the_default_is_the_matching_engine_and_the_first_choice():
    assert DEFAULT_ENGINE == "matching" and next(iter(ENGINES)) == DEFAULT_ENGINE


# -- what ships is what was previewed ------------------------------------------------------------

@pytest.mark.parametrize("engine", [None, "neural"])
def test_build_writes_the_bytes_generate_writes(game, engine):
    """Each script built (a cold cache, then again from the cache) and generated, with the same
    settings: the motion files are byte for byte the same (the script's path recorded relative to
    each file, both one folder below the root)."""
    chosen = () if engine is None else ("--engine", engine)
    out = f"out_{engine or 'default'}"
    sgt("build", "game", "-o", out, "-j", "1", "-q", *chosen, cwd=game)
    for name in SCRIPTS:
        json_name = name.replace(".sgt", ".json")
        sgt("generate", f"game/{name}", "-o", f"gen_{engine or 'default'}/{json_name}", *chosen, cwd=game)
        built = (game / out / json_name).read_bytes()
        generated = (game / f"gen_{engine or 'default'}" / json_name).read_bytes()
        assert built == generated, f"{name}: sgt build and sgt generate differ"
        assert json.loads(built)["engine"] == (engine or DEFAULT_ENGINE)
    (game / out / "manifest.json").unlink()  # the second build takes every utterance from the cache
    sgt("build", "game", "-o", out, "-j", "2", "-q", *chosen, cwd=game)
    for name in SCRIPTS:
        json_name = name.replace(".sgt", ".json")
        assert (game / out / json_name).read_bytes() == (game / f"gen_{engine or 'default'}" / json_name).read_bytes()


# -- every path names no engine and runs the default ---------------------------------------------

def test_generate_render_and_export_of_a_script_use_the_default(game):
    sgt("generate", "game/shop.sgt", "-o", "g.json", cwd=game)
    assert json.loads((game / "g.json").read_text())["engine"] == DEFAULT_ENGINE
    sgt("export", "game/shop.sgt", "-o", "e.json", cwd=game)  # a script is generated on the way (render, export, diff)
    assert json.loads((game / "e.json").read_text())["engine"] == DEFAULT_ENGINE


def test_load_performance_of_a_script_uses_the_default(game):
    """``sgt render script.sgt`` and ``sgt export script.sgt`` generate through load_performance."""
    from sgt_tui.commands.clips import load_performance

    assert load_performance(str(game / "game" / "shop.sgt")).engine == DEFAULT_ENGINE


def test_diff_render_uses_the_default(game, monkeypatch):
    from dsl.diff import diff_scripts
    from model import generate as generate_module
    from sgt_tui import diffing

    seen = []
    real = generate_module.generate

    def spy(*args, **kwargs):
        take = real(*args, **kwargs)
        seen.append(take.engine)
        return take

    monkeypatch.setattr(generate_module, "generate", spy)
    old = SCRIPTS["shop.sgt"]
    new = old.replace("It is new.", "It is brand new.")
    (game / "old.sgt").write_text(old)
    (game / "new.sgt").write_text(new)
    pairs = diffing.pairs_for([str(game / "old.sgt"), str(game / "new.sgt")])
    diffs = [diff_scripts(p.old_text, p.new_text, old_name=p.old_name, new_name=p.new_name, old_path=p.old_path,
                          new_path=p.new_path) for p in pairs]
    assert diffing.render_changes(pairs, diffs, game / "renders", engine=None, size=(64, 64), video=False)
    assert seen and set(seen) == {DEFAULT_ENGINE}


def test_sgt_view_of_a_script_uses_the_default(game):
    from sgt_tui.view.takes import ScriptSource

    assert ScriptSource(game / "game" / "shop.sgt").load().motion.engine == DEFAULT_ENGINE


def test_the_service_and_its_stream_use_the_default():
    from fastapi.testclient import TestClient

    from sgt_tui.serve.app import create_app
    from sgt_tui.serve.config import ServeConfig, checked

    with TestClient(create_app(checked(ServeConfig())), raise_server_exceptions=False) as c:
        answer = c.post("/v1/generate", json={"text": "Hello there, friend.", "timing": "estimate"})
        assert answer.status_code == 200, answer.text
        assert answer.json()["motion"]["engine"] == DEFAULT_ENGINE
        with c.websocket_connect("/v1/stream") as ws:
            ws.send_json({"type": "start"})
            assert ws.receive_json()["engine"] == DEFAULT_ENGINE


def test_build_and_eval_options_default_to_it():
    from sgt_tui.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["build", "x", "-o", "out"]).engine == DEFAULT_ENGINE
    assert parser.parse_args(["eval"]).engine == DEFAULT_ENGINE
    assert parser.parse_args(["generate", "x.sgt", "-o", "x.json"]).engine is None  # None: the default, resolved once


def test_the_editor_and_its_worker_use_the_default(game, tmp_path):
    from sgt_tui.app.main import EditorApp
    from sgt_tui.editor.files import ScriptFile
    from sgt_tui.editor.worker import handle

    app = EditorApp(ScriptFile.open(game / "game" / "shop.sgt"), recovery_dir=tmp_path / "recovery")
    assert app.engine == DEFAULT_ENGINE
    out = tmp_path / "u0.json"
    handle({"id": "1", "op": "generate", "path": str(game / "game" / "shop.sgt"), "source": SCRIPTS["shop.sgt"],
            "engine": app.engine, "utterances": [0], "timing": "estimate", "out": str(out)}, lambda event: None)
    assert json.loads(out.read_text())["engine"] == DEFAULT_ENGINE


def test_the_language_servers_preview_uses_the_default(game, monkeypatch):
    from sgt_tui.lsp import preview as preview_module
    from sgt_tui.lsp.documents import Document, uri_of
    from sgt_tui.lsp.timing import SpeechTimes

    asked = []

    def refuse(op, analysis, row, **kwargs):
        asked.append(kwargs["engine"])
        raise preview_module.JobRefused("stop here: only the engine is looked at")

    monkeypatch.setattr(preview_module, "plan_job", refuse)
    doc = Document(uri_of(game / "game" / "shop.sgt"), SCRIPTS["shop.sgt"])
    with pytest.raises(preview_module.PreviewFailed):
        preview_module.Previews(SpeechTimes()).render(doc, 2)
    assert asked == [DEFAULT_ENGINE]
