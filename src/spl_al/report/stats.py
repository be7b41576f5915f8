"""Paired statistics over seeds: sign-flip test, t-interval, rule, Holm, power, AUBC.

Every method at a seed starts from the same round-0 set and the same training seeds,
so two methods are compared *per seed*: d_s = x_A,s - x_B,s over the seeds both have.

- **Test**: the exact two-sided sign-flip (paired permutation) test of "mean d = 0".
  Under the null each d_s is as likely to be +|d_s| as -|d_s|; the p-value is the share
  of all 2^n sign vectors whose |mean| is at least the observed one. It needs no
  normality, which a handful of seeds cannot check. Its smallest attainable p is 2 / 2^n
  (0.25 at n = 3, 0.0625 at n = 5, 0.03125 at n = 6), reached exactly when every seed
  agrees in direction.
- **Interval**: the 95% t-interval of the mean paired difference,
  mean(d) +- t_{0.975, n-1} sd(d) / sqrt(n). It is the interval a reader expects and
  it widens honestly with few seeds (t_{0.975, 2} = 4.30); it leans on normality of d.
- **Rule** (``resolved``): the t-interval excludes zero *and* the sign-flip p is
  significant, with one of two bars (``rule_name`` says which applies):

  - "5%" rule, n >= ``seeds_for_level()`` = 6 seeds: p <= ``LEVEL`` (0.05), i.e.
    significance at 5%;
  - "small-n" rule, ``MIN_SEEDS`` (3) <= n < 6: no test on n seeds can reach 0.05, so
    the bar is the strongest evidence n seeds can give, p = 2 / 2^n: every seed agrees
    in direction. A result resolved this way is weaker than 5% significance, and
    tables and claims say so. Fewer than 3 seeds never resolve.

- **Holm** (``holm``): step-down adjusted p-values of a family of m tests. With
  p_(1) <= ... <= p_(m) sorted, p~_(i) = min(1, max_{j <= i} (m - j + 1) p_(j));
  rejecting p~ <= 0.05 controls the family-wise error at 5%. The claims use it for
  "contradicted" (one comparison against, out of many).
- **Power** (``seeds_needed``): how many seeds a paired difference with mean delta and
  sd sigma would need to be resolved at 5%: the smallest n >= 6 (the fewest seeds whose
  sign-flip test can reach 0.05) whose two-sided paired t-test at 0.05 has power >= 80%,
  power(n) = 1 - F(c; n - 1, lambda) + F(-c; n - 1, lambda) with c = t_{0.975, n-1},
  lambda = sqrt(n) |delta| / sigma and F the noncentral t CDF (``scipy.stats.nct``).
  Capped at ``MAX_SEEDS_NEEDED`` (100; more is reported as ">100"); a zero or undefined
  effect (delta = 0, or sigma undefined with fewer than 2 seeds) has none ("-"). The t
  test stands in for the sign-flip test, whose discrete p-values make it somewhat less
  powerful at the smallest n (at n = 6 it needs every seed to agree), and the observed
  delta and sigma are themselves noisy: the number is a guide (no effect vs. too few
  seeds), not a guarantee.
- **AUBC** (``curve_area``, ``aubc``): area under a budget curve over its ratio span,
  trapz(values, ratio) / (ratio_max - ratio_min); ``summary`` imports it from here.
- **Encoders as the unit** (``unit_means``): in the embedding framework every run seed
  reads one of K self-supervised encoders (``spl_al.experiment.encoders``), and a
  rerun draws the encoders again. Seeds sharing an encoder are not independent draws,
  so where every value names its encoder (column ``encoder`` >= 0) each method's
  values are first averaged within each encoder, and the K encoder means are the
  units of everything above: the paired differences, the t-interval (K - 1 degrees of
  freedom), the exact sign-flip p over the 2^K sign patterns, the rules and the units
  needed (then encoders, not seeds). ``pairwise`` also reports the variance of the
  paired difference between encoders (of the K means) and within them (pooled over the
  seeds of each).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

LEVEL = 0.05
"""Two-sided level of the test; the interval is at 1 - LEVEL (95%)."""

MIN_SEEDS = 3
"""Fewest paired seeds for any difference to count as resolved."""

POWER = 0.8
"""Target power of ``seeds_needed``."""

MAX_SEEDS_NEEDED = 100
"""``seeds_needed`` searches n up to this; beyond, the effect is reported as ">100"."""

MAX_EXACT_SEEDS = 40
"""Up to this many seeds the sign-flip p is exact (two halves of at most 2^20 sums);
beyond, it is estimated from ``MONTE_CARLO_DRAWS`` seeded random sign vectors."""

MONTE_CARLO_DRAWS = 2**20

# Relative tolerance when comparing permuted statistics with the observed one, so that
# a sign vector giving the same |mean| up to rounding counts as "as extreme".
_TIE_RTOL = 1e-9


def min_p_value(n: int) -> float:
    """Smallest two-sided p-value the exact sign-flip test can give on n nonzero pairs."""
    return 1.0 if n < 1 else 2.0 / 2.0**n


def seeds_for_level(level: float = LEVEL) -> int:
    """Fewest seeds whose sign-flip test can reach ``level`` (6 for 0.05)."""
    return max(1, math.ceil(1 + math.log2(1 / level)))


def units_for_family(m: int, level: float = LEVEL) -> int:
    """Fewest units at which Holm over m comparisons can reject at all: the exact
    sign-flip test's smallest p, 2/2^K, must reach Holm's first bar, level / m, so
    K >= 1 + log2(m / level) (6 for one comparison, 10 for 15, 11 for 30)."""
    return seeds_for_level(level / max(int(m), 1))


def _signed_sums(d: np.ndarray) -> np.ndarray:
    """(2^k,) sums sum_i eps_i d_i over every sign vector eps of the k values ``d``."""
    sums = np.zeros(1)
    for x in d:
        sums = np.concatenate([sums + x, sums - x])
    return sums


def sign_flip_p(d) -> float:
    """Two-sided sign-flip p-value of paired differences ``d`` (1-D).

    p = #{eps in {-1, +1}^n : |sum(eps * d)| >= |sum(d)|} / 2^n, counted exactly up to
    ``MAX_EXACT_SEEDS`` values: the sums of the first half's 2^(n/2) sign vectors are
    paired with the sorted sums of the second half's (meet in the middle), so n = 40
    needs two arrays of 2^20, not 2^40 rows. Beyond, the share among
    ``MONTE_CARLO_DRAWS`` random sign vectors (seeded: the same d gives the same p),
    as (1 + hits) / (1 + draws). All-zero differences give 1; an empty array gives NaN.
    """
    d = np.asarray(d, dtype=float).ravel()
    n = d.size
    if n == 0:
        return math.nan
    # a sign vector whose |sum| equals the observed one up to rounding counts as extreme
    bar = abs(d.sum()) * (1 - _TIE_RTOL) - 1e-15
    if bar <= 0:
        return 1.0
    if n > MAX_EXACT_SEEDS:
        return float(_monte_carlo_p(d[None, :])[0])
    first = _signed_sums(d[: n // 2])
    second = np.sort(_signed_sums(d[n // 2 :]))
    at_least = second.size - np.searchsorted(second, bar - first, side="left")
    at_most = np.searchsorted(second, -bar - first, side="right")
    return float((at_least.sum() + at_most.sum()) / 2.0**n)


def t_interval(d, level: float = LEVEL) -> tuple[float, float]:
    """(low, high) of the 1 - level t-interval of mean(d); NaN for fewer than 2 values."""
    d = np.asarray(d, dtype=float).ravel()
    n = d.size
    if n < 2:
        return math.nan, math.nan
    # scipy.stats takes 0.7 s to import, and parsing the workflow imports this module
    from scipy.stats import t as student_t

    half = student_t.ppf(1 - level / 2, n - 1) * d.std(ddof=1) / math.sqrt(n)
    return float(d.mean() - half), float(d.mean() + half)


def _monte_carlo_p(d: np.ndarray) -> np.ndarray:
    """``sign_flip_p`` beyond ``MAX_EXACT_SEEDS`` of each row of ``d`` (k, n): the
    share among ``MONTE_CARLO_DRAWS`` random sign vectors, the same vectors for every
    row (seed 0), so many rows cost one pass of draws (``sign_flip_ps``)."""
    total = d.sum(axis=1)
    bar = np.abs(total) * (1 - _TIE_RTOL) - 1e-15
    rng = np.random.default_rng(0)
    hits = np.zeros(len(d), dtype=np.int64)
    n = d.shape[1]
    for _ in range(MONTE_CARLO_DRAWS // 2**14):
        # random bits b, signs 1 - 2b: sum(signs * d) = sum(d) - 2 b.d (bytes of random
        # bits unpacked: 10x faster than drawing an integer per sign)
        packed = rng.integers(0, 256, size=(2**14, (n + 7) // 8), dtype=np.uint8)
        bits = np.unpackbits(packed, axis=1, count=n).astype(np.float64)
        hits += np.count_nonzero(np.abs(total - 2 * (bits @ d.T)) >= bar, axis=0)
    p = (1 + hits) / (1 + MONTE_CARLO_DRAWS)
    return np.where(bar <= 0, 1.0, p)


def sign_flip_ps(ds: list[np.ndarray]) -> list[float]:
    """``sign_flip_p`` of each array of ``ds``, those of one length beyond
    ``MAX_EXACT_SEEDS`` in one pass of Monte Carlo draws (the same values)."""
    out: list[float] = [math.nan] * len(ds)
    by_length: dict[int, list[int]] = {}
    for i, d in enumerate(ds):
        d = np.asarray(d, dtype=float).ravel()
        if d.size > MAX_EXACT_SEEDS:
            by_length.setdefault(d.size, []).append(i)
        else:
            out[i] = sign_flip_p(d)
    for rows in by_length.values():
        stacked = np.stack([np.asarray(ds[i], dtype=float).ravel() for i in rows])
        for i, p in zip(rows, _monte_carlo_p(stacked), strict=True):
            out[i] = float(p)
    return out


def rule_name(n: int, level: float = LEVEL) -> str:
    """Which resolution rule applies at n paired seeds: "5%" (n >= 6 for 0.05) or "small-n"."""
    return f"{100 * level:g}%" if n >= seeds_for_level(level) else "small-n"


def significant(p: float, n: int, level: float = LEVEL) -> bool:
    """The sign-flip bar of the rule: p <= level from n >= 6 seeds (for 0.05), else
    p <= 2 / 2^n (every seed agrees); never with fewer than ``MIN_SEEDS`` seeds."""
    bar = level if n >= seeds_for_level(level) else min_p_value(n)
    return bool(n >= MIN_SEEDS and p <= bar * (1 + _TIE_RTOL))


def paired_test(a, b, level: float = LEVEL, *, p: float | None = None) -> dict:
    """Paired comparison of A and B over the seeds where both have a finite value.

    ``a``, ``b``: (n,) values of the same seeds in the same order (NaN = missing).
    Returns n, mean_a, mean_b, diff (mean of d = a - b), sd_diff (sd of d, ddof 1),
    ci_low, ci_high, p_value, p_min, rule (``rule_name``), resolved (``significant``
    and an interval that excludes zero) and direction (+1 A better, -1 B better, 0
    unresolved). ``p``: the sign-flip p of the finite pairs' differences, when computed
    already (``sign_flip_ps``).
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
    p = sign_flip_p(d) if p is None else p
    resolved = significant(p, n, level) and bool(low > 0 or high < 0)
    mean = float(d.mean()) if n else math.nan
    return {
        "n": n,
        "mean_a": float(a.mean()) if n else math.nan,
        "mean_b": float(b.mean()) if n else math.nan,
        "diff": mean,
        "sd_diff": float(d.std(ddof=1)) if n > 1 else math.nan,
        "ci_low": low,
        "ci_high": high,
        "p_value": p,
        "p_min": min_p_value(n),
        "rule": rule_name(n, level),
        "resolved": resolved,
        "direction": int(np.sign(mean)) if resolved else 0,
    }


