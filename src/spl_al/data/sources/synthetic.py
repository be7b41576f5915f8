"""Source ``synthetic``: procedural images, observed (``spl_al.data.procedural``).

Reads ``task`` and ``synthesis`` (the keyword arguments of
``make_classification_dataset`` or ``make_segmentation_dataset``; ``seed`` among them).
"""

from __future__ import annotations

from spl_al.data.dataset import Dataset
from spl_al.data.procedural import make_classification_dataset, make_segmentation_dataset
from spl_al.data.sources.base import always, register, synthesis_options


def synthesize(entry: dict) -> Dataset:
    """The procedural dataset of the entry's task from its ``synthesis`` options."""
    make = (
        make_classification_dataset
        if entry["task"] == "classification"
        else make_segmentation_dataset
    )
    return make(**synthesis_options(entry))


@register("synthetic", synthesised=always, levels=always)
def build(entry: dict, *, release_dir=None) -> Dataset:
    """Synthesize the dataset (``release_dir`` is not used)."""
    return synthesize(entry)
