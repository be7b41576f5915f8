"""Workflow steps of a human oracle: labeling batches out, checked label files in.

A dataset with ``oracle: human`` runs the same rounds as a simulated one, except
where labels enter:

- round 0 (``initial_set``): the rows of ``seed_labels`` when it lists training
  samples, else ``al.initial`` samples drawn at random (never stratified: that
  would read labels nobody has given);
- every queried set (round 0's included) becomes a labeling batch
  (``label_batch``), and ``accept_labels`` turns the filled label file into the
  round's ``labeled.json`` + ``labels.npz``. Until the file exists it stops with
  one line naming it; a wrong file stops with one line naming its line and value,
  and nothing is written.

Training reads the labels of ``labels.npz`` (``train_round(labels_path=...)``), so a
run never uses a training label nobody gave; strategies see no labels at all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import read_json, write_json


def initial_set(
    dataset_path, al: dict, seed: int, out_path, oracle: str = "simulated", seed_labels=None
) -> dict:
    """The round-0 labeled set: ``steps.initial_set`` for a simulated oracle; for a
    human one the training rows of ``seed_labels`` (when it has any) or a random draw."""
    from spl_al.experiment import steps

    if oracle != "human":
        return steps.initial_set(dataset_path, al, seed, out_path)
    from spl_al.data import Dataset
    from spl_al.labeling import listed_samples
    from spl_al.pool import initial_labeled_set

    if al.get("stratified_initial"):
        raise ValueError(
            "config key 'al.stratified_initial': a human oracle has given no labels to "
            "stratify by; remove it or list the first samples in seed_labels."
        )
    dataset = Dataset.load(dataset_path)
    listed = listed_samples(seed_labels, dataset) if seed_labels else np.zeros(0, np.int64)
    if listed.size:
        idx = listed
    else:
        idx = initial_labeled_set(len(dataset.train_idx), int(al["initial"]), int(seed))
    return steps.write_initial_set(idx, seed, out_path)


def _asked(record: dict) -> list[int]:
    """The training-pool indices a request asks labels for (round 0: all of them)."""
    return record["queried"] if "queried" in record else record["pool_indices"]


def label_batch(dataset_path, request_path, labels_file, out_dir) -> dict:
    """The labeling batch of a query (or of the round-0 set) in ``out_dir``."""
    from spl_al.data import Dataset
    from spl_al.labeling import write_batch

    dataset = Dataset.load(dataset_path)
    asked = _asked(read_json(request_path))
    write_batch(dataset, asked, out_dir, labels_file)
    return {"samples": len(asked), "labels_file": str(labels_file)}


def accept_labels(
    dataset_path,
    request_path,
    labels_file,
    batch_dir,
    previous_labels,
    out_labeled,
    out_labels,
) -> dict:
    """Check the filled label file of a batch and write the round's labeled set and
    every label given so far (``previous_labels``: the round before's, or None)."""
    from spl_al.data import Dataset
    from spl_al.labeling import load_labels, read_label_file, save_labels

    record = read_json(request_path)
    asked = np.asarray(_asked(record), dtype=np.int64)
    labels_file = Path(labels_file)
    if not labels_file.is_file():
        raise ValueError(
            f"waiting for labels: fill in {Path(batch_dir) / 'to_label.csv'} "
            f"({asked.size} samples) and save it as {labels_file}, then run Snakemake again."
        )
    dataset = Dataset.load(dataset_path)
    given = read_label_file(labels_file, dataset, asked)
    idx, labels = asked, given
    if previous_labels is not None:
        before_idx, before = load_labels(previous_labels)
        idx = np.concatenate([before_idx, asked])
        labels = np.concatenate([before, given])
    if sorted(idx.tolist()) != sorted(record["pool_indices"]):
        raise ValueError(
            f"{request_path}: its labeled set is not the labels given so far plus this batch."
        )
    save_labels(out_labels, idx, labels)
    out = {**record, "oracle": "human", "labels_file": str(labels_file)}
    write_json(out, out_labeled)
    return {"accepted": int(asked.size), "n_labeled": int(idx.size)}
