"""End to end: the ci config through Snakemake, resumed after a kill, and in cluster mode.

One full run of config/ci.yaml is shared by the tests of this module (a few minutes
on 2 cores); the other runs build subsets of it and must agree with it bit for bit.
With SPL_AL_SLURM=1 the whole DAG also runs on a real single-node SLURM
(scripts/slurm-local.sh) through profiles/slurm.
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from helpers.snakemake_cli import CI_CONFIG, SNAKEMAKE

from spl_al.warm.client import SOCKET_ENV

ROOT = Path(__file__).resolve().parents[1]
pytestmark = [
    pytest.mark.slow,
    pytest.mark.usefixtures("warm_server"),  # tests/conftest.py: one server for every run
    pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed"),
]

# config/ci.yaml's real_cls budget: the default's methods less BADGE, and TypiClust
# selecting on the self-supervised embedding (features: embedding)
CLS_METHODS = ["random", "margin", "typiclust_ssl", "duis"]
# the matched family of real_cls: the baselines' twins trained on the variants, and
# Syn+Diversity for the decomposition of DUIS - Random
CLS_MATCHED = ["syn_random", "syn_margin", "syn_typiclust_ssl"]
CLS_BUDGET = [*CLS_METHODS, *CLS_MATCHED, "syn_diversity"]


# wall seconds of the runs, for the report of the SLURM test
WALL: dict[str, float] = {}


def snakemake(results: Path, *args, check=True, profile=None, background=False, env=None):
    """Snakemake on config/ci.yaml into ``results``, from the folder that holds it (its
    .snakemake/ records what made ``results``)."""
    cmd = [*SNAKEMAKE, "--configfile", CI_CONFIG]
    cmd += ["--config", f"results={results}"]
    # a profile of the checkout by its name there, or one by its full path
    cmd += ["--profile", str(ROOT / profile)] if profile else ["-j2"]
    cmd += list(args)
    results.parent.mkdir(parents=True, exist_ok=True)
    if background:
        return subprocess.Popen(
            cmd,
            cwd=results.parent,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
            env=env,
        )
    run = subprocess.run(cmd, cwd=results.parent, capture_output=True, text=True, env=env)
    if check and run.returncode != 0:
        raise AssertionError(f"snakemake failed:\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    return run


@pytest.fixture(scope="module")
def ci_results(tmp_path_factory):
    results = tmp_path_factory.mktemp("ci") / "results"
    start = time.monotonic()
    snakemake(results)
    WALL["local"] = time.monotonic() - start
    return results


def labeled_sets(results: Path, dataset: str) -> dict[str, list[int]]:
    root = results / dataset
    return {
        str(p.relative_to(root)): json.loads(p.read_text())["pool_indices"]
        for p in sorted(root.glob("**/labeled.json")) + sorted(root.glob("initial/*.json"))
    }


def test_every_table_has_its_rows_columns_and_ranges(ci_results):
    cls = ci_results / "real_cls" / "tables"
    budget = pd.read_csv(cls / "budget.csv")
    assert sorted(budget["method"].unique()) == sorted(CLS_BUDGET)
    assert sorted(budget["round"].unique()) == [0, 1]
    assert len(budget) == len(CLS_BUDGET) * 2
    assert budget["n_labeled"].tolist() == [11, 17] * len(CLS_BUDGET)
    assert budget["col"].tolist()[0].endswith("(round 0)")
    assert budget["ratio"].between(0, 1).all() and budget["mean"].between(0, 100).all()
    assert (budget["n_seeds"] == 2).all() and (budget["std"] >= 0).all()
    assert budget["synthetic_standin"].all()  # no path given: the real protocol runs on a stand-in

    levels = pd.read_csv(cls / "levels.csv")
    assert set(levels["level"]) == {"high", "medium", "low"}
    assert len(levels) == len(CLS_BUDGET) * 3 and levels["mean"].between(0, 100).all()

    ablation = pd.read_csv(cls / "ablation.csv")
    assert ablation["row"].tolist() == ["Syn+Random", "Syn+Diversity", "Full"]

    sens = pd.read_csv(cls / "sensitivity.csv")
    assert sorted(sens["parameter"].unique()) == ["alpha", "m", "n_cand"]
    assert len(sens) == 6 and sens["mean"].between(0, 100).all()

    for name in ("budget", "levels", "ablation", "sensitivity"):
        assert (cls / f"{name}.md").read_text().count("|") > 10
        assert "\\begin{tabular}" in (cls / f"{name}.tex").read_text()

    for dataset in ("street_seg", "street_pc"):  # range images (U-Net) and points (PointNet++)
        seg = pd.read_csv(ci_results / dataset / "tables" / "budget.csv")
        assert sorted(seg["method"].unique()) == ["duis", "random"]
        assert (seg["metric"] == "miou").all() and seg["mean"].between(0, 100).all()
        assert not seg["synthetic_standin"].any()
        # the query records N_cand against the 10 unlabeled scans it drew from (14 - 4)
        for seed in (1, 2):
            query = json.loads(
                (ci_results / dataset / f"duis/seed{seed}/round1/labeled.json").read_text()
            )
            assert (query["n_cand"], query["n_unlabeled"], query["batch"]) == (5, 10, 3)
            assert query["cand_ratio"] == 0.5 and query["n_labeled"] == 7

    summary = json.loads((cls / "summary.json").read_text())
    assert sorted(summary["methods"]) == sorted(
        set(CLS_BUDGET) | {"duis_ncand6", "duis_alpha0.25", "duis_m1", "duis_from_typiclust"}
    )
    for stats in summary["methods"].values():
        assert 0 <= stats["auc"] <= 1 and 0 <= stats["final_mean"] <= 1

    for dataset in ("real_cls", "street_seg", "street_pc"):
        figures = ci_results / dataset / "figures"
        for name in (
            "curves.png",
            "level_curves.png",
            "contact_sheet.png",
            "variants_sheet.png",
            "differences.png",
            "batch_conditions.png",
        ):
            assert (figures / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (figures / "curves.pdf").read_bytes()[:4] == b"%PDF"
        assert (figures / "differences.pdf").read_bytes()[:4] == b"%PDF"
        # one panel per MSPPP level, not the budget curves again
        curves = (figures / "curves.png").read_bytes()
        assert (figures / "level_curves.png").read_bytes() != curves


def test_the_batch_conditions_count_each_budget_methods_queried_frames(ci_results):
    """tables/batch_conditions.csv of both frameworks: the pool first, then every
    budget method, each row's shares summing to 1 per condition, the frames each
    method queried over its query rounds and seeds."""
    for folder, methods, frames in (
        (ci_results / "real_cls", CLS_BUDGET, 2 * 6),  # 2 seeds x 1 query of 6
        (ci_results / "real_cls" / "embedding", None, 3 * 2 * 6),  # 3 seeds x 2 of 6
        (ci_results / "street_pc", ["random", "duis"], 2 * 3),
    ):
        table = pd.read_csv(folder / "tables" / "batch_conditions.csv")
        assert table["method"].iloc[0] == "pool"
        if methods is not None:
            assert set(table["method"]) == {"pool", *methods}
        sums = table.groupby(["method", "condition"])["share"].sum()
        assert np.allclose(sums.to_numpy(), 1.0)
        counted = table[(table["method"] != "pool") & (table["condition"] == "msppp_level")]
        assert (counted.groupby("method")["n_frames"].sum() == frames).all()
        assert set(table["condition"]) == {"msppp_level", "sbr"}
        figures = folder / "figures"
        for name in ("differences.png", "batch_conditions.png"):
            assert (figures / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_run_records_the_ci_config_with_the_defaults_it_does_not_name(ci_results):
    """results/config.yaml is what Snakemake ran with: config/ci.yaml over the defaults,
    the datasets it does not run (synth_cls) gone, and the precision each dataset used."""
    import yaml

    got = yaml.safe_load((ci_results / "config.yaml").read_text())
    used = got.pop("precision_used")
    assert set(used) == set(got["datasets"]) and set(used.values()) <= {"fp32", "bf16", "fp16"}
    default = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    assert sorted(got["datasets"]) == ["real_cls", "street_pc", "street_seg"]
    assert got["datasets"]["real_cls"]["al"] == {"initial": 11, "batch": 6, "ratio_of": "all"}
    assert got["methods"]["duis"] == {
        "strategy": "duis",
        "params": {"n_cand": 12, "alpha": 0.5},
        "use_variants": True,
    }
    assert got["datasets"]["street_seg"]["task"] == "segmentation"
    assert got["datasets"]["street_pc"]["train"]["model"]["arch"] == "pointnet2"
    assert got["datasets"]["street_pc"]["synthesis"]["seed"] == 2  # the street scenes
    assert got["methods"]["syn_badge"] == default["methods"]["syn_badge"]


def test_paired_statistics_claims_and_robustness_map(ci_results):
    cls = ci_results / "real_cls" / "tables"
    cmp = pd.read_csv(cls / "comparisons.csv")
    assert set(cmp["experiment"]) == {"budget", "levels", "ablation", "sensitivity", "cold_start"}
    budget = cmp[cmp["experiment"] == "budget"]
    # 8 methods: 28 pairs at each of 2 rounds and for the AUBC over the query round
    assert len(budget) == 28 * 3 and (budget["point"] == "AUBC").sum() == 28
    assert set(budget.loc[budget["point"] == "AUBC", "span"]) == {"round 1 (19.3%)"}
    assert cmp["n"].between(1, 2).all() and cmp["p_value"].between(0, 1).all()
    paired = cmp[cmp["n"] == 2]  # sensitivity runs one seed: no interval there
    assert (paired["ci_low"] <= paired["diff"]).all() and (
        paired["diff"] <= paired["ci_high"]
    ).all()
    assert cmp.loc[cmp["n"] == 1, "ci_low"].isna().all()
    assert not cmp["resolved"].any()  # at most two seeds: nothing can be resolved
    claims = pd.read_csv(cls / "claims.csv")
    assert {
        "duis_best_every_budget",
        "duis_best_aubc_matched",
        "variant_training",
        "inconsistency_over_diversity",
        "m_gt_1_beats_m_1",
        "duis_over_low_budget_matched",
    } <= set(claims["claim_id"])
    low = claims.loc[claims["claim_id"] == "duis_over_low_budget_matched", "claim"].iloc[0]
    # a declared family: every low-budget baseline the run has, named, none chosen
    assert "than each low-budget baseline" in low and "strongest" not in low
    assert "(against Syn+TypiClust (SSL) only, selecting on the frozen self-supervised" in low
    assert set(claims["source"]) == {"paper", "extension"}
    parts = pd.read_csv(cls / "decomposition.csv")
    for _, block in parts.groupby("point"):
        total = block.loc[block["part"] == "total", "diff"].iloc[0]
        assert block.loc[block["part"] != "total", "diff"].sum() == pytest.approx(total)
    assert (claims["verdict"] == "inconclusive").all()
    assert claims["reason"].str.contains("too few seeds").all()
    assert "inconclusive" in (cls / "claims.md").read_text()
    # the verdicts name the precision their models were trained at, as the rounds say
    trained = json.loads((ci_results / "real_cls/duis/seed1/round1/metrics.json").read_text())
    assert set(claims["precision"]) == {trained["precision"]}
    assert f"(models trained in {trained['precision']})" in (cls / "claims.md").read_text()
    assert json.loads((cls / "summary.json").read_text())["precision"] == trained["precision"]
    aubc = json.loads((cls / "summary.json").read_text())["methods"]["duis"]["aubc"]
    assert aubc["n"] == 2 and aubc["ci_low"] <= aubc["mean"] <= aubc["ci_high"]
    assert "n = 2 seeds per cell" in (cls / "budget.md").read_text()

    for dataset, methods in (("real_cls", CLS_METHODS), ("street_seg", ["random", "duis"])):
        tables = ci_results / dataset / "tables"
        rob = pd.read_csv(tables / "robustness.csv")
        assert sorted(rob["method"].unique()) == sorted(methods)
        assert len(rob) == len(methods) * 4  # ci grid: MSPPP 1, 5 x SBR 0.1, 1
        assert rob["mean"].between(0, 100).all() and (rob["n_seeds"] == 2).all()
        assert set(rob["source"]) == {"clean"}
        diff = pd.read_csv(tables / "robustness_diff.csv")
        assert len(diff) == 4 and (diff["method"] == "duis").all()
        assert diff["diff"].abs().le(100).all() and diff["spans_zero"].dtype == bool
        figures = ci_results / dataset / "figures"
        for name in ("aubc.png", "robustness.png", "robustness_diff.png"):
            assert (figures / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_labeled_sets_grow_by_the_batch_without_repeats(ci_results):
    sets = labeled_sets(ci_results, "real_cls")
    for seed in (1, 2):
        initial = sets[f"initial/seed{seed}.json"]
        for method in CLS_METHODS:
            after = sets[f"{method}/seed{seed}/round1/labeled.json"]
            assert len(after) == len(set(after)) == len(initial) + 6
            assert set(initial) <= set(after)


def test_every_method_trains_the_same_steps_at_every_dataset_seed_and_round(ci_results):
    """The training-step policy (steps_by: groups): at equal labels every method takes
    the same optimiser steps, whether it trains on variants or not; every round's
    record, round 0's shared fit included, says how many it took."""
    from spl_al.report import load_records

    paths = sorted(ci_results.glob("*/*/seed*/round*/metrics.json"))
    df = load_records(paths)
    assert set(df["dataset"]) == {"real_cls", "street_seg", "street_pc"}
    assert df["train_steps"].notna().all() and df["images_seen"].notna().all()
    assert (df["train_steps"] >= 1).all() and (df["images_seen"] >= df["train_steps"]).all()
    per_cell = df.groupby(["dataset", "seed", "round"])["train_steps"].nunique()
    assert (per_cell == 1).all(), per_cell[per_cell > 1]
    # the cells where images would have added steps (street_seg and street_pc, round 1)
    # hold methods with and without variants: M = 2 gives 3x the images at equal steps
    seg = df[(df["dataset"] == "street_seg") & (df["round"] == 1)].set_index(["method", "seed"])
    assert (seg.loc["duis", "images_seen"] > seg.loc["random", "images_seen"]).all()
    fits = [json.loads(p.read_text()) for p in ci_results.glob("*/initial/seed*/m*/fit.json")]
    assert fits and all(f["train_steps"] >= 1 and f["images_seen"] >= 1 for f in fits)
    # street_pc's train.warm_start: round 1 fine-tunes round 0's model for its 2 steps
    pc = df[df["dataset"] == "street_pc"].groupby("round")["train_steps"].unique()
    assert pc[0].tolist() == [4] and pc[1].tolist() == [2], pc


