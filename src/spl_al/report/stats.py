"""Paired statistics over seeds: exact sign-flip test, t-interval, AUBC, the decision rule.

Every method at a seed starts from the same round-0 set and the same training seeds,
so two methods are compared *per seed*: d_s = x_A,s - x_B,s over the seeds both have.

- **Test**: the exact two-sided sign-flip (paired permutation) test of "mean d = 0".
  Under the null each d_s is as likely to be +|d_s| as -|d_s|; the p-value is the share
  of all 2^n sign vectors whose |mean| is at least the observed one. It needs no
  normality, which n = 3 seeds cannot check. Its smallest attainable p is 2 / 2^n
  (0.25 at n = 3, 0.0625 at n = 5, 0.03125 at n = 6), reached exactly when every seed
  agrees in direction.
- **Interval**: the 95% t-interval of the mean paired difference,
  mean(d) +- t_{0.975, n-1} sd(d) / sqrt(n). It is the interval a reader expects and
  it widens honestly with few seeds (t_{0.975, 2} = 4.30); it leans on normality of d.
- **Rule** (``resolved``): a difference is resolved when n >= ``MIN_SEEDS`` (3), the
  t-interval excludes zero, and the sign-flip p is <= max(``LEVEL``, 2 / 2^n). From
  n = 6 seeds that is p <= 0.05 (significance at 5%); below, where no test on n seeds
  can reach 0.05, it asks for the strongest evidence n seeds can give: every seed
  agrees in direction *and* the interval excludes zero. A result resolved with n < 6
  is therefore weaker than 5% significance, and tables and claims say so.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.stats import t as student_t

LEVEL = 0.05
"""Two-sided level of the test; the interval is at 1 - LEVEL (95%)."""

MIN_SEEDS = 3
"""Fewest paired seeds for any difference to count as resolved."""

MAX_EXACT_SEEDS = 20
"""The sign-flip test enumerates 2^n sign vectors; beyond this it would be slow."""

# Relative tolerance when comparing permuted statistics with the observed one, so that
# a sign vector giving the same |mean| up to rounding counts as "as extreme".
_TIE_RTOL = 1e-9


def min_p_value(n: int) -> float:
    """Smallest two-sided p-value the exact sign-flip test can give on n nonzero pairs."""
    return 1.0 if n < 1 else 2.0 / 2.0**n


def seeds_for_level(level: float = LEVEL) -> int:
    """Fewest seeds whose sign-flip test can reach ``level`` (6 for 0.05)."""
    return max(1, math.ceil(1 + math.log2(1 / level)))


def sign_flip_p(d) -> float:
    """Exact two-sided sign-flip p-value of paired differences ``d`` (1-D, n <= 20).

    p = #{eps in {-1, +1}^n : |mean(eps * d)| >= |mean(d)|} / 2^n. All-zero
    differences give 1; an empty array gives NaN.
    """
    d = np.asarray(d, dtype=float).ravel()
    n = d.size
    if n == 0:
        return math.nan
    if n > MAX_EXACT_SEEDS:
        raise ValueError(f"sign_flip_p enumerates 2^n sign vectors; n = {n} > {MAX_EXACT_SEEDS}.")
    bits = (np.arange(2**n)[:, None] >> np.arange(n)) & 1  # (2^n, n) of 0/1
    signs = 1 - 2 * bits  # +1 / -1
    stats = np.abs(signs @ d)
    observed = abs(d.sum())
    return float(np.mean(stats >= observed * (1 - _TIE_RTOL) - 1e-15))


def t_interval(d, level: float = LEVEL) -> tuple[float, float]:
    """(low, high) of the 1 - level t-interval of mean(d); NaN for fewer than 2 values."""
    d = np.asarray(d, dtype=float).ravel()
    n = d.size
    if n < 2:
        return math.nan, math.nan
    half = student_t.ppf(1 - level / 2, n - 1) * d.std(ddof=1) / math.sqrt(n)
    return float(d.mean() - half), float(d.mean() + half)


def paired_test(a, b, level: float = LEVEL) -> dict:
    """Paired comparison of A and B over the seeds where both have a finite value.

    ``a``, ``b``: (n,) values of the same seeds in the same order (NaN = missing).
    Returns n, mean_a, mean_b, diff (mean of a - b), ci_low, ci_high, p_value, p_min,
    resolved (the module's rule) and direction (+1 A better, -1 B better, 0 unresolved).
    """
    a = np.asarray(a, dtype=float).ravel()
    b = np.asarray(b, dtype=float).ravel()
    if a.shape != b.shape:
        raise ValueError(f"a and b must hold the same seeds; got shapes {a.shape} and {b.shape}.")
    keep = np.isfinite(a) & np.isfinite(b)
    a, b = a[keep], b[keep]
    d = a - b
    n = int(d.size)
    low, high = t_interval(d, level)
    p = sign_flip_p(d)
    p_min = min_p_value(n)
    resolved = bool(
        n >= MIN_SEEDS and p <= max(level, p_min) * (1 + _TIE_RTOL) and (low > 0 or high < 0)
    )
    mean = float(d.mean()) if n else math.nan
    return {
        "n": n,
        "mean_a": float(a.mean()) if n else math.nan,
        "mean_b": float(b.mean()) if n else math.nan,
        "diff": mean,
        "ci_low": low,
        "ci_high": high,
        "p_value": p,
        "p_min": p_min,
        "resolved": resolved,
        "direction": int(np.sign(mean)) if resolved else 0,
    }


def rule_text(level: float = LEVEL) -> str:
    """The decision rule in one sentence (tables, claims and the README quote it)."""
    n6 = seeds_for_level(level)
    return (
        f"a paired difference is resolved when at least {MIN_SEEDS} seeds pair up, its "
        f"{100 * (1 - level):.0f}% t-interval excludes zero and its exact sign-flip p is "
        f"<= max({level:g}, 2/2^n); below n = {n6} seeds (smallest p = 2/2^n, 0.25 at n = 3) "
        "that means every seed agrees in direction, weaker than significance at "
        f"{level:g}"
    )


# ---------------------------------------------------------------- AUBC


def curve_area(ratio, mean) -> float:
    """Normalised area under a budget curve, a mean metric over the ratio span.

    AUC = trapz(mean, ratio) / (ratio[-1] - ratio[0]) with ratios sorted ascending;
    a single point (zero span) gives its own value. ``ratio``, ``mean``: (R,) arrays.
    """
    ratio = np.asarray(ratio, dtype=float)
    mean = np.asarray(mean, dtype=float)
    if ratio.shape != mean.shape or ratio.ndim != 1 or ratio.size == 0:
        raise ValueError(
            f"ratio and mean must be 1-D arrays of one equal, non-zero length; "
            f"got shapes {ratio.shape} and {mean.shape}."
        )
    order = np.argsort(ratio, kind="stable")
    ratio, mean = ratio[order], mean[order]
    span = ratio[-1] - ratio[0]
    if span <= 0:
        return float(mean.mean())
    # Trapezoid rule written out: np.trapezoid needs numpy >= 2, the project allows 1.26.
    area = np.sum(0.5 * (mean[1:] + mean[:-1]) * np.diff(ratio))
    return float(area / span)


def aubc(ratio, values) -> float:
    """Area under one seed's budget curve normalised to the budget range (a mean metric):
    ``curve_area`` of that seed's values."""
    return curve_area(ratio, values)


def aubc_per_seed(df: pd.DataFrame, value_col: str = "value") -> pd.DataFrame:
    """AUBC of every (method, seed) curve of a records frame.

    A seed's curve counts only when it has every round its method has (a shorter
    curve spans another budget range and would not compare). Returns columns
    method, seed, aubc, n_rounds, ratio_min, ratio_max.
    """
    sub = df[df[value_col].notna()]
    rounds_of = sub.groupby("method")["round"].nunique()
    rows = []
    for (method, seed), g in sub.groupby(["method", "seed"], sort=True):
        if g["round"].nunique() < rounds_of[method]:
            continue
        rows.append(
            {
                "method": method,
                "seed": int(seed),
                "aubc": aubc(g["ratio"].to_numpy(), g[value_col].to_numpy()),
                "n_rounds": int(g["round"].nunique()),
                "ratio_min": float(g["ratio"].min()),
                "ratio_max": float(g["ratio"].max()),
            }
        )
    cols = ["method", "seed", "aubc", "n_rounds", "ratio_min", "ratio_max"]
    return pd.DataFrame(rows, columns=cols)


def mean_interval(values, level: float = LEVEL) -> dict:
    """Mean of one method's per-seed values with its t-interval: mean, ci_low, ci_high, n."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    low, high = t_interval(v, level)
    return {
        "mean": float(v.mean()) if v.size else math.nan,
        "ci_low": low,
        "ci_high": high,
        "n": int(v.size),
    }


# ---------------------------------------------------------------- many methods at one point


def seed_matrix(values: pd.DataFrame, methods) -> pd.DataFrame:
    """Seeds x methods of a frame with columns method, seed, value (NaN where missing)."""
    wide = values.pivot_table(index="seed", columns="method", values="value", aggfunc="first")
    return wide.reindex(columns=list(methods))


def pairwise(values: pd.DataFrame, methods, level: float = LEVEL) -> pd.DataFrame:
    """Paired test of every pair of ``methods`` at one point (a round, a level, AUBC).

    ``values``: columns method, seed, value. Pairs are (A, B) with A after B in
    ``methods`` (so with DUIS last, every difference is DUIS minus a baseline).
    Returns one row per pair: method_a, method_b and ``paired_test``'s fields.
    """
    wide = seed_matrix(values, methods)
    methods = list(wide.columns)
    rows = []
    for i, a in enumerate(methods):
        for b in methods[:i]:
            rows.append({"method_a": a, "method_b": b, **paired_test(wide[a], wide[b], level)})
    return pd.DataFrame(rows)


def leader_test(values: pd.DataFrame, level: float = LEVEL) -> dict | None:
    """The highest mean of one table column against the runner-up.

    ``values``: columns method, seed, value of the methods competing in the column.
    Returns None with fewer than two methods holding a value, else leader, runner_up
    and ``paired_test`` (leader minus runner-up).
    """
    means = values.dropna(subset=["value"]).groupby("method")["value"].mean()
    if len(means) < 2:
        return None
    top = means.sort_values(ascending=False, kind="stable")
    leader, runner_up = top.index[0], top.index[1]
    wide = seed_matrix(values, [leader, runner_up])
    return {
        "leader": leader,
        "runner_up": runner_up,
        **paired_test(wide[leader], wide[runner_up], level),
    }
