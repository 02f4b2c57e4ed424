"""`sgt lsp` driven by pytest-lsp's client over stdio: one test per feature (issue 23).

One server runs for the module, on a workspace of three scripts and a user gesture folder;
each test opens the script it needs (a fresh URI) so the tests do not depend on each other.
The preview test renders a GIF in the editor's worker (a few seconds).
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import pytest

pytest.importorskip("pytest_lsp")
import pytest_lsp
from lsprotocol import types as lsp
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities

from dsl.fmt import format_source
from library import BUILTIN_DIR
from sgt_tui.lsp.outline import TOKEN_TYPES

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.asyncio(loop_scope="module")
_names = itertools.count()

MAIN = """\
# The guide greets the visitor.
@voice en-us
@voice visitor: en-gb
@library ./my_gestures
@preset shy = space:-2 handedness:-1

guide: [pose:wave] Hello, and welcome! <shy>I can help you.</shy>
visitor: [pose:my_wave x2] Thanks! Where is the cinema?
guide: Over there, [pose:point_right] on the right,
    and <speed:-1>take your time</speed>.
"""
OTHER = "guide: [pose:my_wave] Hi again.\nmerchant: Apples!\n"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("ws")
    (root / "my_gestures").mkdir()
    spec = (BUILTIN_DIR / "wave.toml").read_text(encoding="utf-8").replace('name = "wave"', 'name = "my_wave"', 1)
    (root / "my_gestures" / "my_wave.toml").write_text(spec, encoding="utf-8")
    (root / "main.sgt").write_text(MAIN, encoding="utf-8")
    (root / "scenes").mkdir()
    (root / "scenes" / "other.sgt").write_text(OTHER, encoding="utf-8")
    return root


@pytest_lsp.fixture(scope="module", config=ClientServerConfig(server_command=[sys.executable, "-m", "sgt_tui.cli", "lsp"]))
async def client(lsp_client: LanguageClient, workspace: Path):
    await lsp_client.initialize_session(lsp.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"), root_uri=workspace.as_uri(),
        workspace_folders=[lsp.WorkspaceFolder(workspace.as_uri(), "ws")]))
    yield
    await lsp_client.shutdown_session()


async def _open(client: LanguageClient, workspace: Path, text: str, name: str | None = None) -> str:
    """Open ``text`` as a new script in the workspace and wait for its diagnostics."""
    path = workspace / (name or f"t{next(_names)}.sgt")
    path.write_text(text, encoding="utf-8")
    uri = path.as_uri()
    client.text_document_did_open(lsp.DidOpenTextDocumentParams(lsp.TextDocumentItem(uri, "sgt", 1, text)))
    await _diagnostics(client, uri)
    return uri


async def _diagnostics(client: LanguageClient, uri: str) -> list[lsp.Diagnostic]:
    client.diagnostics.pop(uri, None)
    while uri not in client.diagnostics:
        await client.wait_for_notification(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    return list(client.diagnostics[uri])


def _pos(text: str, needle: str, offset: int = 0) -> lsp.Position:
    """The position of ``needle`` (plus ``offset`` characters) in ``text``."""
    i = text.index(needle) + offset
    return lsp.Position(text.count("\n", 0, i), i - (text.rfind("\n", 0, i) + 1))


def _labels(result) -> list[str]:
    items = result.items if isinstance(result, lsp.CompletionList) else result
    return [i.label for i in items]


async def _complete(client, uri: str, text: str, needle: str, offset: int | None = None):
    pos = _pos(text, needle, len(needle) if offset is None else offset)
    return await client.text_document_completion_async(lsp.CompletionParams(lsp.TextDocumentIdentifier(uri), pos))


def _apply(text: str, edits: list[lsp.TextEdit]) -> str:
    lines = text.split("\n")
    offsets = [0]
    for line in lines:
        offsets.append(offsets[-1] + len(line) + 1)

    def at(p: lsp.Position) -> int:
        return offsets[p.line] + p.character if p.line < len(lines) else len(text)

    for e in sorted(edits, key=lambda e: (e.range.start.line, e.range.start.character), reverse=True):
        text = text[: at(e.range.start)] + e.new_text + text[at(e.range.end):]
    return text


# -- diagnostics ------------------------------------------------------------------------------

async def test_diagnostics_as_you_type_with_codes_related_places_and_explain_links(client: LanguageClient, workspace):
    text = "guide: hi [pose:point_rigth] there <speed:1>a <space:1>b</speed> c</>\n"
    uri = await _open(client, workspace, text)
    diags = {d.code: d for d in client.diagnostics[uri]}
    assert set(diags) >= {"SGT201", "SGT109"}
    unknown = diags["SGT201"]
    assert unknown.severity == lsp.DiagnosticSeverity.Error and unknown.source == "sgt"
    assert unknown.range == lsp.Range(_pos(text, "point_rigth"), _pos(text, "point_rigth", 11))
    assert "unknown gesture 'point_rigth'" in unknown.message and "did you mean 'point_right'" in unknown.message
    page = Path(unknown.code_description.href.removeprefix("file://"))
    assert page.read_text(encoding="utf-8").startswith("# SGT201 unknown-gesture") and "sgt explain SGT201" in page.read_text()
    related = diags["SGT109"].related_information
    assert related and related[0].location.uri == uri and related[0].location.range.start == _pos(text, "<space")

    fixed = text.replace("point_rigth", "point_right").replace("</speed>", "</space>")
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=2), [lsp.TextDocumentContentChangeWholeDocument(fixed)]))
    assert await _diagnostics(client, uri) == []
    # an incremental change: a typo typed back in
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=3),
        [lsp.TextDocumentContentChangePartial(lsp.Range(_pos(fixed, "point_right", 5), _pos(fixed, "point_right", 6)), "")]))
    assert [d.code for d in await _diagnostics(client, uri)] == ["SGT201"]
    client.text_document_did_close(lsp.DidCloseTextDocumentParams(lsp.TextDocumentIdentifier(uri)))
    assert await _diagnostics(client, uri) == []  # closed: its diagnostics are cleared


# -- completion -------------------------------------------------------------------------------

async def test_completion_of_gestures_with_details_and_user_folders(client: LanguageClient, workspace):
    text = MAIN + "guide: look [pose:po\n"
    uri = await _open(client, workspace, text)
    result = await _complete(client, uri, text, "[pose:po")
    labels = _labels(result)
    assert "point_right" in labels and "wave" in labels and "my_wave" in labels  # built-in and user gestures
    item = next(i for i in result.items if i.label == "point_right")
    assert item.detail.startswith("1.2 s · deictic") and item.text_edit.new_text == "point_right"
    assert item.text_edit.range.start == _pos(text, "[pose:po", 6)  # replaces what was typed
    mine = next(i for i in result.items if i.label == "my_wave")
    assert "my_gestures" in mine.detail
    resolved = await client.completion_item_resolve_async(item)
    assert "Point to the character's right" in resolved.documentation.value
    assert any("\u2800" < c <= "\u28ff" for c in resolved.documentation.value)  # the stroke's braille figure


async def test_completion_of_pose_options(client: LanguageClient, workspace):
    text = "guide: look [pose:wave x2 f\n"
    uri = await _open(client, workspace, text)
    labels = _labels(await _complete(client, uri, text, " f"))
    assert labels == ["flip", "hold="]  # x1/x2/x3: the speed is given already
    labels = _labels(await _complete(client, uri, text, "[pose:wave "))
    assert labels[:3] == ["x1", "x2", "x3"] and "hold=" in labels
    text2 = "guide: look [pose:wave hold=\n"
    uri2 = await _open(client, workspace, text2)
    assert "500ms" in _labels(await _complete(client, uri2, text2, "hold="))


async def test_completion_of_styles_presets_and_closing_tags(client: LanguageClient, workspace):
    text = MAIN + "guide: <sp\n"
    uri = await _open(client, workspace, text)
    result = await _complete(client, uri, text, "guide: <sp")
    labels = _labels(result)
    assert {"speed", "space", "handedness", "happy", "calm", "shy"} <= set(labels)
    shy = next(i for i in result.items if i.label == "shy")
    assert shy.detail == "preset: space:-2 handedness:-1"
    assert next(i for i in result.items if i.label == "speed").text_edit.new_text == "speed:"
    text2 = "guide: <calm speed:-1>slowly </\n"
    uri2 = await _open(client, workspace, text2)
    assert _labels(await _complete(client, uri2, text2, "</")) == ["calm>"]


async def test_completion_of_look_targets_and_face_expressions(client: LanguageClient, workspace):
    text = "guide: Hello.\nvisitor: Hi [look:\nvisitor: and [look:left h\nguide: <face:\n"
    uri = await _open(client, workspace, text)
    labels = _labels(await _complete(client, uri, text, "Hi [look:"))
    assert {"guide", "visitor", "left", "right", "up", "down", "ahead"} == set(labels)  # this script's speakers only
    assert _labels(await _complete(client, uri, text, "[look:left h")) == ["hold="]
    assert "look:" in _labels(await _complete(client, uri, text, "Hi ["))
    faces = await _complete(client, uri, text, "<face:")
    assert {"smile", "happy", "sad", "angry", "surprised", "neutral"} <= set(_labels(faces))
    assert "face" in _labels(await _complete(client, uri, text, "guide: <"))


async def test_completion_of_directives_voices_and_variants(client: LanguageClient, workspace):
    text = "@vo\n@voice en-g\n@voice guide: en-us+\nguide: hi\n"
    uri = await _open(client, workspace, text)
    assert "@voice" in _labels(await _complete(client, uri, text, "@vo"))
    voices = _labels(await _complete(client, uri, text, "en-g"))
    assert "en-gb" in voices and "en-us" in voices and "guide:" in voices  # a per-speaker voice
    variants = await _complete(client, uri, text, "en-us+")
    assert "en-us+m3" in _labels(variants) and variants.items[0].text_edit.new_text == variants.items[0].label.split("+")[1]


async def test_completion_of_speakers_from_the_file_and_the_workspace(client: LanguageClient, workspace):
    text = "guide: hello.\nguide: again.\nvis\n"
    uri = await _open(client, workspace, text)
    result = await _complete(client, uri, text, "vis")
    labels = _labels(result)
    assert labels[0] == "guide:"  # this script's first
    assert "visitor:" in labels and "merchant:" in labels  # main.sgt's and scenes/other.sgt's
    assert result.items[0].text_edit.new_text == "guide: "


# -- hover ------------------------------------------------------------------------------------

async def test_hover_on_gestures_styles_presets_and_words(client: LanguageClient, workspace):
    uri = await _open(client, workspace, MAIN)

    async def hover(needle: str, offset: int = 1) -> str:
        h = await client.text_document_hover_async(lsp.HoverParams(lsp.TextDocumentIdentifier(uri), _pos(MAIN, needle, offset)))
        return h.contents.value if h else ""

    wave = await hover("[pose:wave", 7)
    assert "**wave**: Wave hello" in wave and "emblem" in wave and "1.8 s" in wave and "stroke" in wave
    assert any("\u2800" < c <= "\u28ff" for c in wave)
    assert "from " in await hover("my_wave") and "my_gestures" in await hover("my_wave")
    assert "mean speed of all joints" in await hover("speed:-1") and "-3 to 3" in await hover("speed:-1")
    shy = await hover("<shy>", 2)
    assert "preset of this script, line 5" in shy and "@preset shy = space:-2 handedness:-1" in shy
    word = await hover("welcome")
    assert word.startswith("**welcome** (word 3 of utterance 1):") and "estimated" in word
    assert "voice en-gb" in await hover("visitor:", 0)


# -- definition, references, rename -----------------------------------------------------------

async def test_go_to_definition_of_gestures_and_presets(client: LanguageClient, workspace):
    uri = await _open(client, workspace, MAIN)

    async def define(needle: str, offset: int = 1):
        return await client.text_document_definition_async(
            lsp.DefinitionParams(lsp.TextDocumentIdentifier(uri), _pos(MAIN, needle, offset)))

    (builtin,) = await define("[pose:wave", 7)
    assert builtin.uri == (BUILTIN_DIR / "wave.toml").as_uri() and builtin.range.start.line == 0
    (user,) = await define("my_wave")
    assert user.uri == (workspace / "my_gestures" / "my_wave.toml").as_uri()
    (preset,) = await define("<shy>", 2)
    assert preset.uri == uri and preset.range.start == _pos(MAIN, "shy = ")
    assert not await define("<speed", 1)  # a style element has no definition


async def test_references_and_rename_across_the_workspace(client: LanguageClient, workspace):
    uri = await _open(client, workspace, MAIN)
    other = (workspace / "scenes" / "other.sgt").as_uri()
    at = lsp.TextDocumentIdentifier(uri)
    refs = await client.text_document_references_async(lsp.ReferenceParams(
        text_document=at, position=_pos(MAIN, "guide: Over"), context=lsp.ReferenceContext(include_declaration=True)))
    places = {(r.uri, r.range.start.line) for r in refs}
    assert {(uri, 6), (uri, 8), (other, 0)} <= places

    edit = await client.text_document_rename_async(lsp.RenameParams(at, _pos(MAIN, "visitor:"), "tourist"))
    assert [(e.range.start.line, e.new_text) for e in edit.changes[uri]] == [(2, "tourist"), (7, "tourist")]

    edit = await client.text_document_rename_async(lsp.RenameParams(at, _pos(MAIN, "<shy>", 1), "timid"))
    assert _apply(MAIN, edit.changes[uri]).count("timid") == 3  # @preset, <timid>, </timid>

    edit = await client.text_document_rename_async(lsp.RenameParams(at, _pos(MAIN, "my_wave"), "my_hello"))
    ops = edit.document_changes
    renames = [op for op in ops if isinstance(op, lsp.RenameFile)]
    assert renames and renames[0].new_uri.endswith("my_gestures/my_hello.toml")
    edited = {op.text_document.uri for op in ops if isinstance(op, lsp.TextDocumentEdit)}
    assert {uri, other, (workspace / "my_gestures" / "my_wave.toml").as_uri()} <= edited

    with pytest.raises(Exception, match="built-in gesture"):
        await client.text_document_prepare_rename_async(lsp.PrepareRenameParams(at, _pos(MAIN, "[pose:wave", 7)))


# -- code actions -----------------------------------------------------------------------------

async def _actions(client, uri: str, text: str, needle: str) -> list[lsp.CodeAction]:
    pos = _pos(text, needle, 1)
    diags = client.diagnostics.get(uri, [])
    return await client.text_document_code_action_async(lsp.CodeActionParams(
        lsp.TextDocumentIdentifier(uri), lsp.Range(pos, pos), lsp.CodeActionContext(diagnostics=diags)))


async def test_code_actions_apply_every_diagnostics_fixes(client: LanguageClient, workspace):
    text = "guide: [pose:point_rigth] hi [pause 300] there <speed:1>a</space> b\nguide: [pose:wave hello\n"
    uri = await _open(client, workspace, text)
    titles = {a.title: a for a in await _actions(client, uri, text, "point_rigth")}
    fixed = _apply(text, titles["replace with 'point_right'"].edit.changes[uri])
    assert "[pose:point_right]" in fixed
    units = {a.title for a in await _actions(client, uri, text, "300]")}
    assert {"write 300ms", "write 300s"} <= units
    closing = {a.title: a for a in await _actions(client, uri, text, "</space>")}
    assert "[pose:point_rigth] hi [pause 300] there <speed:1>a</speed> b" in _apply(text, closing["close <speed...> here"].edit.changes[uri])
    unclosed = {a.title: a for a in await _actions(client, uri, text, "[pose:wave")}
    assert "guide: [pose:wave] hello" in _apply(text, unclosed["close the tag: add ']'"].edit.changes[uri])


async def test_code_action_re_times_a_gesture_whose_stroke_misses_its_word(client: LanguageClient, workspace):
    text = "guide: [pose:beat_both] one [pose:sweep] two three four.\n"
    uri = await _open(client, workspace, text)
    assert [d.code for d in client.diagnostics[uri]] == ["SGT401"]
    titles = {a.title: a for a in await _actions(client, uri, text, "[pose:beat_both")}
    action = titles["re-time 'sweep' to x2 ('beat_both' then makes its word)"]
    fixed = _apply(text, action.edit.changes[uri])
    assert fixed == "guide: [pose:beat_both] one [pose:sweep x2] two three four.\n"
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=2), [lsp.TextDocumentContentChangeWholeDocument(fixed)]))
    assert await _diagnostics(client, uri) == []  # the stroke now lands on its word


async def test_re_timing_a_later_line_leaves_the_first_lines_recording_to_it(client: LanguageClient, workspace):
    """An `@audio` before the first line is that line's: the action's trial of a later line
    (the header and that line) does not give it the recording, whose words it does not say."""
    import wave  # lazy: only this test writes a recording

    (workspace / "rec").mkdir()
    with wave.open(str(workspace / "rec" / "rec.wav"), "wb") as w:  # two seconds of silence, timed by rec.json
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(16000)
        w.writeframes(b"\0\0" * 32000)
    (workspace / "rec" / "rec.json").write_text(
        '[{"word": "hello", "start": 0.2, "end": 0.6}, {"word": "there", "start": 0.7, "end": 1.2}]', encoding="utf-8")
    text = ("@audio rec/rec.wav timings=rec/rec.json\nbot: Hello there.\n"
            "guide: [pose:beat_both] one [pose:sweep] two three four.\n")
    uri = await _open(client, workspace, text)
    assert [(d.code, d.range.start.line) for d in client.diagnostics[uri]] == [("SGT401", 2)]
    titles = {a.title for a in await _actions(client, uri, text, "[pose:beat_both")}
    assert "re-time 'sweep' to x2 ('beat_both' then makes its word)" in titles


async def test_a_rejected_recording_can_be_timed_by_the_aligners_times_in_one_action(client: LanguageClient, workspace):
    """SGT407 (the check rejects a recording's transcript) offers to write the times the
    aligner found (sgt align's file) and name it on the @audio directive: the command writes
    the file, the client applies the edit, and the diagnostic is gone; with the file there,
    the action names it and never replaces it."""
    import numpy as np  # lazy: only this test makes a recording
    import soundfile as sf  # lazy: only this test makes a recording

    from dsl.speech import _espeak, synthesize  # lazy: espeak-ng, only this test speaks

    if _espeak.find_library() is None:
        pytest.skip("libespeak-ng not installed")
    said = "Well, hello there my friend. How are you today?"
    speech = synthesize(said, [(0, 4), (6, 11), (12, 17), (18, 20), (21, 27), (29, 32), (33, 36), (37, 40), (41, 46)],
                        cache_dir=workspace / "syn")
    x, sr = sf.read(str(speech.audio_path))
    sf.write(str(workspace / "said.wav"), np.concatenate([np.zeros(sr // 4), x, np.zeros(sr // 4)]), sr)
    text = "@audio said.wav\nbot: Well, hello there my dear friend. How are you today?\n"
    uri = await _open(client, workspace, text, "said.sgt")
    assert [d.code for d in client.diagnostics[uri]] == ["SGT407"]
    edits = []

    @client.feature(lsp.WORKSPACE_APPLY_EDIT)
    def apply_edit(params: lsp.ApplyWorkspaceEditParams):
        edits.extend(params.edit.changes[uri])
        return lsp.ApplyWorkspaceEditResult(applied=True)

    (offered,) = [a.title for a in await _actions(client, uri, text, "dear") if "aligner" in a.title]
    # (pytest-lsp's client reads a code action that carries a command as a Command; the
    # action itself, as the server builds it:)
    from sgt_tui.lsp import actions  # lazy: the server's code, in this process
    from sgt_tui.lsp.documents import Documents  # lazy: the server's code, in this process

    doc = Documents().open(uri, text, 1)
    pos = _pos(text, "dear", 1)
    (action,) = [a for a in actions.code_actions(doc, lsp.Range(pos, pos)) if a.title == offered]
    assert action.edit is None and action.command.command == "sgt.writeTimings" and action.command.arguments == [uri, 2]
    result = await client.workspace_execute_command_async(lsp.ExecuteCommandParams(
        action.command.command, action.command.arguments))
    target = workspace / "said.timings.json"
    assert result["path"] == str(target) and "'dear'" in result["rejection"] and target.exists()
    fixed = _apply(text, edits)
    assert fixed == "@audio said.wav timings=said.timings.json\nbot: Well, hello there my dear friend. How are you today?\n"
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=2), [lsp.TextDocumentContentChangeWholeDocument(fixed)]))
    assert await _diagnostics(client, uri) == []  # timed by the file now
    # the file exists: the action only names it, and the command refuses to replace it
    client.text_document_did_change(lsp.DidChangeTextDocumentParams(
        lsp.VersionedTextDocumentIdentifier(uri=uri, version=3), [lsp.TextDocumentContentChangeWholeDocument(text)]))
    await _diagnostics(client, uri)
    before = target.read_bytes()
    (named,) = [a for a in await _actions(client, uri, text, "dear") if "exists" in a.title]
    assert named.command is None
    assert _apply(text, named.edit.changes[uri]).startswith("@audio said.wav timings=said.timings.json\n")
    with pytest.raises(Exception, match="exists"):
        await client.workspace_execute_command_async(lsp.ExecuteCommandParams("sgt.writeTimings", [uri, 2]))
    assert target.read_bytes() == before


# -- formatting, symbols, folding, semantic tokens, inlay hints ------------------------------

async def test_formatting_is_sgt_fmt(client: LanguageClient, workspace):
    text = "@voice   en-us\n\n\nguide :  [ pose:wave  x2 ]  Hello,   there!   # hi\n        and more.\n"
    uri = await _open(client, workspace, text)
    edits = await client.text_document_formatting_async(lsp.DocumentFormattingParams(
        lsp.TextDocumentIdentifier(uri), lsp.FormattingOptions(4, True)))
    assert _apply(text, edits) == format_source(text) != text
    bad = await _open(client, workspace, "guide: [pose:wave\n")
    before = len(client.messages)
    assert await client.text_document_formatting_async(lsp.DocumentFormattingParams(
        lsp.TextDocumentIdentifier(bad), lsp.FormattingOptions(4, True))) is None
    if len(client.messages) == before:
        await client.wait_for_notification(lsp.WINDOW_SHOW_MESSAGE)
    assert "syntax errors" in client.messages[-1].message


async def test_document_symbols_are_utterances_by_speaker(client: LanguageClient, workspace):
    uri = await _open(client, workspace, MAIN)
    symbols = await client.text_document_document_symbol_async(lsp.DocumentSymbolParams(lsp.TextDocumentIdentifier(uri)))
    assert [s.name for s in symbols] == ["header", "guide", "visitor"]
    assert [c.name for c in symbols[0].children] == ["shy"]
    guide = symbols[1]
    assert [c.name for c in guide.children] == ["1. Hello, and welcome! I can help you.",
                                                "3. Over there, on the right, and take your time."]
    assert guide.children[1].range.start.line == 8 and guide.children[1].range.end.line == 9


async def test_folding_ranges(client: LanguageClient, workspace):
    text = "# one\n# two\n@voice en-us\n@rate 160\n\nguide: a\n    b\n    c\nguide: d\n"
    uri = await _open(client, workspace, text)
    ranges = await client.text_document_folding_range_async(lsp.FoldingRangeParams(lsp.TextDocumentIdentifier(uri)))
    got = {(r.start_line, r.end_line, r.kind) for r in ranges}
    assert got == {(2, 3, lsp.FoldingRangeKind.Region), (5, 7, None), (0, 1, lsp.FoldingRangeKind.Comment)}


async def test_semantic_tokens(client: LanguageClient, workspace):
    text = "@rate 160  # fast\nguide: [pose:wave x2] <calm>hi \\[ok\\]</calm>\n"
    uri = await _open(client, workspace, text)
    legend = TOKEN_TYPES
    tokens = await client.text_document_semantic_tokens_full_async(lsp.SemanticTokensParams(lsp.TextDocumentIdentifier(uri)))
    row = col = 0
    found = []
    data = tokens.data
    for i in range(0, len(data), 5):
        row += data[i]
        col = data[i + 1] + (col if data[i] == 0 else 0)
        line = text.split("\n")[row]
        found.append((line[col : col + data[i + 2]], legend[data[i + 3]]))
    assert ("@rate", "keyword") in found and ("160", "number") in found and ("# fast", "comment") in found
    assert ("guide:", "class") in found or ("guide", "class") in found
    assert ("wave", "function") in found and ("x2", "number") in found and ("calm", "function") in found
    assert ("\\[", "string") in found and ("[", "operator") in found


async def test_inlay_hints_give_each_utterances_start_and_length(client: LanguageClient, workspace):
    text = "@gap 1s\nguide: Hello there.\nguide: And again, once more.  # two\n"
    uri = await _open(client, workspace, text)
    hints = await client.text_document_inlay_hint_async(lsp.InlayHintParams(
        lsp.TextDocumentIdentifier(uri), lsp.Range(lsp.Position(0, 0), lsp.Position(3, 0))))
    assert [(h.position.line, h.position.character) for h in hints] == [(1, 19), (2, 28)]
    first, second = (h.label for h in hints)
    assert first.startswith("≈0.00 s · ") and second.startswith("≈")
    start2, length1 = float(second[1:].split(" s")[0]), float(first.split("· ")[1].split(" s")[0])
    assert start2 >= length1 + 0.9  # after the first line's speech and the 1 s gap


# -- preview ----------------------------------------------------------------------------------

async def test_preview_command_renders_the_utterance_at_the_cursor(client: LanguageClient, workspace):
    text = "guide: Hello.\nguide: [pose:wave] Welcome to the mall.\n"
    uri = await _open(client, workspace, text)
    result = await client.workspace_execute_command_async(lsp.ExecuteCommandParams(
        "sgt.preview", [{"uri": uri, "line": 1, "engine": "keyframe"}]))
    gif = Path(result["gif"])
    assert result["utterance"] == 2 and gif.suffix == ".gif" and gif.read_bytes()[:6] == b"GIF89a" and result["frames"] > 10
    h = await client.text_document_hover_async(lsp.HoverParams(lsp.TextDocumentIdentifier(uri), _pos(text, "Welcome", 1)))
    assert "speech timing" in h.contents.value and "estimated" not in h.contents.value  # real times once cached
    with pytest.raises(Exception, match="no utterances|nothing to generate"):
        empty = await _open(client, workspace, "# nothing\n")
        await client.workspace_execute_command_async(lsp.ExecuteCommandParams("sgt.preview", [empty, 0]))
