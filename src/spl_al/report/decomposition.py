"""DUIS − Random as a sum of four paired parts, per query round and over the AUBC.

Four methods sit between Random and DUIS, each adding one ingredient to the one before:

    DUIS − Random = (Syn+Random − Random)             training on the variants
                  + (Syn+Margin − Syn+Random)         uncertainty over random
                  + (Syn+Diversity − Syn+Margin)      diversity over uncertainty
                  + (DUIS − Syn+Diversity)            inconsistency over diversity

The sum telescopes seed by seed, so over the seeds where all five methods ran the
mean differences add up exactly to DUIS − Random. Each part gets the paired 95%
t-interval and the exact sign-flip p of ``spl_al.report.stats.paired_test``, at every
query round (round >= 1: round 0 holds the same labels for every method) and on the
area under the budget curve over those rounds.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from spl_al.report.display import FULL_METHOD, format_ratio, method_label
from spl_al.report.records import one_dataset
from spl_al.report.stats import (
    aubc_per_seed,
    clustered,
    paired_test,
    query_rounds,
    seed_matrix,
    span_text,
    values_of,
)

PARTS = (
    ("variant_training", "syn_random", "random", "training on the variants"),
    ("uncertainty_over_random", "syn_margin", "syn_random", "uncertainty over random"),
    ("diversity_over_uncertainty", "syn_diversity", "syn_margin", "diversity over uncertainty"),
    ("inconsistency_over_diversity", FULL_METHOD, "syn_diversity", "inconsistency over diversity"),
)
"""(part id, A, B, what A − B adds), from Random to DUIS."""

TOTAL = ("total", FULL_METHOD, "random", "DUIS over Random")

METHODS = ("random", "syn_random", "syn_margin", "syn_diversity", FULL_METHOD)
"""The five methods the decomposition needs."""

COLUMNS = (
    "point",
    "round",
    "n_labeled",
    "part",
    "what",
    "method_a",
    "method_b",
    "n",
    "diff",
    "ci_low",
    "ci_high",
    "p_value",
    "rule",
    "resolved",
    "dataset",
    "metric",
    "scale",
    "unit",
)


def _point_rows(wide: pd.DataFrame, scale: float, **fields) -> list[dict]:
    """The four parts and the total over the seeds (rows of ``wide``) that hold all five
    methods."""
    wide = wide.dropna()
    rows = []
    for part, a, b, what in (*PARTS, TOTAL):
        test = paired_test(wide[a], wide[b])
        rows.append(
            {
                **fields,
                "part": part,
                "what": what,
                "method_a": a,
                "method_b": b,
                "n": test["n"],
                "diff": scale * test["diff"],
                "ci_low": scale * test["ci_low"],
                "ci_high": scale * test["ci_high"],
                "p_value": test["p_value"],
                "rule": test["rule"],
                "resolved": test["resolved"],
            }
        )
    return rows


def decomposition(
    df: pd.DataFrame, n_rounds: int, *, metric_scale: float = 100, dataset: str | None = None
) -> pd.DataFrame:
    """The decomposition of DUIS − Random at every query round < ``n_rounds`` and on
    the AUBC over them, in percentage points (``metric_scale`` = 100).

    ``df``: a records frame. Returns one row per (point, part) with the columns
    ``COLUMNS``; empty when one of ``METHODS`` has no records. ``n`` counts the units
    (``unit``): seeds, or encoders where every record names one (``stats.unit_means``).
    At each point the four parts' ``diff`` sum to the total's (same units: the sum
    telescopes).
    """
    d = one_dataset(df, dataset)
    d = d[d["method"].isin(METHODS)]
    if set(METHODS) - set(d["method"]):
        return pd.DataFrame(columns=list(COLUMNS))
    queried = query_rounds(d, n_rounds)
    queried = queried[queried["round"] >= 1]
    rows = []
    for r in sorted(int(x) for x in queried["round"].unique()):
        at = queried[queried["round"] == r]
        wide = seed_matrix(values_of(at), METHODS)
        point = f"round {r} ({format_ratio(at['ratio'].mean())})"
        n_labeled = int(at["n_labeled"].median())
        rows += _point_rows(wide, metric_scale, point=point, round=r, n_labeled=n_labeled)
    if not queried.empty:
        area = aubc_per_seed(queried).rename(columns={"aubc": "value"})
        wide = seed_matrix(area, METHODS)
        point = f"AUBC, {span_text(queried)}"
        rows += _point_rows(wide, metric_scale, point=point, round=pd.NA, n_labeled=pd.NA)
    frame = pd.DataFrame(rows, columns=[c for c in COLUMNS if c not in ("dataset", "metric")])
    for col in ("round", "n_labeled"):
        frame[col] = pd.array(frame[col], dtype="Int64")
    frame["resolved"] = frame["resolved"].astype(bool)
    frame["dataset"] = d["dataset"].iloc[0]
    frame["metric"] = d["metric"].iloc[0]
    frame["scale"] = float(metric_scale)
    frame["unit"] = "encoder" if clustered(values_of(d)) else "seed"
    return frame[list(COLUMNS)]


def _num(x, fmt: str = "+.1f") -> str:
    x = float(x)
    return "—" if not np.isfinite(x) else format(x, fmt)


def render_decomposition_markdown(frame: pd.DataFrame) -> str:
    """Markdown: one table, a block of five lines (four parts, then the total) per point."""
    if frame.empty:
        return (
            "**No decomposition: the budget experiment does not run all of "
            f"{', '.join(method_label(m) for m in METHODS)}.**\n"
        )
    first = frame.iloc[0]
    unit = str(first["unit"]) if "unit" in frame and isinstance(first["unit"], str) else "seed"
    over = " (each an encoder's mean over its run seeds)" if unit == "encoder" else ""
    lines = [
        f"**DUIS − Random on {first['dataset']} in four paired parts, percentage points: "
        f"mean difference [95% t-interval], exact sign-flip p, n {unit}s{over}.** The "
        "parts of a point sum to its total.",
        "",
        "| Point | Part | A − B | diff [95% CI] (pp) | p | n |",
        "|:---|:---|:---|---:|---:|---:|",
    ]
    for _, row in frame.iterrows():
        what = row["what"] if row["part"] != "total" else "**total**"
        mark = " ✓" if bool(row["resolved"]) else ""
        lines.append(
            f"| {row['point']} | {what} | {method_label(row['method_a'])} − "
            f"{method_label(row['method_b'])} | {_num(row['diff'])} [{_num(row['ci_low'])}, "
            f"{_num(row['ci_high'])}]{mark} | {_num(row['p_value'], '.3g')} | {int(row['n'])} |"
        )
    lines += ["", "✓: resolved under the rule of the comparisons table (its rule column)."]
    return "\n".join(lines) + "\n"
