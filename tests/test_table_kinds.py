"""The table registry's contract (spl_al.report.table_kinds), run on every registered kind.

A kind is declared once; these tests hold each one to what its consumers rely on: the
config schema declares it, a small run's records give it a table, a caption, comparison
rows and a plan line, and the plan, the overview, the workflow's table list and the
docs pages all follow the registry (a kind registered here reaches each of them).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from spl_al.config import check_config
from spl_al.experiment.overview import plan_text
from spl_al.experiment.plan import dataset_runs
from spl_al.report import read_table, records_frame, summary, write_json, write_table
from spl_al.report.table_kinds import (
    TABLE_KINDS,
    TableContext,
    TableKind,
    comparisons,
    register,
    table_kind,
    table_names,
)

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "config" / "schema.yaml"

EXPERIMENTS = {
    "budget": {"methods": ["random", "duis"], "seeds": [1, 2, 3], "rounds": 3},
    "levels": {"round": 2},
    "ablation": {"methods": ["syn_random", "duis"], "seeds": [1, 2, 3], "round": 2},
    "sensitivity": {"seeds": [1, 2, 3], "rounds": {"n_cand": 1, "alpha": 2, "n_variants": 2}},
    "cold_start": {"methods": ["duis"], "starts": ["typiclust"], "seeds": [1, 2, 3], "rounds": 3},
}
SWEEPS = {
    "n_cand": {40: "duis_ncand40", 160: "duis"},
    "alpha": {0.25: "duis_alpha0.25", 0.5: "duis"},
    "n_variants": {1: "duis_m1", 4: "duis"},
}
METHODS = [
    "random",
    "duis",
    "syn_random",
    "duis_ncand40",
    "duis_alpha0.25",
    "duis_m1",
    "duis_from_typiclust",
]


def records():
    """Three seeds x three rounds of every method; DUIS 5 points ahead, seed noise shared."""
    out = []
    for method in METHODS:
        for seed in (1, 2, 3):
            for r in range(3):
                value = 0.5 + 0.05 * r + 0.01 * seed + (0.05 if method == "duis" else 0.0)
                out.append(
                    {
                        "dataset": "d",
                        "method": method,
                        "seed": seed,
                        "round": r,
                        "n_labeled": (20, 40, 80)[r],
                        "n_total": 200,
                        "metric": "accuracy",
                        "value": round(value, 6),
                        "per_level": {"high": value, "medium": value, "low": value},
                        "synthetic_standin": False,
                    }
                )
    return records_frame(out)


def experiment_schemas() -> dict:
    """The schema's experiments blocks: supervised and embedding framework."""
    schema = yaml.safe_load(SCHEMA.read_text())
    dataset = schema["$defs"]["dataset"]["properties"]
    return {
        "experiments": dataset["experiments"],
        "embedding.experiments": dataset["embedding"]["properties"]["experiments"],
    }


def test_the_schema_declares_exactly_the_registered_kinds():
    for where, block in experiment_schemas().items():
        assert list(block["properties"]) == list(TABLE_KINDS), where


@pytest.mark.parametrize("name", list(TABLE_KINDS))
def test_kind_contract(name, tmp_path):
    kind = table_kind(name)
    assert kind.name == name and kind.title
    df = records()
    ctx = TableContext(EXPERIMENTS, SWEEPS, labeled=lambda r: (20, 40, 80)[r])
    block = EXPERIMENTS[name]

    # its table, written as CSV + Markdown + LaTeX, reads back with one row per cell
    frame = kind.build(df, ctx)
    assert len(frame) > 0 and {"table", "method"} <= set(frame.columns)
    caption = kind.caption("accuracy", block)
    assert "accuracy" in caption
    write_table(frame, tmp_path / name, caption=caption)
    for ext in ("csv", "md", "tex"):
        assert (tmp_path / f"{name}.{ext}").stat().st_size > 0
    assert len(read_table(tmp_path / f"{name}.csv")) == len(frame)

    # its comparisons, named by the kind, DUIS ahead of what it is compared with
    rows = kind.rows(df, ctx)
    assert rows and {row["experiment"] for row in rows} == {name}
    cmp = comparisons(df, {n: EXPERIMENTS[n] for n in ("budget", name)}, SWEEPS)
    assert name in set(cmp["experiment"])

    # its plan line starts with its name; what it runs is what the plan trains
    assert kind.describe(block, ctx).startswith(f"{name}:")
    for methods, seeds, rounds in kind.runs(block, ctx):
        assert set(methods) <= set(METHODS) and set(seeds) == {1, 2, 3}
        assert 1 <= rounds <= 3


def test_table_names_follow_the_registry_and_skip_levels_without_them():
    assert table_names(EXPERIMENTS, has_levels=True) == list(TABLE_KINDS)
    without = [n for n, k in TABLE_KINDS.items() if not k.needs_levels]
    assert table_names(EXPERIMENTS, has_levels=False) == without
    with pytest.raises(ValueError, match=r"unknown table 'nope'; expected one of budget, "):
        table_kind("nope")


def test_every_consumer_follows_a_newly_registered_kind(tmp_path):
    """Registering a kind is the one step that reaches the plan, the overview, the
    table list, the comparisons and the docs pages; the schema is the one other place
    a kind is written, and it refuses a kind it does not declare."""
    from spl_al.docs.results_blocks import results_block

    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["results"] = "results"
    tiny = TableKind(
        name="tiny",
        title="Tiny kind",
        runs=lambda block, _ctx: [(["random"], [77], block["round"] + 1)],
        describe=lambda block, _ctx: f"tiny: round {block['round']}",
        caption=lambda metric, _block: f"tiny {metric}",
        build=lambda df, _ctx: df,
        rows=lambda _d, _ctx: [{"experiment": "tiny"}],
    )
    register(tiny)
    try:
        with pytest.raises(ValueError, match="already registered"):
            register(tiny)
        exps = config["datasets"]["real_cls"]["experiments"]
        exps["tiny"] = {"round": 1}
        assert dataset_runs(config, "real_cls")[("random", 77)] == 2
        assert "    tiny: round 1" in plan_text(config)
        assert table_names(exps, has_levels=True)[-1] == "tiny"
        assert "tiny" in set(comparisons(records(), {**EXPERIMENTS, "tiny": {}})["experiment"])
        tables = tmp_path / "real_cls" / "tables"
        tables.mkdir(parents=True)
        (tables / "tiny.md").write_text("| a |\n|---|\n| 1 |\n")
        budget = table_kind("budget").build(records(), TableContext(EXPERIMENTS))
        write_table(budget, tables / "budget", caption="budget")
        write_json(summary(records()), tables / "summary.json")
        assert "### real_cls: tiny kind" in results_block(tmp_path)
        with pytest.raises(ValueError, match="tiny"):
            check_config(config, SCHEMA)
    finally:
        del TABLE_KINDS["tiny"]
