"""Workflow steps of a human oracle: labeling batches out, checked label files in.

A dataset with ``oracle: human`` runs the same rounds as a simulated one, except
where labels enter:

- round 0 (``initial_set``): the rows of ``seed_labels`` when it lists training
  samples, else ``al.initial`` samples drawn at random or chosen without a label on
  the dataset's encoder (``al.initial_strategy``: a cold start; never stratified:
  that would read labels nobody has given);
- every queried set (round 0's included) becomes a labeling batch
  (``label_batch``; from round 1 on its Label Studio tasks carry the predictions of
  the model that chose it), and ``accept_labels`` turns the filled label file (or
  the Label Studio export saved in its place) into the round's ``labeled.json`` +
  ``labels.npz``. Until the file exists it stops with
  one line naming it; a wrong file stops with one line naming its line and value,
  and nothing is written.

Training reads the labels of ``labels.npz`` (``train_round``'s
``RoundStart(labels_path=...)``), so a run never uses a training label nobody gave;
strategies see no labels at all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import read_json, write_json
from spl_al.cold_start import STRATIFIED, initial_strategy
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.data.label_files import listed_samples, load_labels, save_labels
from spl_al.experiment import round0
from spl_al.labeling import read_label_file, write_batch
from spl_al.training.compute import Compute


def initial_set(
    dataset_path,
    al: dict,
    *,
    seed: int,
    out_path,
    oracle: str = "simulated",
    seed_labels=None,
    embeddings=None,
) -> dict:
    """The round-0 labeled set: ``round0.initial_set`` for a simulated oracle; for a
    human one the training rows of ``seed_labels`` (when it has any), else ``al.initial``
    samples chosen by ``al.initial_strategy``: at random, or without a label on the
    encoder's ``embeddings`` (a cold start)."""
    if oracle != "human":
        return round0.initial_set(dataset_path, al, seed, out_path, embeddings=embeddings)

    start = initial_strategy(al)
    if start == STRATIFIED:
        raise ValueError(
            "config key 'al.stratified_initial': a human oracle has given no labels to "
            "stratify by; remove it or list the first samples in seed_labels."
        )
    dataset = Dataset.load(dataset_path)
    listed = listed_samples(seed_labels, dataset) if seed_labels else np.zeros(0, np.int64)
    if listed.size:
        return round0.write_initial_set(listed, seed, out_path)
    idx, chosen = round0.choose_initial(dataset, start, al, seed, embeddings=embeddings)
    return round0.write_initial_set(idx, seed, out_path, chosen=chosen)


def _asked(record: dict) -> list[int]:
    """The training-pool indices a request asks labels for (round 0: all of them)."""
    return record["queried"] if "queried" in record else record["pool_indices"]


def batch_probabilities(dataset, pool_indices, model_path, model_cfg: dict) -> np.ndarray:
    """The probabilities a saved model gives the observed images of training-pool groups
    ``pool_indices``: (n, C), or (n, C, H, W) for segmentation. Images only, no labels."""
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import load_model
    from spl_al.training.forward import predict

    model = load_model(dataset, model_cfg, model_path)
    depth, valid = dataset.groups(dataset.train_idx[np.asarray(pool_indices)], n_variants=0)
    return predict(model, depth[:, 0], valid[:, 0], compute=Compute("cpu"), features="none").probs


def label_batch(
    dataset_path,
    request_path,
    *,
    labels_file,
    out_dir,
    export_file=None,
    model_path=None,
    model_cfg: dict | None = None,
    model_version: str = "",
) -> dict:
    """The labeling batch of a query (or of the round-0 set) in ``out_dir``.

    ``export_file``: where a Label Studio JSON export of the batch may be saved instead
    of ``labels_file``. ``model_path`` / ``model_cfg``: the model that chose the batch
    (the round before's), whose predictions become the Label Studio pre-annotations,
    tagged ``model_version``; without them (round 0) the tasks have none.
    """
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    request = read_json(request_path)
    asked = _asked(request)
    probs = None
    if model_path is not None and asked:
        probs = batch_probabilities(dataset, asked, model_path, model_cfg or {})
    write_batch(
        dataset,
        asked,
        out_dir=out_dir,
        labels_file=labels_file,
        export_file=export_file,
        probs=probs,
        model_version=model_version,
        chosen_by=chosen_by_text(request.get("chosen_by")),
    )
    return {
        "samples": len(asked),
        "labels_file": str(labels_file),
        "pre_annotations": probs is not None,
    }


def chosen_by_text(chosen: dict | None) -> str:
    """How a round-0 batch was chosen, in one sentence ("" for a random draw)."""
    if not chosen or chosen.get("strategy") in (None, "random"):
        return ""
    encoder = chosen.get("encoder") or {}
    seed = encoder.get("encoder_seed")
    which = f" (encoder seed {seed})" if seed is not None else ""
    return (
        f"These samples were chosen by {chosen['strategy']} on the dataset's self-supervised "
        f"encoder{which}, trained on your unlabeled frames and their variants; no label was "
        "read to choose them."
    )


def given_label_file(labels_file, export_file, batch_dir, n_asked: int) -> Path:
    """The label file a person gave: the CSV or the Label Studio export (not both).

    Until one exists, a ValueError says what to fill in and where to save it.
    """
    labels_file = Path(labels_file)
    export_file = Path(export_file) if export_file else None
    given = [p for p in (labels_file, export_file) if p is not None and p.is_file()]
    if len(given) == 2:
        raise ValueError(
            f"both {labels_file} and {export_file} exist; keep the one that holds this "
            "batch's labels and delete the other."
        )
    if given:
        return given[0]
    batch_dir = Path(batch_dir)
    also = (
        f", or label {batch_dir / 'label_studio.json'} in Label Studio and save its JSON "
        f"export as {export_file}"
        if export_file
        else ""
    )
    raise ValueError(
        f"waiting for labels: fill in {batch_dir / 'to_label.csv'} ({n_asked} samples) and "
        f"save it as {labels_file}{also}, then run Snakemake again."
    )


def accept_labels(
    dataset_path,
    request_path,
    *,
    labels_file,
    batch_dir,
    previous_labels,
    out_labeled,
    out_labels,
    export_file=None,
) -> dict:
    """Check the filled label file of a batch and write the round's labeled set and
    every label given so far (``previous_labels``: the round before's, or None).

    The labels come from ``labels_file`` (CSV) or, in its place, from ``export_file``
    (a Label Studio JSON export); both present is refused.
    """
    record = read_json(request_path)
    asked = np.asarray(_asked(record), dtype=np.int64)
    labels_file = given_label_file(labels_file, export_file, batch_dir, asked.size)
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
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
