"""The differences figure (DUIS − each method on the AUBC, a forest plot by claim
family) and the batch-conditions figure and table (the MSPPP levels and SBRs of the
frames each method queried, against the pool's), on small hand-built frames; and the
outputs `all` asks of the CI config for them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers.claim_selection import selection_of

from spl_al.experiment.outputs import framework_outputs
from spl_al.frameworks import EMBEDDING, SUPERVISED
from spl_al.report.claims import (
    AGAINST,
    AGREE,
    CONTRADICTED,
    INCONCLUSIVE,
    NO_CLAIM,
    OTHERS,
    SUPPORTED,
    at_precision,
    aubc_differences,
    claims,
)
from spl_al.report.conditions import (
    POOL,
    batch_conditions,
    batch_conditions_figure,
    queried_frames,
    sbr_bins,
)
from spl_al.report.display import method_label
from spl_al.report.stat_figures import DIFFERENCES_XLABEL, VERDICT_STYLES, differences_figure
from spl_al.report.stats import paired_test

ROOT = Path(__file__).resolve().parents[1]

UP6 = np.array([2.0, 2.1, 1.9, 2.0, 2.2, 1.8])  # every seed for A: p = 2/64, resolved
MIXED6 = np.array([1.0, -0.5, 1.2, -0.3, 0.8, 0.1])  # unresolved
UP3 = np.array([2.0, 2.1, 1.9])  # three seeds agree: the small-n rule


def aubc_rows(diffs: dict[str, np.ndarray], other_rows: bool = True) -> pd.DataFrame:
    """A comparisons frame of DUIS against each method on the AUBC with these per-seed
    differences (DUIS − method, points), as ``comparisons`` writes it (plus a round
    row, which the figure must not read)."""
    rows = []
    for method, d in diffs.items():
        d = np.asarray(d, dtype=float)
        for point in ("AUBC", "round 1 (10.0%)") if other_rows else ("AUBC",):
            rows.append(
                {
                    "experiment": "budget",
                    "point": point,
                    "parameter": None,
                    "round": None if point == "AUBC" else 1,
                    "n_labeled": None,
                    "method_a": method,  # B − A as comparisons may order it: flipped
                    "method_b": "duis",
                    "value_a": None,
                    "value_b": None,
                    **paired_test(-d + (5 if point != "AUBC" else 0), np.zeros_like(d)),
                    "unit": "seed",
                    "n_seeds": len(d),
                    "span": "rounds 1-2 (3.6-5.5%)" if point == "AUBC" else "",
                    "dataset": "d",
                    "metric": "accuracy",
                    "scale": 100.0,
                    "synthetic_standin": False,
                }
            )
    return pd.DataFrame(rows)


SIX = {
    "random": UP6,  # the paper's family: for DUIS
    "margin": MIXED6,  # inconclusive
    "syn_random": -UP6,  # matched: against, Holm over one survives
    "syn_typiclust": -MIXED6,  # low-budget: unresolved
    "syn_diversity": UP6 * 2,  # DUIS's own pairwise claim: inconsistency over diversity
    "typiclust": UP6,  # in no claim (the low-budget claim reads the matched twins)
}
SELECTION = selection_of(
    ["random", "margin", "syn_random", "syn_typiclust", "syn_diversity", "typiclust", "duis"]
)
PAIR = "inconsistency_over_diversity"


def test_the_differences_are_each_comparison_oriented_duis_minus_method_by_family():
    cmp = aubc_rows(SIX)
    diffs = aubc_differences(cmp, SELECTION)
    families = ["paper", "paper", "matched", "low_budget", PAIR, OTHERS]
    assert diffs["family"].tolist() == families
    assert diffs["method"].tolist() == [
        "random",
        "margin",
        "syn_random",
        "syn_typiclust",
        "syn_diversity",
        "typiclust",
    ]
    for _, row in diffs.iterrows():
        d = SIX[row["method"]]
        assert row["diff"] == pytest.approx(d.mean())  # DUIS − method, not method − DUIS
        assert row["ci_low"] < d.mean() < row["ci_high"]
        assert row["n"] == 6 and row["unit"] == "seed"
    verdicts = dict(zip(diffs["method"], diffs["verdict"], strict=True))
    assert verdicts == {
        "random": SUPPORTED,
        "margin": INCONCLUSIVE,
        "syn_random": CONTRADICTED,
        "syn_typiclust": INCONCLUSIVE,
        "syn_diversity": SUPPORTED,  # its own reading, a claim of one comparison
        "typiclust": NO_CLAIM,
    }
    assert set(diffs["span"]) == {"rounds 1-2 (3.6-5.5%)"}


def test_the_family_heading_carries_its_claims_verdict_and_precision_can_undecide_it():
    cmp = aubc_rows(SIX)
    judged = at_precision(claims(cmp, SELECTION), "fp32")
    diffs = aubc_differences(cmp, SELECTION, judged)
    heads = diffs.drop_duplicates("family").set_index("family")["claim_verdict"]
    # random for, margin undecided: the paper's claim is inconclusive; one against:
    # the matched claim is contradicted
    assert heads.to_dict() == {
        "paper": INCONCLUSIVE,
        "matched": CONTRADICTED,
        "low_budget": INCONCLUSIVE,
        # judged at the ablation's round without every part of the decomposition (as
        # here), the claim is not this AUBC's: the heading quotes none
        PAIR: "",
        OTHERS: "",
    }
    bf16 = aubc_differences(cmp, SELECTION, at_precision(claims(cmp, SELECTION), "bf16"))
    assert set(bf16.loc[bf16["family"] != OTHERS, "verdict"]) == {INCONCLUSIVE}


def test_below_six_seeds_a_comparison_reads_by_the_small_n_rule():
    cmp = aubc_rows({"random": UP3, "entropy": -UP3}, other_rows=False)
    diffs = aubc_differences(cmp, selection_of(["random", "entropy", "duis"]))
    assert dict(zip(diffs["method"], diffs["verdict"], strict=True)) == {
        "random": AGREE,
        "entropy": AGAINST,
    }
    assert set(diffs["rule"]) == {"small-n"}


def test_no_aubc_comparison_gives_no_row_and_an_empty_figure():
    assert aubc_differences(aubc_rows({}, other_rows=False), SELECTION).empty
    fig = differences_figure(aubc_differences(aubc_rows({}), SELECTION), dataset="d")
    assert "no paired AUBC comparison" in fig.axes[0].get_title()


def test_the_forest_plot_puts_each_difference_and_interval_where_it_belongs():
    from spl_al.plotting import texts_outside

    cmp = aubc_rows(SIX)
    diffs = aubc_differences(cmp, SELECTION, at_precision(claims(cmp, SELECTION), "fp32"))
    fig = differences_figure(diffs, dataset="real_cls", metric="accuracy", note=", stand-in")
    ax = fig.axes[0]
    markers = {line.get_gid(): line for line in ax.get_lines() if line.get_gid()}
    intervals = {c.get_gid(): c for c in ax.collections if c.get_gid()}
    heads = {t.get_gid(): t for t in ax.texts if (t.get_gid() or "").startswith("family:")}
    ticks = {t.get_text(): y for t, y in zip(ax.get_yticklabels(), ax.get_yticks(), strict=True)}
    for _, row in diffs.iterrows():
        line = markers[row["method"]]
        assert line.get_xdata()[0] == pytest.approx(row["diff"])
        y = line.get_ydata()[0]
        (segment,) = intervals[f"{row['method']}:ci"].get_segments()
        assert segment[:, 0].tolist() == pytest.approx([row["ci_low"], row["ci_high"]])
        assert segment[:, 1].tolist() == [y, y]
        style = VERDICT_STYLES[row["verdict"]]
        assert line.get_marker() == style["marker"] and line.get_color() == style["color"]
    # the rows lie under their family's heading, in the table's order
    ys = [markers[m].get_ydata()[0] for m in diffs["method"]]
    assert ys == sorted(ys)
    assert [ticks[method_label(m)] for m in diffs["method"]] == ys
    at = {gid.removeprefix("family:"): t.get_position()[1] for gid, t in heads.items()}
    assert list(at) == ["paper", "matched", "low_budget", PAIR, OTHERS]
    assert at["paper"] < ys[0] and ys[1] < at["matched"] < ys[2] < at["low_budget"] < ys[3]
    assert ys[3] < at[PAIR] < ys[4] < at[OTHERS] < ys[5]
    assert heads[f"family:{PAIR}"].get_text().startswith("DUIS's inconsistency over diversity")
    assert heads["family:paper"].get_text() == (
        "the paper's baselines, as the paper compares (claim: inconclusive)"
    )
    assert heads["family:matched"].get_text().endswith("(claim: contradicted)")
    assert heads[f"family:{OTHERS}"].get_text() == "in no claim"
    assert any(np.allclose(line.get_xdata(), 0) for line in ax.get_lines() if not line.get_gid())
    assert ax.get_xlabel() == DIFFERENCES_XLABEL == "DUIS − method, AUBC (points)"
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == [SUPPORTED, CONTRADICTED, INCONCLUSIVE, "in no claim"]
    title = ax.get_title().replace("\n", " ")
    assert "n = 6 seeds" in title and "real_cls, stand-in" in title
    assert texts_outside(fig) == []


def test_encoders_as_the_unit_are_named_in_the_title():
    cmp = aubc_rows({"random": UP6}, other_rows=False).assign(unit="encoder", n_seeds=60)
    diffs = aubc_differences(cmp, selection_of(["random", "duis"]))
    assert diffs["n_seeds"].tolist() == [60] and diffs["unit"].tolist() == ["encoder"]
    title = differences_figure(diffs, dataset="d").axes[0].get_title().replace("\n", " ")
    assert "n = 6 encoders' means (60 seeds)" in title


# ---------------------------------------------------------------- batch conditions


def test_each_query_round_adds_the_frames_its_set_gained():
    sets = [
        ("duis", 1, 0, [0, 1]),
        ("duis", 1, 1, [0, 1, 5, 6]),
        ("duis", 1, 2, [0, 1, 5, 6, 2]),
        ("random", 1, 0, [0, 1]),
        ("random", 1, 2, [0, 1, 3, 4, 7]),  # round 1 missing: round 2 adds nothing
    ]
    q = queried_frames(sets)
    assert q.values.tolist() == [["duis", 1, 1, 5], ["duis", 1, 1, 6], ["duis", 1, 2, 2]]


# a pool of 10 frames: 4 low, 3 medium, 3 high; SBR 0.2 (5 frames), 1 (3), 5 (2)
LEVEL = np.array(["low"] * 4 + ["medium"] * 3 + ["high"] * 3)
SBR = np.array([0.2, 0.2, 0.2, 1.0, 0.2, 0.2, 1.0, 1.0, 5.0, 5.0])


def _queried() -> pd.DataFrame:
    sets = [
        ("duis", 1, 0, [9]),
        ("duis", 1, 1, [9, 0, 1]),  # low, low
        ("duis", 2, 0, [8]),
        ("duis", 2, 1, [8, 2, 7]),  # low, high
        ("random", 1, 0, [9]),
        ("random", 1, 1, [9, 4, 8]),  # medium, high
    ]
    return queried_frames(sets)


def test_level_shares_sum_to_one_and_the_pool_row_is_the_pools_make_up():
    table = batch_conditions(_queried(), LEVEL, SBR, methods=["random", "duis"])
    assert list(dict.fromkeys(table["method"])) == [POOL, "random", "duis"]
    sums = table.groupby(["method", "condition"])["share"].sum()
    assert np.allclose(sums.to_numpy(), 1.0)
    shares = table.set_index(["method", "condition", "bin"])["share"]
    assert shares[(POOL, "msppp_level", "low")] == pytest.approx(0.4)
    assert shares[(POOL, "msppp_level", "medium")] == pytest.approx(0.3)
    assert shares[(POOL, "sbr", "0.2")] == pytest.approx(0.5)
    assert shares[(POOL, "sbr", "5")] == pytest.approx(0.2)
    # DUIS queried 0, 1, 2 (low) and 7 (high), over 2 runs: 3/4 low
    assert shares[("duis", "msppp_level", "low")] == pytest.approx(0.75)
    assert shares[("duis", "msppp_level", "medium")] == 0
    assert shares[("random", "msppp_level", "high")] == pytest.approx(0.5)
    assert shares[("duis", "sbr", "1")] == pytest.approx(0.25)
    levels = table[(table["method"] == "duis") & (table["condition"] == "msppp_level")]
    assert levels["bin"].tolist() == ["low", "medium", "high"]  # fewest photons first
    assert levels["n_frames"].tolist() == [3, 0, 1]
    counted = table.drop_duplicates("method").set_index("method")
    assert counted.loc["duis", "n_runs"] == 2 and counted.loc[POOL, "n_runs"] == 0
    assert counted.loc["duis", "rounds"] == "1"


def test_many_sbr_values_are_binned_by_the_pools_tertiles_and_nan_is_unknown():
    sbr = np.array([0.1, 0.2, 0.3, 0.5, 0.8, 1.0, 2.0, 3.0, 5.0, np.nan])
    labels, order = sbr_bins(sbr)
    assert len(order) == 4 and order[-1] == "unknown"
    assert labels[-1] == "unknown" and labels[0] == order[0] and labels[-2] == order[2]
    assert pd.Series(labels[:-1]).value_counts().tolist() == [3, 3, 3]
    few, few_order = sbr_bins(SBR)
    assert few_order == ["0.2", "1", "5"] and few[3] == "1"


def test_the_bars_are_the_shares_with_the_pool_on_top():
    from spl_al.plotting import texts_outside

    table = batch_conditions(_queried(), LEVEL, SBR, methods=["random", "duis"])
    fig = batch_conditions_figure(table, title="real_cls, synthetic stand-in: conditions")
    bars = {p.get_gid(): p for ax in fig.axes for p in ax.patches if p.get_gid()}
    for _, row in table.iterrows():
        bar = bars[f"{row['method']}|{row['condition']}|{row['bin']}"]
        assert bar.get_width() == pytest.approx(row["share"])
    pool = bars[f"{POOL}|msppp_level|low"]
    duis = bars["duis|msppp_level|low"]
    assert pool.get_y() < duis.get_y()  # drawn first, the top row once inverted
    assert fig.axes[0].get_ylim()[0] > fig.axes[0].get_ylim()[1]
    assert bars["duis|msppp_level|high"].get_x() == pytest.approx(0.75)  # stacked
    assert texts_outside(fig) == []


def test_the_report_step_reads_labeled_sets_of_both_frameworks(tmp_path):
    """make_batch_conditions: a dataset file's conditions (no image read), the
    supervised runs' labeled files and the embedding framework's runs files."""
    from spl_al.data.dataset import FORMAT, VERSION, load_conditions
    from spl_al.data.storage import atomic_savez
    from spl_al.experiment.report_steps import make_batch_conditions

    split = np.array(["train"] * 10 + ["test"] * 2)
    arrays = {
        "split": split,
        "level": np.concatenate([LEVEL, ["low", "high"]]),
        "msppp": np.ones(12),
        "sbr": np.concatenate([SBR, [1.0, 1.0]]),
    }
    data = tmp_path / "dataset.npz"
    atomic_savez(
        data, arrays, {"format": FORMAT, "version": VERSION, "meta": {"synthetic_standin": True}}
    )
    got, meta = load_conditions(data)
    assert sorted(got) == ["level", "msppp", "sbr", "split"] and meta["synthetic_standin"]

    files, layout = [], []
    for method, seed, rounds in (("duis", 1, [[9], [9, 0, 1]]), ("random", 1, [[9], [9, 4, 8]])):
        layout.append([method, seed, len(rounds)])
        for r, idx in enumerate(rounds):
            path = tmp_path / f"{method}{seed}_{r}.json"
            path.write_text(json.dumps({"pool_indices": idx}))
            files.append(str(path))
    out = {k: str(tmp_path / f"s.{k}") for k in ("csv", "png", "pdf")}
    make_batch_conditions(
        data,
        methods=["random", "duis"],
        rounds=2,
        out=out,
        title="real_cls",
        framework=SUPERVISED.name,
        labeled_paths=files,
        labeled_runs=layout,
    )
    table = pd.read_csv(out["csv"])
    low = table[(table["condition"] == "msppp_level") & (table["bin"] == "low")]
    assert dict(zip(low["method"], low["share"], strict=True)) == {
        POOL: 0.4,
        "random": 0,
        "duis": 1,
    }
    assert Path(out["png"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert Path(out["pdf"]).read_bytes()[:4] == b"%PDF"

    records = [
        {"method": "duis", "seed": s, "round": r, "pool_indices": idx}
        for s in (1, 2)
        for r, idx in enumerate([[9], [9, 0], [9, 0, 8]])
    ]
    runs = tmp_path / "duis.json"
    runs.write_text(json.dumps(records))
    out = {k: str(tmp_path / f"e.{k}") for k in ("csv", "png", "pdf")}
    make_batch_conditions(
        data,
        methods=["duis"],
        rounds=2,  # round 2 is past the budget's rounds: not counted
        out=out,
        title="real_cls",
        framework=EMBEDDING.name,
        runs_paths=[str(runs)],
    )
    table = pd.read_csv(out["csv"])
    duis = table[(table["method"] == "duis") & (table["condition"] == "msppp_level")]
    assert duis["n_frames"].tolist() == [2, 0, 0] and set(duis["n_runs"]) == {2}


def _merged(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        out[key] = _merged(out.get(key) or {}, value) if isinstance(value, dict) else value
    return out


def test_all_asks_the_ci_run_for_both_figures_in_both_frameworks():
    """config/ci.yaml's datasets have MSPPP levels: `all` asks each budget experiment
    for its differences figure (the stats job's) and its batch conditions."""
    default = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config = _merged(default, yaml.safe_load((ROOT / "config" / "ci.yaml").read_text()))
    for dataset, kind, folder in (
        ("real_cls", SUPERVISED, "R/real_cls"),
        ("real_cls", EMBEDDING, "R/real_cls/embedding"),
        ("street_seg", SUPERVISED, "R/street_seg"),
        ("street_pc", SUPERVISED, "R/street_pc"),
    ):
        out = framework_outputs(config, dataset, kind, results="R")
        for name in ("differences.png", "differences.pdf", "batch_conditions.png"):
            assert f"{folder}/figures/{name}" in out, (dataset, kind.name, name)
        assert f"{folder}/tables/batch_conditions.csv" in out
