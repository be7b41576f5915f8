"""The table kinds of a dataset's experiments, each declared once.

A kind is a key under a dataset's ``experiments`` (and ``embedding.experiments``):
budget, levels, ablation, sensitivity, cold_start. Its ``TableKind`` says everything the project
knows of it, and every other place reads it from ``TABLE_KINDS``:

- ``runs``: the (methods, seeds, rounds) it needs trained (``experiment.plan``, and
  through it the workflow's DAG);
- ``describe``: its line in the plan printed before a run (``experiment.overview``);
- ``caption`` and ``build``: its table, results/{dataset}/tables/{name}.csv/.md/.tex,
  from the round records (the workflow's ``table`` rule, whose wildcard is the kinds);
- ``rows``: its paired comparisons (``comparisons``: comparisons.csv, the claims);
- ``title``: its heading in docs/results.md (``docs.results_blocks``);
- ``needs_levels``: made only for images with MSPPP levels.

config/schema.yaml declares each kind's keys under ``experiments``;
tests/test_table_kinds.py holds every registered kind to this contract, and
CONTRIBUTING.md's "A new table" recipe says how to add one.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import pandas as pd

from spl_al.report import comparisons as cmp
from spl_al.report.display import method_label
from spl_al.report.records import one_dataset
from spl_al.report.tables import ablation_table, budget_table, level_table, sensitivity_table

Runs = Iterable[tuple[Iterable[str], Iterable[int], int]]


def numbers_text(values) -> str:
    """Seeds or counts in words: '1-100 (100)' for a long run of consecutive ones."""
    values = list(values)
    if len(values) > 6 and values == list(range(values[0], values[0] + len(values))):
        return f"{values[0]}-{values[-1]} ({len(values)})"
    return ", ".join(str(v) for v in values)


@dataclass(frozen=True)
class TableContext:
    """What a kind reads besides its own block.

    ``experiments``: the dataset's experiments in one framework, as run
    (``experiment.plan.experiments_of``); ``sweeps``: parameter -> {value: method} of
    the sensitivity sweeps (``experiment.plan.sweep_table_spec``; M as ``n_variants``);
    ``labeled``: round -> labeled groups (the plan's line); ``human``: each round waits
    for a person's labels."""

    experiments: Mapping
    sweeps: Mapping = field(default_factory=dict)
    labeled: Callable[[int], int] | None = None
    human: bool = False


@dataclass(frozen=True)
class TableKind:
    """One table kind; see the module docstring for what reads each field.

    ``runs(block, ctx)``, ``describe(block, ctx)`` and ``caption(metric, block)`` take
    the kind's own config block; ``build(records, ctx)`` the round records (one
    dataset's, ``report.load_records``) and ``rows(records, ctx)`` the same, giving
    comparison rows (``report.comparisons``)."""

    name: str
    title: str
    runs: Callable[[Mapping, TableContext], Runs]
    describe: Callable[[Mapping, TableContext], str]
    caption: Callable[[str, Mapping], str]
    build: Callable[[pd.DataFrame, TableContext], pd.DataFrame]
    rows: Callable[[pd.DataFrame, TableContext], list[dict]]
    needs_levels: bool = False


TABLE_KINDS: dict[str, TableKind] = {}
"""Registered kinds by name, in the order the tables, plan and comparisons list them."""


def register(kind: TableKind) -> TableKind:
    """Add ``kind`` to ``TABLE_KINDS`` (refusing a name already taken)."""
    if kind.name in TABLE_KINDS:
        raise ValueError(f"table kind {kind.name!r} is already registered.")
    TABLE_KINDS[kind.name] = kind
    return kind


def table_kind(name: str) -> TableKind:
    """The registered kind ``name``; a name that is none gets one sentence."""
    if name not in TABLE_KINDS:
        raise ValueError(f"unknown table {name!r}; expected one of {', '.join(TABLE_KINDS)}.")
    return TABLE_KINDS[name]


def table_names(experiments: Mapping, *, has_levels: bool) -> list[str]:
    """The tables a dataset's ``experiments`` ask for, in registry order; none that
    needs MSPPP levels for images without them."""
    return [
        name
        for name, kind in TABLE_KINDS.items()
        if name in experiments and (has_levels or not kind.needs_levels)
    ]


def comparisons(
    df: pd.DataFrame,
    experiments: Mapping,
    sweeps: Mapping | None = None,
    *,
    metric_scale: float = 100,
    dataset: str | None = None,
) -> pd.DataFrame:
    """Every paired comparison of one dataset's ``experiments`` as one frame
    (``spl_al.report.comparisons``): each configured kind's rows, in registry order.
    ``sweeps``: parameter -> {value: method} (M as ``m`` or ``n_variants``). Kinds that
    are not configured, or whose methods have no records, give no rows."""
    d = one_dataset(df, dataset)
    plan_sweeps = {("n_variants" if p == "m" else p): v for p, v in (sweeps or {}).items()}
    ctx = TableContext(experiments, plan_sweeps)
    rows = [
        row
        for name, kind in TABLE_KINDS.items()
        if name in experiments
        for row in kind.rows(d, ctx)
    ]
    return cmp.comparisons_frame(d, rows, metric_scale=metric_scale)


def _for_m(sweeps: Mapping) -> dict:
    """Sweeps as the report names them: M's parameter is ``m``."""
    return {("m" if p == "n_variants" else p): v for p, v in sweeps.items()}


def _budget_line(block: Mapping, ctx: TableContext) -> str:
    rounds = int(block["rounds"])
    at = ""
    if ctx.labeled is not None:
        at = f" at {numbers_text(ctx.labeled(r) for r in range(rounds))} labeled groups"
    more = " (each stops for your labels)" if ctx.human else ""
    return (
        f"budget: methods {', '.join(block['methods'])}; seeds {numbers_text(block['seeds'])}; "
        f"{rounds} rounds{more}{at}"
    )


def _swept(block: Mapping, sweeps: Mapping) -> dict:
    """The sweeps the block runs: those it names a round for."""
    return {p: values for p, values in sweeps.items() if p in block["rounds"]}


def _sensitivity_runs(block: Mapping, ctx: TableContext) -> Runs:
    return [
        (values.values(), block["seeds"], block["rounds"][parameter] + 1)
        for parameter, values in _swept(block, ctx.sweeps).items()
    ]


def _sensitivity_line(block: Mapping, ctx: TableContext) -> str:
    swept = "; ".join(
        f"{param} {numbers_text(values)} at round {block['rounds'][param]}"
        for param, values in _swept(block, ctx.sweeps).items()
    )
    return f"sensitivity: {swept}; seeds {numbers_text(block['seeds'])}"


def _sensitivity_build(records: pd.DataFrame, ctx: TableContext) -> pd.DataFrame:
    block = ctx.experiments["sensitivity"]
    return sensitivity_table(records, _for_m(_swept(block, ctx.sweeps)), _for_m(block["rounds"]))


register(
    TableKind(
        name="budget",
        title="Budget",
        runs=lambda block, _ctx: [(block["methods"], block["seeds"], block["rounds"])],
        describe=_budget_line,
        caption=lambda metric, _block: f"{metric} (%) vs labeling ratio, mean ± std over seeds",
        build=lambda records, ctx: budget_table(
            records, methods=ctx.experiments["budget"]["methods"]
        ),
        rows=lambda d, ctx: cmp.budget_rows(d, ctx.experiments),
    )
)
register(
    TableKind(
        name="levels",
        title="Per MSPPP level",
        runs=lambda _block, _ctx: [],  # the budget experiment's models, measured per level
        describe=lambda block, _ctx: f"levels: round {block['round']}",
        caption=lambda metric, block: f"{metric} (%) per MSPPP level at round {block['round']}",
        build=lambda records, ctx: level_table(
            records,
            round=ctx.experiments["levels"]["round"],
            methods=ctx.experiments["budget"]["methods"],
        ),
        rows=lambda d, ctx: cmp.level_rows(d, ctx.experiments),
        needs_levels=True,
    )
)
register(
    TableKind(
        name="ablation",
        title="Ablation",
        runs=lambda block, _ctx: [(block["methods"], block["seeds"], block["round"] + 1)],
        describe=lambda block, _ctx: (
            f"ablation: methods {', '.join(block['methods'])}; "
            f"seeds {numbers_text(block['seeds'])}; round {block['round']}"
        ),
        caption=lambda metric, block: f"ablation: {metric} (%) at round {block['round']}",
        build=lambda records, ctx: ablation_table(
            records,
            ctx.experiments["ablation"]["round"],
            rows=ctx.experiments["ablation"]["methods"],
        ),
        rows=lambda d, ctx: cmp.ablation_rows(d, ctx.experiments),
    )
)
register(
    TableKind(
        name="sensitivity",
        title="Sensitivity",
        runs=_sensitivity_runs,
        describe=_sensitivity_line,
        caption=lambda metric, _block: f"parameter sensitivity of DUIS: {metric} (%)",
        build=_sensitivity_build,
        rows=lambda d, ctx: cmp.sensitivity_rows(d, ctx.experiments, _for_m(ctx.sweeps)),
    )
)


def _cold_start_methods(block: Mapping) -> list[str]:
    """The cold-start table's rows: each base method, then its arms."""
    out = []
    for base in block["methods"]:
        out += [base, *(arm for b, _s, arm in cmp.cold_start_arms(block) if b == base)]
    return out


def _cold_start_line(block: Mapping, _ctx: TableContext) -> str:
    return (
        f"cold_start: methods {', '.join(block['methods'])}, round 0 at random and chosen by "
        f"{', '.join(block['starts'])} on the embedding; seeds {numbers_text(block['seeds'])}; "
        f"{int(block['rounds'])} rounds"
    )


register(
    TableKind(
        name="cold_start",
        title="Cold start",
        runs=lambda block, _ctx: [(_cold_start_methods(block), block["seeds"], block["rounds"])],
        describe=_cold_start_line,
        caption=lambda metric, block: (
            f"cold start: {metric} (%) vs labeling ratio when round 0 is drawn at random "
            f"(rows {', '.join(method_label(m) for m in block['methods'])}) or chosen without "
            "a label on the self-supervised embedding (rows 'X from S'), mean ± std over seeds"
        ),
        build=lambda records, ctx: budget_table(
            records,
            methods=_cold_start_methods(ctx.experiments["cold_start"]),
            rounds=sorted(
                r for r in set(records["round"]) if r < int(ctx.experiments["cold_start"]["rounds"])
            ),
            kind="cold_start",
        ),
        rows=lambda d, ctx: cmp.cold_start_rows(d, ctx.experiments),
    )
)