def rule_text(level: float = LEVEL, unit: str = "seed") -> str:
    """The decision rule in one sentence (tables, claims and the README quote it);
    ``unit``: what n counts, "seed" or "encoder" (``unit_means``)."""
    n6 = seeds_for_level(level)
    units = f"{unit}s"
    return (
        f"a paired difference is resolved when its {100 * (1 - level):.0f}% t-interval "
        f"excludes zero and its exact sign-flip p is significant: from n = {n6} {units} "
        f"p <= {level:g} (significance at {100 * level:g}%); with {MIN_SEEDS} to {n6 - 1} "
        f"{units}, where no test can reach {level:g}, p = 2/2^n (0.25 at n = 3), i.e. every "
        f"{unit} agrees in direction, weaker than significance at {level:g}; fewer than "
        f"{MIN_SEEDS} {units} never resolve"
    )


# ---------------------------------------------------------------- many tests, power


def holm(p) -> np.ndarray:
    """Holm's step-down adjusted p-values, in the input order.

    With the m p-values sorted, p_(1) <= ... <= p_(m):
    p~_(i) = min(1, max_{j <= i} (m - j + 1) p_(j)). A NaN counts in m and stays NaN.
    """
    p = np.asarray(p, dtype=float).ravel()
    m = p.size
    filled = np.where(np.isnan(p), 1.0, p)
    order = np.argsort(filled, kind="stable")
    adjusted = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * filled[order]))
    out = np.empty(m)
    out[order] = adjusted
    out[np.isnan(p)] = math.nan
    return out