def test_final_models_export_to_onnx_with_cards(ci_results, tmp_path):
    """The final DUIS models of real_cls (SmallCNN) and street_seg (U-Net) are exported,
    onnxruntime matching torch on the test split; each exported method's final model.pt
    has its card (the CI config's ``export.cards: exported``; the default gives every
    budget method one), which names the per-level metric; PointNet++ (street_pc) is
    not exported; predict runs the exported classifier on release-layout frames."""
    for dataset, metric in (("real_cls", "accuracy"), ("street_seg", "miou")):
        for seed in (1, 2):
            folder = ci_results / dataset / "models" / "duis" / f"seed{seed}"
            card = json.loads((folder / "final.card.json").read_text())
            check = card["onnx"]["check"]
            assert check["max_abs_logit_diff"] <= 1e-3 and check["argmax_agreement"] >= 0.999
            assert card["run"]["round"] == 1 and card["test"]["metric"] == metric
            assert set(card["test"]["per_level"]) == {"high", "medium", "low"}
            assert "per MSPPP level" in card["test"]["per_level_metric"]
            assert (folder / "final.onnx").stat().st_size > 1000
            assert "MSPPP low" in (folder / "final.card.md").read_text()
    seg_card = json.loads((ci_results / "street_seg/duis/seed1/round1/model.card.json").read_text())
    assert seg_card["robustness"]["cells"]  # the map ran for street_seg's final models
    assert (ci_results / "real_cls/duis/seed2/round1/model.card.md").is_file()
    assert (ci_results / "street_pc/duis/seed1/round1/model.card.json").is_file()
    assert not (ci_results / "real_cls/syn_random/seed2/round1/model.card.md").exists()
    assert not (ci_results / "street_pc" / "models").exists()
    assert (ci_results / "street_pc/duis/seed1/round1/model.card.json").is_file()

    import numpy as np

    from spl_al.__main__ import main as cli
    from spl_al.data import Dataset

    data = Dataset.load(ci_results / "real_cls/data/dataset.npz")
    frames = tmp_path / "frames"
    frames.mkdir()
    for i in data.test_idx[:3]:
        depth = np.nan_to_num(data.depth_m[i], nan=0.0)
        np.savez(frames / f"f{i}.npz", depth_ssp=depth, msppp=data.msppp[i], sbr=data.sbr[i])
    model = ci_results / "real_cls/models/duis/seed1/final.onnx"
    assert cli(["predict", str(model), str(frames), "--out", str(tmp_path / "out")]) == 0
    rows = pd.read_csv(tmp_path / "out" / "predictions.csv")
    assert len(rows) == 3 and set(rows["class"]) <= set(data.classes)
    assert rows["msppp"].notna().all()


