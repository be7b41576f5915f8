"""The random streams of an experiment's steps, derived in one place.

A stream is named by its **purpose** and keyed by what it belongs to (purposes in
lower case; ``round0`` is ``round0_rng``, ``grid`` ``grid_seed``, ``sample``
``sample_rng``):

| purpose | keyed by | draws |
|---|---|---|
| ``round0`` | seed | round 0's labeled set (random, stratified, or a cold start's tie-breaks) |
| ``train`` | seed, round | a round's initial weights and minibatch order |
| ``query`` | seed, round | the random choices of the query that follows the round |
| ``grid`` | grid seed, MSPPP, SBR | one cell of the robustness map |
| ``sample`` | data seed, stream, sample uid | a sample's scene, photons, variants, split |
| ``acquire`` | seed | the strategy's choices of ``spl_al.query`` (its variants: ``sample``) |

The dataset and the method are not part of any key, on purpose. At one seed every
method starts from the same round-0 set, trains from the same weights stream and
queries with the same random stream, so a paired comparison of two methods varies
their acquisition alone (common random numbers); the two frameworks share the
streams too, so they differ in the model alone. A dataset's runs are its own and no
statistic pairs two datasets' draws; its data are keyed by its own synthesis seed.

Below the step, the training code splits the integer it is handed: ``training.fit``
its minibatch order, augmentation mixing and weight initialisation (from the ``train``
seed), ``training.contrastive`` an encoder's weights and batches (from the encoder's
own seed, ``EncoderConfig.seed``: encoders are a random effect of their own, drawn
apart from the run seeds). Those splits never leave the function that makes them.

A new step draws from a new purpose added here (a new stream number), never from an
existing one, so no earlier draw moves. The numbers below are the ones every earlier
run used: results stay bit-identical.
"""

from __future__ import annotations

import numpy as np

TRAIN, QUERY = "train", "query"

_ROUND_STREAMS = {TRAIN: 1, QUERY: 2}
"""np.random.SeedSequence([seed, round, stream]) of the per-round purposes."""
_ROUND0_STREAM = 0x5EED_0001
"""np.random.default_rng([stream, seed]) of round 0's draw."""
_GRID_STREAM = 11
"""np.random.SeedSequence([seed, stream, msppp x 1000, sbr x 1000]) of a grid cell."""
_ACQUIRE_STREAM = 12
"""np.random.SeedSequence([seed, stream]) of ``spl_al.query``'s strategy."""
_UNITS_STREAM = 13
"""np.random.SeedSequence([encoder seed, stream]) of a dense encoder's sampled units."""


def _as_seed(seed) -> int:
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}.")
    return int(seed)


def _state31(key) -> int:
    return int(np.random.SeedSequence(key).generate_state(1)[0] >> 1)


def round_seed(purpose: str, seed: int, round_: int) -> int:
    """A 31-bit seed of a per-round purpose (``train``, ``query``) of run seed ``seed``
    at round ``round_`` (the query that makes round r + 1 draws at round r)."""
    if purpose not in _ROUND_STREAMS:
        raise ValueError(f"purpose must be one of {list(_ROUND_STREAMS)}, got {purpose!r}.")
    return _state31([_as_seed(seed), int(round_), _ROUND_STREAMS[purpose]])


def round_rng(purpose: str, seed: int, round_: int) -> np.random.Generator:
    """The generator of ``round_seed``."""
    return np.random.default_rng(round_seed(purpose, seed, round_))


def round0_rng(seed: int) -> np.random.Generator:
    """Round 0's generator of run seed ``seed``: the same for every method, framework and
    start (a random draw, a stratified one, a cold start's)."""
    return np.random.default_rng([_ROUND0_STREAM, _as_seed(seed)])


def grid_seed(seed: int, msppp: float, sbr: float) -> int:
    """A 31-bit seed of one robustness-map cell: the grid seed and the cell's values
    alone, so a shard or a wider grid draws each cell the same."""
    return _state31([_as_seed(seed), _GRID_STREAM, round(msppp * 1000), round(sbr * 1000)])


def acquire_rng(seed: int) -> np.random.Generator:
    """The generator of a strategy's random choices in ``spl_al.query`` under ``seed``
    (its frames' variants draw from ``sample_rng(seed, STREAM_VARIANT, frame)``)."""
    return np.random.default_rng(np.random.SeedSequence([_as_seed(seed), _ACQUIRE_STREAM]))


def units_rng(encoder_seed: int) -> np.random.Generator:
    """The generator of the units (pixels) a dense encoder's embeddings keep of each
    training scan (``spl_al.experiment.dense_embedding``): the encoder's own seed, so its
    runs read the same units whatever their run seed."""
    return np.random.default_rng(np.random.SeedSequence([_as_seed(encoder_seed), _UNITS_STREAM]))


def sample_rng(seed: int, stream: int, uid: int = 0) -> np.random.Generator:
    """The generator of sample ``uid`` in data ``stream`` under ``seed``
    (``SeedSequence`` spawn key), so chunking, sharding, worker count and sample order
    never change a result; the streams are ``spl_al.data.seeds``'s."""
    return np.random.default_rng(
        np.random.SeedSequence(_as_seed(seed), spawn_key=(int(stream), int(uid)))
    )
