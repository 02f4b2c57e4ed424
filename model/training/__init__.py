"""Dataset building, training and evaluation of the generator (above the engines).

- :mod:`model.training.corpus`       the procedural corpus (speech + teacher motion)
- :mod:`model.training.loaders`      user motion-capture takes (BVH + WAV + word timings)
- :mod:`model.training.train`        the training loop (Eq. 7), :mod:`~model.training.train_config` its settings
- :mod:`model.training.evaluate`     the metrics table on a held-out split (``sgt eval``)
- :mod:`model.training.metrics`      FGD, PCS, SCS, motion statistics, Hellinger distances
- :mod:`model.training.fgd`          the FGD feature extractor

The engines in :mod:`model` never import this package.
"""
