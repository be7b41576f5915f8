"""Paired statistics, Holm, power, AUBC, the bold/tie rule and the claims, on hand-computed
cases."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from helpers.claim_selection import selection_of
from scipy.stats import t as student_t

from spl_al.report import budget_table, records_frame, render_markdown, summary
from spl_al.report.claims import claims, render_claims_markdown
from spl_al.report.comparisons import render_comparisons_markdown
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
    sign_flip_ps,
    t_interval,
    t_power,
)
from spl_al.report.table_kinds import comparisons

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


def _enumerated_p(d) -> float:
    """The definition, by brute force over all 2^n sign vectors."""
    d = np.asarray(d, dtype=float)
    bits = (np.arange(2**d.size)[:, None] >> np.arange(d.size)) & 1
    sums = np.abs((1 - 2 * bits) @ d)
    return float(np.mean(sums >= abs(d.sum()) * (1 - 1e-9) - 1e-15))


@pytest.mark.parametrize("n", [1, 2, 5, 6, 9, 13, 14])
def test_sign_flip_p_equals_enumerating_every_sign_vector(n):
    rng = np.random.default_rng(n)
    continuous = rng.normal(0.5, 1.0, n)
    # accuracies on 330 test images: differences are multiples of 1/330, ties abound
    tied = rng.integers(-4, 6, n) / 330 * 100
    for d in (continuous, tied, np.abs(tied), np.r_[tied[:-1], 0.0]):
        assert sign_flip_p(d) == pytest.approx(_enumerated_p(d), abs=1e-12)


def test_sign_flip_p_beyond_twenty_seeds():
    agree = np.linspace(0.5, 3.0, 24)  # every one of 24 seeds the same way
    assert sign_flip_p(agree) == pytest.approx(2 / 2**24)
    assert sign_flip_p(np.r_[agree, -agree]) == 1.0  # sum exactly 0
    d = np.random.default_rng(1).normal(0.3, 1.0, 40)  # largest exact n: two 2^20 halves
    assert 0.0 < sign_flip_p(d) < 1.0
    # beyond 40 values: seeded Monte Carlo, reproducible, never below 1 / (draws + 1)
    many = np.random.default_rng(2).normal(0.0, 1.0, 60)
    assert sign_flip_p(many) == sign_flip_p(many)
    t = many.mean() / (many.std(ddof=1) / np.sqrt(60))
    assert sign_flip_p(many) == pytest.approx(2 * student_t.sf(abs(t), 59), abs=0.03)
    assert sign_flip_p(np.abs(many)) == pytest.approx(1 / (2**20 + 1))


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
    # The summary's AUBC covers the query rounds 1-2 only (round 0: the same labels
    # for every method): ratios 0.2, 0.4, values 0.6, 0.7 -> 0.65 + 0.01 s.
    s = summary(records_frame(recs))["methods"]["a"]["aubc"]
    assert s["rounds"] == [1, 2] and s["span"] == "rounds 1-2 (20.0-40.0%)"
    assert s["n"] == 2 and s["mean"] == pytest.approx(0.665)
    half = 12.706204736174707 * 0.01 / math.sqrt(2) / math.sqrt(2)  # t(0.975, 1) sd/sqrt(n)
    assert (s["ci_low"], s["ci_high"]) == pytest.approx((0.665 - half, 0.665 + half))
    assert s["per_seed"] == pytest.approx({"1": 0.66, "2": 0.67})


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
    # Round 0 gets no mark: its labels are the same for every method.
    first = wide["round"] == 0
    assert set(wide.loc[(wide["method"] == "duis") & ~first, "mark"]) == {"bold"}
    assert (
        set(wide.loc[first, "mark"]) == {""}
        and wide.loc[first, "col"].str.endswith("(round 0)").all()
    )
    assert set(wide.loc[wide["method"] == "random", "mark"]) == {""}
    md = render_markdown(wide)
    assert md.count("**") == 2 * 2 + 2  # two bold cells (rounds 1, 2) and the caption
    assert "n = 3 seeds per cell" in md and "every seed agrees in direction" in md

    close = budget_table(
        frame_of({"random": 0.0, "duis": 0.002}, jitter={"duis": (0.01, -0.012, 0.008)})
    )
    assert set(close.loc[(close["method"] == "duis") & (close["round"] > 0), "mark"]) == {"tie"}
    assert "†" in render_markdown(close)

    two_seeds = budget_table(frame_of({"random": 0.0, "duis": 0.10}, seeds=(1, 2)))
    assert set(two_seeds["mark"]) == {"", "tie"}

    equal = budget_table(frame_of({"random": 0.0, "entropy": 0.0, "duis": -0.05}))
    queried = equal["round"] > 0
    assert set(equal.loc[(equal["method"] != "duis") & queried, "mark"]) == {"tie"}  # top means
    assert set(equal.loc[equal["method"] == "duis", "mark"]) == {""}


def test_tables_and_decomposition_name_the_encoder_as_their_unit():
    """Six seeds reading two encoders (three each): the leader test pairs the two
    encoders' means, and the table says so in encoders, not seeds."""
    df = frame_of({"random": 0.0, "duis": 0.002}, seeds=(1, 2, 3, 4, 5, 6))
    df["encoder"] = (df["seed"] - 1) // 3
    table = budget_table(df)
    assert set(table["n_encoders"]) == {2} and set(table["n_expected"]) == {6}
    md = render_markdown(table)
    assert "6 seeds per cell, reading 2 encoders" in md
    assert "a tie at this number of encoders" in md and "from n = 6 encoders" in md
    plain = render_markdown(budget_table(frame_of({"random": 0.0, "duis": 0.002})))
    assert "n = 3 seeds per cell." in plain and "encoder" not in plain
    from spl_al.report.decomposition import METHODS, decomposition, render_decomposition_markdown

    five = frame_of(dict.fromkeys(METHODS, 0.0), seeds=(1, 2, 3, 4, 5, 6))
    five["encoder"] = (five["seed"] - 1) // 3
    parts = decomposition(five, n_rounds=3)
    assert set(parts["unit"]) == {"encoder"} and set(parts["n"]) == {2}
    assert "n encoders (each an encoder's mean" in render_decomposition_markdown(parts)


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
    out = claims(cmp, selection_of(["random", "entropy", "syn_random", "syn_diversity", "duis"]))
    return dict(zip(out["claim_id"], out["verdict"], strict=True))


