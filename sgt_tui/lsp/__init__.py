"""The language server (``sgt lsp``): the editor's analysis behind the Language Server Protocol.

- :mod:`~sgt_tui.lsp.documents`: each open script's text and its analysis (the editor's chunked
  :class:`sgt_tui.editor.analysis.Analyser`, one per document), positions between LSP and sgt
- :mod:`~sgt_tui.lsp.features`: what each request answers (completion, hover, definitions,
  references, rename, code actions, symbols, folding, semantic tokens, inlay hints), as plain
  functions of a document and a position
- :mod:`~sgt_tui.lsp.index`: the names in scripts, and the workspace's scripts (read only under
  its folders, through the bounded reader; the scan bounded)
- :mod:`~sgt_tui.lsp.aligning`: recordings aligned in a child process, so no request waits
- :mod:`~sgt_tui.lsp.server`: the pygls server that wires them to the protocol, answering every
  request in one line

No Textual here (import-linter checks it): the server stands on the editor model
(:mod:`sgt_tui.editor`), not on the app.
"""
