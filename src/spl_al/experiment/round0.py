"""Round 0's labeled set of a seed: chosen by ``al.initial_strategy``
(``cold_start.round0_set``: random, stratified, or a cold start on the encoder's
embeddings) and written as its JSON record. The simulated oracle's step
(``initial_set``) and the human oracle's (``human.initial_set``) both choose and write
it here; the embedding framework, whose embeddings are already in memory, calls
``cold_start.round0_set`` itself (``embedding_steps``): every round 0 is drawn by that
one function, from the seed's ``seeding.round0_rng``.

Index convention: training-split indices (``dataset.train_idx[i]`` is the sample).
"""

from __future__ import annotations

import numpy as np

from spl_al.atomic import write_json
from spl_al.cold_start import RANDOM, STRATIFIED, initial_strategy, is_cold_start, round0_set
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.experiment.encoders import embeddings_source, load_embeddings


def initial_set(dataset_path, al: dict, seed: int, out_path, *, embeddings=None) -> dict:
    """The round-0 labeled set of a seed, shared by every method that starts the same
    way (paired comparison): ``al.initial_strategy`` (``spl_al.cold_start``).

    Reads the dataset's split sizes; when stratified the training labels (drawing the
    initial set is then the oracle's job, not a strategy's); for a cold start the
    run seed's encoder ``embeddings`` (``train_encoder``'s file) and no label.
    """
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    start = initial_strategy(al)
    if start == STRATIFIED and dataset.task != "classification":
        start = RANDOM  # stratified_initial only stratifies classes
    labels = dataset.labels[dataset.train_idx] if start == STRATIFIED else None
    idx, chosen = choose_initial(dataset, start, al, seed, embeddings=embeddings, labels=labels)
    return write_initial_set(idx, seed, out_path, chosen=chosen)


def choose_initial(dataset, start: str, al: dict, seed: int, *, embeddings=None, labels=None):
    """(training-split indices, how they were chosen) of ``start``'s round 0 on
    ``dataset``: ``cold_start.round0_set`` given the ``labels`` a stratified draw reads,
    or, for a cold start, the observed images' embeddings from the file ``embeddings``
    (its encoder named in the record)."""
    features = None
    if is_cold_start(start):
        if embeddings is None:
            raise ValueError(f"a {start} round 0 reads the encoder's embeddings; none given.")
        features = load_embeddings(embeddings, dataset)[0][:, 0]
    idx, chosen = round0_set(
        start,
        len(dataset.train_idx),
        int(al["initial"]),
        int(seed),
        labels=labels,
        embeddings=features,
        n_classes=len(dataset.classes),
    )
    if features is not None:
        chosen["encoder"] = embeddings_source(embeddings)
    return idx, chosen


def write_initial_set(idx, seed: int, out_path, chosen: dict | None = None) -> dict:
    """Write a seed's round-0 labeled set (training-split indices) as its JSON record;
    ``chosen``: how it was chosen (``cold_start.round0_set``), kept when not random."""
    idx = np.asarray(idx)
    record = {
        "seed": int(seed),
        "round": 0,
        "n_labeled": int(idx.size),
        "pool_indices": np.sort(idx).tolist(),
    }
    if chosen and chosen.get("strategy") != RANDOM:
        record["chosen_by"] = chosen
    write_json(record, out_path)
    return record
