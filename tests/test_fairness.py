"""Matched training and the decomposition of DUIS − Random: what a reader of the
budget tables relies on to tell acquisition from training."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers.claim_selection import selection_of

from spl_al.experiment.plan import budget_families, dataset_runs, experiments_of, method_specs
from spl_al.frameworks import get_feature_space
from spl_al.report import records_frame
from spl_al.report.claims import claims, render_claims_markdown
from spl_al.report.decomposition import METHODS, PARTS, decomposition
from spl_al.report.table_kinds import comparisons

N_TOTAL = 1000


def config_with(budget: dict) -> dict:
    return {
        "methods": {
            "random": {"strategy": "random"},
            "margin": {"strategy": "margin", "params": {"k": 1}},
            "badge": {"strategy": "badge"},
            "syn_diversity": {
                "strategy": "diversity",
                "params": {"n_cand": 40},
                "use_variants": True,
            },
            "duis": {"strategy": "duis", "params": {"n_cand": 40}, "use_variants": True},
        },
        "datasets": {"d": {"variants": {"n": 4}, "experiments": {"budget": budget}}},
    }


def test_matched_twins_train_on_variants_with_the_same_acquisition():
    budget = {
        "methods": ["random", "margin", "badge", "syn_diversity", "duis"],
        "seeds": [1, 2],
        "rounds": 3,
        "matched": True,
    }
    config = config_with(budget)
    specs = method_specs(config)
    for name in ("random", "margin", "badge"):
        twin = specs[f"syn_{name}"]
        assert twin.use_variants and not specs[name].use_variants
        assert (twin.strategy, twin.params) == (specs[name].strategy, specs[name].params)
    families = budget_families(config, "d")
    assert families == {
        "paper": ["random", "margin", "badge", "duis"],
        "matched": ["syn_random", "syn_margin", "syn_badge", "syn_diversity", "duis"],
    }
    run = experiments_of(config, "d")["budget"]["methods"]
    assert run[-1] == "duis" and set(run) == set(families["paper"]) | set(families["matched"])
    # every method of both families runs every round at every seed
    assert dataset_runs(config, "d") == {(m, s): 3 for m in run for s in (1, 2)}


def test_without_matched_no_twin_is_run():
    config = config_with({"methods": ["random", "duis"], "seeds": [1], "rounds": 2})
    assert "syn_random" not in method_specs(config)
    assert budget_families(config, "d") == {"paper": ["random", "duis"], "matched": ["duis"]}
    assert set(dataset_runs(config, "d")) == {("random", 1), ("duis", 1)}


def test_default_config_runs_the_matched_family_and_the_decomposition():
    root = Path(__file__).resolve().parents[1]
    config = yaml.safe_load((root / "config" / "config.yaml").read_text())
    # the supervised framework on real_cls; the embedding framework on both datasets
    for dataset, framework in (
        ("real_cls", "supervised"),
        ("real_cls", "embedding"),
        ("synth_cls", "embedding"),
    ):
        budget = experiments_of(config, dataset, framework=framework)["budget"]
        assert set(METHODS) <= set(budget["methods"]), dataset
        assert {f"syn_{m}" for m in budget["families"]["paper"] if m != "duis"} <= set(
            budget["families"]["matched"]
        )


# --- records with known per-seed values ---------------------------------------------------

SEEDS = (1, 2, 3, 4, 5, 6)
RNG = np.random.default_rng(7)
# accuracy per method at rounds 0..3 and seed: a base curve, a method offset, seed noise
OFFSET = {
    "random": 0.0,
    "syn_random": 0.04,
    "syn_margin": 0.05,
    "syn_diversity": 0.055,
    "duis": 0.06,
    "margin": 0.01,
}
NOISE = {(m, s, r): RNG.normal(0, 0.01) for m in OFFSET for s in SEEDS for r in range(4)}


def records(methods=OFFSET, seeds=SEEDS) -> pd.DataFrame:
    recs = []
    for m in methods:
        for s in seeds:
            for r in range(4):
                n = 20 * (r + 1)
                # round 0: the same labels and (per family) the same model
                off = 0.0 if r == 0 else OFFSET[m]
                v = 0.4 + 0.1 * r + off + (NOISE[(m, s, r)] if r else NOISE[("random", s, 0)])
                recs.append(
                    {
                        "dataset": "d",
                        "method": m,
                        "seed": s,
                        "round": r,
                        "n_labeled": n,
                        "n_total": N_TOTAL,
                        "metric": "accuracy",
                        "value": round(float(v), 6),
                        "synthetic_standin": False,
                    }
                )
    return records_frame(recs)


def test_decomposition_parts_sum_exactly_to_duis_minus_random():
    frame = decomposition(records(), n_rounds=4)
    points = list(dict.fromkeys(frame["point"]))
    assert points == [
        "round 1 (4.0%)",
        "round 2 (6.0%)",
        "round 3 (8.0%)",
        "AUBC, rounds 1-3 (4.0-8.0%)",
    ]
    df = records()
    for point, block in frame.groupby("point", sort=False):
        parts = block[block["part"] != "total"]
        total = block[block["part"] == "total"].iloc[0]
        assert list(parts["part"]) == [p[0] for p in PARTS]
        assert parts["diff"].sum() == pytest.approx(total["diff"], abs=1e-9), point
        assert (block["n"] == len(SEEDS)).all()
        if point.startswith("round"):  # the total is the paired mean of DUIS − Random
            r = int(total["round"])
            at = df[df["round"] == r].pivot(index="seed", columns="method", values="value")
            assert total["diff"] == pytest.approx(100 * (at["duis"] - at["random"]).mean())
    # variant training dominates in these records and is resolved at 5% on six seeds
    aubc = frame[frame["point"].str.startswith("AUBC")].set_index("part")
    assert aubc.loc["variant_training", "resolved"] and aubc.loc["total", "rule"] == "5%"
    assert aubc.loc["variant_training", "diff"] == pytest.approx(4.0, abs=1.0)


def test_decomposition_uses_only_seeds_where_all_five_ran():
    df = records()
    df = df[~((df["method"] == "syn_margin") & (df["seed"] == 6))]
    frame = decomposition(df, n_rounds=4)
    assert (frame["n"] == 5).all()
    for _, block in frame.groupby("point"):
        parts = block[block["part"] != "total"]["diff"].sum()
        assert parts == pytest.approx(block[block["part"] == "total"]["diff"].iloc[0])


def test_decomposition_is_empty_without_its_methods():
    frame = decomposition(records(methods=["random", "duis"]), n_rounds=4)
    assert frame.empty


def test_claims_over_query_rounds_in_both_families():
    df = records()
    budget = {
        "methods": ["random", "margin", "syn_random", "syn_margin", "syn_diversity", "duis"],
        "seeds": list(SEEDS),
        "rounds": 4,
    }
    cmp = comparisons(df, {"budget": budget}, {})
    stored = cmp.assign(span=cmp["span"].replace("", np.nan))  # as read back from CSV
    out = claims(stored, selection_of(budget["methods"])).set_index("claim_id")
    # round 0 is never evidence: the every-budget claims count rounds 1-3 only;
    # Syn+Diversity is DUIS's own ablation, no member of the matched family
    assert out.loc["duis_best_every_budget", "n_comparisons"] == 2 * 3
    assert out.loc["duis_best_every_budget_matched", "n_comparisons"] == 2 * 3
    assert out.loc["duis_best_every_budget_matched", "methods"].split() == [
        "duis",
        "syn_random",
        "syn_margin",
    ]
    assert "rounds 1-3" in out.loc["duis_best_aubc_matched", "claim"]
    assert (
        "matched training (against Syn+Random and Syn+Margin only)"
        in (out.loc["duis_best_aubc_matched", "claim"])
    )
    # DUIS is far above the paper's baselines
    assert out.loc["duis_best_aubc", "verdict"] == "supported"
    # each part of the decomposition is a claim named for what it tests
    assert out.loc["variant_training", "verdict"] == "supported"
    assert {p[0] for p in PARTS} <= set(out.index)
    assert out.loc["duis_best_every_budget", "source"] == "paper"
    assert out.loc["duis_best_aubc", "source"] == "extension"
    assert out.loc["inconsistency_over_diversity", "source"] == "paper"
    md = render_claims_markdown(out.reset_index())
    assert md.index("*The paper's claims*") < md.index("*Extensions*")
    # the run has two of the paper's five baselines: the sentence says which
    assert out.loc["duis_best_aubc", "claim"].endswith(
        ", as the paper compares (against Random and Margin only)."
    )


def test_an_added_baseline_never_enters_a_paper_claim():
    """The hidden case of issue 68: Random, Margin, TypiClust and MaxHerding with their
    matched twins, and DUIS, in the embedding framework."""
    renamed = {"syn_diversity": "syn_typiclust", "margin": "typiclust"}
    df = records().replace({"method": renamed})
    extra = records(methods=["syn_margin", "margin"]).replace(
        {"method": {"syn_margin": "syn_maxherding", "margin": "maxherding"}}
    )
    df = pd.concat([df, extra, records(methods=["margin"])], ignore_index=True)
    methods = ["random", "margin", "typiclust", "maxherding"]
    methods += ["syn_random", "syn_margin", "syn_typiclust", "syn_maxherding", "duis"]
    budget = {"methods": methods, "seeds": list(SEEDS), "rounds": 4}
    cmp = comparisons(df, {"budget": budget}, {})
    out = claims(cmp, selection_of(methods), framework="embedding").set_index("claim_id")
    paper = out.loc["duis_best_every_budget"]
    assert paper["n_comparisons"] == 2 * 3  # Random and Margin at rounds 1-3
    assert set(paper["methods"].split()) == {"duis", "random", "margin"}
    assert paper["claim"].endswith("as the paper compares (against Random and Margin only).")
    low = out.loc["duis_over_low_budget_matched"]
    assert set(low["methods"].split()) == {"duis", "syn_typiclust", "syn_maxherding"}
    assert low["n_comparisons"] == 2
    assert "Syn+TypiClust and Syn+MaxHerding only, selecting on the frozen" in low["claim"]
    assert not out["claim"].str.contains("strongest").any()
    assert "duis_best_aubc" in out.index and "typiclust" not in out.loc["duis_best_aubc", "methods"]


def test_low_budget_claim_tests_every_low_budget_twin_with_holm():
    """One claim: DUIS's AUBC against every low-budget twin the run has, whatever its
    name: Holm over them for "contradicted", each at 0.05 for "supported"."""
    renamed = {"syn_margin": "syn_typiclust", "syn_random": "syn_probcover"}
    df = records().replace({"method": renamed})
    methods = ["random", "syn_probcover", "syn_typiclust", "syn_diversity", "duis"]
    budget = {"methods": methods, "seeds": list(SEEDS), "rounds": 4}
    selection = selection_of(methods)
    cmp = comparisons(df, {"budget": budget}, {})
    out = claims(cmp, selection).set_index("claim_id")
    row = out.loc["duis_over_low_budget_matched"]
    assert row["n_comparisons"] == 2 and row["source"] == "extension"
    assert "each low-budget baseline, under matched training" in row["claim"]
    # no Syn+MaxHerding in this run
    assert "(against Syn+ProbCover and Syn+TypiClust only, selecting on" in row["claim"]
    assert "rounds 1-3" in row["claim"] and row["rule"] == "5%"
    # the verdict of the comparisons it rests on: DUIS above both at 5%
    area = cmp[(cmp["point"] == "AUBC") & (cmp["method_a"] == "duis")]
    both = area[area["method_b"].isin(["syn_typiclust", "syn_probcover"])]
    expected = "supported" if (both["resolved"] & (both["direction"] > 0)).all() else None
    assert expected is None or row["verdict"] == expected
    # the selection says what a method is and selects on, whatever its name
    on_embedding = {**selection, "syn_typiclust": {**selection["syn_typiclust"]}}
    on_embedding["syn_typiclust"]["features"] = "embedding"
    named = claims(cmp, on_embedding).set_index("claim_id")
    embedding_words = get_feature_space("embedding").words
    assert (
        f"Syn+TypiClust (selecting on {embedding_words})"
        in (named.loc["duis_over_low_budget_matched", "claim"])
    )
    not_low = {**selection, "syn_typiclust": {**selection["syn_typiclust"], "strategy": "margin"}}
    swapped = claims(cmp, not_low).set_index("claim_id")
    assert swapped.loc["duis_over_low_budget_matched", "methods"].split() == [
        "duis",
        "syn_probcover",
    ]
    # without a low-budget twin, no such claim
    plain = claims(
        comparisons(records(), {"budget": {**budget, "methods": list(OFFSET)}}, {}),
        selection_of(list(OFFSET)),
    )
    assert "duis_over_low_budget_matched" not in set(plain["claim_id"])


def test_small_n_never_says_supported():
    df = records(seeds=(1, 2, 3))
    budget = {"methods": ["random", "duis"], "seeds": [1, 2, 3], "rounds": 4}
    out = claims(comparisons(df, {"budget": budget}, {}), selection_of(["random", "duis"]))
    assert set(out["rule"]) == {"small-n"}
    assert not set(out["verdict"]) & {"supported", "contradicted"}
    assert "seeds agree (untested)" in set(out["verdict"])


def test_budget_curves_draw_each_family_in_its_own_panel(tmp_path):
    from spl_al.report.curves import curves_figure

    df = records()
    panels = {
        "baselines on observed images": ["random", "margin", "duis"],
        "matched training": ["syn_random", "syn_margin", "syn_diversity", "duis"],
    }
    fig = curves_figure(df, panels=panels)
    axes = fig.get_axes()
    assert [ax.get_title() for ax in axes] == list(panels)
    assert [len(ax.get_lines()) for ax in axes] == [3, 4]
    assert [t.get_text() for t in axes[1].get_legend().get_texts()][-1] == "DUIS"
    # one panel without a matched family
    assert len(curves_figure(df, methods=["random", "duis"]).get_axes()) == 1
