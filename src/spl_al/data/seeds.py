"""Per-sample random streams: every random draw of sample ``uid`` comes from a
generator keyed by (seed, stream, uid), so that chunking, sharding, worker count
and sample order never change a result.
"""

from __future__ import annotations

import numpy as np

STREAM_SCENE = 0  # procedural scene geometry
STREAM_OBSERVE = 1  # photons of the observed image
STREAM_VARIANT = 2  # conditions and photons of the SIV variants
STREAM_SPLIT = 3  # train / test split and condition levels (dataset-wide)
STREAM_SUBSET = 4  # which files of an external folder are kept (n_per_class)
STREAM_INSTANCE = 5  # the shape of a physical object instance (keyed by class, instance)
STREAM_VALIDATION = 6  # the validation split carved from the training pool for tuning


def sample_rng(seed: int, stream: int, uid: int = 0) -> np.random.Generator:
    """Generator for sample ``uid`` in ``stream`` under ``seed`` (SeedSequence spawn key)."""
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}.")
    return np.random.default_rng(
        np.random.SeedSequence(int(seed), spawn_key=(int(stream), int(uid)))
    )
