"""Tests of spl_al.report on hand-built metrics records with hand-computed statistics."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from spl_al.report import (
    PALETTE,
    ablation_table,
    budget_table,
    curve_area,
    curves_figure,
    format_ratio,
    latex_escape,
    level_curves_figure,
    level_table,
    load_records,
    method_colors,
    plot_curves,
    plot_level_curves,
    read_table,
    records_frame,
    render_latex,
    render_markdown,
    round_for_budget,
    sensitivity_table,
    summary,
    write_json,
    write_table,
)
from spl_al.report.display import unique_ratio_labels
from spl_al.report.writers import atomic_write

N_TOTAL = 1000
N_LABELED = (29, 57, 86)  # ratios 2.9%, 5.7%, 8.6%

# VALUES[method][round] = metric of seeds 1, 2, 3. Hand-computed (percent, std ddof=1):
#   random : 42.0 ± 2.0 | 52.0 ± 3.5 (sqrt 12) | 61.0 ± 1.0
#   entropy: 52.0 ± 2.0 | 57.0 ± 2.0            | 66.0 ± 2.0
#   duis   : 50.0 ± 2.0 | 62.0 ± 2.0            | 71.0 ± 1.0
VALUES = {
    "random": ((0.40, 0.42, 0.44), (0.50, 0.50, 0.56), (0.60, 0.61, 0.62)),
    "entropy": ((0.50, 0.52, 0.54), (0.55, 0.57, 0.59), (0.64, 0.66, 0.68)),
    "duis": ((0.48, 0.50, 0.52), (0.60, 0.62, 0.64), (0.70, 0.71, 0.72)),
}


def make_records(values=VALUES, dataset="synth_cls", standin=False, n_labeled=N_LABELED):
    records = []
    for method, rounds in values.items():
        for r, per_seed in enumerate(rounds):
            for seed, v in enumerate(per_seed, start=1):
                per_level = {"high": v, "medium": round(v + 0.01, 6), "low": round(v - 0.01, 6)}
                if method == "random" and seed == 3:
                    del per_level["low"]  # a level missing from one seed's records
                records.append(
                    {
                        "dataset": dataset,
                        "method": method,
                        "seed": seed,
                        "round": r,
                        "n_labeled": n_labeled[r],
                        "n_pool": 700 - n_labeled[r],
                        "n_total": N_TOTAL,
                        "ratio": round(n_labeled[r] / N_TOTAL, 4),
                        "metric": "accuracy",
                        "value": v,
                        "per_level": per_level,
                        "synthetic_standin": standin,
                        "train_seconds": 1.5,
                        "train_steps": 10 * (r + 1),
                        "images_seen": 320 * (r + 1),
                    }
                )
    return records


@pytest.fixture
def df():
    return records_frame(make_records())


def cell(frame, row, col):
    hit = frame[(frame["row"] == row) & (frame["col"] == col)]
    assert len(hit) == 1, (row, col)
    return hit.iloc[0]


# --- records -----------------------------------------------------------------------------


def test_load_records_reads_files_and_flattens_levels(tmp_path):
    paths = []
    for i, rec in enumerate(make_records()):
        path = tmp_path / f"m{i}.json"
        path.write_text(json.dumps(rec))
        paths.append(path)
    df = load_records(paths)
    assert len(df) == 27
    row = df[(df["method"] == "random") & (df["seed"] == 3) & (df["round"] == 2)].iloc[0]
    assert row["level_high"] == pytest.approx(0.62)
    assert math.isnan(row["level_low"])
    assert row["ratio"] == 86 / N_TOTAL  # recomputed exactly, not the rounded 0.086
    assert row["source"].endswith(".json")
    assert (row["train_steps"], row["images_seen"]) == (30, 960)


def test_records_without_steps_get_nan_steps():
    records = make_records()
    for record in records:
        del record["train_steps"], record["images_seen"]
    df = records_frame(records)
    assert df["train_steps"].isna().all() and df["images_seen"].isna().all()


@pytest.mark.parametrize(
    ("mutate", "key"),
    [
        (lambda r: r.pop("value"), "value"),
        (lambda r: r.update(value=1.7), "value"),
        (lambda r: r.update(seed="1"), "seed"),
        (lambda r: r.update(ratio=0.5), "ratio"),
        (lambda r: r.update(synthetic_standin="no"), "synthetic_standin"),
        (lambda r: r.update(per_level={"extreme": 0.5}), "per_level"),
        (lambda r: r.update(n_labeled=2000), "n_labeled"),
        (lambda r: r.update(train_steps=0), "train_steps"),
        (lambda r: r.update(train_steps=True), "train_steps"),
        (lambda r: r.update(images_seen=2.5), "images_seen"),
    ],
)
def test_malformed_record_names_file_and_key(tmp_path, mutate, key):
    good, bad = make_records()[:2]
    mutate(bad)
    (tmp_path / "good.json").write_text(json.dumps(good))
    (tmp_path / "bad_round.json").write_text(json.dumps(bad))
    with pytest.raises(ValueError, match=rf"bad_round\.json.*'{key}'"):
        load_records([tmp_path / "good.json", tmp_path / "bad_round.json"])


def test_unreadable_json_names_file(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"dataset": ')
    with pytest.raises(ValueError, match=r"broken\.json"):
        load_records(path)


def test_duplicate_record_is_an_error():
    recs = make_records()
    with pytest.raises(ValueError, match=r"duplicate records.*method='random', seed=1, round=0"):
        records_frame([*recs, dict(recs[0])])


def test_round_for_budget_picks_closest_and_earlier_on_tie(df):
    assert round_for_budget(df, 60) == 1
    assert round_for_budget(df, 1000) == 2
    assert round_for_budget(df, 43) == 0  # 29 and 57 are equally close


# --- budget table --------------------------------------------------------------------------


def test_ratio_formatting():
    assert format_ratio(2 / 70) == "2.9%"
    assert format_ratio(0.1714) == "17.1%"
    assert unique_ratio_labels([0.0286, 0.0289]) == ["2.86%", "2.89%"]


def test_budget_table_mean_std_hand_computed(df):
    t = budget_table(df)
    assert list(dict.fromkeys(t["row"])) == ["Entropy", "Random", "DUIS"]  # paper order
    assert list(dict.fromkeys(t["col"])) == ["2.9% (round 0)", "5.7%", "8.6%"]
    c = cell(t, "Random", "5.7%")
    assert c["mean"] == pytest.approx(52.0)
    assert c["std"] == pytest.approx(math.sqrt(12.0))
    assert (c["round"], c["n_labeled"], c["n_seeds"]) == (1, 57, 3)
    assert c["ratio"] == pytest.approx(0.057)
    assert not t["partial"].any()
    md = render_markdown(t)
    assert "| Random | 42.0 ± 2.0 | 52.0 ± 3.5 | 61.0 ± 1.0 |" in md


def test_bold_marks_best_per_column(df):
    md = render_markdown(budget_table(df))
    # Round 0 (2.9%) holds the same labels for every method: never marked.
    assert "| Entropy | 52.0 ± 2.0 | 57.0 ± 2.0 | 66.0 ± 2.0 |" in md
    assert "| DUIS | 50.0 ± 2.0 | **62.0 ± 2.0** | **71.0 ± 1.0** |" in md
    tex = render_latex(budget_table(df))
    assert r"DUIS & 50.0 $\pm$ 2.0 & \textbf{62.0 $\pm$ 2.0}" in tex


def test_unresolved_leader_gets_a_dagger_not_bold():
    # Two seeds: too few for any paired difference to be resolved, however consistent.
    values = {"random": ((0.4, 0.4), (0.500, 0.500)), "duis": ((0.4, 0.4), (0.5004, 0.5004))}
    t = budget_table(records_frame(make_records(values)))
    assert t["mark"].tolist() == ["", "", "", "tie"]  # round 0 unmarked
    md = render_markdown(t)
    assert "**50.0" not in md and "| DUIS | 40.0 ± 0.0 | 50.0 ± 0.0 † |" in md
    assert "†: the highest mean (every one, when several are equal), not resolved" in md
    assert r"50.0 $\pm$ 0.0$^\dagger$" in render_latex(t)


def test_frame_without_marks_bolds_the_best_printed_mean():
    values = {"random": ((0.500, 0.500),), "duis": ((0.5004, 0.5004),)}
    t = budget_table(records_frame(make_records(values))).drop(columns="mark")
    assert render_markdown(t).count("**50.0 ± 0.0**") == 2


def test_latex_escapes():
    assert latex_escape("a_b & 50% #1 $x$ {y} ~^\\") == (
        r"a\_b \& 50\% \#1 \$x\$ \{y\} \textasciitilde{}\textasciicircum{}\textbackslash{}"
    )
    assert latex_escape("α ± 1") == r"$\alpha$ $\pm$ 1"


def test_latex_table_is_booktabs_with_escaped_percent(df):
    tex = render_latex(budget_table(df), label="tab:budget")
    for token in (r"\toprule", r"\midrule", r"\bottomrule", r"\label{tab:budget}", r"2.9\%"):
        assert token in tex
    assert r"synth\_cls" in tex
    body = [line for line in tex.splitlines() if not line.startswith("%")]
    assert not [line for line in body if re.search(r"(?<!\\)%", line)]
    assert tex.count(r"\begin{tabular}{lccc}") == 1


def test_budget_table_rounds_and_missing_method(df):
    t = budget_table(df, methods=["duis", "badge"], rounds=[0, 2], metric_scale=1)
    assert cell(t, "DUIS", "8.6%")["mean"] == pytest.approx(0.71)
    md = render_markdown(t, decimals=3)
    assert "| BADGE | — | — |" in md  # asked for but never run: a row of dashes
    with pytest.raises(ValueError, match="rounds"):
        budget_table(df, rounds=[7])


def test_missing_seed_is_averaged_and_flagged():
    recs = [
        r
        for r in make_records()
        if not (r["method"] == "duis" and r["seed"] == 3 and r["round"] == 2)
    ]
    recs += [
        r | {"method": "margin"}
        for r in make_records()
        if r["seed"] == 1 and r["method"] == "random"
    ]
    df = records_frame(recs)
    t = budget_table(df)
    c = cell(t, "DUIS", "8.6%")
    assert (c["n_seeds"], c["n_expected"], bool(c["partial"])) == (2, 3, True)
    assert c["mean"] == pytest.approx(70.5)
    one = cell(t, "Margin", "2.9% (round 0)")
    assert one["n_seeds"] == 1 and math.isnan(one["std"])
    md = render_markdown(t)
    assert "70.5 ± 0.7 (n=2)" in md
    assert "| Margin | 40.0 (n=1) |" in md
    assert "averaged over the k seeds present out of 3" in md
    s = summary(df)
    assert s["methods"]["duis"]["partial_rounds"] == [2]
    assert s["methods"]["margin"]["final_std"] is None
    json.dumps(s, allow_nan=False)
    fig = curves_figure(df)  # one seed and a partial round: drawn, no crash
    assert len(fig.axes[0].get_lines()) == 4


# --- level, ablation, sensitivity ----------------------------------------------------------


def test_level_table_at_round_and_budget(df):
    t = level_table(df, 2)
    assert list(dict.fromkeys(t["col"])) == ["High", "Medium", "Low"]
    assert cell(t, "DUIS", "Medium")["mean"] == pytest.approx(72.0)
    low = cell(t, "Random", "Low")  # seed 3 has no "low": (59, 60) -> 59.5 ± 0.7
    assert (low["n_seeds"], low["mean"]) == (2, pytest.approx(59.5))
    assert "59.5 ± 0.7 (n=2)" in render_markdown(t)
    by_budget = level_table(df, budget=60)
    assert set(by_budget["round"]) == {1}
    assert "round 1 (57 labeled, 5.7%)" in render_markdown(by_budget)
    with pytest.raises(ValueError, match="exactly one"):
        level_table(df, 1, budget=60)


def test_ablation_rows_in_paper_order_with_full_last():
    names = ["duis", "syn_random", "syn_badge", "syn_coreset", "syn_entropy", "syn_margin"]
    values = {m: VALUES["duis"] for m in names}  # syn_diversity never ran
    t = ablation_table(records_frame(make_records(values)), 1)
    assert list(t["row"]) == [
        "Syn+BADGE",
        "Syn+Entropy",
        "Syn+Margin",
        "Syn+Coreset",
        "Syn+Random",
        "Syn+Diversity",
        "Full",
    ]
    assert list(t["col"].unique()) == ["Round 1: 57 labeled (5.7%)"]
    assert cell(t, "Full", "Round 1: 57 labeled (5.7%)")["mean"] == pytest.approx(62.0)
    assert "| Syn+Diversity | — |" in render_markdown(t)


def test_sensitivity_table_shape_and_rounds():
    values = {
        "duis": VALUES["duis"],
        "duis_ncand40": VALUES["random"],
        "duis_ncand80": VALUES["entropy"],
        "duis_alpha0.25": VALUES["random"],
    }
    df = records_frame(make_records(values))
    sweeps = {
        "n_cand": {40: "duis_ncand40", 80: "duis_ncand80", 500: "duis"},
        "alpha": {0.25: "duis_alpha0.25", 0.5: "duis"},
    }
    t = sensitivity_table(df, sweeps, {"n_cand": 1, "alpha": 2})
    assert len(t) == 5
    assert list(dict.fromkeys(t["row"])) == ["N_cand (round 1)", "α (round 2)"]
    assert list(t.loc[t["parameter"] == "n_cand", "col"]) == ["40", "80", "500"]
    assert list(t.loc[t["parameter"] == "alpha", "col"]) == ["0.25", "0.5"]
    assert cell(t, "α (round 2)", "0.5")["mean"] == pytest.approx(71.0)
    md = render_markdown(t)
    assert "| N_cand (round 1) | 40 | 80 | 500 |" in md
    assert "| α (round 2) | 0.25 | 0.5 |  |" in md
    assert "|  | 61.0 ± 1.0 | **71.0 ± 1.0** |  |" in md  # best per parameter
    tex = render_latex(t)
    assert r"$\alpha$ (round 2) & 0.25 & 0.5 &  \\" in tex
    same_round = sensitivity_table(df, sweeps, 0)
    assert set(same_round["round"]) == {0}
    with pytest.raises(ValueError, match="no entry for parameter 'alpha'"):
        sensitivity_table(df, sweeps, {"n_cand": 1})


# --- writers, stand-in labelling --------------------------------------------------------


def test_write_table_csv_is_source_of_truth(df, tmp_path):
    t = sensitivity_table(df, {"alpha": {0.5: "duis", 0.75: "entropy"}}, 1)
    paths = write_table(t, tmp_path / "tables" / "sens_alpha0.5")
    assert sorted(p.name for p in paths.values()) == [
        "sens_alpha0.5.csv",
        "sens_alpha0.5.md",
        "sens_alpha0.5.tex",
    ]
    back = read_table(paths["csv"])
    assert list(back.columns) == list(t.columns)
    assert np.allclose(back["mean"], t["mean"])
    assert paths["md"].read_text() == render_markdown(t)
    assert paths["tex"].read_text() == render_latex(back, label="tab:sens_alpha0.5")
    assert not list((tmp_path / "tables").glob(".*"))  # no temporary files left


def test_atomic_write_keeps_old_file_on_failure(tmp_path):
    target = tmp_path / "t.csv"
    target.write_text("old")

    def fail(tmp):
        tmp.write_text("half")
        raise RuntimeError("killed")

    with pytest.raises(RuntimeError):
        atomic_write(target, fail)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


def test_synthetic_standin_is_labelled_everywhere(tmp_path):
    recs = make_records()
    recs[5]["synthetic_standin"] = True  # one record flags the whole dataset
    df = records_frame(recs)
    t = budget_table(df, methods=["duis"])  # duis' own records are not stand-in flagged
    assert t["synthetic_standin"].all()
    paths = write_table(t, tmp_path / "budget")
    for suffix in ("md", "tex"):
        assert "synthetic stand-in" in paths[suffix].read_text()
    for table in (level_table(df, 1), ablation_table(df, 1)):
        assert "synthetic stand-in" in render_markdown(table)
    assert "synthetic stand-in" in curves_figure(df).axes[0].get_title()
    assert "synthetic stand-in" in level_curves_figure(df).get_suptitle()
    assert summary(df)["synthetic_standin"] is True
    clean = records_frame(make_records())
    assert "synthetic stand-in" not in render_markdown(budget_table(clean))
    assert "synthetic stand-in" not in curves_figure(clean).axes[0].get_title()


# --- summary -------------------------------------------------------------------------------


def test_curve_area_toy():
    # trapezoids: 0.1 * (0.5 + 0.7) / 2 + 0.2 * (0.7 + 0.7) / 2 = 0.20 over a span of 0.3
    assert curve_area([0.1, 0.2, 0.4], [0.5, 0.7, 0.7]) == pytest.approx(0.2 / 0.3)
    assert curve_area([0.4, 0.1, 0.2], [0.7, 0.5, 0.7]) == pytest.approx(0.2 / 0.3)
    assert curve_area([0.3], [0.8]) == pytest.approx(0.8)
    with pytest.raises(ValueError, match="ratio and mean"):
        curve_area([0.1, 0.2], [0.5])


def test_summary_hand_computed(df, tmp_path):
    s = summary(df)
    assert (s["dataset"], s["metric"], s["n_seeds"]) == ("synth_cls", "accuracy", 3)
    duis = s["methods"]["duis"]
    # mean curve of the query rounds 1, 2 (round 0 has the same labels for every method):
    # (0.057, 0.62), (0.086, 0.71)
    assert duis["auc"] == pytest.approx((0.62 + 0.71) / 2)
    assert duis["aubc"]["rounds"] == [1, 2]
    assert duis["final_mean"] == pytest.approx(0.71)
    assert duis["final_std"] == pytest.approx(0.01)
    assert (duis["n_seeds"], duis["n_rounds"], duis["final_n_labeled"]) == (3, 3, 86)
    assert list(s["methods"]) == ["entropy", "random", "duis"]
    path = write_json(s, tmp_path / "summary.json")
    assert json.loads(path.read_text()) == s


def test_mixed_datasets_need_a_choice():
    df = records_frame(make_records() + make_records(dataset="real_cls"))
    with pytest.raises(ValueError, match="pass dataset="):
        budget_table(df)
    assert summary(df, dataset="real_cls")["dataset"] == "real_cls"


# --- curves --------------------------------------------------------------------------------


def test_curves_duis_drawn_last_and_thicker(df):
    fig = curves_figure(df, methods=["duis", "random", "entropy"])
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == ["Random", "Entropy", "DUIS"]
    assert lines[-1].get_linewidth() > max(ln.get_linewidth() for ln in lines[:-1])
    assert lines[-1].get_zorder() > max(ln.get_zorder() for ln in lines[:-1])
    assert np.allclose(lines[-1].get_xdata(), [2.9, 5.7, 8.6])
    assert np.allclose(lines[-1].get_ydata(), [50.0, 62.0, 71.0])
    assert ax.get_xlabel() == "Labeling ratio (%)"
    assert ax.get_ylabel() == "Accuracy (%)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["Random", "Entropy", "DUIS"]


def test_colours_are_fixed_per_method():
    assert method_colors(["duis", "random"])["duis"] == PALETTE["duis"]
    assert method_colors(["badge", "syn_badge", "duis"])["syn_badge"] == PALETTE["badge"]
    sweep = method_colors(["duis_ncand40", "duis_ncand80", "duis_ncand120"])
    assert len(set(sweep.values())) == 3
    assert sweep == method_colors(["duis_ncand120", "duis_ncand80", "duis_ncand40"])


def test_plot_files_are_png_and_pdf(df, tmp_path):
    png, pdf = plot_curves(df, tmp_path / "fig" / "c.png", path_pdf=tmp_path / "fig" / "c.pdf")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert pdf.read_bytes()[:5] == b"%PDF-"
    png, pdf = plot_level_curves(df, tmp_path / "l.png", path_pdf=tmp_path / "l.pdf")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert pdf.read_bytes()[:5] == b"%PDF-"


def _report_imports() -> dict[str, set[str]]:
    """spl_al.report module -> the spl_al.report modules it imports (at any depth of code)."""
    import ast
    from pathlib import Path

    import spl_al.report as pkg

    root = Path(pkg.__file__).parent
    stems = {p.stem for p in root.glob("*.py")}
    graph = {}
    for path in root.glob("*.py"):
        names = []
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names += [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names.append(node.module)
                names += [f"{node.module}.{a.name}" for a in node.names]
        found = {n.split(".")[2] for n in names if n.startswith("spl_al.report.")}
        graph[path.stem] = (found & stems) - {path.stem}
    return graph


def test_report_modules_import_no_circle():
    graph = _report_imports()
    assert "summary" not in graph["stats"]  # the circle stats <-> summary is gone

    def reach(start: str) -> set[str]:
        seen, todo = set(), [start]
        while todo:
            for nxt in graph.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return seen

    circles = sorted(m for m in graph if m != "__init__" and m in reach(m))
    assert circles == []


def test_a_budget_table_caption_carries_the_training_notes(tmp_path):
    from spl_al.config import STEPS_BY_IMAGES_NOTE
    from spl_al.experiment.report_steps import make_table

    paths = []
    for i, rec in enumerate(make_records()):
        paths.append(tmp_path / f"m{i}.json")
        paths[-1].write_text(json.dumps(rec))
    experiments = {"budget": {"methods": list(VALUES), "seeds": [1, 2, 3], "rounds": 3}}
    for notes, stem in (((), "plain"), ((STEPS_BY_IMAGES_NOTE,), "images")):
        make_table(
            paths,
            "budget",
            experiments=experiments,
            sweeps={},
            out_stem=tmp_path / stem,
            notes=notes,
        )
    assert "steps_by" not in (tmp_path / "plain.md").read_text()
    md, tex = (tmp_path / "images.md").read_text(), (tmp_path / "images.tex").read_text()
    assert "seeds (train.fit.steps_by: images, so training steps scale with images" in md
    assert "steps\\_by: images" in tex.split("\\caption{")[1]


# --- every title and label inside its figure ---------------------------------------------

# The matched family's names (the widest tick labels push an Axes' centre, and so its
# title, towards the right edge: real_cls's AUBC title was cut there).
WIDE = {
    m: ((0.40, 0.42, 0.44), (0.50 + k / 100, 0.52, 0.56), (0.60, 0.61, 0.62 + k / 50))
    for k, m in enumerate(
        [
            "random",
            "margin",
            "badge",
            "syn_random",
            "syn_margin",
            "syn_badge",
            "syn_diversity",
            "duis",
        ]
    )
}
LONG_TITLE = (
    "a_dataset_with_a_long_name: accuracy against the labeling ratio, every method "
    "of the budget experiment, both families"
)


def _grid_cells(methods, column="mean"):
    import pandas as pd

    rows = []
    for method in methods:
        for i, msppp in enumerate([1, 2, 5, 10, 20]):
            for j, sbr in enumerate([0.05, 0.2, 1, 5, 20]):
                rows.append(
                    {
                        "dataset": "a_dataset_with_a_long_name",
                        "metric": "miou",
                        "method": method,
                        "baseline": "syn_diversity",
                        "msppp": msppp,
                        "sbr": sbr,
                        column: 40.0 + i - j,
                        "n_seeds": 3,
                        "n": 3,
                        "spans_zero": (i + j) % 2 == 0,
                        "trained_range": 1 <= i <= 3 and 1 <= j <= 3,
                    }
                )
    return pd.DataFrame(rows)


def _charts():
    from spl_al.experiment.robustness import _empty_figure
    from spl_al.report.stat_figures import aubc_figure, difference_figure, heatmap_figure

    df = records_frame(make_records(WIDE, dataset="real_cls", standin=True))
    queries = df[df["round"] >= 1]
    note = (
        "\n(test scenes re-observed through the photon engine); dashed: the training "
        "conditions' range"
    )
    return {
        "curves": lambda: curves_figure(df, title=LONG_TITLE),
        "curves, two panels": lambda: curves_figure(
            df,
            title=LONG_TITLE,
            panels={"as the paper trains them": ["random", "margin"], "matched": ["duis"]},
        ),
        "level curves": lambda: level_curves_figure(df, title=LONG_TITLE + LONG_TITLE),
        "aubc": lambda: aubc_figure(queries),
        "aubc, one method": lambda: aubc_figure(queries, ["syn_diversity"]),
        "heatmap, one method": lambda: heatmap_figure(_grid_cells(["duis"]), note=note),
        "heatmap": lambda: heatmap_figure(_grid_cells(["random", "margin", "duis"]), note=note),
        "difference": lambda: difference_figure(
            _grid_cells(["duis"], "diff"), note=" (SIV re-imaged)"
        ),
        "no difference map": lambda: _empty_figure(
            "No DUIS run or no baseline: no difference map."
        ),
    }


def test_the_check_finds_a_title_past_the_edge_and_fit_texts_wraps_it():
    from spl_al.plotting import fit_texts, new_figure, texts_outside

    fig = new_figure(4, 3)
    ax = fig.add_subplot()
    ax.set_title(LONG_TITLE)
    ax.set_ylabel("a label far longer than the figure is high, in words")
    assert len(texts_outside(fig)) == 2
    fit_texts(fig)
    assert texts_outside(fig) == []
    assert "\n" in ax.get_title() and ax.get_title().replace("\n", " ") == LONG_TITLE


@pytest.mark.parametrize("name", list(_charts()))
def test_no_title_or_label_of_a_chart_reaches_past_its_figure(name):
    from spl_al.plotting import texts_outside

    fig = _charts()[name]()
    assert texts_outside(fig) == [], name


def test_no_title_or_label_of_a_picture_reaches_past_its_figure(tmp_path, monkeypatch):
    """The pictures saved as they are drawn (dataset sheets, a labeling batch, the
    photon engine's): each figure as it was saved."""
    import spl_al.data.pictures as data_pictures
    import spl_al.labeling.batch as batch
    import spl_al.photon.pictures as photon_pictures
    from spl_al.data import make_classification_dataset, make_segmentation_dataset
    from spl_al.data.variants import make_variants
    from spl_al.photon import SensorParams
    from spl_al.photon.scene import Condition, PhotonScene
    from spl_al.photon.simulate import simulate_photons
    from spl_al.plotting import texts_outside

    saved = {}

    def spy(save):
        def wrapped(fig, path):
            out = save(fig, path)
            saved[str(Path(path).relative_to(tmp_path))] = fig
            return out

        return wrapped

    monkeypatch.setattr(data_pictures, "save_png", spy(data_pictures.save_png))
    monkeypatch.setattr(batch, "save_png", spy(batch.save_png))
    monkeypatch.setattr(photon_pictures, "_save", spy(photon_pictures._save))
    cls = make_classification_dataset(n_per_class=2, image_shape=(16, 16), seed=0, workers=1)
    seg = make_segmentation_dataset(n_samples=4, image_shape=(16, 64), seed=1, workers=1)
    for name, data in (("cls", cls), ("seg", seg)):
        data_pictures.contact_sheet(data, tmp_path / f"{name}_contact.png", per_class=1)
        with_variants = make_variants(data, n_variants=2, workers=1)
        data_pictures.variants_sheet(with_variants, 0, tmp_path / f"{name}_variants.png")
        batch.write_batch(
            with_variants,
            [0],
            out_dir=tmp_path / f"{name}_batch",
            labels_file=tmp_path / f"{name}.csv",
        )
    sensor = SensorParams.tabletop()
    depth, refl = photon_pictures.demo_scene(32, 32)
    events = simulate_photons(
        PhotonScene(depth, reflectance=refl), Condition(5, 1, sensor), np.random.default_rng(0)
    )
    photon_pictures.render_real_capture(
        events, sensor, tmp_path / "capture.png", title=LONG_TITLE + LONG_TITLE
    )
    assert len(saved) >= 9
    outside = {name: texts_outside(fig) for name, fig in saved.items()}
    assert {name: texts for name, texts in outside.items() if texts} == {}


def test_a_dataset_whose_rounds_were_trained_at_two_precisions_is_refused():
    """A bf16 and an fp32 run of one config reach different verdicts: one table never
    mixes them, and the error names both precisions and a record of each."""
    from spl_al.report import summary, trained_at

    records = make_records()
    for record in records:
        record["precision"] = "bf16"
    assert trained_at(records_frame(records)) == "bf16"
    assert summary(records_frame(records))["precision"] == "bf16"
    records[-1]["precision"] = "fp32"
    with pytest.raises(ValueError, match=r"mixes rounds trained at different precisions") as err:
        records_frame(records)
    assert "bf16 (records[0])" in str(err.value) and f"fp32 (records[{len(records) - 1}])" in str(
        err.value
    )
    records[-1]["precision"] = "half"
    with pytest.raises(ValueError, match=r"key 'precision' must be one of"):
        records_frame(records)
    # records of an older spl-al say nothing: no precision, and nothing to refuse
    assert trained_at(records_frame(make_records())) == ""
