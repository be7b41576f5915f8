"""Datasets that share another's embedding framework: ``embedding: {shared: SOURCE}``.

A dataset whose scans are another's (street_pc's point clouds are street_seg's scans: a
point is a valid pixel) has the same embedding experiment. ``share_embeddings`` resolves
the config once (the Snakefile, ``bench estimate``): the dataset's block becomes the
source's, and the workflow reads the source's encoders and relabels its runs
(``embedding_steps.shared_runs``, which checks the two data files hold the same arrays).
"""

from __future__ import annotations

import copy

from spl_al.config import ONLY_DATASETS
from spl_al.frameworks import EMBEDDING

SHARED = "shared"
"""The embedding block's key naming the dataset whose embedding runs a dataset shares."""
RUNS_READ = ("task", "al", "method_params")
"""What a dataset's embedding runs read of its entry, besides its data and its block."""


def share_embeddings(config: dict) -> dict[str, str]:
    """Resolve every ``embedding: {shared: SOURCE}`` of ``config`` in place.

    A dataset whose scans are another's (street_pc's point clouds are street_seg's
    scans: a point is a valid pixel) has the same embedding experiment: the same
    encoders, units and probe. ``shared`` makes it read that dataset's encoders and
    runs instead of drawing its own: its block becomes a copy of the source's, with
    ``shared`` kept. Returns {dataset: source}. Raises ValueError naming the key:
    ``shared`` beside other keys, a source that is not a dataset of this run, has no
    embedding block of its own, or reads another task, budget or method setting
    (``RUNS_READ``).
    """
    datasets = config.get("datasets") or {}
    shared = {}
    for name, entry in datasets.items():
        block = entry.get(EMBEDDING.block) or {}
        if SHARED not in block:
            continue
        key = f"datasets.{name}.{EMBEDDING.block}"
        source = block[SHARED]
        own = (datasets.get(source) or {}).get(EMBEDDING.block) or {}
        if set(block) != {SHARED} and block != {**own, SHARED: source}:  # resolved already
            others = ", ".join(sorted(set(block) - {SHARED}))
            raise ValueError(
                f"config key {key!r} sets {SHARED} and {others}; expected {SHARED} alone "
                f"(the whole block is {source!r}'s)."
            )
        if source == name or not own or SHARED in own:
            raise ValueError(
                f"config key '{key}.{SHARED}' names {source!r}; expected another dataset "
                f"of this run ({ONLY_DATASETS} lists it too) with an embedding block of "
                "its own."
            )
        for part in RUNS_READ:
            if entry.get(part) != datasets[source].get(part):
                raise ValueError(
                    f"config key 'datasets.{name}.{part}' differs from "
                    f"'datasets.{source}.{part}', whose embedding runs {name} shares; "
                    f"expected the same {part}, or an embedding block of {name}'s own."
                )
        entry[EMBEDDING.block] = {**copy.deepcopy(own), SHARED: source}
        shared[name] = source
    return shared
