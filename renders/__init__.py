"""Offscreen rendering and exports of motion (``sgt render``, ``sgt export``).

- :mod:`renders.gl`: picks EGL or OSMesa for pyrender (lazily; workarounds documented there)
- :mod:`renders.mannequin`: the shaded mannequin scene, posed per frame
- :mod:`renders.overlay`: word, control timeline, playhead and time drawn with Pillow
- :mod:`renders.gifwriter`: streaming 15 fps GIF writer with one shared palette
- :mod:`renders.animate`: preview GIFs, comparison GIFs and contact sheets
- :mod:`renders.export`: BVH and CSV exports
- :mod:`renders.clips`: choosing and joining utterances

Nothing here imports pyrender, OpenGL or trimesh at import time except
:mod:`renders.mannequin` when a :class:`~renders.mannequin.Mannequin` is made.
"""