def planned(results: Path, tmp_path: Path, change: str | None) -> tuple[set[str], str]:
    """(the files a dry run over the shared run's ``results`` plans, below ``results``;
    its output) with the YAML override ``change`` on top of config/ci.yaml."""
    args = ["-n"]
    if change is not None:
        override = tmp_path / "change.yaml"
        override.write_text(change)
        args = ["-n", "--configfile", CI_CONFIG, str(override)]
    run = snakemake(results, *args)
    out = run.stdout + run.stderr
    files = set()
    for line in re.findall(r"^\s+output: (.+)$", out, flags=re.M):
        files |= {str(Path(f).relative_to(results)) for f in line.split(", ")}
    return files, out


# (override, files that must rerun, patterns of files that must not)
CHANGES = {
    "a method's params": (
        "methods: {duis: {params: {alpha: 0.4}}}",
        [
            "real_cls/duis/seed1/round1/labeled.json",
            "real_cls/duis/seed2/round1/metrics.json",
            "street_seg/duis/seed1/round1/labeled.json",
            "real_cls/tables/budget.csv",
        ],
        # (a new sweep method, duis_alpha0.5, is planned whole: it is new)
        ["*/duis/*/round0/*", "*/random/*", "*/syn_diversity/*", "*/data/*", "*/initial/*"],
    ),
    "a dataset's fit": (
        "datasets: {real_cls: {train: {fit: {epochs: 3}}}}",
        ["real_cls/initial/seed1/m0/model.pt", "real_cls/random/seed2/round1/metrics.json"],
        ["real_cls/data/*", "real_cls/initial/seed?.json", "street_seg/*", "street_pc/*"],
    ),
    "a dataset's synthesis": (
        "datasets: {street_pc: {synthesis: {n_samples: 22}}}",
        ["street_pc/data/observed.npz", "street_pc/random/seed1/round1/labeled.json"],
        ["real_cls/*", "street_seg/*"],
    ),
    "a dataset's variants": (
        "datasets: {real_cls: {variants: {seed: 1}}}",
        ["real_cls/data/dataset.npz", "real_cls/duis/seed1/round1/metrics.json"],
        ["real_cls/data/observed.npz", "real_cls/initial/seed?.json", "street_*"],
    ),
    "a new seed": (
        "datasets: {street_pc: {experiments: {budget: {seeds: [1, 2, 3]}}}}",
        ["street_pc/random/seed3/round1/metrics.json", "street_pc/tables/budget.csv"],
        ["street_pc/*/seed1/*", "street_pc/*/seed2/*", "*/data/*", "real_cls/*", "street_seg/*"],
    ),
    "a dataset's method parameters": (
        # (street_pc's would be refused: it shares street_seg's embedding runs)
        "datasets: {real_cls: {method_params: {duis: {n_cand: 8}}}}",
        ["real_cls/duis/seed1/round1/labeled.json", "real_cls/tables/budget.csv"],
        [
            "*/data/*",
            "*/initial/*",
            "*/duis/*/round0/*",
            "*/random/*",
            "street_*",
        ],
    ),
    "a dataset's batch": (
        "datasets: {real_cls: {al: {batch: 5}}}",
        ["real_cls/random/seed1/round1/labeled.json"],
        ["*/round0/*", "*/initial/*", "*/data/*", "street_*"],
    ),
    "the embedding framework's seeds": (
        # Margin runs in the budget experiment alone; Random's seeds stay (the cold
        # start runs it at seed 3 still)
        "datasets: {real_cls: {embedding: {experiments: {budget: {seeds: [1, 2]}}}}}",
        ["real_cls/embedding/runs/margin.json", "real_cls/embedding/tables/budget.csv"],
        [
            "*/data/*",
            "*/initial/*",
            "real_cls/embedding/encoders/*",
            "real_cls/embedding/runs/random.json",
            "real_cls/random/*",
        ],
    ),
    "the encoder's recipe": (
        "datasets: {real_cls: {embedding: {encoder: {steps: 32}}}}",
        [
            "real_cls/embedding/encoders/seed0/encoder.pt",
            "real_cls/embedding/encoders/seed1/encoder.pt",
            "real_cls/embedding/runs/duis.json",
            "real_cls/typiclust_ssl/seed1/round0/scores.npz",  # it selects on them
        ],
        ["*/data/*", "*/initial/*", "real_cls/random/*", "real_cls/duis/*", "street_*"],
    ),
    "a cold start's strategies": (
        "datasets: {real_cls: {experiments: {cold_start: {starts: [typiclust, maxherding]}}}}",
        ["real_cls/initial_maxherding/seed1.json", "real_cls/tables/cold_start.csv"],
        ["*/data/*", "real_cls/initial/*", "real_cls/initial_typiclust/*", "real_cls/duis/*"],
    ),
    "an encoder seed": (
        "datasets: {real_cls: {embedding: {encoder: {seeds: [0, 1, 5]}}}}",
        ["real_cls/embedding/encoders/seed5/encoder.pt", "real_cls/embedding/runs/duis.json"],
        # block 1: run seed 3 reads the new encoder; run seeds 1-2, and the supervised
        # runs that select on their encoders, still read encoders 0 and 1
        [
            "real_cls/embedding/encoders/seed0/*",
            "real_cls/embedding/encoders/seed1/*",
            "*/data/*",
            "real_cls/typiclust_ssl/*",
        ],
    ),
}


