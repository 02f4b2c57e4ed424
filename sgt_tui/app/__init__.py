"""The Textual front of ``sgt edit``: thin widgets over the editing model in :mod:`sgt_tui.editor`.

- :mod:`~sgt_tui.app.main`: the application, its keys and command-palette entries
- :mod:`~sgt_tui.app.script_area`: the text area (highlighting, diagnostics, one undo history)
- :mod:`~sgt_tui.app.panels`: preview, timeline, status and job bars
- :mod:`~sgt_tui.app.screens`: problems list, motion library, style, and choice dialogs

Importing this package imports Textual; the ``sgt`` command imports it only inside
``sgt edit`` so that ``sgt --help`` stays fast.
"""
