"""Training, prediction and evaluation of spl_al models.

Public API:

- ``TrainConfig`` (``from_dict``, ``paper``), ``resolve_device(name)``.
- ``flatten_groups(depth_m, valid, targets, variants=True)``: groups to training images.
- ``train(model, depth_m, valid, targets, *, cfg, seed, device=None, log=None) -> model``.
- ``predict(model, depth_m, valid, *, device=None, batch_size=256, features="image")
  -> Predictions(probs, features)``.
- ``evaluate(model, depth_m, valid, targets, levels=None, classes=None, device=None) -> dict``.
"""

from spl_al.training.device import deterministic_algorithms, resolve_device
from spl_al.training.fit import flatten_groups, masked_cross_entropy, train
from spl_al.training.metrics import confusion_per_image, evaluate, summarise
from spl_al.training.precision import MEASURE_PRECISION
from spl_al.training.predict import Predictions, iter_forward, pool_pixels, predict
from spl_al.training.recipe import TrainConfig

__all__ = [
    "MEASURE_PRECISION",
    "Predictions",
    "TrainConfig",
    "confusion_per_image",
    "deterministic_algorithms",
    "evaluate",
    "flatten_groups",
    "iter_forward",
    "masked_cross_entropy",
    "pool_pixels",
    "predict",
    "resolve_device",
    "summarise",
    "train",
]
