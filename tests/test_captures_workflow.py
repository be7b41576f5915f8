"""A folder of raw photon captures runs through the pipeline (source: captures):
captures in two formats are reconstructed, split into MSPPP levels from their own
photons, and reach the budget, per-level and comparison tables. (Every other table is
built from the runs' records whatever their source: tests/test_pipeline.py covers it.)"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers.photon_captures import simulate_capture, write_ptu, write_timestamps_mat
from helpers.snakemake_cli import CI_CONFIG, SNAKEMAKE

from spl_al.data.digits import digit_scene
from spl_al.data.seeds import STREAM_SCENE, sample_rng
from spl_al.photon import SensorParams

pytestmark = [
    pytest.mark.slow,
    pytest.mark.usefixtures("warm_server"),  # tests/conftest.py: one server for every run
    pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed"),
]
# 80 ps bins, 520 ps jitter (the paper's sensor) over a 4096-bin gate (49 m): what a
# PicoHarp's T3 records hold.
SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=4096)
LEVELS = {2.0: "low", 5.0: "medium", 10.0: "high"}
N_PER_CLASS = 6


@pytest.fixture(scope="module")
def captures(tmp_path_factory) -> tuple[Path, dict[str, str]]:
    """digit{k}_{NNNN}.ptu / .mat captures, 24x24; returns (folder, {stem: true level})."""
    from sklearn.datasets import load_digits

    digits = load_digits()
    root = tmp_path_factory.mktemp("captures") / "scans"
    root.mkdir()
    truth = {}
    for k in range(10):
        for j, i in enumerate(np.flatnonzero(digits.target == k)[:N_PER_CLASS]):
            depth, _ = digit_scene(
                digits.images[i], sample_rng(0, STREAM_SCENE, int(i)), image_px=24, digit_px=20
            )
            msppp = list(LEVELS)[j % 3]
            events = simulate_capture(depth, msppp, 1.0, SENSOR, seed=int(i))
            stem = f"digit{k}_{j:04d}"
            if j % 2:
                write_timestamps_mat(root / f"{stem}.mat", events, bin_width_ps=80)
            else:
                write_ptu(root / f"{stem}.ptu", events, SENSOR)
            truth[stem] = LEVELS[msppp]
    return root, truth


def test_captures_run_through_the_budget_and_level_tables(captures, tmp_path):
    root, truth = captures
    override = tmp_path / "captures.yaml"
    override.write_text(
        "only_datasets: [real_cls]\ndatasets:\n  real_cls:\n"
        f"    source: captures\n    path: {root}\n    captures: {{shards: 2}}\n"
        "    experiments:\n"
        "      budget: {methods: [random, duis], matched: false, seeds: [1, 2], rounds: 2}\n"
        "      ablation: null\n      sensitivity: null\n      cold_start: null\n"
        "    robustness: {enabled: false}\n"
    )
    results = tmp_path / "results"
    tables = results / "real_cls" / "tables"
    targets = [str(tables / f"{name}.csv") for name in ("budget", "levels", "comparisons")]
    cmd = [*SNAKEMAKE, "-j2", *targets, "--configfile", CI_CONFIG]
    cmd += [str(override), "--config", f"results={results}"]
    run = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]

    conditions = pd.read_csv(results / "real_cls" / "captures" / "release" / "conditions.csv")
    assert len(conditions) == 10 * N_PER_CLASS
    pairs = zip(conditions.capture, conditions.level, strict=True)
    found = {Path(capture).stem: level for capture, level in pairs}
    assert found == truth  # the level split of the photons is the simulation's
    for level, msppp in (("low", 2.0), ("medium", 5.0), ("high", 10.0)):
        estimated = conditions.msppp[conditions.level == level]
        assert np.all(np.abs(estimated / msppp - 1) < 0.25), (level, estimated.tolist())
    # sigma estimated from each frame's photons (no file states it)
    assert np.all(np.abs(conditions.pulse_sigma_ps / 520 - 1) < 0.25)

    budget = pd.read_csv(tables / "budget.csv")
    assert not budget["synthetic_standin"].any() and len(budget) > 0
    levels = pd.read_csv(tables / "levels.csv")
    assert len(levels) > 0
    assert set(budget["method"]) == {"random", "duis"}
    assert set(levels["level"]) == set(LEVELS.values())
    assert len(pd.read_csv(tables / "comparisons.csv")) > 0


def walkthrough_config() -> dict:
    """The zero-label walk-through's config, as docs/labeling.md shows it."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "labeling.md").read_text()
    block = re.search(r"<!-- plans: caps -->\n```yaml\n(.*?)```", text, re.S)
    assert block, "docs/labeling.md has no zero-label config (<!-- plans: caps -->)"
    return yaml.safe_load(block.group(1))


def test_the_zero_label_walkthrough_writes_a_typiclust_first_batch(captures, tmp_path):
    """docs/labeling.md's config on simulated captures with test rows alone: the run
    trains the encoder on the unlabeled frames and stops at a first batch TypiClust
    chose on it, which says so; no label file exists yet."""
    root, _ = captures
    config = walkthrough_config()
    entry = config["datasets"]["caps"]
    assert entry["al"]["initial_strategy"] == "typiclust" and entry["oracle"] == "human"
    seed_labels = tmp_path / "test_labels.csv"
    rows = [f"digit{k}_0005.npz,digit{k},test" for k in range(10)]
    seed_labels.write_text("file,label,split\n" + "\n".join(rows) + "\n")
    # the walk-through's settings on 60 small captures: a short encoder, two variants
    entry.update(path=str(root), seed_labels=str(seed_labels), captures={"shards": 2})
    entry.update(
        classes=[f"digit{k}" for k in range(10)], variants={"n": 2, "shards": 1, "seed": 0}
    )
    entry["embedding"]["encoder"].update(steps=20, batch_size=16, width=4)
    config["results"] = str(tmp_path / "results")
    (tmp_path / "zero.yaml").write_text(yaml.safe_dump(config))
    batch = tmp_path / "results" / "caps" / "initial" / "seed1" / "to_label"
    cmd = [*SNAKEMAKE, "-j2", str(batch), "--configfile", str(tmp_path / "zero.yaml")]
    run = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]

    record = json.loads((batch.parent.parent / "seed1.json").read_text())
    assert record["n_labeled"] == 10 and record["chosen_by"]["strategy"] == "typiclust"
    assert record["chosen_by"]["encoder"]["encoder_seed"] == 0
    with open(batch / "to_label.csv") as f:
        assert len(f.read().splitlines()) == 11  # header + the 10 frames, labels empty
    assert "chosen by typiclust on the dataset's self-supervised encoder" in (
        (batch / "README.txt").read_text()
    )
    assert not (tmp_path / "labels").exists()  # nothing labeled: the run waits for you
