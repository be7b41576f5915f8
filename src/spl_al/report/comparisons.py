"""Every paired comparison of a dataset's experiments, as one long-form frame.

``spl_al.report.table_kinds.comparisons(df, experiments, sweeps)`` gathers each table
kind's rows (``budget_rows``, ``level_rows``, ...), which run
``spl_al.report.stats.pairwise`` at each point the tables show: the budget table's
rounds and the area under the budget curve over the query rounds (AUBC, rounds >= 1:
round 0 holds the same labels for every method; ``span`` says which rounds and ratios
it covers), each MSPPP level at the levels round, the ablation round, and each swept
parameter at its round. One row per (point, pair of methods), in percentage points
(metric x 100); ``tables/comparisons.csv`` is this frame and the claims read it.

Columns: experiment, point, parameter, round, n_labeled, method_a, method_b, value_a,
value_b, n, mean_a, mean_b, diff (mean of A - B over paired units), sd_diff (sd of the
paired differences), ci_low, ci_high, p_value, p_min, rule ("5%" from 6 units, else
"small-n"), resolved, direction, unit ("seed", or "encoder" in the embedding
framework: ``spl_al.report.stats.unit_means``), n_seeds (the seeds behind the units),
var_between and var_within (points squared: the paired difference's variance between
the encoders' means and within an encoder; empty where the unit is the seed), span
(AUBC rows: the rounds and ratios covered), dataset, metric, scale, synthetic_standin.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from spl_al.cold_start import start_name
from spl_al.report.display import LEVEL_LABELS, METRIC_LABELS, format_ratio, method_label
from spl_al.report.records import LEVELS
from spl_al.report.stats import (
    aubc_per_seed,
    pairwise,
    query_rounds,
    rule_text,
    span_text,
    values_of,
)

COLUMNS = (
    "experiment",
    "point",
    "parameter",
    "round",
    "n_labeled",
    "method_a",
    "method_b",
    "value_a",
    "value_b",
    "n",
    "mean_a",
    "mean_b",
    "diff",
    "sd_diff",
    "ci_low",
    "ci_high",
    "p_value",
    "p_min",
    "rule",
    "resolved",
    "direction",
    "unit",
    "n_seeds",
    "var_between",
    "var_within",
    "span",
    "dataset",
    "metric",
    "scale",
    "synthetic_standin",
)
_SCALED = ("mean_a", "mean_b", "diff", "sd_diff", "ci_low", "ci_high")


def _values(d: pd.DataFrame, methods, round_: int, value_col: str = "value") -> pd.DataFrame:
    at = d[d["method"].isin(methods) & (d["round"] == round_)]
    return values_of(at, value_col)


def _rows(values: pd.DataFrame, methods, **fields) -> list[dict]:
    values = values.dropna(subset=["value"])  # e.g. images without MSPPP levels
    present = [m for m in methods if m in set(values["method"])]
    if len(present) < 2:
        return []
    return [{**fields, **row} for row in pairwise(values, present).to_dict("records")]


def _n_labeled(d: pd.DataFrame, round_: int) -> int | None:
    at = d.loc[d["round"] == round_, "n_labeled"]
    return int(at.median()) if not at.empty else None


def comparisons_frame(d: pd.DataFrame, rows: list[dict], *, metric_scale: float = 100):
    """The comparisons frame (``COLUMNS``) of one dataset's records ``d`` from comparison
    rows (``budget_rows`` and its kin), differences scaled by ``metric_scale``."""
    frame = pd.DataFrame(rows, columns=[c for c in COLUMNS if c not in ("dataset", "metric")])
    scale = float(metric_scale)
    for col in _SCALED:
        frame[col] = frame[col].astype(float) * scale
    for col in ("var_between", "var_within"):  # variances: in points squared
        frame[col] = frame[col].astype(float) * scale**2
    for col in ("round", "n_labeled"):
        frame[col] = pd.array(frame[col], dtype="Int64")
    frame["resolved"] = frame["resolved"].astype(bool)
    frame["span"] = frame["span"].fillna("")
    frame["dataset"] = d["dataset"].iloc[0]
    frame["metric"] = d["metric"].iloc[0]
    frame["scale"] = scale
    frame["synthetic_standin"] = bool(d["synthetic_standin"].any())
    return frame[list(COLUMNS)]


def budget_rows(d: pd.DataFrame, experiments: Mapping) -> list[dict]:
    """The budget experiment's comparisons at each round and over its AUBC."""
    budget = experiments.get("budget")
    if not budget:
        return []
    rows: list[dict] = []
    methods = list(budget["methods"])
    rounds = sorted(r for r in d["round"].unique() if r < int(budget["rounds"]))
    for r in rounds:
        n_lab = _n_labeled(d, r)
        ratio = d.loc[d["round"] == r, "ratio"].mean()
        rows += _rows(
            _values(d, methods, r),
            methods,
            experiment="budget",
            point=f"round {r} ({format_ratio(ratio)})",
            round=r,
            n_labeled=n_lab,
        )
    curves = query_rounds(d[d["method"].isin(methods)], int(budget["rounds"]))
    area = aubc_per_seed(curves).rename(columns={"aubc": "value"})
    rows += _rows(area, methods, experiment="budget", point="AUBC", span=span_text(curves))
    return rows


