"""The paper's tables as long-form frames (the CSV source of truth).

Every table function returns one row per cell, in the metric scale of the table
(``metric_scale=100``: percent), with the columns

    method, round, n_labeled, ratio, mean, std, n_seeds, n_expected, n_encoders, partial,
    mark,
    [level | parameter, value], row, col, row_pos, col_pos,
    table, dataset, metric, scale, synthetic_standin

``row``/``col`` are the display labels and ``row_pos``/``col_pos`` their order, so
``render_markdown`` / ``render_latex`` can draw the table from this frame alone (also
after a round trip through CSV). ``n_expected`` is the number of distinct seeds of the
table's methods; a cell with ``n_seeds < n_expected`` is ``partial`` and shows its n.
``n_encoders`` is the number of self-supervised encoders those seeds read, where every
record names one (the embedding framework: the leader tests count encoders), else 0.
A method asked for but absent gets a row of empty cells (mean NaN, n_seeds 0).
``mark`` is "bold" on a column's (sensitivity: a parameter's) highest mean when its
paired difference to the runner-up is resolved (``spl_al.report.stats``), "tie" on a
highest mean that is not, and empty elsewhere.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from spl_al.report.aggregate import method_curves
from spl_al.report.display import (
    ABLATION_LABELS,
    ABLATION_ROWS,
    LEVEL_LABELS,
    METHOD_LABELS,
    PARAMETER_LABELS,
    format_number,
    format_ratio,
    method_label,
    ordered_methods,
    unique_ratio_labels,
)
from spl_al.report.records import LEVELS, one_dataset, round_for_budget
from spl_al.report.stats import clustered, leader_test, values_of

ROUND0_MARK = " (round 0)"
"""Suffix of the budget table's round-0 column: before any query."""

TABLE_COLUMNS = (
    "method",
    "round",
    "n_labeled",
    "ratio",
    "mean",
    "std",
    "n_seeds",
    "n_expected",
    "n_encoders",
    "partial",
    "mark",
)
TRAILING_COLUMNS = (
    "row",
    "col",
    "row_pos",
    "col_pos",
    "table",
    "dataset",
    "metric",
    "scale",
    "synthetic_standin",
)


def _check_scale(metric_scale) -> float:
    if not (isinstance(metric_scale, int | float) and metric_scale > 0):
        raise ValueError(f"metric_scale must be a number > 0, got {metric_scale!r}.")
    return float(metric_scale)


def _check_round(d: pd.DataFrame, r, what: str = "round") -> int:
    rounds = sorted(int(x) for x in d["round"].unique())
    if isinstance(r, bool) or not isinstance(r, int | np.integer) or int(r) not in rounds:
        raise ValueError(f"{what} must be one of the dataset's rounds {rounds}, got {r!r}.")
    return int(r)


def _methods(d: pd.DataFrame, methods: Sequence[str] | None) -> list[str]:
    if methods is None:
        return ordered_methods(d["method"])
    if isinstance(methods, str) or len(methods) == 0:
        raise ValueError(f"methods must be a non-empty list of method names, got {methods!r}.")
    return list(dict.fromkeys(methods))


def _finish(
    cells: list[dict],
    kind: str,
    d: pd.DataFrame,
    n_expected: int,
    scale: float,
    extra: Sequence[str] = (),
) -> pd.DataFrame:
    """Add the shared columns and put the frame in its column order."""
    frame = pd.DataFrame(cells)
    frame["mean"] = frame["mean"].astype(float) * scale
    frame["std"] = frame["std"].astype(float) * scale
    frame["n_seeds"] = frame["n_seeds"].astype(int)
    frame["n_expected"] = n_expected
    values = values_of(d[d["method"].isin(frame["method"])])
    frame["n_encoders"] = int(values["encoder"].nunique()) if clustered(values) else 0
    frame["partial"] = (frame["n_seeds"] > 0) & (frame["n_seeds"] < n_expected)
    for col in ("round", "n_labeled"):
        frame[col] = pd.array(frame[col], dtype="Int64")
    frame["table"] = kind
    frame["dataset"] = d["dataset"].iloc[0]
    frame["metric"] = d["metric"].iloc[0]
    frame["scale"] = scale
    # Any stand-in record of the dataset marks the whole table, not only its own cells.
    frame["synthetic_standin"] = bool(d["synthetic_standin"].any())
    frame = frame.sort_values(["row_pos", "col_pos"], ignore_index=True)
    frame["mark"] = _leader_marks(frame, d, by="row" if kind == "sensitivity" else "col")
    return frame[[*TABLE_COLUMNS, *extra, *TRAILING_COLUMNS]]