def t_power(n, effect: float, level: float = LEVEL) -> np.ndarray:
    """Power of the two-sided paired t-test at ``level`` on n pairs (array-like).

    ``effect`` = delta / sigma. power = 1 - F(c; n-1, lam) + F(-c; n-1, lam) with
    c = t_{1-level/2, n-1}, lam = sqrt(n) |effect| and F the noncentral t CDF.
    """
    n = np.asarray(n, dtype=float)
    # scipy.stats takes 0.7 s to import, and parsing the workflow imports this module
    from scipy.stats import nct
    from scipy.stats import t as student_t

    c = student_t.ppf(1 - level / 2, n - 1)
    lam = np.sqrt(n) * abs(effect)
    return 1 - nct.cdf(c, n - 1, lam) + nct.cdf(-c, n - 1, lam)


def seeds_needed(
    diff: float,
    sd: float,
    *,
    level: float = LEVEL,
    power: float = POWER,
    cap: int = MAX_SEEDS_NEEDED,
) -> float:
    """Seeds a paired difference (mean ``diff``, sd ``sd``) needs to be resolved at ``level``.

    The smallest n in [seeds_for_level(level), cap] with ``t_power(n, diff / sd)`` >=
    ``power``; ``math.inf`` when no n up to ``cap`` is enough; NaN when the effect is
    zero or undefined (diff 0 or NaN, sd NaN). sd = 0 with diff != 0 gives the floor.
    """
    floor = seeds_for_level(level)
    if not (math.isfinite(diff) and math.isfinite(sd)) or diff == 0:
        return math.nan
    if sd == 0:
        return float(floor)
    ns = np.arange(floor, max(floor, cap) + 1)
    enough = t_power(ns, diff / sd, level) >= power
    return float(ns[np.argmax(enough)]) if enough.any() else math.inf


