"""A folder of raw photon captures runs through the pipeline (source: captures):
captures in two formats are reconstructed, split into MSPPP levels from their own
photons, and reach the budget, per-level and comparison tables. (Every other table is
built from the runs' records whatever their source: tests/test_pipeline.py covers it.)"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from photon_captures import simulate_capture, write_ptu, write_timestamps_mat
from snakemake_cli import CI_CONFIG, SNAKEMAKE

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
        "      ablation: null\n      sensitivity: null\n"
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