@pytest.mark.parametrize("name", list(CHANGES))
def test_a_changed_setting_reruns_exactly_the_jobs_that_read_it(ci_results, tmp_path, name):
    change, rerun, kept = CHANGES[name]
    files, out = planned(ci_results, tmp_path, change)
    assert set(rerun) <= files, f"{name}: not planned: {sorted(set(rerun) - files)}"
    wrong = sorted(f for f in files if any(fnmatch.fnmatch(f, p) for p in kept))
    assert not wrong, f"{name}: planned although the change does not reach them: {wrong}"
    assert "Changed since the last run into" in out


def test_the_unchanged_config_plans_nothing_and_names_its_change(ci_results, tmp_path):
    files, out = planned(ci_results, tmp_path, None)
    assert not files and "Nothing to be done" in out
    _, out = planned(ci_results, tmp_path, CHANGES["a method's params"][0])
    assert "  methods.duis.params.alpha 0.5 -> 0.4\n" in out
    assert "older spl-al" not in out


def resume_from(ci_results: Path, results: Path, dataset: str, *folders: str) -> None:
    """Copy ``folders`` of the shared run's ``dataset`` into ``results``, file times kept:
    a run there takes them as done (a run that stopped after them) and does the rest."""
    for folder in folders:
        shutil.copytree(ci_results / dataset / folder, results / dataset / folder)


