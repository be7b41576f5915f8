"""The paper's claims and this project's extensions, checked against one dataset's
paired comparisons.

Which claims there are, and whom each compares DUIS with, is declared before any run
in ``spl_al.report.claim_registry``: "as the paper compares" is DUIS against the
paper's five baselines trained on observed images, "matched training" against their
twins Syn+X trained on the variants like DUIS (the comparison varies the acquisition
alone), and the low-budget baselines and DropQuery each have a claim of their own;
the run's ``selection`` says which members of each family it has. No claim picks a
comparator from the results, and each sentence names every comparator it tested.
Claims about acquisition count the query rounds only (rounds >= 1: round 0 holds the
same labels for every method). The additive decomposition of DUIS − Random
(``DECOMPOSITION``) gives one claim per part, named for what it tests.

Each claim is restated in one line and judged from the rows of
``spl_al.report.comparisons`` it needs, its *family* (so tables, comparisons and claims
apply one rule, ``spl_al.report.stats``). Which rule applies depends on the fewest
seeds any comparison of the family pairs up (``rule`` column):

- **"5%" rule, n >= 6 seeds.**
  *supported*: every comparison the claim needs is resolved in its favour at 5%
  (sign-flip p <= 0.05, 95% interval excluding zero). A claim that needs several
  comparisons to hold at once is an intersection-union test: each comparison at level
  0.05, no correction. *contradicted*: at least one comparison resolved against the
  claim survives Holm's step-down at 0.05 over the claim's family (adjusted p~ =
  ``stats.holm`` of the family's p-values <= 0.05, interval excluding zero): "any one
  of m comparisons against" tests m hypotheses at once, and Holm keeps the chance of a
  false contradiction at 5%.
- **"small-n" rule, 3 <= n < 6 seeds.** No test on n seeds reaches 0.05, so each
  comparison is resolved when every seed agrees and the interval excludes zero
  (weaker than 5% significance, and no test): *seeds agree (untested)* when every
  comparison is resolved in favour, *seeds against (untested)* when one is resolved
  against, without correction (Holm could never reject: its smallest p~ is
  m * 2/2^n > 0.05). Nothing below 6 seeds is called supported or contradicted.
- **inconclusive**: otherwise: too few seeds (n < 3), an interval that spans zero,
  seeds that disagree, or a comparison against that does not survive Holm.

"Not worse than" is a non-inferiority claim with margin ``MARGIN_PP`` percentage
points, one rule for every such comparison (``not_worse``): *not worse* when the 95%
interval of (A minus B) lies above -MARGIN_PP, *worse* when it lies wholly below
-MARGIN_PP, undecided otherwise (and with fewer than 3 units). "alpha = 0.5 is not
worse than its neighbours" is supported when every comparison is not worse and
contradicted when one is worse. "Grows up to a plateau" (N_cand) is judged on the
largest vs the smallest N_cand and each step between neighbouring values: supported
when the largest is resolved above the smallest and every step is not worse;
contradicted when the largest is resolved below the smallest (Holm over the family) or
a step is worse. A claim whose experiment is not configured for the dataset (or has
no records) is absent.

``seeds_needed`` (per claim): ``stats.seeds_needed`` of the comparison the claim needs
that needs the most units: the fewest units at which a paired t-test has 80% power for
the observed effect |mean d| / sd(d), at 0.05 for a comparison in the claim's favour
(at least 6 units) and at Holm's first step, 0.05 / m, for one against it (at least
``stats.units_for_family(m)``: 11 for m = 30); for non-inferiority the effect is
(mean d + MARGIN_PP) / sd(d), for N_cand the largest vs the smallest. ">100" above the
cap; "-" when a needed effect is zero or undefined (no effect to resolve, or fewer
than 2 units), which tells "no effect" from "too few units".
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from spl_al.cold_start import split_start_name
from spl_al.frameworks import (
    DEFAULT,
    framework_names,
    get_feature_space,
    get_framework,
)
from spl_al.report.claim_registry import (
    CLAIM_SPECS,
    CLAIMS,
    DROPQUERY_FAMILY,
    EXTENSION,
    FIRST_BATCH_CLAIM,
    LOW_BUDGET_FAMILY,
    PAPER,
    ClaimSpec,
    Family,
    source_of,
)
from spl_al.report.comparisons import comparison_text
from spl_al.report.decomposition import PARTS
from spl_al.report.display import ABLATION_LABELS, FULL_METHOD, METRIC_WORDS, method_label
from spl_al.report.stats import (
    LEVEL,
    MIN_SEEDS,
    format_seeds_needed,
    holm,
    rule_name,
    rule_text,
    seeds_for_level,
    seeds_needed,
    units_for_family,
)

MARGIN_PP = 1.0
"""Non-inferiority margin in percentage points of the metric."""

SUPPORTED, CONTRADICTED, INCONCLUSIVE = "supported", "contradicted", "inconclusive"
AGREE, AGAINST = "seeds agree (untested)", "seeds against (untested)"
"""The small-n rule's verdicts: below 6 seeds no test reaches 5%, so a claim whose
comparisons every seed favours is not "supported", only agreed with."""
VERDICTS = (SUPPORTED, CONTRADICTED, AGREE, AGAINST, INCONCLUSIVE)

DECOMPOSITION = PARTS

COLUMNS = (
    "claim_id",
    "claim",
    "experiment",
    "verdict",
    "reason",
    "evidence",
    "n_comparisons",
    "n_for",
    "n_against",
    "min_n",
    "rule",
    "seeds_needed",
    "methods",
    "effect_pair",
    "effect",
    "effect_low",
    "effect_high",
    "unit",
    "source",
    "dataset",
    "metric",
)


def _oriented(rows: pd.DataFrame, winner_of) -> pd.DataFrame:
    """Rows turned so that A is the side the claim says wins: diff, interval and
    direction flip sign where the claimed winner is ``method_b``. ``winner_of(row)``
    names the claimed winner of a row."""
    out = rows.copy()
    flip = np.array([winner_of(r) == r["method_b"] for _, r in rows.iterrows()], dtype=bool)
    sign = np.where(flip, -1.0, 1.0)
    out["diff"] = rows["diff"].to_numpy() * sign
    low, high = rows["ci_low"].to_numpy() * sign, rows["ci_high"].to_numpy() * sign
    out["ci_low"], out["ci_high"] = np.minimum(low, high), np.maximum(low, high)
    out["direction"] = rows["direction"].to_numpy() * sign.astype(int)
    a, b = rows["method_a"].to_numpy(), rows["method_b"].to_numpy()
    out["method_a"], out["method_b"] = np.where(flip, b, a), np.where(flip, a, b)
    for x, y in (("mean_a", "mean_b"), ("value_a", "value_b")):
        xa, yb = rows[x].to_numpy(), rows[y].to_numpy()
        out[x], out[y] = np.where(flip, yb, xa), np.where(flip, xa, yb)
    return out


def _rule(rows: pd.DataFrame) -> str:
    """The claim's rule: "5%" when every comparison pairs >= 6 seeds, else "small-n"."""
    return rule_name(int(rows["n"].min()))