def test_claims_seeds_agree_when_better_on_every_seed_by_a_wide_margin():
    # Three seeds: the small-n rule, so no claim is "supported", only agreed with.
    v = verdicts(+0.10)
    for claim in (
        "duis_best_every_budget",
        "duis_best_aubc",
        "duis_best_every_level",
        "inconsistency_over_diversity",
        "m_gt_1_beats_m_1",
        "alpha_half_not_worse",
    ):
        assert v[claim] == "seeds agree (untested)", claim
    # Syn+Diversity and Syn+Random are equal here, so diversity over random is
    # inconclusive; N_cand 160 (DUIS) beats 40 with no fall.
    assert v["diversity_over_random"] == "inconclusive"
    assert v["ncand_grows_to_plateau"] == "seeds agree (untested)"
    assert "supported" not in v.values() and "contradicted" not in v.values()


def test_claims_inconclusive_when_equal_in_distribution():
    v = verdicts(0.0, jitter=(0.01, -0.012, 0.003))
    assert set(v.values()) == {"inconclusive"}


def test_claims_seeds_against_when_worse():
    v = verdicts(-0.10)
    for claim in (
        "duis_best_every_budget",
        "duis_best_every_level",
        "inconsistency_over_diversity",
        "m_gt_1_beats_m_1",
        "alpha_half_not_worse",
        "ncand_grows_to_plateau",
    ):
        assert v[claim] == "seeds against (untested)", claim


def test_claims_inconclusive_with_too_few_seeds_and_absent_when_not_run():
    df = frame_of({"random": 0.0, "duis": 0.10}, seeds=(1, 2))
    out = claims(
        comparisons(df, {"budget": EXPERIMENTS["budget"]}, {}), selection_of(["random", "duis"])
    )
    assert out["claim_id"].tolist() == ["duis_best_every_budget", "duis_best_aubc"]
    assert set(out["verdict"]) == {"inconclusive"}
    assert out["reason"].str.contains("too few seeds").all()


# --- claims from six seeds: intersection-union, Holm, seeds needed ----------------------

UP6 = np.array([0.020, 0.021, 0.019, 0.020, 0.022, 0.018])  # every seed agrees: p = 2/64
MIXED6 = np.array([0.010, -0.005, 0.012, -0.003, 0.008, 0.001])  # unresolved, leaning A


