"""The differences figure (DUIS − each method on the AUBC, a forest plot by claim
family) on small hand-built frames; and the outputs `all` asks of the CI config for it."""

from __future__ import annotations

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
    "syn_diversity": UP6 * 2,  # in no family
}
SELECTION = selection_of(
    ["random", "margin", "syn_random", "syn_typiclust", "syn_diversity", "duis"]
)


def test_the_differences_are_each_comparison_oriented_duis_minus_method_by_family():
    cmp = aubc_rows(SIX)
    diffs = aubc_differences(cmp, SELECTION)
    assert diffs["family"].tolist() == ["paper", "paper", "matched", "low_budget", OTHERS]
    assert diffs["method"].tolist() == [
        "random",
        "margin",
        "syn_random",
        "syn_typiclust",
        "syn_diversity",
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
        "syn_diversity": NO_CLAIM,
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
    assert list(at) == ["paper", "matched", "low_budget", OTHERS]
    assert at["paper"] < ys[0] and ys[1] < at["matched"] < ys[2] < at["low_budget"] < ys[3]
    assert at[OTHERS] < ys[4]
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


def _merged(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        out[key] = _merged(out.get(key) or {}, value) if isinstance(value, dict) else value
    return out


def test_all_asks_the_ci_run_for_both_figures_in_both_frameworks():
    """`all` asks each budget experiment of config/ci.yaml for its differences figure
    (the stats job's)."""
    default = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config = _merged(default, yaml.safe_load((ROOT / "config" / "ci.yaml").read_text()))
    for dataset, kind, folder in (
        ("real_cls", SUPERVISED, "R/real_cls"),
        ("real_cls", EMBEDDING, "R/real_cls/embedding"),
        ("street_seg", SUPERVISED, "R/street_seg"),
        ("street_pc", SUPERVISED, "R/street_pc"),
    ):
        out = framework_outputs(config, dataset, kind, results="R")
        for name in ("differences.png", "differences.pdf"):
            assert f"{folder}/figures/{name}" in out, (dataset, kind.name, name)