def _resolved_against(rows: pd.DataFrame) -> pd.Series:
    """Oriented rows resolved against the claim, each on its own (no correction)."""
    return (rows["direction"] < 0) & rows["resolved"].astype(bool)


def _against(rows: pd.DataFrame) -> pd.Series:
    """Oriented rows against the claim that count for "contradicted".

    "5%" rule: resolved against and Holm-adjusted p~ <= LEVEL over the family ``rows``;
    "small-n" rule: resolved against (no correction; see the module docstring).
    """
    against = _resolved_against(rows)
    if _rule(rows) == "small-n":
        return against
    adjusted = pd.Series(holm(rows["p_value"]), index=rows.index)
    return against & (adjusted <= LEVEL * (1 + 1e-9))


def _seeds_needed(rows: pd.DataFrame, margin: float = 0.0) -> str:
    """``stats.seeds_needed`` of the needed comparison that needs the most units, for a
    table: effect (diff + margin) / sd_diff per row, at level 0.05 for a comparison in
    the claim's favour (intersection-union: each at 0.05) and at Holm's first step,
    0.05 / m over the claim's m comparisons, for one against it (so never fewer units
    than ``stats.units_for_family(m)``); "-" when one has no effect."""
    shifted = rows["diff"].astype(float) + margin
    if margin > 0:
        shifted = shifted.where(shifted > 0, np.nan)  # inferior beyond the margin: none
    holm_level = LEVEL / max(len(rows), 1)
    needed = [
        seeds_needed(d, sd, level=LEVEL if d > 0 else holm_level)
        for d, sd in zip(shifted, rows["sd_diff"].astype(float), strict=True)
    ]
    return format_seeds_needed(max(needed) if not np.isnan(needed).any() else np.nan)


def _reason(rows: pd.DataFrame, verdict: str) -> str:
    min_n = int(rows["n"].min())
    if verdict == SUPPORTED:
        return "every comparison resolved in favour"
    if verdict == CONTRADICTED:
        if _rule(rows) == "small-n":
            return "a comparison resolved against"
        return f"a comparison resolved against survives Holm over {len(rows)}"
    if min_n < MIN_SEEDS:
        return f"too few seeds (n = {min_n} < {MIN_SEEDS})"
    if _resolved_against(rows).any():
        return f"a comparison against does not survive Holm over {len(rows)}"
    return "an interval spans zero or the seeds disagree"


def _claim(claim_id, text, experiment, rows, verdict, *, reason=None, focus=None, seeds=None):
    """One claims row of the family ``rows``; the evidence quotes ``focus`` (default:
    the weakest comparison); ``seeds`` defaults to ``_seeds_needed(rows)``."""
    if focus is None:
        # The comparison that holds the claim back: not resolved in favour, fewest
        # seeds, lowest interval bound.
        key = rows.assign(
            _ok=(rows["direction"] > 0) & rows["resolved"],
            _low=rows["ci_low"].astype(float).fillna(-np.inf),
        )
        focus = key.sort_values(["_ok", "n", "_low"], kind="stable").iloc[0]
    n_for = int(((rows["direction"] > 0) & rows["resolved"]).sum())
    n_against = int(_resolved_against(rows).sum())
    holm_note = ""
    if n_against and _rule(rows) != "small-n":
        holm_note = f" ({int(_against(rows).sum())} after Holm)"
    point = f"{focus['point']}: " if focus.get("point") else ""
    evidence = (
        f"{n_for} of {len(rows)} comparisons resolved for, {n_against} against{holm_note}; "
        f"weakest: {point}{comparison_text(focus)}"
    )
    reason = reason or _reason(rows, verdict)
    if _rule(rows) == "small-n":
        verdict = {SUPPORTED: AGREE, CONTRADICTED: AGAINST}.get(verdict, verdict)
    return {
        "claim_id": claim_id,
        "claim": text,
        "experiment": experiment,
        "verdict": verdict,
        "reason": reason,
        "evidence": evidence,
        "n_comparisons": len(rows),
        "n_for": n_for,
        "n_against": n_against,
        "min_n": int(rows["n"].min()),
        "rule": _rule(rows),
        "seeds_needed": _seeds_needed(rows) if seeds is None else seeds,
        "methods": " ".join(dict.fromkeys([*rows["method_a"], *rows["method_b"]])),
        # the comparison the evidence quotes, as numbers (the README's answer reads them)
        "effect_pair": f"{focus['method_a']} - {focus['method_b']}",
        "effect": float(focus["diff"]),
        "effect_low": float(focus["ci_low"]),
        "effect_high": float(focus["ci_high"]),
    }


