"""Statistics over seeds: the mean curve of each method and its spread.

Every statistic is over the seeds present: a round that some seed lacks is averaged
over the others, and ``n_seeds`` says how many went in. The spread is the sample
standard deviation (ddof = 1), NaN for a single seed.
"""

from __future__ import annotations

import pandas as pd


def seed_stats(df: pd.DataFrame, keys: list[str], value_col: str = "value") -> pd.DataFrame:
    """Mean, sample std and number of seeds of ``value_col`` per group of ``keys``.

    Rows with NaN in ``value_col`` (a level missing from a record) are left out.
    Returns one row per group: ``keys`` + mean, std, n_seeds, ratio (mean labeling
    ratio), n_labeled_min, n_labeled_max.
    """
    sub = df[df[value_col].notna()]
    if sub.empty:
        cols = [*keys, "mean", "std", "n_seeds", "ratio", "n_labeled_min", "n_labeled_max"]
        return pd.DataFrame(columns=cols)
    return (
        sub.groupby(keys, sort=True)
        .agg(
            mean=(value_col, "mean"),
            std=(value_col, "std"),
            n_seeds=("seed", "nunique"),
            ratio=("ratio", "mean"),
            n_labeled_min=("n_labeled", "min"),
            n_labeled_max=("n_labeled", "max"),
        )
        .reset_index()
    )


def method_curves(df: pd.DataFrame, value_col: str = "value") -> pd.DataFrame:
    """Mean curve of each method over rounds: method, round, n_labeled, ratio, mean, std, n_seeds.

    Raises ValueError when the seeds of a method disagree on n_labeled at a round,
    which breaks the premise that a round is one labeling budget.
    """
    stats = seed_stats(df, ["method", "round"], value_col)
    bad = stats[stats["n_labeled_min"] != stats["n_labeled_max"]]
    if not bad.empty:
        row = bad.iloc[0]
        raise ValueError(
            f"method {row['method']!r} has n_labeled from {row['n_labeled_min']} to "
            f"{row['n_labeled_max']} at round {row['round']}; every seed of a round must "
            "label the same number of samples."
        )
    stats = stats.rename(columns={"n_labeled_min": "n_labeled"}).drop(columns="n_labeled_max")
    return stats[["method", "round", "n_labeled", "ratio", "mean", "std", "n_seeds"]]
