"""Names vulture reports that are used, each with why (tests/test_dead_code.py runs vulture with
this file; framework conventions are ignored by pattern in pyproject.toml's [tool.vulture]).

Vulture only parses this file: ``_.name`` marks ``name`` as used. Add a name here only with its
reason; delete the code instead when it really is dead.
"""

_ = object  # vulture reads the attribute accesses below; nothing here runs

# -- called by a framework ---------------------------------------------------------------------
# Lark calls transformer methods named after the grammar's rules (dsl/sgt.lark, dsl/body.py).
_.escape
_.style_item
_.style_open
_.style_close
# Textual's TextArea: the script area overrides these to keep one history and its own
# highlighting (sgt_tui/app/script_area.py), and Textual reads them.
_.record
_.history
_.theme

# pygls serialises a completion item the language server fills in when the client resolves it
# (sgt_tui/lsp/features.py, resolve_gesture).
_.documentation
# pygls calls these on the language server's protocol and server (sgt_tui/lsp/server.py: the
# answer to a request, one line and no traceback; an error outside a request, logged).
_._send_handler_result
_.report_server_error

# xml.sax calls a content handler's methods by these names (dsl/xmlread.py, _Builder).
_.setDocumentLocator
_.startElementNS
_.endElementNS
_.characters

# -- used outside the scanned code -------------------------------------------------------------
# The documented command that retrains the shipped FGD extractor (fgd.load's fix message,
# docs/metrics.md); tests/test_evaluate.py runs it on a tiny corpus.
_.train_default_extractor
# The espeak-ng C event enum (dsl/speech/_espeak.py), kept whole next to the members used.
_.EVENT_SENTENCE
_.EVENT_END
_.EVENT_MSG_TERMINATED
_.EVENT_SAMPLERATE
# Read by the tests to observe the editor (sgt_tui/editor, sgt_tui/app): state that tests need
# and the app does not.
_.animating  # tests/test_editor_app.py: the preview timer runs only while visible
_.chunks_analysed  # tests/test_editor_core.py: incremental analysis re-analyses one chunk
_.can_undo  # tests/test_editor_core.py
_.can_redo  # tests/test_editor_core.py
_.reload  # tests/test_editor_core.py: ScriptFile.reload
_.worker_pid  # tests/test_editor_jobs.py: the job worker process is reused


# -- PyAV stream and frame settings (renders/video.py): PyAV reads these attributes -------------
_.pix_fmt
_.time_base
_.thread_count
# renders/video.py: the MP4 writer of `sgt render -o take.mp4`; tests/test_video.py covers
# encode_mp4, which it wraps.
_.write_mp4
# Textual calls these: a command Provider's discover (the palette's list before typing), and the
# TextArea methods the script area overrides so Home/End go to the start/end of a wrapped line.
_.discover
_.get_cursor_line_start_location
_.get_cursor_line_end_location
# Textual reads these: App.app_focus (set when the editor handles a key itself, as Textual's own
# key dispatch does; sgt_tui/app/main.py) and a widget style's overflow_y (sgt_tui/app/script_area.py).
_.app_focus
_.overflow_y
# The utterance whose take is current; tests/test_editor_app.py reads it to check the preview.
_.current_key
# The grammar's own parser (dsl/body.py): the definition the scanner is proved equal to
# (tests/test_scan.py parses random bodies with both).
_.lark_parser
# The Python API's one-call form (README "Python API", model/generate.py's docstring; the README
# block is run by tests/test_readme_api.py).
_.generate_clips
# onnxruntime reads these SessionOptions attributes (model/runtime.py: one thread per session, quiet logs).
_.intra_op_num_threads
_.inter_op_num_threads
_.log_severity_level
# pydantic reads each model's model_config, and Style's fields through model_dump (sgt_tui/serve/requests.py).
_.model_config
_.handedness
# Hand keys sampled at even times, without the speed retiming of Gesture.clip: what
# tests/test_hands.py checks the interpolation of hand keys with.
_.sample_hands