def _all_beat(claim_id, text, experiment, rows) -> dict | None:
    """Claim "A beats B" for every (oriented) row: intersection-union for supported,
    ``_against`` (Holm from 6 seeds) for contradicted."""
    if rows.empty:
        return None
    against = _against(rows)
    support = (rows["direction"] > 0).all() and rows["resolved"].all()
    verdict = CONTRADICTED if against.any() else SUPPORTED if support else INCONCLUSIVE
    focus = rows[against].iloc[0] if against.any() else None
    return _claim(claim_id, text, experiment, rows, verdict, focus=focus)


def _with_full(rows: pd.DataFrame, members: list[str]) -> pd.DataFrame:
    """Rows of DUIS against a method of ``members``, DUIS as A."""
    other = rows["method_a"].where(rows["method_b"] == FULL_METHOD, rows["method_b"])
    full = (rows["method_a"] == FULL_METHOD) | (rows["method_b"] == FULL_METHOD)
    return _oriented(rows[full & other.isin(members)], lambda r: FULL_METHOD)


def _and(words: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def feature_space(features: str, framework: str) -> str:
    """What a feature-only baseline selected on, in words: the framework's own feature
    space where it has one (every method of the embedding framework selects on the
    embedding), else the method's ``features``."""
    space = get_framework(framework).features
    return get_feature_space(space if space is not None else features).words


def _against_whom(family: Family, members: list[str], selection: dict, framework: str) -> str:
    """'(against Random and Margin only)': every comparator, "only" when the run lacks
    some of the family's declared strategies; a low-budget family says what its
    members selected on."""
    names = [method_label(m) for m in members]
    selecting = ""
    if family is LOW_BUDGET_FAMILY:
        spaces = [feature_space(selection[m].get("features", "model"), framework) for m in members]
        if len(set(spaces)) == 1:
            selecting = f", selecting on {spaces[0]}"
        else:
            names = [f"{n} (selecting on {w})" for n, w in zip(names, spaces, strict=True)]
    only = " only" if family.missing(selection) else ""
    return f"(against {_and(names)}{only}{selecting})"


def _family_rows(cmp: pd.DataFrame, spec: ClaimSpec, members: list[str]) -> pd.DataFrame:
    """DUIS against ``members`` at the claim's points: every query round, the AUBC over
    the query rounds, or every MSPPP level."""
    rows = cmp[cmp["experiment"] == spec.experiment]
    if spec.points == "rounds":
        rows = rows[(rows["point"] != "AUBC") & (rows["round"].astype(float) >= 1)]
    elif spec.points == "aubc":
        rows = rows[rows["point"] == "AUBC"]
    return _with_full(rows, members)


def _family_text(spec: ClaimSpec, rows: pd.DataFrame, metric: str, whom: str) -> str:
    """The claim's sentence, naming every comparator (``whom``)."""
    words = spec.family.words
    if spec.points == "levels":
        at = f" at round {int(rows['round'].iloc[0])}" if rows["round"].notna().any() else ""
        return f"DUIS has the highest {metric} on every MSPPP split{at}, {words} {whom}."
    if spec.points == "rounds":
        return f"DUIS has the highest {metric} at every query round, {words} {whom}."
    span = f" ({rows['span'].iloc[0]})" if "span" in rows and pd.notna(rows["span"].iloc[0]) else ""
    if spec.family is LOW_BUDGET_FAMILY:
        return (
            f"DUIS has a larger AUBC over query rounds{span} than each low-budget "
            f"baseline, {words} {whom}."
        )
    if spec.family is DROPQUERY_FAMILY:
        return (
            f"DUIS has a larger AUBC over query rounds{span} than DropQuery, {words} {whom} "
            "(DUIS's inconsistency over photon conditions against DropQuery's over "
            "feature dropout)."
        )
    return f"DUIS has the largest AUBC over query rounds{span}, {words} {whom}."


def _family_claims(cmp: pd.DataFrame, metric: str, selection, framework: str) -> list[dict]:
    """Every declared claim of DUIS against a family (``claim_registry.FAMILIES``),
    judged on the members the run has; absent without one."""
    out = []
    for spec in CLAIMS:
        if spec.family is None:
            continue
        members = spec.family.members(selection)
        rows = _family_rows(cmp, spec, members) if members else cmp.iloc[0:0]
        if rows.empty:
            continue
        tested = [m for m in members if m in set(rows["method_b"])]
        whom = _against_whom(spec.family, tested, selection, framework)
        text = _family_text(spec, rows, metric, whom)
        out.append(_all_beat(spec.claim_id, text, spec.experiment, rows))
    return out


def _first_batch_claims(cmp: pd.DataFrame) -> list[dict]:
    """Per cold-start strategy S: every method's arm whose round 0 S chose on the
    embedding beats the same method from a random round 0, on the AUBC over every
    round, round 0 included (this project's extension; ``report.comparisons.
    cold_start_rows``)."""
    rows = cmp[(cmp["experiment"] == "cold_start") & (cmp["point"] == "AUBC")]
    out = []
    for start in dict.fromkeys(rows["parameter"]):
        mine = rows[rows["parameter"] == start]
        family = _oriented(
            mine, lambda r: r["method_a"] if split_start_name(r["method_a"]) else r["method_b"]
        )
        bases = [
            b if split_start_name(a) else a
            for a, b in zip(mine["method_a"], mine["method_b"], strict=True)
        ]
        span = mine["span"].iloc[0] if "span" in mine and mine["span"].iloc[0] else ""
        out.append(
            _all_beat(
                f"{FIRST_BATCH_CLAIM}_{start}",
                f"A first batch chosen by {method_label(start)} on the self-supervised "
                f"embedding, without a label, beats a random one, with "
                f"{_and([method_label(b) for b in dict.fromkeys(bases)])} after it: AUBC "
                f"over {span or 'every round'}, round 0 included.",
                "cold_start",
                family,
            )
        )
    return out


def _pair(cmp: pd.DataFrame, experiment: str, a: str, b: str) -> pd.DataFrame:
    rows = cmp[cmp["experiment"] == experiment]
    pick = ((rows["method_a"] == a) & (rows["method_b"] == b)) | (
        (rows["method_a"] == b) & (rows["method_b"] == a)
    )
    return _oriented(rows[pick], lambda r: a)


def _decomposition_claims(cmp: pd.DataFrame) -> list[dict]:
    """Each part of DUIS − Random beats zero: on the AUBC over the query rounds when the
    budget experiment runs every method of ``DECOMPOSITION``, else at the ablation round
    (where the paper's ablation lacks Random and Syn+Margin, the parts it has)."""
    budget = cmp[(cmp["experiment"] == "budget") & (cmp["point"] == "AUBC")]
    names = set(budget["method_a"]) | set(budget["method_b"])
    if all(a in names and b in names for _, a, b, _ in DECOMPOSITION):  # every part's pair
        rows, where = budget, "AUBC over query rounds"
    else:
        rows = cmp[cmp["experiment"] == "ablation"]
        where = f"at round {int(rows['round'].iloc[0])}" if not rows.empty else ""
    experiment = str(rows["experiment"].iloc[0]) if not rows.empty else "ablation"
    labels = ABLATION_LABELS if experiment == "ablation" else None
    ids = [part[0] for part in DECOMPOSITION]
    if experiment == "ablation":  # the paper's ablation: diversity against random
        ids = ["diversity_over_random", "inconsistency_over_diversity"]
    out = []
    for claim_id in ids:
        spec = CLAIM_SPECS[claim_id]
        a, b = spec.pair
        pair = _pair(rows, experiment, a, b)
        text = (
            f"{method_label(a, labels)} beats {method_label(b, labels)}, {where} "
            f"({spec.what} helps)."
        )
        out.append(_all_beat(claim_id, text, experiment, pair))
    return out


def _sweep_rows(cmp: pd.DataFrame, parameter: str) -> pd.DataFrame:
    return cmp[(cmp["experiment"] == "sensitivity") & (cmp["parameter"] == parameter)]


def _m_claim(cmp: pd.DataFrame) -> dict | None:
    rows = _sweep_rows(cmp, "m")
    rows = rows[(rows["value_a"].astype(float) == 1) | (rows["value_b"].astype(float) == 1)]
    if rows.empty:
        return None
    return _all_beat(
        "m_gt_1_beats_m_1",
        "Every M > 1 beats M = 1 (the synthetic variants help).",
        "sensitivity",
        _oriented(rows, lambda r: r["method_a"] if float(r["value_a"]) != 1 else r["method_b"]),
    )


def not_worse(rows: pd.DataFrame) -> tuple[pd.Series, pd.Series]:
    """The non-inferiority rule, per oriented row (A claimed not worse than B by more
    than ``MARGIN_PP``): (*not worse*: the 95% interval's lower bound lies above
    -MARGIN_PP, *worse*: its upper bound lies below -MARGIN_PP), each needing
    ``MIN_SEEDS`` paired units; a row that is neither is undecided."""
    enough = rows["n"] >= MIN_SEEDS
    low, high = rows["ci_low"].astype(float), rows["ci_high"].astype(float)
    return enough & (low > -MARGIN_PP), enough & (high < -MARGIN_PP)


def _alpha_claim(cmp: pd.DataFrame) -> dict | None:
    rows = _sweep_rows(cmp, "alpha")
    half = (rows["value_a"].astype(float) == 0.5) | (rows["value_b"].astype(float) == 0.5)
    rows = rows[half]
    if rows.empty:
        return None
    rows = _oriented(rows, lambda r: r["method_a"] if float(r["value_a"]) == 0.5 else r["method_b"])
    fine, worse = not_worse(rows)
    verdict = CONTRADICTED if worse.any() else SUPPORTED if fine.all() else INCONCLUSIVE
    if verdict == SUPPORTED:
        reason = f"every 95% interval lies above -{MARGIN_PP:g} pp (non-inferiority)"
    elif verdict == CONTRADICTED:
        reason = f"a 95% interval lies wholly below -{MARGIN_PP:g} pp"
    elif (rows["n"] >= MIN_SEEDS).all():
        reason = f"an interval reaches across -{MARGIN_PP:g} pp"
    else:
        reason = _reason(rows, INCONCLUSIVE)
    focus = rows[worse].iloc[0] if worse.any() else None
    others = sorted({float(v) for v in rows["value_b"]})
    return _claim(
        "alpha_half_not_worse",
        f"alpha = 0.5 is not worse than alpha = {', '.join(f'{v:g}' for v in others)} "
        f"(by more than {MARGIN_PP:g} pp).",
        "sensitivity",
        rows,
        verdict,
        reason=reason,
        focus=focus,
        seeds=_seeds_needed(rows, margin=MARGIN_PP),
    )


def _ncand_family(rows: pd.DataFrame, values: list[float]) -> pd.DataFrame:
    """The N_cand comparisons the claim needs, oriented: the largest vs the smallest
    first, then each step between neighbouring values (empty without the ends)."""
    a, b = rows["value_a"].astype(float), rows["value_b"].astype(float)
    ends = rows[(a == values[-1]) & (b == values[0])]
    if ends.empty:
        return ends
    steps = [rows[(a == hi) & (b == lo)] for lo, hi in itertools.pairwise(values)]
    family = pd.concat([ends.iloc[:1], *steps])
    return family[~family.index.duplicated()]  # with two values the end is the step


def _ncand_claim(cmp: pd.DataFrame) -> dict | None:
    rows = _sweep_rows(cmp, "n_cand")
    if rows.empty:
        return None
    rows = _oriented(
        rows,
        lambda r: r["method_a"] if float(r["value_a"]) > float(r["value_b"]) else r["method_b"],
    )
    values = sorted({float(v) for v in pd.concat([rows["value_a"], rows["value_b"]])})
    family = _ncand_family(rows, values)
    if family.empty:
        return None
    # the end (largest vs smallest) must grow; every step between neighbours must not
    # fall, by the non-inferiority rule (``not_worse``)
    end, steps = family.iloc[0], family.iloc[1:]
    fine, fell = not_worse(steps)
    end_against = bool(_against(family).iloc[0])
    if end_against or fell.any():
        verdict = CONTRADICTED
        reason = (
            "the largest N_cand is resolved below the smallest"
            if end_against
            else f"a step's 95% interval lies wholly below -{MARGIN_PP:g} pp"
        )
    elif end["resolved"] and end["direction"] > 0 and fine.all():
        verdict = SUPPORTED
        reason = f"largest above smallest, every step's interval above -{MARGIN_PP:g} pp"
    elif int(family["n"].min()) >= MIN_SEEDS:
        verdict = INCONCLUSIVE
        reason = (
            f"a step's interval reaches across -{MARGIN_PP:g} pp"
            if end["resolved"] and end["direction"] > 0
            else "the largest N_cand is not resolved above the smallest"
        )
    else:
        verdict, reason = INCONCLUSIVE, _reason(family, INCONCLUSIVE)
    return _claim(
        "ncand_grows_to_plateau",
        f"Accuracy grows with N_cand ({', '.join(f'{v:g}' for v in values)}) up to a plateau.",
        "sensitivity",
        family,
        verdict,
        reason=reason,
        focus=end,
        seeds=_seeds_needed(family.iloc[:1]),
    )


def claims(
    cmp: pd.DataFrame,
    selection: dict | None = None,
    *,
    levels_in_paper: bool = True,
    framework: str = DEFAULT.name,
    notes: dict | None = None,
) -> pd.DataFrame:
    """The paper's claims and this project's extensions judged on one dataset's
    comparisons frame (see module docstring).

    ``selection``: {method: {"strategy", "features", "use_variants"}}, the budget
    experiment's methods (``spl_al.experiment.plan.experiments_of``): which of them
    each declared family holds (``claim_registry.Family``); None: no claim of DUIS
    against a family. ``levels_in_paper``: whether the paper
    reports a per-MSPPP-level split for this protocol (it does for its real and
    segmentation data, not for its synthetic classification). ``notes``: claim id -> a
    sentence appended to that claim's reason (``encoder_claim_notes``). Returns one row
    per claim whose comparisons exist, columns ``COLUMNS``; ``source`` is ``paper`` or
    ``extension`` (``claim_registry``); ``methods`` the method keys the claim tested;
    ``effect_pair`` ("a - b"), ``effect``, ``effect_low`` and ``effect_high`` the
    comparison its evidence quotes (the weakest, or the one against it) and its 95%
    interval, oriented as the claim reads; ``unit`` what ``seeds_needed`` counts:
    seeds, or encoders.
    """
    if cmp.empty:
        return pd.DataFrame(columns=list(COLUMNS))
    first = cmp.iloc[0]
    metric = METRIC_WORDS.get(first["metric"], first["metric"].lower())
    rows = [
        *_family_claims(cmp, metric, selection, framework),
        *_decomposition_claims(cmp),
        *_first_batch_claims(cmp),
        _m_claim(cmp),
        _ncand_claim(cmp),
        _alpha_claim(cmp),
    ]
    rows = [r for r in rows if r is not None]
    unit = str(first["unit"]) if "unit" in cmp and isinstance(first["unit"], str) else "seed"
    for row in rows:
        row["source"] = source_of(row["claim_id"])
        row["unit"] = unit
        if row["claim_id"] == "duis_best_every_level" and not levels_in_paper:
            row["source"] = EXTENSION
        if (notes or {}).get(row["claim_id"]):
            row["reason"] = f"{row['reason']} {notes[row['claim_id']]}"
    frame = pd.DataFrame(rows, columns=list(COLUMNS)[:-2])
    frame["dataset"] = first["dataset"]
    frame["metric"] = first["metric"]
    return frame[list(COLUMNS)]


DIFFERENCE_COLUMNS = (
    "family",
    "heading",
    "claim_id",
    "claim_verdict",
    "method",
    "diff",
    "ci_low",
    "ci_high",
    "n",
    "n_seeds",
    "unit",
    "rule",
    "verdict",
    "span",
)
OTHERS = "others"
"""``aubc_differences``' family of the budget methods no declared family holds."""
FAMILY_HEADINGS = {
    "paper": "the paper's baselines, as the paper compares",
    "matched": "their matched twins (trained on the variants)",
    "low_budget": "low-budget baselines, matched training",
    "dropquery": "DropQuery, matched training",
    OTHERS: "in no claim",
}
"""How ``aubc_differences`` heads each family (``claim_registry.FAMILIES`` by name)."""
NO_CLAIM = "no claim"
"""The verdict of a comparison no claim tests (``OTHERS``)."""


def aubc_differences(
    cmp: pd.DataFrame, selection: dict | None, claims_frame: pd.DataFrame | None = None
) -> pd.DataFrame:
    """DUIS − each budget method on the AUBC over the query rounds, grouped by the
    declared families (``claim_registry.FAMILIES``, in their order), then DUIS's pairwise
    claims (its inconsistency term over Syn+Diversity; family: the claim id), the budget
    methods none holds last (family ``OTHERS``): one row per comparator, columns
    ``DIFFERENCE_COLUMNS``, the differences and intervals in points as
    ``comparisons.csv`` has them, oriented DUIS − method.

    ``verdict``: the comparison's own reading under its family's claim, by the claim's
    rule: ``SUPPORTED`` when resolved in DUIS's favour, ``CONTRADICTED`` when it counts
    against the claim (resolved against and, from 6 units, surviving Holm over the
    family), else ``INCONCLUSIVE``; below 6 units ``AGREE`` and ``AGAINST`` instead of
    the first two; ``NO_CLAIM`` for ``OTHERS``. ``claims_frame`` (``claims`` after
    ``at_precision``): the family's claim verdict (``claim_verdict``), and a run whose
    claims are not decided at its precision reads every comparison inconclusive."""
    aubc = cmp[(cmp["experiment"] == "budget") & (cmp["point"] == "AUBC")] if len(cmp) else cmp
    decided = claims_frame is None or "precision" not in claims_frame or claims_frame.empty
    if not decided:
        decided = str(claims_frame["precision"].iloc[0]) in ("", "nan", DECIDING_PRECISION)
    claim_verdict = (
        dict(zip(claims_frame["claim_id"], claims_frame["verdict"], strict=True))
        if claims_frame is not None and not claims_frame.empty
        else {}
    )
    out, seen = [], set()
    for spec in CLAIMS:
        if spec.family is None or spec.points != "aubc" or aubc.empty:
            continue
        members = spec.family.members(selection)
        rows = _family_rows(cmp, spec, members) if members else aubc.iloc[0:0]
        if rows.empty:
            continue
        rows = _read_each(rows, decided)
        rows = rows.set_index("method_b").loc[[m for m in members if m in set(rows["method_b"])]]
        for method, row in rows.iterrows():
            seen.add(method)
            heading = FAMILY_HEADINGS.get(spec.family.name, spec.family.words)
            out.append(_difference(row, method, spec.family.name, heading))
            out[-1].update(
                claim_id=spec.claim_id, claim_verdict=claim_verdict.get(spec.claim_id, "")
            )
    # DUIS against one method (its inconsistency term over Syn+Diversity): that claim's
    # own verdict is the comparison's
    for spec in CLAIMS:
        if spec.pair is None or spec.pair[0] != FULL_METHOD or spec.experiment != "budget":
            continue
        rows = _with_full(aubc, [spec.pair[1]]) if not aubc.empty else aubc
        if rows.empty or spec.pair[1] in seen:
            continue
        row = _read_each(rows, decided).iloc[0]
        seen.add(spec.pair[1])
        out.append(_difference(row, spec.pair[1], spec.claim_id, f"DUIS's {spec.what}"))
        # the heading quotes the claim only where it was judged on this AUBC (without
        # every part of the decomposition it is judged at the ablation's round)
        judged_here = (
            claim_verdict
            and (
                (claims_frame["claim_id"] == spec.claim_id)
                & (claims_frame["experiment"] == "budget")
            ).any()
        )
        verdict = claim_verdict.get(spec.claim_id, "") if judged_here else ""
        out[-1].update(claim_id=spec.claim_id, claim_verdict=verdict)
    if not aubc.empty:
        rest = [m for m in (selection or {}) if m not in seen and m != FULL_METHOD]
        others = _with_full(aubc, rest)
        order = [m for m in (selection or {}) if m in set(others["method_b"])]
        for method, row in others.set_index("method_b").loc[order].iterrows():
            row = row.copy()
            row["rule"], row["verdict"] = rule_name(int(row["n"])), NO_CLAIM
            out.append(_difference(row, method, OTHERS, FAMILY_HEADINGS[OTHERS]))
            out[-1].update(claim_id="", claim_verdict="")
    return pd.DataFrame(out, columns=list(DIFFERENCE_COLUMNS))


def _read_each(rows: pd.DataFrame, decided: bool) -> pd.DataFrame:
    """``rows`` (DUIS as A) with each comparison's own ``verdict`` under its claim's rule
    and the ``rule`` read: for DUIS when resolved so, against it when ``_against``
    (Holm over the rows from 6 units), else inconclusive; the small-n words below 6
    units; inconclusive throughout where the run's precision decides nothing."""
    favour = ((rows["direction"] > 0) & rows["resolved"].astype(bool)).to_numpy()
    against = _against(rows).to_numpy()
    verdict = np.where(against, CONTRADICTED, np.where(favour, SUPPORTED, INCONCLUSIVE))
    rule = _rule(rows)
    if rule == "small-n":
        small = {SUPPORTED: AGREE, CONTRADICTED: AGAINST}
        verdict = np.array([small.get(v, v) for v in verdict])
    if not decided:
        verdict[:] = INCONCLUSIVE
    return rows.assign(verdict=verdict, rule=rule)


def _difference(row, method: str, family: str, heading: str) -> dict:
    """One row of ``aubc_differences``."""
    return {
        "family": family,
        "heading": heading,
        "method": method,
        "diff": float(row["diff"]),
        "ci_low": float(row["ci_low"]),
        "ci_high": float(row["ci_high"]),
        "n": int(row["n"]),
        "n_seeds": int(row["n_seeds"]) if pd.notna(row.get("n_seeds")) else int(row["n"]),
        "unit": str(row.get("unit", "seed")),
        "rule": str(row["rule"]),
        "verdict": str(row["verdict"]),
        "span": str(row.get("span", "") or ""),
    }


DECIDING_PRECISION = "fp32"
"""The precision claims are decided at: the decisive runs'. A run trained in bf16 is
another draw of every seed's trajectory, and at 8 and 16 seeds its verdicts differed
from an fp32 run's beyond what its intervals allowed (docs/benchmarks.md#precision-and-
verdicts), so it decides nothing."""


def at_precision(frame: pd.DataFrame, precision: str) -> pd.DataFrame:
    """The claims of a run whose models were trained at ``precision`` ("" when its
    records do not say), with a ``precision`` column and ``seeds_read``, the verdict
    its own seeds give. A run trained at another precision than ``DECIDING_PRECISION``
    decides no claim: a verdict other than inconclusive becomes inconclusive, its
    reason naming the precision and what the run's seeds read."""
    out = frame.copy()
    out["precision"] = precision
    out["seeds_read"] = out["verdict"]
    if precision in ("", DECIDING_PRECISION) or out.empty:
        return out
    decided = out["verdict"] != INCONCLUSIVE
    out.loc[decided, "reason"] = (
        f"trained in {precision}, and claims are decided in {DECIDING_PRECISION} (the "
        f"decisive runs' precision); at {precision} its seeds read: " + out.loc[decided, "verdict"]
    )
    out.loc[decided, "verdict"] = INCONCLUSIVE
    return out


_MARKS = {"5%": "¹", "small-n": "²"}


def rule_notes(unit: str = "seed") -> dict[str, str]:
    """Rule name -> the verdict rule it stands for, in one sentence each; ``unit``: what
    n counts ("seed", or "encoder")."""
    n6 = seeds_for_level()
    units = f"{unit}s"
    return {
        "5%": (
            f"n >= {n6} {units} (5% rule): supported is an intersection-union test, every "
            "comparison the claim needs resolved in its favour at 5% (sign-flip p <= 0.05, "
            "95% interval excluding zero), each at 0.05 with no correction; contradicted: "
            "a comparison resolved against the claim survives Holm's step-down at 0.05 "
            f"over the claim's m comparisons (possible from {units_for_family(2)} {units} "
            f"for m = 2, {units_for_family(15)} for m = 15: 2/2^n <= 0.05/m)."
        ),
        "small-n": (
            f"n < {n6} {units} (small-n rule): no test on so few {units} reaches 0.05, so a "
            f"comparison is resolved when every {unit} agrees in direction and its 95% "
            "interval excludes zero (p = 2/2^n, 0.25 at n = 3), weaker than 5% "
            f"significance and no test: '{AGREE}' when all are resolved in favour, "
            f"'{AGAINST}' when one is resolved against (no correction); fewer than "
            f"{MIN_SEEDS} {units} never resolve."
        ),
    }


def seeds_note(unit: str = "seed") -> str:
    """What the seeds-needed column means, in one sentence; ``unit``: "seed", or
    "encoder" where the units are encoders' means (``spl_al.report.stats.unit_means``)."""
    units = f"{unit}s"
    d = "d (a difference of encoders' means)" if unit == "encoder" else "d"
    return (
        f"{units.capitalize()} needed (80% power): the fewest {units} at which a two-sided "
        f"paired t-test has 80% power for the observed effect mean(d)/sd(d) of {d}, for "
        f"the comparison the claim needs that needs the most: at 0.05 for a comparison "
        f"in the claim's favour (at least {seeds_for_level()}, the fewest at which the "
        f"sign-flip test can reach 0.05), at 0.05/m for one against it, Holm's first step "
        f"over the claim's m comparisons (at least K with 2/2^K <= 0.05/m: "
        f"{units_for_family(15)} for m = 15, {units_for_family(30)} for m = 30); 'not "
        f"worse than': (mean(d) + {MARGIN_PP:g} pp)/sd(d); >100: more than 100; -: a "
        f"needed comparison shows no effect (or has fewer than 2 {units})."
    )


SIV_ENCODER_NOTE = (
    "(Embedding framework: the encoder was trained with a frame's SIV variants as "
    "positives, to embed them alike, which is the disagreement this term reads; on the "
    "validation split the inconsistency still varies over the pool (coefficient of "
    "variation 2.3 on real_cls, 1.9 on synth_cls, against 1.4 and 1.5 with the generic "
    "objective): docs/benchmarks.md.)"
)
"""Appended to the claims about DUIS's inconsistency term when the encoder's objective
is ``siv`` (``encoder_claim_notes``); the figures are ``python -m spl_al.bench
encoders``'s (docs/benchmarks.md, "Encoders")."""

INCONSISTENCY_CLAIMS = (
    "inconsistency_over_diversity",
    "alpha_half_not_worse",
    "condition_over_dropout_inconsistency",
)


DENSE_SIV_ENCODER_NOTE = (
    "(Embedding framework: the dense encoder was trained with a scan's SIV variants as "
    "positives, pixel by pixel, to embed them alike, which is the disagreement this term "
    "reads; the probe also reads nine local depth features, which the variants change.)"
)
"""``SIV_ENCODER_NOTE`` of a segmentation dataset's dense encoder."""


def encoder_claim_notes(objective: str, task: str = "classification") -> dict[str, str]:
    """Claim id -> note for the embedding framework's claims about the inconsistency
    term, given the encoder's ``objective`` ("siv" or "generic") and the dataset's
    ``task`` (segmentation: the dense encoder's note)."""
    if objective != "siv":
        return {}
    note = DENSE_SIV_ENCODER_NOTE if task == "segmentation" else SIV_ENCODER_NOTE
    return dict.fromkeys(INCONSISTENCY_CLAIMS, note)


def render_claims_markdown(frame: pd.DataFrame, dataset: str | None = None) -> str:
    """Markdown of a claims frame, the paper's claims first, then this project's
    extensions: claim, verdict marked with its rule, reason, seeds needed, evidence; a
    footnote per rule the table uses, then the seeds-needed note."""
    name = dataset or (frame["dataset"].iloc[0] if not frame.empty else "")
    precision = frame["precision"].iloc[0] if "precision" in frame and not frame.empty else ""
    has = isinstance(precision, str) and precision
    trained = f" (models trained in {precision})" if has else ""
    kind = frame["framework"].iloc[0] if "framework" in frame and not frame.empty else None
    if kind in framework_names():
        trained = get_framework(kind).claims_words(precision if has else "")
    lines = [f"**Claims checked on {name}{trained}.**"]
    if frame.empty:
        return (
            "\n".join([*lines, "", "No claim's experiment is configured for this dataset."]) + "\n"
        )
    sources = frame["source"] if "source" in frame else pd.Series(PAPER, index=frame.index)
    unit = (
        str(frame["unit"].iloc[0])
        if "unit" in frame and isinstance(frame["unit"].iloc[0], str)
        else "seed"
    )
    for source, title in ((PAPER, "The paper's claims"), (EXTENSION, "Extensions")):
        part = frame[sources.fillna(PAPER) == source]
        if part.empty:
            continue
        lines += [
            "",
            f"*{title}*",
            "",
            f"| Claim | Verdict | Why | {unit.capitalize()}s needed (80% power) | Evidence |",
            "|:---|:---|:---|---:|:---|",
        ]
        for _, row in part.iterrows():
            verdict = f"**{row['verdict']}**{_MARKS.get(row['rule'], '')}"
            cells = [row["claim"], verdict, row["reason"], row["seeds_needed"], row["evidence"]]
            lines.append("| " + " | ".join(str(c).replace("|", r"\|") for c in cells) + " |")
    notes = rule_notes(unit)
    for rule in [r for r in _MARKS if r in set(frame["rule"])]:
        lines += ["", f"{_MARKS[rule]} {notes[rule]}"]
    lines += [
        "",
        f"Inconclusive: neither. Resolved: {rule_text(unit=unit)}. 'Not worse than' (by more than "
        f"{MARGIN_PP:g} pp) is supported when every 95% interval lies above -{MARGIN_PP:g} pp "
        f"and contradicted when one lies wholly below it.",
        "",
        seeds_note(unit),
    ]
    return "\n".join(lines) + "\n"
