"""Neovim as a real client of `sgt lsp`: `nvim --headless` with its built-in LSP client, set up
by the shipped editors/neovim/sgt.lua, opens a script and sees a diagnostic, a completion and a
go-to-definition (issue 23)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NVIM = shutil.which("nvim")
pytestmark = pytest.mark.skipif(NVIM is None, reason="Neovim is not installed (Debian: apt-get install neovim)")

# The init file: the shipped set-up, then the checks, written as JSON for the test to read.
INIT = """
local out = os.getenv("SGT_TEST_OUT")
dofile(os.getenv("SGT_LUA")).setup({ cmd = { os.getenv("SGT_PYTHON"), "-m", "sgt_tui.cli", "lsp" } })
vim.cmd("edit " .. os.getenv("SGT_SCRIPT"))
local result = { filetype = vim.bo.filetype }
local ok = vim.wait(30000, function() return #vim.diagnostic.get(0) > 0 end, 50)
result.diagnostics = {}
for _, d in ipairs(vim.diagnostic.get(0)) do
  table.insert(result.diagnostics, { code = d.code, lnum = d.lnum, col = d.col, message = d.message })
end
local uri = vim.uri_from_bufnr(0)
local function request(method, line, character)
  local params = { textDocument = { uri = uri }, position = { line = line, character = character } }
  local replies = vim.lsp.buf_request_sync(0, method, params, 20000) or {}
  for _, reply in pairs(replies) do
    if reply.result then return reply.result end
  end
  return nil
end
local completion = request("textDocument/completion", 1, 20)
result.completion = {}
for _, item in ipairs((completion and (completion.items or completion)) or {}) do
  table.insert(result.completion, item.label)
end
local definition = request("textDocument/definition", 0, 16)
result.definition = definition and (definition[1] or definition).uri or vim.NIL
local file = io.open(out, "w")
file:write(vim.fn.json_encode(result))
file:close()
vim.cmd("qa!")
"""


def _run_nvim(tmp_path, script, init_text: str, timeout: int) -> dict:
    """Run ``nvim --headless`` on ``script`` with the shipped set-up and ``init_text`` (which
    writes its findings as JSON to $SGT_TEST_OUT, then quits); the findings."""
    init = tmp_path / "init.lua"
    init.write_text(init_text, encoding="utf-8")
    out = tmp_path / "result.json"
    env = {**os.environ, "SGT_TEST_OUT": str(out), "SGT_LUA": str(ROOT / "editors" / "neovim" / "sgt.lua"),
           "SGT_PYTHON": sys.executable, "SGT_SCRIPT": str(script), "XDG_CONFIG_HOME": str(tmp_path / "config"),
           "XDG_DATA_HOME": str(tmp_path / "data"), "XDG_STATE_HOME": str(tmp_path / "state")}
    r = subprocess.run([NVIM, "--headless", "--clean", "-u", str(init)], check=False, cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=timeout, stdin=subprocess.DEVNULL)
    assert out.exists(), r.stdout[-2000:] + r.stderr[-2000:]
    return json.loads(out.read_text())


def test_neovim_sees_a_diagnostic_a_completion_and_a_definition(tmp_path):
    script = tmp_path / "lobby.sgt"
    script.write_text("guide: hi [pose:wave] there [pose:point_rigth] now.\nguide: look [pose:poi\n", encoding="utf-8")
    result = _run_nvim(tmp_path, script, INIT, timeout=120)
    assert result["filetype"] == "sgt"
    codes = {(d["code"], d["lnum"], d["col"]) for d in result["diagnostics"]}
    assert ("SGT201", 0, 34) in codes, result["diagnostics"]  # point_rigth, 0-based line and column
    assert {"point_right", "point_left", "wave"} <= set(result["completion"])
    assert result["definition"] == (ROOT / "library" / "gestures" / "wave.toml").as_uri()


def test_neovim_shows_sgt_checks_verdict_on_look_marks(tmp_path):
    """`[look:bob]` on ann's line names bob, who speaks a later line: no warning, as `sgt check`
    says; `[look:cara]` names nobody: the one warning (the server judges a look mark among all
    the script's speakers, not those of its own line)."""
    script = tmp_path / "min.sgt"
    script.write_text("ann: [look:bob] Hello there.\nbob: Hi. [look:cara] Who?\n", encoding="utf-8")
    result = _run_nvim(tmp_path, script, INIT, timeout=120)
    check = subprocess.run([sys.executable, "-m", "sgt_tui.cli", "check", "--format", "json", str(script)], check=False,
                           capture_output=True, text=True, timeout=120)
    expected = [(d["code"], d["line"] - 1, d["col"] - 1) for d in json.loads(check.stdout)["diagnostics"]]
    assert sorted((d["code"], d["lnum"], d["col"]) for d in result["diagnostics"]) == expected == [("SGT214", 1, 15)]


# Neovim takes the language server's action for a recording the check rejects (SGT407): the
# command writes the aligner's times, Neovim applies the edit the server sends, and the
# diagnostic goes away.
INIT_ALIGN = """
local out = os.getenv("SGT_TEST_OUT")
dofile(os.getenv("SGT_LUA")).setup({ cmd = { os.getenv("SGT_PYTHON"), "-m", "sgt_tui.cli", "lsp" } })
vim.cmd("edit " .. os.getenv("SGT_SCRIPT"))
local result = {}
vim.wait(30000, function() return #vim.diagnostic.get(0) > 0 end, 50)
result.before = {}
for _, d in ipairs(vim.diagnostic.get(0)) do table.insert(result.before, d.code) end
local uri = vim.uri_from_bufnr(0)
local params = { textDocument = { uri = uri }, range = { start = { line = 1, character = 30 }, ["end"] = { line = 1, character = 30 } },
                 context = { diagnostics = {} } }  -- (the server reads its own analysis)
local titles, command = {}, nil
for _, reply in pairs(vim.lsp.buf_request_sync(0, "textDocument/codeAction", params, 20000) or {}) do
  for _, action in ipairs(reply.result or {}) do
    table.insert(titles, action.title)
    if type(action.command) == "table" and action.command.command == "sgt.writeTimings" then command = action.command end
  end
end
result.titles = titles
if command then
  vim.lsp.buf_request_sync(0, "workspace/executeCommand", command, 60000)
end
vim.wait(30000, function() return #vim.diagnostic.get(0) == 0 end, 50)
result.line = vim.api.nvim_buf_get_lines(0, 0, 1, false)[1]
result.after = {}
for _, d in ipairs(vim.diagnostic.get(0)) do table.insert(result.after, d.code) end
local file = io.open(out, "w")
file:write(vim.fn.json_encode(result))
file:close()
vim.cmd("qa!")
"""


def test_neovim_times_a_rejected_recording_by_the_aligners_times(tmp_path):
    import numpy as np  # lazy: only this test makes a recording
    import soundfile as sf  # lazy: only this test makes a recording

    from dsl.speech import _espeak, synthesize  # lazy: espeak-ng, only this test speaks

    if _espeak.find_library() is None:
        pytest.skip("libespeak-ng not installed")
    said = "Well, hello there my friend. How are you today?"
    spans = [(0, 4), (6, 11), (12, 17), (18, 20), (21, 27), (29, 32), (33, 36), (37, 40), (41, 46)]
    x, sr = sf.read(str(synthesize(said, spans, cache_dir=tmp_path / "syn").audio_path))
    sf.write(str(tmp_path / "said.wav"), np.concatenate([np.zeros(sr // 4), x, np.zeros(sr // 4)]), sr)
    script = tmp_path / "said.sgt"
    script.write_text("@audio said.wav\nbot: Well, hello there my dear friend. How are you today?\n", encoding="utf-8")
    result = _run_nvim(tmp_path, script, INIT_ALIGN, timeout=180)
    assert result["before"] == ["SGT407"], result
    assert any("aligner" in t for t in result["titles"]), result["titles"]
    assert result["line"] == "@audio said.wav timings=said.timings.json" and result["after"] == [], result
    assert json.loads((tmp_path / "said.timings.json").read_text())[4]["word"] == "dear"