def warm_processes(folder: str) -> list[int]:
    """Pids of the processes whose command line names ``folder`` (a warm server's)."""
    pids = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            if folder.encode() in (proc / "cmdline").read_bytes():
                pids.append(int(proc.name))
        except OSError:
            continue  # ended meanwhile
    return pids


def test_killed_run_resumes_to_identical_tables_and_labeled_sets(ci_results, tmp_path):
    """A second run of the same config (street_seg, from its data and round-0 fits), with
    its own warm job server, SIGKILLed as a whole process group in its query rounds and
    restarted after `snakemake --unlock`, ends with the same labeled sets and tables as
    the uninterrupted run; the killed run's server and socket do not outlive it. It is
    killed as its first round-0 record appears: the rounds after it take seconds, and a
    kill at round 1's labeled set came after the tables on a busy machine."""
    results = tmp_path / "results"
    resume_from(ci_results, results, "street_seg", "data", "initial")
    target = [str(results / "street_seg" / "tables" / f"{t}.csv") for t in ("budget", "levels")]
    own = {k: v for k, v in os.environ.items() if k != SOCKET_ENV}  # its own server
    proc = snakemake(results, *target, background=True, env=own)
    deadline = time.monotonic() + 300
    while not list((results / "street_seg").glob("*/seed*/round0/metrics.json")):
        assert proc.poll() is None, "the run ended before it could be killed"
        assert time.monotonic() < deadline
        time.sleep(0.05)
    ready = (results / "logs" / "warm_server.log").read_text()
    socket = re.search(r"ready at (\S+)", ready).group(1)
    os.killpg(proc.pid, signal.SIGKILL)  # Snakemake, its jobs and the server it started
    proc.wait()
    assert not (results / "street_seg" / "tables" / "budget.csv").exists()
    folder = str(Path(socket).parent)
    deadline = time.monotonic() + 10
    while (warm_processes(folder) or Path(folder).exists()) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not warm_processes(folder), "the killed run's warm server is still running"
    assert not Path(folder).exists(), "the killed run's warm socket folder is left behind"

    snakemake(results, "--unlock", *target)
    snakemake(results, *target)
    assert labeled_sets(results, "street_seg") == labeled_sets(ci_results, "street_seg")
    for t in ("budget", "levels"):
        name = f"street_seg/tables/{t}.csv"
        assert (results / name).read_bytes() == (ci_results / name).read_bytes()


