"""A person labels two rounds through Snakemake: the test plays the annotator, filling
each batch's to_label.csv from the hidden labels, and must end with the labeled sets
and test metrics of the simulated oracle on the same data. A second human dataset is
labeled through Label Studio instead (its exports, shaped like the real ones recorded
in tests/fixtures/label_studio, saved in place of the CSVs) and must end with the same
labels, labeled sets and budget table as the CSV path."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from helpers.snakemake_cli import SNAKEMAKE

from spl_al.data import Dataset

pytestmark = [
    pytest.mark.slow,
    pytest.mark.usefixtures("warm_server"),  # tests/conftest.py: one server for every run
    pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed"),
]

DATASET = """
    task: classification
    source: synthetic
    synthesis: {n_per_class: 5, image_shape: [32, 32], test_fraction: 0.3, seed: 0, workers: 1}
    variants: {n: 2, shards: 1, seed: 0}
    al: {initial: 6, batch: 4}
    method_params: {duis: {n_cand: 8}}  # at most half the 27 unlabeled samples
    train: {model: {arch: smallcnn}, fit: {epochs: 1, batch_size: 16}}
    experiments:
      budget: {methods: [duis], seeds: [1], rounds: 2}
"""


def read_json(path):
    return json.loads(path.read_text())


def snakemake(tmp_path, *targets):
    cmd = [*SNAKEMAKE, "-j2", "--keep-going", *targets]
    cmd += ["--configfile", str(tmp_path / "config.yaml")]
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)


def annotate(dataset_path: Path, batch: Path, out: Path, wrong: str | None = None) -> None:
    """Fill to_label.csv from the hidden labels (``wrong``: the first label instead)."""
    data = Dataset.load(dataset_path)
    row_of = {int(u): i for i, u in enumerate(data.uid)}
    with open(batch / "to_label.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for k, row in enumerate(rows):
        row["label"] = data.classes[data.labels[row_of[int(row["sample"])]]]
        if wrong and k == 0:
            row["label"] = wrong
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=["sample", "file", "label"])
        writer.writeheader()
        writer.writerows(rows)


def annotate_in_label_studio(dataset_path: Path, batch: Path, out: Path, wrong=None) -> None:
    """A Label Studio JSON export of the batch's label_studio.json, each task annotated
    with its hidden label (``wrong``: the first one instead), predictions kept."""
    data = Dataset.load(dataset_path)
    row_of = {int(u): i for i, u in enumerate(data.uid)}
    export = []
    for k, task in enumerate(json.loads((batch / "label_studio.json").read_text())):
        name = data.classes[data.labels[row_of[int(task["data"]["sample"])]]]
        choice = {"choices": [wrong if wrong and k == 0 else name]}
        result = [{"from_name": "label", "to_name": "image", "type": "choices", "value": choice}]
        annotation = {"id": 50 + k, "result": result, "was_cancelled": False}
        export.append(
            {
                "id": 10 + k,
                "annotations": [{**annotation, "ground_truth": False, "task": 10 + k}],
                "predictions": task.get("predictions", []),
                "data": task["data"],
            }
        )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(export, indent=1))


def test_two_human_rounds_match_the_simulated_oracle(tmp_path):
    results, labels, ls_labels = tmp_path / "results", tmp_path / "labels", tmp_path / "ls"
    (tmp_path / "config.yaml").write_text(
        f"results: {results}\ndevice: cpu\n"
        "only_datasets: [sim, hum, ls]\ndatasets:\n"
        f"  sim:{DATASET}"
        f"  hum:\n    oracle: human\n    labels_dir: {labels}{DATASET}"
        f"  ls:\n    oracle: human\n    labels_dir: {ls_labels}{DATASET}"
    )
    targets = [str(results / "sim/duis/seed1/round1/metrics.json")]
    targets += [str(results / d / "tables/budget.csv") for d in ("hum", "ls")]
    hum, ls = results / "hum", results / "ls"
    data = hum / "data" / "dataset.npz"

    run = snakemake(tmp_path, *targets)
    assert run.returncode != 0
    initial_csv = labels / "initial" / "seed1.csv"
    assert f"waiting for labels: fill in {hum}/initial/seed1/to_label/to_label.csv" in run.stderr
    assert f"save it as {initial_csv}" in run.stderr
    initial_json = ls_labels / "initial" / "seed1.json"
    assert f"in Label Studio and save its JSON export as {initial_json}" in run.stderr
    assert not (hum / "duis/seed1/round0/labeled.json").exists()
    tasks = json.loads((ls / "initial/seed1/to_label/label_studio.json").read_text())
    assert len(tasks) == 6 and not any("predictions" in t for t in tasks)

    annotate(data, hum / "initial/seed1/to_label", initial_csv)
    annotate_in_label_studio(data, ls / "initial/seed1/to_label", initial_json)
    run = snakemake(tmp_path, *targets)
    round1_csv = labels / "duis" / "seed1" / "round1.csv"
    round1_json = ls_labels / "duis" / "seed1" / "round1.json"
    assert run.returncode != 0 and f"save it as {round1_csv}" in run.stderr
    assert f"save its JSON export as {round1_json}" in run.stderr
    tasks = json.loads((ls / "duis/seed1/round1/to_label/label_studio.json").read_text())
    assert [t["predictions"][0]["model_version"] for t in tasks] == ["duis seed1 round0"] * 4

    annotate(data, hum / "duis/seed1/round1/to_label", round1_csv, wrong="bycicle")
    annotate_in_label_studio(data, ls / "duis/seed1/round1/to_label", round1_json, "bycicle")
    run = snakemake(tmp_path, *targets)
    assert run.returncode != 0
    assert f"{round1_csv} line 2: 'bycicle' is not a class; expected one of: building" in run.stderr
    assert f"{round1_json} task 10 (sample " in run.stderr
    assert "annotation 50: 'bycicle' is not a class; expected one of: building" in run.stderr
    assert not (hum / "duis/seed1/round1/labeled.json").exists()
    assert not (ls / "duis/seed1/round1/labeled.json").exists()

    annotate(data, hum / "duis/seed1/round1/to_label", round1_csv)
    annotate_in_label_studio(data, ls / "duis/seed1/round1/to_label", round1_json)
    run = snakemake(tmp_path, *targets)
    assert run.returncode == 0, run.stderr[-3000:]
    assert not (results / "logs" / "warm_server.log").exists()  # each run used the shared one
    for r in (0, 1):  # Label Studio labels train exactly as CSV labels
        run_dir = f"duis/seed1/round{r}"
        for name in ("labeled.json", "metrics.json"):
            assert (ls / run_dir / name).is_file()
        hum_labels, ls_labels_given = (np.load(d / run_dir / "labels.npz") for d in (hum, ls))
        for key in ("pool_indices", "labels"):
            assert np.array_equal(hum_labels[key], ls_labels_given[key])
        assert (
            read_json(ls / run_dir / "metrics.json")["value"]
            == read_json(hum / run_dir / "metrics.json")["value"]
        )

    def table(folder):  # the budget table's rows, less the dataset's name
        with open(folder / "tables/budget.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        assert rows and all(row.pop("dataset") == folder.name for row in rows)
        return rows

    assert table(ls) == table(hum)

    sim = results / "sim"
    assert (
        read_json(hum / "duis/seed1/round0/labeled.json")["pool_indices"]
        == (read_json(sim / "initial/seed1.json")["pool_indices"])
    )
    for r in (0, 1):
        run_dir = f"duis/seed1/round{r}"
        if r:
            assert (
                read_json(hum / run_dir / "labeled.json")["pool_indices"]
                == (read_json(sim / run_dir / "labeled.json")["pool_indices"])
            )
        assert (
            read_json(hum / run_dir / "metrics.json")["value"]
            == (read_json(sim / run_dir / "metrics.json")["value"])
        )