def cold_start_arms(block: Mapping) -> list[tuple[str, str, str]]:
    """(base, start, arm) of a cold-start experiment block, in its order: method
    ``base`` with round 0 chosen at random, and ``arm`` (``X_from_S``) with round 0
    chosen by ``start`` on the embedding."""
    return [(b, s, start_name(b, s)) for b in block["methods"] for s in block["starts"]]


def cold_start_rows(d: pd.DataFrame, experiments: Mapping) -> list[dict]:
    """Each cold-start arm against its base method (round 0 random): at round 0, and
    over the AUBC of every round, round 0 included (round 0 is what differs)."""
    block = experiments.get("cold_start")
    if not block:
        return []
    rounds = int(block["rounds"])
    rows: list[dict] = []
    for base, start, arm in cold_start_arms(block):
        pair = d[d["method"].isin([base, arm]) & (d["round"] < rounds)]
        if pair.empty:
            continue
        ratio = pair.loc[pair["round"] == 0, "ratio"].mean()
        fields = {"experiment": "cold_start", "parameter": start}
        rows += _rows(
            _values(pair, [base, arm], 0),
            [base, arm],
            **fields,
            point=f"round 0 ({format_ratio(ratio)})",
            round=0,
            n_labeled=_n_labeled(pair, 0),
        )
        area = aubc_per_seed(pair).rename(columns={"aubc": "value"})
        rows += _rows(area, [base, arm], **fields, point="AUBC", span=span_text(pair))
    return rows


def level_rows(d: pd.DataFrame, experiments: Mapping) -> list[dict]:
    """The budget experiment's methods compared per MSPPP level at the levels round."""
    budget, levels = experiments.get("budget"), experiments.get("levels")
    if not (budget and levels):
        return []
    rows: list[dict] = []
    methods, r = list(budget["methods"]), int(levels["round"])
    for level in LEVELS:
        rows += _rows(
            _values(d, methods, r, f"level_{level}"),
            methods,
            experiment="levels",
            point=f"{LEVEL_LABELS[level]} at round {r}",
            parameter=level,
            round=r,
            n_labeled=_n_labeled(d, r),
        )
    return rows


def ablation_rows(d: pd.DataFrame, experiments: Mapping) -> list[dict]:
    """The ablation's comparisons at its round."""
    ablation = experiments.get("ablation")
    if not ablation:
        return []
    r = int(ablation["round"])
    return _rows(
        _values(d, ablation["methods"], r),
        list(ablation["methods"]),
        experiment="ablation",
        point=f"round {r}",
        round=r,
        n_labeled=_n_labeled(d, r),
    )