def test_cluster_mode_runs_group_jobs_and_agrees(ci_results, tmp_path):
    """The generic cluster executor with a local submit script: one submission per
    round (train + the query it feeds), same numbers as the local run. Its jobs are
    fresh processes, the local run's forked warm ones: street_pc's round 1 fine-tunes
    PointNet++, whose own point sampling must follow the seed in both."""
    results = tmp_path / "results"
    resume_from(ci_results, results, "street_pc", "data", "initial", "random/seed1/round0")
    target = results / "street_pc" / "random" / "seed1" / "round1" / "metrics.json"
    # the profile names its submit script from the checkout: here, by its full path
    profile = tmp_path / "local-cluster"
    shutil.copytree(ROOT / "profiles" / "local-cluster", profile)
    text = (profile / "config.yaml").read_text()
    submit = str(ROOT / "profiles" / "local-cluster" / "submit.sh")
    (profile / "config.yaml").write_text(text.replace("profiles/local-cluster/submit.sh", submit))
    run = snakemake(results, str(target), profile=str(profile))
    out = run.stdout + run.stderr
    assert "Submitted group job" in out and "rule dataset" not in out
    ours = json.loads(target.read_text())
    local = json.loads((ci_results / "street_pc/random/seed1/round1/metrics.json").read_text())
    assert ours["value"] == local["value"] and ours["n_labeled"] == local["n_labeled"]


def tables(results: Path) -> dict[str, bytes]:
    """Every file under a dataset's tables/ folder, by its path below ``results``."""
    return {
        str(p.relative_to(results)): p.read_bytes()
        for p in sorted(results.glob("*/tables/*"))
        if p.is_file()
    }