def budget_family(diffs, baseline: str = "random") -> pd.DataFrame:
    """A comparisons frame of DUIS vs ``baseline`` at the query rounds 1..k with these
    per-seed differences (DUIS minus baseline, pp), as ``comparisons`` would write it."""
    rows = []
    for r, d in enumerate(diffs, start=1):
        d = np.asarray(d, dtype=float)
        rows.append(
            {
                "experiment": "budget",
                "point": f"round {r}",
                "parameter": None,
                "round": r,
                "n_labeled": 10 * (r + 1),
                "method_a": "duis",
                "method_b": baseline,
                "value_a": None,
                "value_b": None,
                **paired_test(d, np.zeros_like(d)),
                "dataset": "d",
                "metric": "accuracy",
                "scale": 100.0,
                "synthetic_standin": False,
            }
        )
    return pd.DataFrame(rows)


def budget_claim(diffs) -> pd.Series:
    out = claims(budget_family(diffs), selection_of(["random", "duis"]))
    assert out["claim_id"].tolist() == ["duis_best_every_budget"]
    return out.iloc[0]


def test_one_against_at_p_003_does_not_survive_holm_over_three():
    # One round against at p = 2/64 = 0.031 with its interval below zero: resolved against
    # on its own, but Holm over the claim's 3 comparisons lifts it to 3 * 0.031 = 0.094.
    fam = budget_family([-UP6, MIXED6, MIXED6])
    assert fam["p_value"].iloc[0] == pytest.approx(0.03125) and fam["resolved"].iloc[0]
    assert holm(fam["p_value"])[0] == pytest.approx(0.09375)
    row = budget_claim([-UP6, MIXED6, MIXED6])
    assert row["rule"] == "5%" and row["n_against"] == 1
    assert row["verdict"] == "inconclusive" and "does not survive Holm" in row["reason"]
    # The same comparison alone is a family of one: Holm leaves p = 0.031, contradicted.
    alone = budget_claim([-UP6])
    assert alone["verdict"] == "contradicted" and "survives Holm" in alone["reason"]


def test_one_against_survives_holm_with_eight_seeds():
    down8 = -np.array([0.020, 0.021, 0.019, 0.020, 0.022, 0.018, 0.020, 0.021])  # p = 2/256
    mixed8 = np.array([0.010, -0.005, 0.012, -0.003, 0.008, 0.001, 0.002, -0.001])
    row = budget_claim([down8, mixed8, mixed8])  # Holm: 3 * 2/256 = 0.023 <= 0.05
    assert row["verdict"] == "contradicted" and row["rule"] == "5%"


def test_supported_is_intersection_union_without_correction():
    # Three rounds each at p = 0.031: a Bonferroni or Holm correction (3 * 0.031 > 0.05)
    # would refuse them, the intersection-union test needs each at 0.05 only.
    row = budget_claim([UP6, UP6 * 1.5, UP6 * 2])
    assert row["verdict"] == "supported" and row["rule"] == "5%"
    assert budget_claim([UP6, UP6, MIXED6])["verdict"] == "inconclusive"


def test_small_n_claims_are_against_without_holm():
    up3 = UP6[:3]  # every seed agrees: p = 0.25, resolved by the small-n rule
    row = budget_claim([-up3, up3 + 0.01, up3 + 0.02])
    assert row["rule"] == "small-n" and row["verdict"] == "seeds against (untested)"
    assert row["reason"] == "a comparison resolved against"


def with_effect(mean: float, sd: float, n: int = 6) -> np.ndarray:
    """n per-seed differences with exactly this mean and sd (ddof 1)."""
    z = np.linspace(-1, 1, n)
    return mean + sd * z / z.std(ddof=1)


def test_claim_seeds_needed_is_the_weakest_comparison():
    # effects 1.0 and 0.5 -> 10 and 34 seeds: the claim needs both, so 34
    row = budget_claim([with_effect(2.0, 2.0), with_effect(1.0, 2.0)])
    assert row["seeds_needed"] == "34"
    assert budget_claim([with_effect(2.0, 2.0)])["seeds_needed"] == "10"
    assert budget_claim([with_effect(0.1, 1.0), UP6])["seeds_needed"] == ">100"
    # a round with no difference at all: no effect to resolve, not "too few seeds"
    assert budget_claim([np.zeros(6), UP6])["seeds_needed"] == "-"


def test_units_needed_respect_the_claims_holm_family():
    # 15 comparisons, one far against the claim: Holm's first step asks p <= 0.05/15,
    # which the sign-flip test reaches from 2/2^10 on: 10 units, not the level's 6
    from spl_al.report.stats import units_for_family

    assert (units_for_family(1), units_for_family(15), units_for_family(30)) == (6, 10, 11)
    row = budget_claim([with_effect(-2.0, 0.1), *[UP6 * 100] * 14])
    assert row["n_comparisons"] == 15 and row["seeds_needed"] == "10"
    assert budget_claim([UP6 * 100] * 15)["seeds_needed"] == "6"  # all in favour: 0.05 each