def _leader_marks(frame: pd.DataFrame, d: pd.DataFrame, by: str) -> pd.Series:
    """Mark "bold" on a group's leader resolved from its runner-up (``spl_al.report.stats``),
    "tie" on a leader that is not, "" elsewhere. A group is a column of a method table
    or a parameter row of the sensitivity table; the test pairs the two methods' seeds
    in the records ``d`` at the cell's round (and MSPPP level)."""
    marks = pd.Series("", index=frame.index, dtype=object)
    valued = frame[(frame["n_seeds"] > 0) & (frame["col_pos"] >= 0)]
    if (frame["table"] == "budget").all():  # round 0: the same labels for every method
        valued = valued[valued["round"].fillna(-1) != 0]
    for _, group in valued.groupby(by, sort=False):
        parts = []
        for _, cell in group.iterrows():
            level = cell.get("level")
            value_col = f"level_{level}" if isinstance(level, str) else "value"
            at = d[(d["method"] == cell["method"]) & (d["round"] == cell["round"])]
            parts.append(values_of(at, value_col))
        result = leader_test(pd.concat(parts, ignore_index=True))
        if result is None:
            continue
        if result["direction"] > 0:
            marks[group.index[group["method"] == result["leader"]]] = "bold"
        else:  # every cell sharing the top mean is part of the tie
            top = group["mean"].max()
            marks[group.index[np.isclose(group["mean"], top, rtol=0, atol=1e-9)]] = "tie"
    return marks


def _cell(stat: pd.Series | None, **fields) -> dict:
    if stat is None:
        return {"mean": np.nan, "std": np.nan, "n_seeds": 0, "ratio": np.nan, **fields}
    return {
        "mean": stat["mean"],
        "std": stat["std"],
        "n_seeds": int(stat["n_seeds"]),
        "ratio": stat["ratio"],
        **fields,
    }


def _stat_at(at: pd.DataFrame, method: str, value_col: str = "value") -> pd.Series | None:
    """Seed statistics of one method in records of one round, or None when it has none."""
    curve = method_curves(at[at["method"] == method], value_col)
    return curve.iloc[0] if not curve.empty else None


def budget_table(
    df: pd.DataFrame,
    metric_scale: float = 100,
    *,
    methods: Sequence[str] | None = None,
    rounds: Sequence[int] | None = None,
    labels: Mapping[str, str] | None = None,
    dataset: str | None = None,
    kind: str = "budget",
) -> pd.DataFrame:
    """Metric per method (rows) x labeling budget (columns), mean and std over seeds.

    Columns are the distinct n_labeled of the chosen ``rounds`` (default: all), labelled
    by labeling ratio like the paper ("2.9%"); rows follow ``methods`` (default: every
    method of ``df`` in the paper's order, DUIS last). The paper's segmentation table.
    Round 0's column is labelled "(round 0)" and gets no leader mark: its labels are the
    same for every method, so it says nothing about acquisition. ``kind`` names the
    table: "cold_start" (the cold-start experiment's arms, whose round 0 differ) marks
    round 0's leader too.
    """
    scale = _check_scale(metric_scale)
    full = one_dataset(df, dataset)
    methods = _methods(full, methods)
    d = full[full["method"].isin(methods)]
    n_expected = int(d["seed"].nunique())
    if rounds is not None:
        rounds = [_check_round(full, r, "each of rounds") for r in rounds]
        d = d[d["round"].isin(rounds)]
    curves = method_curves(d)

    budgets = curves.groupby("n_labeled")["ratio"].mean().sort_index()
    col_labels = dict(zip(budgets.index, unique_ratio_labels(budgets.to_numpy()), strict=True))
    for n in set(curves.loc[curves["round"] == 0, "n_labeled"]):
        col_labels[n] += ROUND0_MARK
    col_pos = {n: i for i, n in enumerate(budgets.index)}
    labels = dict(labels or METHOD_LABELS)

    cells = []
    for pos, method in enumerate(methods):
        mine = curves[curves["method"] == method]
        fields = {"method": method, "row": method_label(method, labels), "row_pos": pos}
        if mine.empty:
            cells.append(_cell(None, **fields, round=pd.NA, n_labeled=pd.NA, col="", col_pos=-1))
            continue
        for _, stat in mine.iterrows():
            n = stat["n_labeled"]
            cells.append(
                _cell(
                    stat,
                    **fields,
                    round=int(stat["round"]),
                    n_labeled=int(n),
                    col=col_labels[n],
                    col_pos=col_pos[n],
                )
            )
    return _finish(cells, kind, full, n_expected, scale)