def format_seeds_needed(n: float, cap: int = MAX_SEEDS_NEEDED) -> str:
    """``seeds_needed`` for a table: "12", ">100" above the cap, "-" for no effect."""
    if math.isnan(n):
        return "-"
    return f">{cap}" if math.isinf(n) else str(int(n))


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
    method, seed, aubc, n_rounds, ratio_min, ratio_max, encoder (-1: none).
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
                "encoder": int(g["encoder"].iloc[0]) if "encoder" in g else -1,
            }
        )
    cols = ["method", "seed", "aubc", "n_rounds", "ratio_min", "ratio_max", "encoder"]
    return pd.DataFrame(rows, columns=cols)


def query_rounds(df: pd.DataFrame, n_rounds: int | None = None) -> pd.DataFrame:
    """The records of the query rounds: rounds >= 1 (and < ``n_rounds`` when given).

    Round 0 holds the same labels for every method of a seed, chosen before any query,
    so an area or a claim about acquisition counts rounds >= 1 only. A frame without
    a round >= 1 is returned as it is (its area is then round 0's own value).
    """
    keep = df["round"] >= 1
    if n_rounds is not None:
        keep &= df["round"] < int(n_rounds)
    return df[keep] if keep.any() else df


def span_text(df: pd.DataFrame) -> str:
    """The rounds and labeling ratios a records frame covers: 'rounds 1-3 (3.6-7.3%)'."""
    if df.empty:
        return ""
    lo, hi = int(df["round"].min()), int(df["round"].max())
    r_lo = 100 * float(df.loc[df["round"] == lo, "ratio"].mean())
    r_hi = 100 * float(df.loc[df["round"] == hi, "ratio"].mean())
    if lo == hi:
        return f"round {lo} ({r_lo:.1f}%)"
    return f"rounds {lo}-{hi} ({r_lo:.1f}-{r_hi:.1f}%)"


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


