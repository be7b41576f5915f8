"""The authors' release end to end: a folder in their exact layout ({class}_{NNNN}.npz
with depth_ssp and Z_true, 55x55, no condition keys) runs through the budget,
comparison and robustness tables; the per-level outputs, which need MSPPP levels, are
skipped with a note."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from helpers.snakemake_cli import CI_CONFIG, SNAKEMAKE

from spl_al.data import load_folder
from spl_al.data.digits import write_digits_folder

ROOT = Path(__file__).resolve().parents[1]
pytestmark = [
    pytest.mark.slow,
    pytest.mark.usefixtures("warm_server"),  # tests/conftest.py: one server for every run
    pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed"),
]


@pytest.fixture(scope="module")
def release(tmp_path_factory) -> Path:
    """40 files of 10 classes in the release's layout, 55x55, voids as zeros."""
    root = write_digits_folder(
        tmp_path_factory.mktemp("release") / "frames", n_per_class=4, image_px=55
    )
    with np.load(root / "digit3_0002.npz") as z:
        assert sorted(z.files) == ["Z_true", "depth_ssp"] and z["depth_ssp"].shape == (55, 55)
    return root


def test_subset_per_class_and_levels_file(release, tmp_path):
    sub = load_folder(release, n_per_class=3, seed=1)
    assert len(sub) == 30 and np.bincount(sub.labels).tolist() == [3] * 10
    assert load_folder(release, n_per_class=3, seed=1).meta["files"] == sub.meta["files"]
    assert set(sub.level) == {"unknown"}
    with pytest.raises(ValueError, match="has 4 files; n_per_class=5"):
        load_folder(release, n_per_class=5)

    files = load_folder(release).meta["files"]
    csv = tmp_path / "levels.csv"
    rows = [f"{f},{['high', 'medium', 'low'][k % 3]},{k % 3 + 1}," for k, f in enumerate(files)]
    csv.write_text("file,level,msppp,sbr\n" + "\n".join(rows) + "\n")
    given = load_folder(release, levels_file=csv)
    assert given.level[:3].tolist() == ["high", "medium", "low"]
    assert given.msppp[:3].tolist() == [1, 2, 3] and np.isnan(given.sbr).all()
    csv.write_text("file,level\n" + f"{files[0]},dim\n")
    with pytest.raises(ValueError, match=r"levels.csv, line 2: level 'dim'"):
        load_folder(release, levels_file=csv)
    csv.write_text("file,level\n" + f"{files[0]},high\n")
    with pytest.raises(ValueError, match="no level for 39 loaded files"):
        load_folder(release, levels_file=csv)


def test_release_layout_runs_through_every_table(release, tmp_path):
    override = tmp_path / "release.yaml"
    # 20 training files, 9 unlabeled after the 11 of round 0: N_cand at most 4
    override.write_text(
        "methods:\n  duis: {params: {n_cand: 4}}\n"
        "only_datasets: [real_cls]\ndatasets:\n"
        f"  real_cls:\n    path: {release}\n    n_per_class: 3\n    experiments:\n"
        "      budget: {methods: [random, duis], matched: false, seeds: [1, 2], rounds: 2}\n"
        "      ablation: null\n      sensitivity: null\n      cold_start: null\n"
        "    embedding: null\n"  # the supervised tables are what this layout is about
    )
    results = tmp_path / "results"
    cmd = [*SNAKEMAKE, "-j2", "--configfile", CI_CONFIG]
    cmd += [str(override), "--config", f"results={results}"]
    run = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "files carry no MSPPP level; give `levels_file`" in run.stdout + run.stderr

    tables = results / "real_cls" / "tables"
    budget = pd.read_csv(tables / "budget.csv")
    assert not budget["synthetic_standin"].any()
    # the ratio's denominator is the 3-per-class subset: 30 files
    assert (budget["ratio"] * 30).round(6).tolist() == budget["n_labeled"].astype(float).tolist()
    assert len(pd.read_csv(tables / "comparisons.csv")) > 0
    assert not (tables / "levels.csv").exists()
    figures = results / "real_cls" / "figures"
    assert (figures / "curves.png").exists() and not (figures / "level_curves.png").exists()
    summary = json.loads((tables / "summary.json").read_text())
    assert any("MSPPP level" in note for note in summary["notes"])
    robustness = pd.read_csv(tables / "robustness.csv")
    assert len(robustness) > 0
