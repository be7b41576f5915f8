"""Training, prediction and evaluation of spl_al models.

Public API:

- ``Compute`` (device, threads, precision; ``resolved`` once per step) and ``LOCAL``.
- ``TrainConfig`` (``from_dict``, ``paper``), ``resolve_device(name)``.
- ``flatten_groups(depth_m, valid, targets, variants=True)``: groups to training images.
- ``train(model, depth_m, valid, targets, *, cfg, seed, compute=None, log=None) -> model``.
- ``predict(model, depth_m, valid, *, compute=None, batch_size=256, features="image")
  -> Predictions(probs, features)`` (``forward``).
- ``evaluate(model, depth_m, valid, targets, levels=None, classes=None, compute=None) -> dict``.
"""

from importlib import import_module

# The API below loads on first use (PEP 562): ``spl_al.training.compute`` and
# ``spl_al.training.recipe`` are imported by job scripts and the workflow, which must
# not pay torch's import for them.
_HOMES = {
    "Compute": "compute",
    "LOCAL": "compute",
    "MEASURE_PRECISION": "precision",
    "Predictions": "forward",
    "TrainConfig": "recipe",
    "confusion_per_image": "metrics",
    "deterministic_algorithms": "device",
    "evaluate": "metrics",
    "flatten_groups": "fit",
    "iter_forward": "forward",
    "masked_cross_entropy": "fit",
    "pool_pixels": "forward",
    "predict": "forward",
    "resolve_device": "device",
    "summarise": "metrics",
    "train": "fit",
}


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module 'spl_al.training' has no attribute {name!r}")
    value = getattr(import_module(f"spl_al.training.{_HOMES[name]}"), name)
    globals()[name] = value
    return value


__all__ = [
    "LOCAL",
    "MEASURE_PRECISION",
    "Compute",
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