def values_of(records: pd.DataFrame, value_col: str = "value") -> pd.DataFrame:
    """Columns method, seed, value (from ``value_col``) and encoder (-1 where the
    records name none) of some records: what the functions below compare."""
    encoder = records.get("encoder", -1)
    return pd.DataFrame(
        {
            "method": records["method"],
            "seed": records["seed"],
            "value": records[value_col],
            "encoder": encoder,
        }
    )


def clustered(values: pd.DataFrame) -> bool:
    """Whether every row of ``values`` names the encoder its seed read (column
    ``encoder`` >= 0): then the encoders are the units of replication."""
    return "encoder" in values.columns and not values.empty and bool((values["encoder"] >= 0).all())


def unit_means(values: pd.DataFrame) -> pd.DataFrame:
    """``values`` (method, seed, value[, encoder]) at its unit of replication, as
    columns method, seed, value: where ``clustered``, each method's mean over the seeds
    of each encoder, the encoder's seed standing in the column ``seed``; else as given."""
    if not clustered(values):
        return values[["method", "seed", "value"]]
    means = values.groupby(["method", "encoder"], sort=True)["value"].mean().reset_index()
    return means.rename(columns={"encoder": "seed"})


def seed_matrix(values: pd.DataFrame, methods) -> pd.DataFrame:
    """Units x methods of a frame with columns method, seed, value (NaN where missing):
    seeds, or encoders where the frame names them (``unit_means``)."""
    units = unit_means(values)
    wide = units.pivot_table(index="seed", columns="method", values="value", aggfunc="first")
    return wide.reindex(columns=list(methods))


def _variance_parts(by_seed: pd.DataFrame, encoder: pd.Series | None, a: str, b: str) -> dict:
    """Seeds behind the units of A - B, and (``encoder``: seed -> encoder, clustered)
    the variance of the difference between the encoders' means and within an encoder
    (pooled over the encoders). ``by_seed``: seeds x methods."""
    d = (by_seed[a] - by_seed[b]).dropna()
    out = {"n_seeds": int(d.size), "var_between": math.nan, "var_within": math.nan}
    if encoder is not None and d.size:
        by = d.groupby(encoder.reindex(d.index))
        if by.ngroups > 1:
            out["var_between"] = float(by.mean().var(ddof=1))
        within = by.var(ddof=1).dropna()
        if not within.empty:
            out["var_within"] = float(within.mean())
    return out


def pairwise(values: pd.DataFrame, methods, level: float = LEVEL) -> pd.DataFrame:
    """Paired test of every pair of ``methods`` at one point (a round, a level, AUBC).

    ``values``: columns method, seed, value (and ``encoder``: ``unit_means``). Pairs
    are (A, B) with A after B in ``methods`` (so with DUIS last, every difference is
    DUIS minus a baseline). Returns one row per pair: method_a, method_b,
    ``paired_test``'s fields over the units, unit ("seed" or "encoder"), n_seeds,
    var_between and var_within (``_variance_parts``; NaN unless clustered).
    """
    wide = seed_matrix(values, methods)
    methods = list(wide.columns)
    unit = "encoder" if clustered(values) else "seed"
    pairs = [(a, b) for i, a in enumerate(methods) for b in methods[:i]]
    diffs = []
    for a, b in pairs:
        d = wide[a].to_numpy(float) - wide[b].to_numpy(float)
        diffs.append(d[np.isfinite(d)])
    ps = sign_flip_ps(diffs)  # beyond 40 units, one pass of draws for every pair
    # the seed-level matrix once for every pair's variance parts
    by_seed = values.pivot_table(index="seed", columns="method", values="value", aggfunc="first")
    encoder = values.groupby("seed")["encoder"].first() if unit == "encoder" else None
    rows = [
        {
            "method_a": a,
            "method_b": b,
            **paired_test(wide[a], wide[b], level, p=p),
            "unit": unit,
            **_variance_parts(by_seed, encoder, a, b),
        }
        for (a, b), p in zip(pairs, ps, strict=True)
    ]
    return pd.DataFrame(rows)


def leader_test(values: pd.DataFrame, level: float = LEVEL) -> dict | None:
    """The highest mean of one table column against the runner-up.

    ``values``: columns method, seed, value of the methods competing in the column.
    Returns None with fewer than two methods holding a value, else leader, runner_up
    and ``paired_test`` (leader minus runner-up).
    """
    means = unit_means(values.dropna(subset=["value"])).groupby("method")["value"].mean()
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
