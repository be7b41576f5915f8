"""Paired statistics, Holm, power, AUBC, the bold/tie rule and the claims, on hand-computed
cases."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from spl_al.report import budget_table, records_frame, render_markdown, summary
from spl_al.report.claims import claims
from spl_al.report.comparisons import comparisons, render_comparisons_markdown
from spl_al.report.stats import (
    aubc,
    aubc_per_seed,
    format_seeds_needed,
    holm,
    min_p_value,
    paired_test,
    seeds_for_level,
    seeds_needed,
    sign_flip_p,
    t_interval,
    t_power,
)

T_975_2 = 4.302652729911275  # t quantile 0.975 with 2 degrees of freedom


# --- sign-flip test and t-interval ---------------------------------------------------


@pytest.mark.parametrize(
    ("d", "p"),
    [
        ([1, 2, 3], 2 / 8),  # every seed agrees: the smallest p at n = 3
        # sums of +-1 +-2 +-3: |6|, 0, 2, 4, 4, 2, 0, |6|; six of eight are >= |2|
        ([1, -2, 3], 6 / 8),
        # |d| all 1: |sum| >= 2 unless two are + and two - (6 of 16 vectors)
        ([1, 1, 1, -1], 10 / 16),
        ([0, 0, 0], 1.0),
        ([0.5, 1, 1.5, 2, 2.5, 3], 2 / 64),
        ([0.1], 1.0),  # one pair: both sign vectors are as extreme
    ],
)
def test_sign_flip_p_by_hand(d, p):
    assert sign_flip_p(d) == pytest.approx(p)


def test_minimum_p_and_seeds_for_five_percent():
    assert min_p_value(3) == 0.25 and min_p_value(5) == 0.0625 and min_p_value(6) == 0.03125
    assert seeds_for_level(0.05) == 6
    assert math.isnan(sign_flip_p([]))


def test_t_interval_by_hand():
    low, high = t_interval([1.0, 2.0, 3.0])  # mean 2, sd 1, se 1/sqrt(3)
    half = T_975_2 / math.sqrt(3)
    assert (low, high) == pytest.approx((2 - half, 2 + half))
    assert all(math.isnan(x) for x in t_interval([1.0]))


def test_rule_needs_interval_and_sign_flip_and_three_seeds():
    base = np.array([0.5, 0.6, 0.7])
    # Every seed agrees (p = 0.25 = p_min) but the interval spans zero: not resolved.
    wide = paired_test(base + np.array([0.01, 0.02, 0.03]), base)
    assert wide["p_value"] == 0.25 and wide["ci_low"] < 0 < wide["ci_high"]
    assert not wide["resolved"] and wide["direction"] == 0
    # Consistent and tight: resolved, A better.
    tight = paired_test(base + np.array([0.020, 0.021, 0.019]), base)
    assert tight["resolved"] and tight["direction"] == 1
    assert tight["diff"] == pytest.approx(0.02)
    # Reversed: resolved, B better.
    assert paired_test(base, base + np.array([0.020, 0.021, 0.019]))["direction"] == -1
    # Two seeds, however consistent: too few.
    assert not paired_test([0.7, 0.8], [0.5, 0.6])["resolved"]
    # Seeds that disagree: p > p_min.
    mixed = paired_test(base + np.array([0.03, -0.01, 0.02]), base)
    assert mixed["p_value"] == pytest.approx(0.5) and not mixed["resolved"]


def test_rule_at_six_seeds_is_five_percent_significance():
    base = np.linspace(0.4, 0.9, 6)
    all_up = paired_test(base + np.array([0.02, 0.03, 0.02, 0.025, 0.03, 0.02]), base)
    assert all_up["p_value"] == pytest.approx(2 / 64) and all_up["resolved"]
    one_down = paired_test(base + np.array([0.02, 0.03, 0.02, 0.025, 0.03, -0.001]), base)
    # Flipping the tiny negative pair (or it with others) keeps |sum| as large: p = 4/64.
    assert one_down["p_value"] == pytest.approx(4 / 64) and not one_down["resolved"]


def test_five_percent_rule_from_six_seeds_vs_small_n_rule_below():
    # Five seeds that all agree: p = 2/32 = 0.0625 > 0.05, resolved by the small-n rule.
    five = paired_test(np.array([0.02, 0.03, 0.02, 0.025, 0.03]), np.zeros(5))
    assert five["rule"] == "small-n" and five["p_value"] == pytest.approx(0.0625)
    assert five["resolved"] and five["direction"] == 1
    # Six seeds with one tiny disagreement: p = 4/64 = 0.0625 again, but now the bar is
    # 5% significance, so the same p no longer resolves.
    six = paired_test(np.array([0.02, 0.03, 0.02, 0.025, 0.03, -0.001]), np.zeros(6))
    assert six["rule"] == "5%" and six["p_value"] == pytest.approx(0.0625)
    assert not six["resolved"]
    # Eight seeds, one disagreeing a little: p = 4/256 < 0.05 and the interval excludes
    # zero, so the 5% rule resolves what the small-n rule (every seed agrees) would not.
    d = np.array([0.02, 0.03, 0.02, 0.025, 0.03, 0.02, 0.028, -0.001])
    eight = paired_test(d, np.zeros(8))
    assert eight["p_value"] == pytest.approx(4 / 256) and eight["ci_low"] > 0
    assert eight["rule"] == "5%" and eight["resolved"] and eight["direction"] == 1
    assert eight["sd_diff"] == pytest.approx(d.std(ddof=1))


def test_missing_seeds_are_dropped_pairwise():
    r = paired_test([0.5, np.nan, 0.7, 0.8], [0.4, 0.5, np.nan, 0.6])
    assert r["n"] == 2 and r["diff"] == pytest.approx(0.15)


# --- Holm and power --------------------------------------------------------------------


def test_holm_by_hand():
    # sorted 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1 = 0.02, 0.03, 0.06, 0.04; the running
    # max makes the last 0.06; returned in the input order.
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    # capped at 1, and a single test is left as it is
    assert holm([0.4, 0.5, 0.03]) == pytest.approx([0.8, 0.8, 0.09])
    assert holm([0.03]) == pytest.approx([0.03])
    # a NaN counts in the family and stays NaN
    out = holm([0.01, math.nan])
    assert out[0] == pytest.approx(0.02) and math.isnan(out[1])


def test_holm_is_monotone_and_capped_on_random_p_values():
    rng = np.random.default_rng(0)
    for _ in range(20):
        p = rng.uniform(0, 0.5, size=rng.integers(1, 9))
        adj = holm(p)
        order = np.argsort(p)
        assert (np.diff(adj[order]) >= -1e-15).all()  # same order as the raw p-values
        assert (adj >= p - 1e-15).all() and (adj <= 1).all()


def test_holm_matches_statsmodels():
    multitest = pytest.importorskip("statsmodels.stats.multitest")
    p = np.array([0.01, 0.04, 0.03, 0.005, 0.2, 0.6])
    expected = multitest.multipletests(p, alpha=0.05, method="holm")[1]
    assert holm(p) == pytest.approx(expected)


def test_t_power_is_the_noncentral_t_tail():
    # n = 10 pairs, effect 1: c = t_{0.975, 9} = 2.262, noncentrality sqrt(10) = 3.162.
    from scipy.stats import nct

    c, lam = 2.2621571627409915, math.sqrt(10)
    expected = 1 - nct.cdf(c, 9, lam) + nct.cdf(-c, 9, lam)
    assert t_power(10, 1.0) == pytest.approx(expected)
    assert 0.80 < t_power(10, 1.0) < 0.81 < t_power(11, 1.0)
    assert t_power(6, 0.0) == pytest.approx(0.05)  # no effect: the level


@pytest.mark.parametrize(
    ("effect", "n"),
    # Textbook sample sizes of a two-sided paired t-test at 0.05 with 80% power (G*Power,
    # Cohen's d_z): 0.3 -> 90, 0.5 -> 34, 0.8 -> 15, 1.0 -> 10.
    [(0.3, 90), (0.5, 34), (0.8, 15), (1.0, 10)],
)
def test_seeds_needed_matches_textbook_sample_sizes(effect, n):
    assert seeds_needed(2.0 * effect, 2.0) == n  # only the ratio diff / sd matters
    assert seeds_needed(-2.0 * effect, 2.0) == n  # either direction
    assert t_power(n, effect) >= 0.8 > t_power(n - 1, effect)


def test_seeds_needed_floor_cap_and_no_effect():
    # A huge effect would need 3 seeds for the t-test, but the sign-flip test cannot
    # reach 0.05 below 6: the floor.
    assert seeds_needed(3.0, 1.0) == 6 == seeds_for_level(0.05)
    assert seeds_needed(1.0, 0.0) == 6  # no spread at all
    assert math.isinf(seeds_needed(0.1, 1.0))  # needs ~787 seeds: above the cap of 100
    assert all(math.isnan(seeds_needed(d, sd)) for d, sd in ((0.0, 1.0), (1.0, math.nan)))
    assert [format_seeds_needed(x) for x in (34.0, math.inf, math.nan)] == ["34", ">100", "-"]


def test_bigger_effect_needs_fewer_seeds():
    effects = [0.3, 0.4, 0.5, 0.7, 1.0, 1.4, 2.0]
    needed = [seeds_needed(e, 1.0) for e in effects]
    assert needed == sorted(needed, reverse=True) and needed[0] > needed[-1]


# --- AUBC -----------------------------------------------------------------------------


def test_aubc_trapezoid_normalised_to_budget_range():
    # 0.1 * (0.5 + 0.6) / 2 + 0.2 * (0.6 + 0.8) / 2 = 0.055 + 0.14 = 0.195, / 0.3
    assert aubc([0.1, 0.2, 0.4], [0.5, 0.6, 0.8]) == pytest.approx(0.65)
    assert aubc([0.4, 0.1, 0.2], [0.8, 0.5, 0.6]) == pytest.approx(0.65)  # order-free
    assert aubc([0.2], [0.7]) == pytest.approx(0.7)


def record(method, seed, round_, value, n_labeled=(20, 40, 80), levels=None, dataset="d"):
    return {
        "dataset": dataset,
        "method": method,
        "seed": seed,
        "round": round_,
        "n_labeled": n_labeled[round_],
        "n_total": 200,
        "metric": "accuracy",
        "value": value,
        "per_level": levels or {"high": value, "medium": value, "low": value},
        "synthetic_standin": False,
    }


def test_aubc_per_seed_skips_incomplete_curves_and_summary_carries_interval():
    recs = [record("a", s, r, 0.5 + 0.1 * r + 0.01 * s) for s in (1, 2, 3) for r in range(3)]
    recs = [x for x in recs if not (x["seed"] == 3 and x["round"] == 2)]
    areas = aubc_per_seed(records_frame(recs))
    assert areas["seed"].tolist() == [1, 2]
    # ratios 0.1, 0.2, 0.4; values 0.5, 0.6, 0.7 (+ 0.01 s):
    # (0.1 * 0.55 + 0.2 * 0.65) / 0.3 + 0.01 s = 0.185 / 0.3 + 0.01 s
    base = 0.185 / 0.3
    assert areas["aubc"].tolist() == pytest.approx([base + 0.01, base + 0.02])
    s = summary(records_frame(recs))["methods"]["a"]["aubc"]
    assert s["n"] == 2 and s["mean"] == pytest.approx(base + 0.015)
    half = 12.706204736174707 * 0.01 / math.sqrt(2) / math.sqrt(2)  # t(0.975, 1) sd/sqrt(n)
    mean = base + 0.015
    assert (s["ci_low"], s["ci_high"]) == pytest.approx((mean - half, mean + half))
    assert s["per_seed"] == pytest.approx({"1": base + 0.01, "2": base + 0.02})


# --- bold / tie -----------------------------------------------------------------------

NOISE = (0.0, 0.01, -0.01)  # per seed, shared by every method: paired seeds


def frame_of(offsets: dict, seeds=(1, 2, 3), jitter=None) -> pd.DataFrame:
    """Records where method m scores 0.5 + offsets[m] + NOISE[seed] (+ jitter[m][seed])."""
    recs = []
    for method, off in offsets.items():
        for k, seed in enumerate(seeds):
            for r in range(3):
                extra = jitter[method][k] if jitter and method in jitter else 0.0
                v = round(0.5 + 0.05 * r + off + NOISE[k % 3] + extra, 6)
                recs.append(record(method, seed, r, v))
    return records_frame(recs)


def test_leader_bold_only_when_resolved_else_dagger():
    wide = budget_table(
        frame_of({"random": 0.0, "duis": 0.10}, jitter={"duis": (0, 0.002, -0.001)})
    )
    assert set(wide.loc[wide["method"] == "duis", "mark"]) == {"bold"}
    assert set(wide.loc[wide["method"] == "random", "mark"]) == {""}
    md = render_markdown(wide)
    assert md.count("**") == 2 * 3 + 2  # three bold cells and the caption
    assert "n = 3 seeds per cell" in md and "every seed agrees in direction" in md

    close = budget_table(
        frame_of({"random": 0.0, "duis": 0.002}, jitter={"duis": (0.01, -0.012, 0.008)})
    )
    assert set(close.loc[close["method"] == "duis", "mark"]) == {"tie"}
    assert "†" in render_markdown(close)

    two_seeds = budget_table(frame_of({"random": 0.0, "duis": 0.10}, seeds=(1, 2)))
    assert set(two_seeds["mark"]) == {"", "tie"}

    equal = budget_table(frame_of({"random": 0.0, "entropy": 0.0, "duis": -0.05}))
    assert set(equal.loc[equal["method"] != "duis", "mark"]) == {"tie"}  # both top means
    assert set(equal.loc[equal["method"] == "duis", "mark"]) == {""}


# --- claims ---------------------------------------------------------------------------

EXPERIMENTS = {
    "budget": {"methods": ["random", "entropy", "duis"], "seeds": [1, 2, 3], "rounds": 3},
    "levels": {"round": 2},
    "ablation": {
        "methods": ["syn_random", "syn_diversity", "duis"],
        "seeds": [1, 2, 3],
        "round": 2,
    },
    "sensitivity": {"seeds": [1, 2, 3], "rounds": {"n_cand": 2, "alpha": 2, "n_variants": 2}},
}
SWEEPS = {
    "n_cand": {40: "duis_ncand40", 160: "duis"},
    "alpha": {0.25: "duis_alpha0.25", 0.5: "duis"},
    "m": {1: "duis_m1", 4: "duis"},
}
JITTER = (0.003, -0.002, 0.001)  # DUIS's own seed noise: differences are not constant


def verdicts(duis_offset: float, jitter=JITTER) -> dict[str, str]:
    others = ["random", "entropy", "syn_random", "syn_diversity"]
    others += ["duis_ncand40", "duis_alpha0.25", "duis_m1"]
    offsets = {m: 0.0 for m in others} | {"duis": duis_offset}
    df = frame_of(offsets, jitter={"duis": jitter})
    cmp = comparisons(df, EXPERIMENTS, SWEEPS)
    assert "| Point |" in render_comparisons_markdown(cmp)
    return dict(zip(claims(cmp)["claim_id"], claims(cmp)["verdict"], strict=True))


def test_claims_supported_when_better_on_every_seed_by_a_wide_margin():
    v = verdicts(+0.10)
    for claim in (
        "duis_best_every_budget",
        "duis_best_aubc",
        "duis_best_every_level",
        "inconsistency_helps",
        "m_gt_1_beats_m_1",
        "alpha_half_not_worse",
    ):
        assert v[claim] == "supported", claim
    # Syn+Diversity and Syn+Random are equal here, so diversity does not help and the order
    # (which needs both steps) is inconclusive; N_cand 160 (DUIS) beats 40 with no fall.
    assert v["diversity_helps"] == "inconclusive" and v["ablation_order"] == "inconclusive"
    assert v["ncand_grows_to_plateau"] == "supported"


def test_claims_inconclusive_when_equal_in_distribution():
    v = verdicts(0.0, jitter=(0.01, -0.012, 0.003))
    assert set(v.values()) == {"inconclusive"}


def test_claims_contradicted_when_worse():
    v = verdicts(-0.10)
    for claim in (
        "duis_best_every_budget",
        "duis_best_every_level",
        "inconsistency_helps",
        "m_gt_1_beats_m_1",
        "alpha_half_not_worse",
        "ncand_grows_to_plateau",
    ):
        assert v[claim] == "contradicted", claim


def test_claims_inconclusive_with_too_few_seeds_and_absent_when_not_run():
    df = frame_of({"random": 0.0, "duis": 0.10}, seeds=(1, 2))
    out = claims(comparisons(df, {"budget": EXPERIMENTS["budget"]}, {}))
    assert out["claim_id"].tolist() == ["duis_best_every_budget", "duis_best_aubc"]
    assert set(out["verdict"]) == {"inconclusive"}
    assert out["reason"].str.contains("too few seeds").all()


def test_comparisons_carry_the_paired_sd_and_the_rule():
    df = frame_of({"random": 0.0, "duis": 0.10}, jitter={"duis": JITTER})
    cmp = comparisons(df, {"budget": EXPERIMENTS["budget"]}, {})
    assert (cmp["rule"] == "small-n").all()  # three seeds
    # DUIS - Random per seed is 0.10 + JITTER; in pp, sd(JITTER) * 100
    assert cmp["sd_diff"].to_numpy() == pytest.approx(np.std(JITTER, ddof=1) * 100)