def test_claims_table_marks_the_rule_and_shows_seeds_needed():
    six = claims(budget_family([UP6, -UP6 * 0.5]), selection_of(["random", "duis"]))
    md = render_claims_markdown(six)
    assert "| Seeds needed (80% power) |" in md
    assert "**inconclusive**¹" in md and "¹ n >= 6 seeds (5% rule)" in md
    assert "intersection-union" in md and "Holm" in md and "small-n rule" not in md
    three = render_claims_markdown(
        claims(budget_family([UP6[:3]]), selection_of(["random", "duis"]))
    )
    assert "**seeds agree (untested)**²" in three and "² n < 6 seeds (small-n rule)" in three
    assert "¹ n >= 6" not in three


def sweep_family(parameter: str, pairs) -> pd.DataFrame:
    """Sensitivity rows of ``parameter``: (value_a, value_b, per-seed d = A - B) each."""
    rows = []
    for value_a, value_b, d in pairs:
        fam = budget_family([d]).iloc[0].to_dict()
        method = {v: f"duis_{parameter}{v}" for v in (value_a, value_b)}
        fam |= {"experiment": "sensitivity", "point": f"{parameter} at round 2"}
        fam |= {"parameter": parameter, "round": 2, "value_a": value_a, "value_b": value_b}
        fam |= {"method_a": method[value_a], "method_b": method[value_b]}
        rows.append(fam)
    return pd.DataFrame(rows)


def test_not_worse_than_needs_seeds_for_the_distance_to_the_margin():
    # alpha = 0.5 vs 0.25 with no difference (mean 0, sd 2 pp): the non-inferiority bound
    # is -1 pp, so the effect is (0 + 1) / 2 = 0.5 -> 34 seeds, not "-" (no effect).
    row = claims(sweep_family("alpha", [(0.5, 0.25, with_effect(0.0, 2.0))])).iloc[0]
    assert row["claim_id"] == "alpha_half_not_worse" and row["seeds_needed"] == "34"
    assert row["verdict"] == "inconclusive"  # the interval reaches below -1 pp
    # three times worse than the margin: no effect towards non-inferiority
    row = claims(sweep_family("alpha", [(0.5, 0.25, with_effect(-3.0, 2.0))])).iloc[0]
    assert row["seeds_needed"] == "-"


# Per-seed differences (pp) whose 95% interval lies inside the 1-pp margin (resolved
# below zero: every seed negative), across it, and wholly below it.
INSIDE = with_effect(-0.3, 0.2)  # [-0.51, -0.09]
ACROSS = with_effect(-1.0, 1.0)  # [-2.05, +0.05]
BELOW = with_effect(-3.0, 0.3)  # [-3.32, -2.68]


def test_non_inferiority_is_one_rule_inside_across_and_below_the_margin():
    verdict = {}
    for name, d in (("inside", INSIDE), ("across", ACROSS), ("below", BELOW)):
        alpha = claims(sweep_family("alpha", [(0.5, 0.25, d)])).iloc[0]
        # N_cand: 160 resolved 2 pp above 40, the step 160 vs 80 as given
        pairs = [(160, 40, UP6 * 100), (80, 40, UP6 * 100), (160, 80, d)]
        ncand = claims(sweep_family("n_cand", pairs)).iloc[0]
        assert ncand["claim_id"] == "ncand_grows_to_plateau" and ncand["n_comparisons"] == 3
        verdict[name] = (alpha["verdict"], ncand["verdict"])
    # a resolved fall inside the margin is still "not worse"
    assert INSIDE.max() < 0 and verdict["inside"] == ("supported", "supported")
    assert verdict["across"] == ("inconclusive", "inconclusive")
    assert verdict["below"] == ("contradicted", "contradicted")


def test_ncand_claim_needs_the_largest_above_the_smallest():
    # every step inside the margin, but 160 is not resolved above 40: not supported
    pairs = [(160, 40, MIXED6), (80, 40, MIXED6), (160, 80, INSIDE)]
    row = claims(sweep_family("n_cand", pairs)).iloc[0]
    assert row["verdict"] == "inconclusive" and row["rule"] == "5%"
    assert "not resolved above the smallest" in row["reason"]
    # the largest resolved below the smallest contradicts, as a family of one
    alone = claims(sweep_family("n_cand", [(160, 40, -UP6 * 100)])).iloc[0]
    assert alone["verdict"] == "contradicted"


