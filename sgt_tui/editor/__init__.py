"""The editing model of ``sgt edit``, in plain Python (no Textual import; a test enforces it).

- :mod:`~sgt_tui.editor.document`: the text as lines and one undo history for every change
- :mod:`~sgt_tui.editor.files`: opening and saving scripts atomically, noticing changes on disk
- :mod:`~sgt_tui.editor.recovery`: the recovery file that keeps unsaved work through a crash
- :mod:`~sgt_tui.editor.tokens`: a line read by the language's own scanner, tolerant of typos
- :mod:`~sgt_tui.editor.highlight`: syntax classes of each line of a script
- :mod:`~sgt_tui.editor.analysis`: diagnostics and estimated plans, re-analysing only what changed
- :mod:`~sgt_tui.editor.edits`: text edits made by actions (insert a pose, apply a style, move a
  pose, apply a diagnostic's fix)
- :mod:`~sgt_tui.editor.timeline`: the timeline of one utterance laid out in character cells
- :mod:`~sgt_tui.editor.takes`: what the preview and timeline show: generated motion, else a draft
- :mod:`~sgt_tui.editor.player`: preview playback state (frame, playing) at the motion frame rate
- :mod:`~sgt_tui.editor.jobs` and :mod:`~sgt_tui.editor.worker`: long work in a subprocess,
  with progress messages and cancellation; :mod:`~sgt_tui.editor.protocol`: the typed requests,
  results and events they exchange

The Textual widgets in :mod:`sgt_tui.app` are thin views over these.
"""
