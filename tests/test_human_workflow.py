"""A person labels two rounds through Snakemake: the test plays the annotator, filling
each batch's to_label.csv from the hidden labels, and must end with the labeled sets
and test metrics of the simulated oracle on the same data."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from spl_al.data import Dataset

ROOT = Path(__file__).resolve().parents[1]
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed"),
]

DATASET = """
    task: classification
    source: synthetic
    synthesis: {n_per_class: 5, image_shape: [32, 32], test_fraction: 0.3, seed: 0, workers: 1}
    variants: {n: 2, shards: 1, seed: 0}
    al: {initial: 6, batch: 4}
    train: {model: {arch: smallcnn}, fit: {epochs: 1, batch_size: 16}}
    experiments:
      budget: {methods: [duis], seeds: [1], rounds: 2}
"""


def snakemake(tmp_path, *targets):
    cmd = [sys.executable, "-m", "snakemake", "-j2", *targets]
    cmd += ["--configfile", str(tmp_path / "config.yaml")]
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)


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


def test_two_human_rounds_match_the_simulated_oracle(tmp_path):
    results, labels = tmp_path / "results", tmp_path / "labels"
    (tmp_path / "config.yaml").write_text(
        f"results: {results}\ndevice: cpu\n"
        "datasets:\n  real_cls: null\n  synth_cls: null\n  street_seg: null\n"
        f"  sim:{DATASET}"
        f"  hum:\n    oracle: human\n    labels_dir: {labels}{DATASET}"
    )
    targets = [str(results / d / "duis/seed1/round1/metrics.json") for d in ("sim", "hum")]
    hum = results / "hum"
    data = hum / "data" / "dataset.npz"

    run = snakemake(tmp_path, *targets)
    assert run.returncode != 0
    initial_csv = labels / "initial" / "seed1.csv"
    assert f"waiting for labels: fill in {hum}/initial/seed1/to_label/to_label.csv" in run.stderr
    assert f"save it as {initial_csv}" in run.stderr
    assert not (hum / "duis/seed1/round0/labeled.json").exists()

    annotate(data, hum / "initial/seed1/to_label", initial_csv)
    run = snakemake(tmp_path, *targets)
    round1_csv = labels / "duis" / "seed1" / "round1.csv"
    assert run.returncode != 0 and f"save it as {round1_csv}" in run.stderr

    annotate(data, hum / "duis/seed1/round1/to_label", round1_csv, wrong="bycicle")
    run = snakemake(tmp_path, *targets)
    assert run.returncode != 0
    assert f"{round1_csv} line 2: 'bycicle' is not a class; expected one of: building" in run.stderr
    assert not (hum / "duis/seed1/round1/labeled.json").exists()

    annotate(data, hum / "duis/seed1/round1/to_label", round1_csv)
    run = snakemake(tmp_path, *targets)
    assert run.returncode == 0, run.stderr[-3000:]

    def read(path):
        return json.loads(path.read_text())

    sim = results / "sim"
    assert (
        read(hum / "duis/seed1/round0/labeled.json")["pool_indices"]
        == (read(sim / "initial/seed1.json")["pool_indices"])
    )
    for r in (0, 1):
        run_dir = f"duis/seed1/round{r}"
        if r:
            assert (
                read(hum / run_dir / "labeled.json")["pool_indices"]
                == (read(sim / run_dir / "labeled.json")["pool_indices"])
            )
        assert (
            read(hum / run_dir / "metrics.json")["value"]
            == (read(sim / run_dir / "metrics.json")["value"])
        )