def test_comparisons_carry_the_paired_sd_and_the_rule():
    df = frame_of({"random": 0.0, "duis": 0.10}, jitter={"duis": JITTER})
    cmp = comparisons(df, {"budget": EXPERIMENTS["budget"]}, {})
    assert (cmp["rule"] == "small-n").all()  # three seeds
    # DUIS - Random per seed is 0.10 + JITTER; in pp, sd(JITTER) * 100
    assert cmp["sd_diff"].to_numpy() == pytest.approx(np.std(JITTER, ddof=1) * 100)


def test_a_run_trained_in_bf16_decides_no_claim_and_says_what_its_seeds_read():
    """Claims are decided in fp32 (the decisive runs'): a bf16 run's verdicts are kept
    as reasons, its verdicts inconclusive; an fp32 run, and one whose records name no
    precision, decide as before."""
    from spl_al.report.claims import at_precision

    frame = pd.DataFrame(
        {
            "claim_id": ["a", "b", "c"],
            "verdict": ["supported", "contradicted", "inconclusive"],
            "reason": ["all resolved for", "one resolved against", "too few seeds"],
        }
    )
    for precision in ("fp32", ""):
        same = at_precision(frame, precision)
        assert same["verdict"].tolist() == frame["verdict"].tolist()
        assert set(same["precision"]) == {precision}
    bf16 = at_precision(frame, "bf16")
    assert set(bf16["verdict"]) == {"inconclusive"} and set(bf16["precision"]) == {"bf16"}
    assert bf16["reason"].iloc[1] == (
        "trained in bf16, and claims are decided in fp32 (the decisive runs' precision); "
        "at bf16 its seeds read: contradicted"
    )
    assert bf16["reason"].iloc[2] == "too few seeds"
    assert bf16["seeds_read"].tolist() == frame["verdict"].tolist()


def test_sign_flip_ps_equal_one_at_a_time():
    rng = np.random.default_rng(5)
    ds = [rng.normal(0.2, 1.0, 60), rng.normal(0.0, 1.0, 60), rng.normal(0.5, 1.0, 8)]
    ds.append(np.zeros(60))
    assert sign_flip_ps(ds) == [sign_flip_p(d) for d in ds]


def test_with_encoders_the_units_are_the_encoders_means_by_hand():
    """4 encoders x 3 run seeds: the test, interval and p are those of the 4 encoder
    means of the paired differences, computed here by hand."""
    import itertools

    from scipy.stats import t as student_t

    from spl_al.report.stats import leader_test, pairwise

    d_by_encoder = {
        7: [0.02, 0.04, 0.03],
        8: [0.01, 0.00, 0.02],
        9: [0.05, 0.03, 0.04],
        11: [-0.01, 0.02, 0.02],
    }
    rows = []
    seed = 0
    for enc, ds in d_by_encoder.items():
        for d in ds:
            seed += 1
            base = 0.5 + 0.01 * seed
            rows += [
                {"method": "b", "seed": seed, "value": base, "encoder": enc},
                {"method": "a", "seed": seed, "value": base + d, "encoder": enc},
            ]
    values = pd.DataFrame(rows)
    out = pairwise(values, ["b", "a"]).iloc[0]
    means = np.array([np.mean(v) for v in d_by_encoder.values()])
    half = student_t.ppf(0.975, 3) * means.std(ddof=1) / 2
    assert out["unit"] == "encoder" and out["n"] == 4 and out["n_seeds"] == 12
    assert out["diff"] == pytest.approx(means.mean())
    assert (out["ci_low"], out["ci_high"]) == pytest.approx(
        (means.mean() - half, means.mean() + half)
    )
    flips = [
        abs(np.dot(s, means)) >= abs(means.sum()) - 1e-12
        for s in itertools.product([-1, 1], repeat=4)
    ]
    assert out["p_value"] == pytest.approx(np.mean(flips))  # 2/16: every encoder agrees
    assert out["var_between"] == pytest.approx(means.var(ddof=1))
    within = np.mean([np.var(v, ddof=1) for v in d_by_encoder.values()])
    assert out["var_within"] == pytest.approx(within)
    assert not out["resolved"]  # every encoder agrees (p = 2/16), but the interval holds 0
    # without the encoder column the 12 seeds are the units
    seeds = pairwise(values.drop(columns="encoder"), ["b", "a"]).iloc[0]
    assert seeds["unit"] == "seed" and seeds["n"] == 12 and np.isnan(seeds["var_between"])
    assert leader_test(values)["n"] == 4