def sensitivity_rows(d: pd.DataFrame, experiments: Mapping, sweeps: Mapping | None) -> list:
    """Each swept parameter's comparisons between its values, at the sweep's round."""
    sensitivity = experiments.get("sensitivity")
    if not (sensitivity and sweeps):
        return []
    rows: list[dict] = []
    for param, values in sweeps.items():
        key = "n_variants" if param == "m" else param
        if key not in sensitivity["rounds"]:
            continue
        r = int(sensitivity["rounds"][key])
        value_of = {m: v for v, m in values.items()}
        methods = list(value_of)
        for row in _rows(
            _values(d, methods, r),
            methods,
            experiment="sensitivity",
            point=f"{param} at round {r}",
            parameter=param,
            round=r,
            n_labeled=_n_labeled(d, r),
        ):
            row["value_a"] = value_of[row["method_a"]]
            row["value_b"] = value_of[row["method_b"]]
            rows.append(row)
    return rows


def _num(x, fmt: str = "+.1f") -> str:
    return "—" if x is None or not np.isfinite(float(x)) else format(float(x), fmt)


def comparison_text(row) -> str:
    """One comparison in words: 'DUIS − Random: +2.0 [-1.1, 5.1] pp, p = 0.25 (n = 3)'."""
    return (
        f"{method_label(row['method_a'])} − {method_label(row['method_b'])}: "
        f"{_num(row['diff'])} [{_num(row['ci_low'])}, {_num(row['ci_high'])}] pp, "
        f"p = {_num(row['p_value'], '.3g')} (n = {int(row['n'])})"
    )


def render_comparisons_markdown(frame: pd.DataFrame) -> str:
    """Markdown of a comparisons frame: one section per experiment, the rule once."""
    if frame.empty:
        return "**No paired comparisons: no experiment of this dataset has two methods.**\n"
    first = frame.iloc[0]
    metric = METRIC_LABELS.get(first["metric"], first["metric"])
    by_encoder = "unit" in frame and (frame["unit"] == "encoder").all()
    over = (
        "over the encoders both methods ran: each encoder's mean over its run seeds, so n "
        "counts encoders (the rule's n too)"
        if by_encoder
        else "over the seeds both methods ran"
    )
    lines = [
        f"**Paired comparisons on {first['dataset']}: {metric}, A − B in percentage points "
        f"{over}.**",
        "",
        f"Rule: {rule_text(unit='encoder' if by_encoder else 'seed')}. p: exact two-sided "
        "sign-flip test over all 2^n sign vectors (p_min = 2/2^n); interval: 95% "
        "t-interval of the mean paired difference.",
    ]
    if by_encoder:
        lines += [
            "",
            "Variance of the paired difference (pp²): between encoders, of the encoders' "
            "means; within, of the run seeds around their encoder's mean (pooled).",
        ]
    head = "| Point | A − B | n | diff [95% CI] (pp) | p (min) | resolved |"
    rule = "|:---|:---|---:|---:|---:|:---|"
    if by_encoder:
        head += " var between / within |"
        rule += "---:|"
    for experiment, part in frame.groupby("experiment", sort=False):
        lines += ["", f"*{experiment}*", "", head, rule]
        for _, row in part.iterrows():
            names = f"{method_label(row['method_a'])} − {method_label(row['method_b'])}"
            if row["experiment"] == "sensitivity":
                names = f"{row['value_a']} − {row['value_b']}"
            verdict = "no"
            if row["resolved"]:
                verdict = "A better" if row["direction"] > 0 else "B better"
                verdict += f" ({row['rule']} rule)"
            point = row["point"]
            if isinstance(row.get("span"), str) and row["span"]:
                point += f", {row['span']}"
            line = (
                f"| {point} | {names} | {int(row['n'])} | {_num(row['diff'])} "
                f"[{_num(row['ci_low'])}, {_num(row['ci_high'])}] | "
                f"{_num(row['p_value'], '.3g')} ({_num(row['p_min'], '.3g')}) | {verdict} |"
            )
            if by_encoder:
                line += f" {_num(row['var_between'])} / {_num(row['var_within'])} |"
            lines.append(line)
    if bool(first["synthetic_standin"]):
        lines += ["", f"*{first['dataset']} is a synthetic stand-in for real data.*"]
    return "\n".join(lines) + "\n"
