"""The Textual front of ``sgt edit``: thin widgets over the editing model in :mod:`sgt_tui.editor`.

- :mod:`~sgt_tui.app.main`: the application: widgets wired to the services and flows below
- :mod:`~sgt_tui.app.actions`: every action once (key, footer, help) and the command palette
- :mod:`~sgt_tui.app.services`: live analysis, disk watching, recovery and jobs, with typed messages
- :mod:`~sgt_tui.app.file_flow` / :mod:`~sgt_tui.app.job_flow`: the dialogs around the file, the jobs
- :mod:`~sgt_tui.app.script_area`: the text area (highlighting, diagnostics, one undo history)
- :mod:`~sgt_tui.app.panels`: preview, timeline, status and job bars
- :mod:`~sgt_tui.app.screens`: problems list, motion library, style, choice and question dialogs

Importing this package imports Textual; the ``sgt`` command imports it only inside
``sgt edit`` so that ``sgt --help`` stays fast.
"""