@pytest.fixture
def slurm_cluster(tmp_path):
    """A single-node SLURM from scripts/slurm-local.sh, brought down again whatever
    happens; the environment that reaches it (SLURM_CONF)."""
    if os.environ.get("SPL_AL_SLURM") != "1":
        pytest.skip("real SLURM test is opt-in: set SPL_AL_SLURM=1 (root, apt, no other SLURM)")
    env = {**os.environ, "SPL_AL_SLURM_DIR": str(tmp_path / "slurm")}
    script = [str(ROOT / "scripts" / "slurm-local.sh")]
    try:
        up = subprocess.run([*script, "up"], env=env, capture_output=True, text=True)
        assert up.returncode == 0, f"slurm-local.sh up failed:\n{up.stdout}\n{up.stderr}"
        yield {**env, "SLURM_CONF": str(tmp_path / "slurm" / "slurm.conf")}
    finally:
        down = subprocess.run([*script, "down"], env=env, capture_output=True, text=True)
        assert down.returncode == 0, f"slurm-local.sh down failed:\n{down.stderr}"


def test_slurm_runs_the_ci_dag_to_identical_tables(ci_results, slurm_cluster, tmp_path):
    """The whole config/ci.yaml DAG submitted to a real slurmctld through
    profiles/slurm: every job an sbatch job (rounds as group jobs), every table byte for
    byte the local run's. No slurmdbd, so the plugin polls squeue."""
    results = tmp_path / "results"
    logs = tmp_path / "slurm_logs"
    start = time.monotonic()
    run = snakemake(
        results,
        "--slurm-status-command", "squeue",
        "--slurm-logdir", str(logs),
        "--slurm-keep-successful-logs",
        profile="profiles/slurm",
        env=slurm_cluster,
    )  # fmt: skip
    WALL["slurm"] = time.monotonic() - start
    out = run.stdout + run.stderr
    submitted = out.count("has been submitted with SLURM jobid")
    groups = len(list(logs.glob("group_round_*")))
    print(
        f"\nci DAG: local -j2 {WALL.get('local', float('nan')):.0f} s, "
        f"SLURM {WALL['slurm']:.0f} s, {submitted} sbatch jobs, {groups} round groups"
    )
    # every job but the local rule `all` went through sbatch (a round's train and the
    # query it feeds as one group job), each with its SLURM log ending in success
    job_logs = sorted(logs.glob("**/*.log"))
    assert submitted > 50 and groups > 10 and len(job_logs) == submitted
    for log in job_logs:
        assert "steps (100%) done" in log.read_text(), f"{log} does not end in success"
    ours, local = tables(results), tables(ci_results)
    assert sorted(ours) == sorted(local) and len(ours) > 40
    differ = [name for name in local if ours[name] != local[name]]
    assert not differ, f"tables that differ from the local run: {differ}"
    assert labeled_sets(results, "real_cls") == labeled_sets(ci_results, "real_cls")


def test_the_precision_benchmark_compares_two_runs_claim_by_claim(ci_results, tmp_path):
    """python -m spl_al.bench precision: a run compared with itself (tables copied as a
    bf16 and an fp32 run) agrees on every pair and claim; the folders given in the
    wrong order are refused in one sentence."""
    from spl_al.bench import precision

    folders = {}
    for name in ("bf16", "fp32"):
        tables = tmp_path / name / "real_cls" / "tables"
        shutil.copytree(ci_results / "real_cls" / "tables", tables)
        summary = json.loads((tables / "summary.json").read_text())
        (tables / "summary.json").write_text(json.dumps({**summary, "precision": name}))
        folders[name] = tmp_path / name
    text = precision.report(folders, "real_cls")
    assert "| duis − syn_diversity |" in text and "**no**" not in text
    assert "DUIS has the largest AUBC over query rounds" in text
    with pytest.raises(ValueError, match="trained in fp32, not bf16"):
        precision.report({"bf16": folders["fp32"], "fp32": folders["bf16"]}, "real_cls")
    # --picks: each query redone from its weights, scored in bf16 and in fp32; Random
    # reads no score, so it picks the same groups either way
    picks = {row[0]: row for row in precision.pick_agreement(ci_results, "real_cls")}
    assert set(picks) == {"random", "margin", "syn_diversity", "duis"}
    assert picks["random"][1:] == ["100%", "100%", "2 of 2"]


