"""The generation engines by name, and the one every path uses when none is named.

numpy-free (names only): the commands read it to build their ``--engine`` options without
importing the engines (``sgt --help`` stays fast). :mod:`model.generate` runs them.
"""

from __future__ import annotations

#: Engine name -> module with ``generate(inputs, *, seed, ...)``.
ENGINES = {
    "matching": "model.matching",  # motion matching over the training takes (shipped database)
    "neural": "model.neural",  # the controllable network (shipped weights)
    "flow": "model.flow",  # flow matching: a network that samples takes (shipped weights model/weights/flow.pt)
    "keyframe": "model.keyframe",  # SGToolkit's MANUAL condition: splines through the pose controls
    "rules": "model.teacher",  # the rule-based teacher of the procedural corpus
}

#: The engine of every path that names none: the commands, the editor, the language server's
#: preview, the service and its stream, ``sgt view``, ``sgt build`` and ``sgt eval``. Motion
#: matching moves like its teacher where the network averages it away (docs/model.md, "Which
#: engine ships as the default").
DEFAULT_ENGINE = "matching"

#: Engines that ``sgt eval`` measures in its model rows.
EVAL_ENGINES = ("matching", "neural", "flow")

#: Engines that run a network's weights file (``--weights``; each its own shipped file,
#: ``model.weights.default_weights(engine)``): what a build's cache key and manifest hash.
NETWORK_ENGINES = ("neural", "flow")
