"""A JSON-serialisable summary of one dataset's runs: budget-curve area and final values."""

from __future__ import annotations

import math

import pandas as pd

from spl_al.report.aggregate import method_curves
from spl_al.report.display import ordered_methods
from spl_al.report.records import one_dataset, trained_at
from spl_al.report.stats import (
    aubc_per_seed,
    clustered,
    curve_area,
    mean_interval,
    query_rounds,
    span_text,
    unit_means,
)


def _num(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _aubc(areas: pd.DataFrame, span: pd.DataFrame) -> dict:
    units = unit_means(areas.rename(columns={"aubc": "value"}))
    stats = mean_interval(units["value"])
    return {
        "rounds": [int(span["round"].min()), int(span["round"].max())],
        "span": span_text(span),
        "mean": _num(stats["mean"]) if stats["n"] else None,
        "ci_low": _num(stats["ci_low"]),
        "ci_high": _num(stats["ci_high"]),
        "n": stats["n"],
        "unit": "encoder" if clustered(areas) else "seed",
        "per_seed": {
            str(int(s)): float(v) for s, v in zip(areas["seed"], areas["aubc"], strict=True)
        },
    }


def summary(df: pd.DataFrame, dataset: str | None = None) -> dict:
    """Per-method summary of one dataset, in the metric's own scale [0, 1].

    Returns ``{"dataset", "metric", "synthetic_standin", "n_seeds", "precision" (what
    the models were trained at; null when the records do not say), "encoders"
    (``encoders_of``), "methods": {method:
    {"auc", "final_mean", "final_std", "final_round", "final_n_labeled", "final_ratio",
    "n_seeds", "n_rounds", "partial_rounds"}}}``. ``auc`` is ``curve_area`` of the mean
    curve (mean over the seeds present at each round); ``final_*`` describe the last
    round; ``partial_rounds`` lists rounds with fewer seeds than the method has; a
    std over one seed is null. ``aubc`` is the per-seed area under the budget curve
    (``spl_al.report.stats.aubc_per_seed``): its mean, 95% t-interval (null for one
    unit) and n over its units (``unit``: seeds, or encoders where the runs read
    several: ``spl_al.report.stats.unit_means``), the value of each seed, and the
    ``rounds`` [first, last] and ``span`` (rounds and ratios in words) it covers. ``auc``
    and ``aubc`` cover the query rounds (>= 1) of the method: round 0 holds the same
    labels for every method.
    """
    d = one_dataset(df, dataset)
    curves = method_curves(d)
    methods = {}
    for method in ordered_methods(d["method"]):
        c = curves[curves["method"] == method].sort_values("round")
        mine = query_rounds(d[d["method"] == method])
        n_seeds = int(d.loc[d["method"] == method, "seed"].nunique())
        last = c.iloc[-1]
        queried = c[c["round"].isin(mine["round"].unique())]
        methods[method] = {
            "auc": curve_area(queried["ratio"], queried["mean"]),
            "final_mean": _num(last["mean"]),
            "final_std": _num(last["std"]),
            "final_round": int(last["round"]),
            "final_n_labeled": int(last["n_labeled"]),
            "final_ratio": float(last["ratio"]),
            "n_seeds": n_seeds,
            "n_rounds": len(c),
            "partial_rounds": [int(r) for r in c.loc[c["n_seeds"] < n_seeds, "round"]],
            "aubc": _aubc(aubc_per_seed(mine), mine),
        }
    return {
        "dataset": str(d["dataset"].iloc[0]),
        "metric": str(d["metric"].iloc[0]),
        "synthetic_standin": bool(d["synthetic_standin"].any()),
        "n_seeds": int(d["seed"].nunique()),
        "precision": trained_at(d) or None,
        "encoders": encoders_of(d),
        "methods": methods,
    }


def encoders_of(d: pd.DataFrame) -> list[dict]:
    """The encoders the records' runs read (embedding framework; [] elsewhere): each
    one's seed, health and run seeds."""
    if "encoder" not in d or not (d["encoder"] >= 0).any():
        return []
    out = []
    for seed, part in d[d["encoder"] >= 0].groupby("encoder", sort=True):
        out.append(
            {
                "seed": int(seed),
                "health": str(part["encoder_health"].iloc[0] or "healthy"),
                "run_seeds": sorted(int(s) for s in part["seed"].unique()),
            }
        )
    return out


def aubc_text(summary: dict, method: str, scale: float = 100.0) -> str:
    """A method's AUBC in a summary (``summary``'s JSON) as a page quotes it:
    "mean [95% low, high]" times ``scale``, the mean alone without an interval, "-"
    for a method without one."""
    entry = summary.get("methods", {}).get(method, {}).get("aubc")
    if not entry or entry.get("mean") is None:
        return "-"

    def number(key) -> float:
        try:
            return float(entry.get(key)) * scale
        except (TypeError, ValueError):
            return math.nan

    mean, low, high = number("mean"), number("ci_low"), number("ci_high")
    if math.isnan(low) or math.isnan(high):
        return f"{mean:.1f}"
    return f"{mean:.1f} [{low:.1f}, {high:.1f}]"
