"""The small records a step takes (which round, its files, what its model starts
from, the runs of an embedding-framework job; where its models run is
``spl_al.training.compute.Compute``), importable
without numpy or torch: the workflow's scripts build them in the job's own process
before handing the step on."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class RoundId:
    """Which round: dataset and method names, run seed, round index (0 = initial set)."""

    dataset: str
    method: str
    seed: int
    round: int


@dataclass(frozen=True)
class RoundStart:
    """What a round's model starts from besides its labeled set: round 0's shared fit
    (``initial``: ``train_initial``'s files), the method's previous-round weights to
    fine-tune (``previous_model``), and a person's labels (``labels_path``) instead of
    the dataset's. All None: fresh weights on the dataset's labels."""

    initial: ModelFiles | None = None
    previous_model: str | Path | None = None
    labels_path: str | Path | None = None


@dataclass(frozen=True)
class ModelFiles:
    """What a fit writes: the weights, a JSON record and the scores of the pool."""

    model: str | Path
    record: str | Path
    scores: str | Path | None = None


@dataclass(frozen=True)
class ProbeRuns:
    """The runs one embedding-framework job makes: every seed of one method.

    ``method``: its ``MethodSpec`` fields; ``variants``, ``al``: the dataset's config
    blocks (the encoder's card must match the former); ``rounds``: per run, round 0
    included; ``probe``: the dataset's ``embedding.probe`` (``c``); ``encoders``: the
    encoder seed of each run seed (``spl_al.experiment.encoders.encoder_of``)."""

    dataset: str
    method_name: str
    method: dict
    variants: dict
    al: dict
    seeds: tuple[int, ...]
    rounds: int
    probe: dict | None = None
    encoders: tuple[int, ...] = ()  # the encoder seed each of ``seeds`` reads


FRESH = RoundStart()
"""Fresh weights on the dataset's labels (``train_round``'s default start)."""
