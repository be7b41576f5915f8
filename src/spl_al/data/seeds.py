"""The data's per-sample random streams: every random draw of sample ``uid`` comes
from ``sample_rng(seed, stream, uid)`` (``spl_al.seeding``, where every stream of an
experiment is derived), so that chunking, sharding, worker count and sample order
never change a result.
"""

from __future__ import annotations

from spl_al.seeding import sample_rng

__all__ = ["sample_rng"]

STREAM_SCENE = 0  # procedural scene geometry
STREAM_OBSERVE = 1  # photons of the observed image
STREAM_VARIANT = 2  # conditions and photons of the SIV variants
STREAM_SPLIT = 3  # train / test split and condition levels (dataset-wide)
STREAM_SUBSET = 4  # which files of an external folder are kept (n_per_class)
STREAM_INSTANCE = 5  # the shape of a physical object instance (keyed by class, instance)
STREAM_VALIDATION = 6  # the validation split carved from the training pool for tuning