def level_table(
    df: pd.DataFrame,
    round: int | None = None,
    *,
    budget: int | None = None,
    methods: Sequence[str] | None = None,
    levels: Sequence[str] = LEVELS,
    metric_scale: float = 100,
    labels: Mapping[str, str] | None = None,
    dataset: str | None = None,
) -> pd.DataFrame:
    """Metric per method (rows) x MSPPP level (columns) at one round, mean and std over seeds.

    Give ``round`` (a record's round number) or ``budget`` (a number of labeled samples:
    the round whose n_labeled is closest is used), not both. A level missing from some
    records is averaged over the seeds that have it.
    """
    scale = _check_scale(metric_scale)
    full = one_dataset(df, dataset)
    methods = _methods(full, methods)
    d = full[full["method"].isin(methods)]
    if (round is None) == (budget is None):
        raise ValueError("level_table needs exactly one of round= or budget=.")
    if budget is not None:
        round = round_for_budget(d if not d.empty else full, budget)
    r = _check_round(full, round)
    bad = [lv for lv in levels if lv not in LEVELS]
    if bad or not levels:
        raise ValueError(f"levels must be a non-empty subset of {list(LEVELS)}, got {levels!r}.")
    n_expected = int(d["seed"].nunique())
    at = d[d["round"] == r]
    labels = dict(labels or METHOD_LABELS)

    cells = []
    for pos, method in enumerate(methods):
        overall = _stat_at(at, method)
        n_labeled = int(overall["n_labeled"]) if overall is not None else pd.NA
        for j, level in enumerate(levels):
            cells.append(
                _cell(
                    _stat_at(at, method, f"level_{level}"),
                    method=method,
                    round=r,
                    n_labeled=n_labeled,
                    level=level,
                    row=method_label(method, labels),
                    row_pos=pos,
                    col=LEVEL_LABELS[level],
                    col_pos=j,
                )
            )
    return _finish(cells, "level", full, n_expected, scale, extra=("level",))


def ablation_table(
    df: pd.DataFrame,
    round: int,
    rows: Sequence[str] = ABLATION_ROWS,
    *,
    labels: Mapping[str, str] | None = None,
    metric_scale: float = 100,
    dataset: str | None = None,
) -> pd.DataFrame:
    """Ablation at one round: rows Syn+BADGE ... Syn+Diversity, Full (DUIS), mean and std.

    ``rows`` are method names in display order; ``labels`` maps them to display names
    (default: the paper's, with DUIS shown as "Full").
    """
    scale = _check_scale(metric_scale)
    full = one_dataset(df, dataset)
    rows = _methods(full, rows)
    r = _check_round(full, round)
    d = full[full["method"].isin(rows)]
    n_expected = int(d["seed"].nunique())
    at = d[d["round"] == r]
    labels = dict(labels or ABLATION_LABELS)
    n_at = full.loc[full["round"] == r, "n_labeled"].median()
    ratio_at = full.loc[full["round"] == r, "ratio"].mean()
    col = f"Round {r}: {n_at:g} labeled ({format_ratio(ratio_at)})"

    cells = []
    for pos, method in enumerate(rows):
        stat = _stat_at(at, method)
        cells.append(
            _cell(
                stat,
                method=method,
                round=r,
                n_labeled=int(stat["n_labeled"]) if stat is not None else pd.NA,
                row=method_label(method, labels),
                row_pos=pos,
                col=col,
                col_pos=0,
            )
        )
    return _finish(cells, "ablation", full, n_expected, scale)


def sensitivity_table(
    df: pd.DataFrame,
    sweeps: Mapping[str, Mapping],
    round: int | Mapping[str, int],
    *,
    parameter_labels: Mapping[str, str] | None = None,
    metric_scale: float = 100,
    dataset: str | None = None,
) -> pd.DataFrame:
    """One-parameter sensitivity: one row per parameter, one column per value of it.

    ``sweeps``: parameter -> {value: method name}, e.g. ``{"n_cand": {40: "duis_ncand40"}}``,
    in display order. ``round``: one round for every parameter, or parameter -> round
    (the paper reads N_cand at the 4th round and alpha, M at the 5th). Rows of
    different parameters have different columns, so the rendered table is a block
    of two lines (values, then metric) per parameter.
    """
    scale = _check_scale(metric_scale)
    full = one_dataset(df, dataset)
    if not isinstance(sweeps, Mapping) or not sweeps:
        raise ValueError("sweeps must map each parameter to {value: method name}; got none.")
    rounds = {}
    for param, values in sweeps.items():
        if not isinstance(values, Mapping) or not values:
            raise ValueError(f"sweeps[{param!r}] must map values to method names, got {values!r}.")
        if isinstance(round, Mapping):
            if param not in round:
                raise ValueError(f"round has no entry for parameter {param!r}.")
            rounds[param] = _check_round(full, round[param], f"round[{param!r}]")
        else:
            rounds[param] = _check_round(full, round)
    swept = {m for values in sweeps.values() for m in values.values()}
    n_expected = int(full.loc[full["method"].isin(swept), "seed"].nunique())
    labels = dict(parameter_labels or PARAMETER_LABELS)

    cells = []
    for pos, (param, values) in enumerate(sweeps.items()):
        r = rounds[param]
        at = full[full["round"] == r]
        for j, (value, method) in enumerate(values.items()):
            stat = _stat_at(at, method)
            cells.append(
                _cell(
                    stat,
                    method=method,
                    round=r,
                    n_labeled=int(stat["n_labeled"]) if stat is not None else pd.NA,
                    parameter=param,
                    value=value,
                    row=f"{labels.get(param, param)} (round {r})",
                    row_pos=pos,
                    col=format_number(value),
                    col_pos=j,
                )
            )
    return _finish(cells, "sensitivity", full, n_expected, scale, extra=("parameter", "value"))