def test_embedding_framework_runs_on_the_same_round0_sets(ci_results):
    """config/ci.yaml's real_cls embedding framework: every table kind under
    real_cls/embedding/, each naming its framework, its rounds starting from the seeds'
    own round-0 sets, and a supervised method with features: embedding selecting on
    the same embeddings."""
    root = ci_results / "real_cls" / "embedding"
    card = json.loads((root / "encoders" / "seed0" / "card.json").read_text())
    assert card["dataset"] == "real_cls" and card["precision"] == "fp32"
    assert card["encoder"]["seed"] == 0 and card["health"]["verdict"] in ("healthy", "doubtful")
    for name in ("budget", "levels", "ablation", "sensitivity"):
        caption = (root / "tables" / f"{name}.md").read_text().splitlines()[0]
        assert "embedding framework" in caption
    assert "in the embedding framework" in (root / "tables" / "claims.md").read_text()
    claims = pd.read_csv(root / "tables" / "claims.csv")
    assert set(claims["framework"]) == {"embedding"}
    assert json.loads((root / "tables" / "summary.json").read_text())["framework"] == "embedding"
    runs = json.loads((root / "runs" / "duis.json").read_text())
    assert sorted({r["seed"] for r in runs}) == [1, 2, 3]
    # block 1: run seed s reads encoder seed s - 1
    assert {(r["seed"], r["encoder"]) for r in runs} == {(1, 0), (2, 1), (3, 2)}
    for record in (r for r in runs if r["round"] == 0 and r["seed"] in (1, 2)):
        initial = ci_results / "real_cls" / "initial" / f"seed{record['seed']}.json"
        assert sorted(record["pool_indices"]) == json.loads(initial.read_text())["pool_indices"]
    with np.load(root / "encoders" / "seed0" / "embeddings.npz") as f:
        train = f["train"]
    scores = np.load(ci_results / "real_cls" / "typiclust_ssl" / "seed1" / "round0" / "scores.npz")
    np.testing.assert_array_equal(scores["features"], train[scores["unlabeled_idx"], 0])


@pytest.mark.parametrize("dataset", ["street_seg", "street_pc"])
def test_segmentation_runs_in_the_embedding_framework_over_encoders(ci_results, dataset):
    """config/ci.yaml's street scans in the embedding framework: dense encoders (one
    per run seed), mIoU records of the per-pixel probe, every table kind and the claims
    with the encoder as the unit. street_pc's points are street_seg's scans' valid
    pixels (embedding: {shared: street_seg}): it reads street_seg's encoders and runs,
    the same records under its own name."""
    root = ci_results / dataset / "embedding"
    source = ci_results / "street_seg" / "embedding"
    card = json.loads((source / "encoders" / "seed0" / "card.json").read_text())
    assert card["encoder"]["depth"] == 2 and card["units_per_scan"] > 0  # the dense recipe
    runs = json.loads((root / "runs" / "dropquery.json").read_text())
    assert {r["metric"] for r in runs} == {"miou"}
    assert {(r["seed"], r["encoder"]) for r in runs} == {(s, s - 1) for s in (1, 2, 3)}
    if dataset == "street_pc":
        assert not (root / "encoders").exists()
        assert {(r["dataset"], r["runs_of"]) for r in runs} == {("street_pc", "street_seg")}
        own = json.loads((source / "runs" / "dropquery.json").read_text())
        assert [{**r, "dataset": "street_seg"} for r in own] == [
            {k: v for k, v in {**r, "dataset": "street_seg"}.items() if k != "runs_of"}
            for r in runs
        ]
    for name in ("budget", "levels", "ablation", "sensitivity"):
        caption = (root / "tables" / f"{name}.md").read_text().splitlines()[0]
        assert "embedding framework" in caption and "3 encoders" in caption
    claims = pd.read_csv(root / "tables" / "claims.csv")
    assert set(claims["framework"]) == {"embedding"} and set(claims["unit"]) == {"encoder"}
    assert "dense encoder" in (root / "tables" / "claims.md").read_text()


def test_a_cold_start_round_0_is_typiclust_on_the_seed_encoder(ci_results):
    """config/ci.yaml's supervised cold-start arm: DUIS from a TypiClust first batch
    chosen on run seed 1's encoder (no label), against DUIS from the random one."""
    from spl_al.cold_start import first_batch

    cold = json.loads((ci_results / "real_cls" / "initial_typiclust" / "seed1.json").read_text())
    assert cold["chosen_by"]["strategy"] == "typiclust"
    assert cold["chosen_by"]["encoder"]["encoder_seed"] == 0  # run seed 1 reads encoder 0
    with np.load(
        ci_results / "real_cls" / "embedding" / "encoders" / "seed0" / "embeddings.npz"
    ) as f:
        expected, _ = first_batch(f["train"][:, 0], cold["n_labeled"], seed=1, strategy="typiclust")
    assert cold["pool_indices"] == expected.tolist()
    arm = ci_results / "real_cls" / "duis_from_typiclust" / "seed1"
    round1 = json.loads((arm / "round1" / "labeled.json").read_text())["pool_indices"]
    assert set(cold["pool_indices"]) < set(round1)  # the arm's rounds go on from its round 0
    round0 = json.loads((arm / "round0" / "metrics.json").read_text())
    assert round0["n_labeled"] == cold["n_labeled"]
    random0 = json.loads((ci_results / "real_cls" / "initial" / "seed1.json").read_text())
    assert random0["pool_indices"] != cold["pool_indices"] and "chosen_by" not in random0
    claims = pd.read_csv(ci_results / "real_cls" / "tables" / "claims.csv")
    assert "typical_first_batch_typiclust" in set(claims["claim_id"])
