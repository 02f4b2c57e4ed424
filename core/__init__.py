"""The bottom layer: data types and conventions every other package shares.

numpy and the standard library only (no torch, lark, textual, GL), so that a CLI, a
server, a language server or a notebook can import it cheaply. Nothing here imports
another sgt package; every other package imports this one downward (see DEVELOPERS.md
and the import-linter contracts in pyproject.toml).

- :mod:`core.skeleton`    joints, bones, the 27-number pose, the frame rate
- :mod:`core.controls`    the control layout (SGToolkit Eq. 1-3), :class:`~core.controls.Control`
- :mod:`core.words`       :class:`~core.words.TimedWord`, the one timed-word type
- :mod:`core.motion`      :class:`~core.motion.MotionClip` and the motion-file schema
- :mod:`core.diagnostics` diagnostics as data, and their one text/JSON renderer
- :mod:`core.rules`       the registry of diagnostic codes (``sgt explain``)
- :mod:`core.fileio`      safe file writes
- :mod:`core.interrupts`  ctrl+c held while a library would swallow it
- :mod:`core.paths`       user locations: config, cache, gesture folders (XDG honoured)
- :mod:`core.seeds`       the range of random seeds (``@seed``, ``--seed``)
"""
