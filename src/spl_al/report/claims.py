"""The paper's claims, checked against one dataset's paired comparisons.

Each claim is restated in one line and judged from the rows of
``spl_al.report.comparisons`` it needs (so tables, comparisons and claims apply one
rule, ``spl_al.report.stats``):

- **supported**: every comparison the claim needs is resolved in its favour;
- **contradicted**: at least one is resolved against it;
- **inconclusive**: otherwise: too few seeds (n < 3), or an interval that spans zero,
  or seeds that disagree in direction.

"Not worse than" (alpha = 0.5 vs its neighbours) is a non-inferiority claim: supported
when every 95% interval of (0.5 minus the other) lies above -``MARGIN_PP`` percentage
points (and n >= 3), contradicted when one is resolved below zero. "Grows up to a
plateau" (N_cand) is supported when the largest N_cand is resolved above the smallest
and no step between neighbouring values is resolved downward; contradicted when the
largest is resolved below the smallest or a step falls by more than ``MARGIN_PP``
(its whole interval below -MARGIN_PP). A claim whose experiment is not configured for
the dataset (or has no records) is absent.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from spl_al.report.comparisons import comparison_text
from spl_al.report.display import ABLATION_LABELS, FULL_METHOD, METRIC_LABELS, method_label
from spl_al.report.stats import MIN_SEEDS, rule_text

MARGIN_PP = 1.0
"""Non-inferiority margin in percentage points of the metric."""

SUPPORTED, CONTRADICTED, INCONCLUSIVE = "supported", "contradicted", "inconclusive"

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


def _reason(rows: pd.DataFrame, verdict: str) -> str:
    min_n = int(rows["n"].min())
    if verdict == SUPPORTED:
        return "every comparison resolved in favour"
    if verdict == CONTRADICTED:
        return "a comparison resolved against"
    if min_n < MIN_SEEDS:
        return f"too few seeds (n = {min_n} < {MIN_SEEDS})"
    return "an interval spans zero or the seeds disagree"


def _claim(claim_id, text, experiment, rows, verdict, reason=None, focus=None) -> dict:
    """One claims row; the evidence quotes ``focus`` (default: the weakest comparison)."""
    if focus is None:
        # The comparison that holds the claim back: not resolved in favour, fewest
        # seeds, lowest interval bound.
        key = rows.assign(
            _ok=(rows["direction"] > 0) & rows["resolved"],
            _low=rows["ci_low"].astype(float).fillna(-np.inf),
        )
        focus = key.sort_values(["_ok", "n", "_low"], kind="stable").iloc[0]
    n_for = int(((rows["direction"] > 0) & rows["resolved"]).sum())
    n_against = int(((rows["direction"] < 0) & rows["resolved"]).sum())
    point = f"{focus['point']}: " if focus.get("point") else ""
    evidence = (
        f"{n_for} of {len(rows)} comparisons resolved for, {n_against} against; "
        f"weakest: {point}{comparison_text(focus)}"
    )
    return {
        "claim_id": claim_id,
        "claim": text,
        "experiment": experiment,
        "verdict": verdict,
        "reason": reason or _reason(rows, verdict),
        "evidence": evidence,
        "n_comparisons": len(rows),
        "n_for": n_for,
        "n_against": n_against,
        "min_n": int(rows["n"].min()),
    }


def _all_beat(claim_id, text, experiment, rows) -> dict | None:
    """Claim "A beats B" for every (oriented) row."""
    if rows.empty:
        return None
    against = ((rows["direction"] < 0) & rows["resolved"]).any()
    support = (rows["direction"] > 0).all() and rows["resolved"].all()
    verdict = CONTRADICTED if against else SUPPORTED if support else INCONCLUSIVE
    focus = None
    if against:
        focus = rows[(rows["direction"] < 0) & rows["resolved"]].iloc[0]
    return _claim(claim_id, text, experiment, rows, verdict, focus=focus)


def _best_method_claims(cmp: pd.DataFrame, metric: str) -> list[dict]:
    out = []
    rows = cmp[(cmp["experiment"] == "budget") & (cmp["point"] != "AUBC")]
    rows = rows[(rows["method_a"] == FULL_METHOD) | (rows["method_b"] == FULL_METHOD)]
    out.append(
        _all_beat(
            "duis_best_every_budget",
            f"DUIS has the highest {metric} at every labeling budget.",
            "budget",
            _oriented(rows, lambda r: FULL_METHOD),
        )
    )
    rows = cmp[(cmp["experiment"] == "budget") & (cmp["point"] == "AUBC")]
    rows = rows[(rows["method_a"] == FULL_METHOD) | (rows["method_b"] == FULL_METHOD)]
    out.append(
        _all_beat(
            "duis_best_aubc",
            f"DUIS has the largest area under the {metric} budget curve.",
            "budget",
            _oriented(rows, lambda r: FULL_METHOD),
        )
    )
    rows = cmp[cmp["experiment"] == "levels"]
    rows = rows[(rows["method_a"] == FULL_METHOD) | (rows["method_b"] == FULL_METHOD)]
    at = f" at round {int(rows['round'].iloc[0])}" if not rows.empty else ""
    out.append(
        _all_beat(
            "duis_best_every_level",
            f"DUIS has the highest {metric} on every MSPPP split{at}.",
            "levels",
            _oriented(rows, lambda r: FULL_METHOD),
        )
    )
    return out


def _pair(cmp: pd.DataFrame, experiment: str, a: str, b: str) -> pd.DataFrame:
    rows = cmp[cmp["experiment"] == experiment]
    pick = ((rows["method_a"] == a) & (rows["method_b"] == b)) | (
        (rows["method_a"] == b) & (rows["method_b"] == a)
    )
    return _oriented(rows[pick], lambda r: a)


def _ablation_claims(cmp: pd.DataFrame) -> list[dict]:
    div = _pair(cmp, "ablation", "syn_diversity", "syn_random")
    inc = _pair(cmp, "ablation", FULL_METHOD, "syn_diversity")
    full, syn_div, syn_rand = (
        method_label(m, ABLATION_LABELS) for m in (FULL_METHOD, "syn_diversity", "syn_random")
    )
    out = [
        _all_beat(
            "diversity_helps", f"{syn_div} beats {syn_rand} (diversity helps).", "ablation", div
        ),
        _all_beat(
            "inconsistency_helps",
            f"{full} beats {syn_div} (inconsistency helps).",
            "ablation",
            inc,
        ),
    ]
    if not div.empty and not inc.empty:
        both = pd.concat([inc, div], ignore_index=True)
        out.append(
            _all_beat(
                "ablation_order",
                f"Ablation order {full} >= {syn_div} >= {syn_rand}.",
                "ablation",
                both,
            )
        )
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


def _alpha_claim(cmp: pd.DataFrame) -> dict | None:
    rows = _sweep_rows(cmp, "alpha")
    half = (rows["value_a"].astype(float) == 0.5) | (rows["value_b"].astype(float) == 0.5)
    rows = rows[half]
    if rows.empty:
        return None
    rows = _oriented(rows, lambda r: r["method_a"] if float(r["value_a"]) == 0.5 else r["method_b"])
    against = ((rows["direction"] < 0) & rows["resolved"]).any()
    support = (rows["n"] >= MIN_SEEDS).all() and (rows["ci_low"] > -MARGIN_PP).all()
    verdict = CONTRADICTED if against else SUPPORTED if support else INCONCLUSIVE
    reason = None
    if verdict == SUPPORTED:
        reason = f"every 95% interval lies above -{MARGIN_PP:g} pp (non-inferiority)"
    elif verdict == INCONCLUSIVE and (rows["n"] >= MIN_SEEDS).all():
        reason = f"an interval reaches below -{MARGIN_PP:g} pp"
    others = sorted({float(v) for v in rows["value_b"]})
    return _claim(
        "alpha_half_not_worse",
        f"alpha = 0.5 is not worse than alpha = {', '.join(f'{v:g}' for v in others)}.",
        "sensitivity",
        rows,
        verdict,
        reason,
    )


def _ncand_claim(cmp: pd.DataFrame) -> dict | None:
    rows = _sweep_rows(cmp, "n_cand")
    if rows.empty:
        return None
    rows = _oriented(
        rows,
        lambda r: r["method_a"] if float(r["value_a"]) > float(r["value_b"]) else r["method_b"],
    )
    values = sorted({float(v) for v in pd.concat([rows["value_a"], rows["value_b"]])})
    lo, hi = values[0], values[-1]
    ends = rows[(rows["value_a"].astype(float) == hi) & (rows["value_b"].astype(float) == lo)]
    steps = pd.concat(
        [
            rows[(rows["value_a"].astype(float) == b) & (rows["value_b"].astype(float) == a)]
            for a, b in itertools.pairwise(values)
        ]
    )
    if ends.empty:
        return None
    end = ends.iloc[0]
    fell = (steps["ci_high"] < -MARGIN_PP) & steps["resolved"]
    step_down = (steps["direction"] < 0) & steps["resolved"]
    if (end["resolved"] and end["direction"] < 0) or fell.any():
        verdict, reason = CONTRADICTED, "the largest N_cand is worse, or a step falls"
    elif end["resolved"] and end["direction"] > 0 and not step_down.any():
        verdict, reason = SUPPORTED, "largest above smallest, no step resolved downward"
    else:
        verdict, reason = INCONCLUSIVE, _reason(rows, INCONCLUSIVE)
    return _claim(
        "ncand_grows_to_plateau",
        f"Accuracy grows with N_cand ({', '.join(f'{v:g}' for v in values)}) up to a plateau.",
        "sensitivity",
        rows,
        verdict,
        reason,
        focus=end,
    )


def claims(cmp: pd.DataFrame) -> pd.DataFrame:
    """The paper's claims judged on one dataset's comparisons frame (see module docstring).

    Returns one row per claim whose comparisons exist, columns ``COLUMNS``.
    """
    if cmp.empty:
        return pd.DataFrame(columns=list(COLUMNS))
    first = cmp.iloc[0]
    metric = METRIC_LABELS.get(first["metric"], first["metric"])
    metric = "mIoU" if first["metric"] == "miou" else metric.lower()
    rows = [
        *_best_method_claims(cmp, metric),
        *_ablation_claims(cmp),
        _m_claim(cmp),
        _ncand_claim(cmp),
        _alpha_claim(cmp),
    ]
    frame = pd.DataFrame([r for r in rows if r is not None], columns=list(COLUMNS)[:-2])
    frame["dataset"] = first["dataset"]
    frame["metric"] = first["metric"]
    return frame[list(COLUMNS)]


def claims_rule_text() -> str:
    """The verdict rule in one paragraph (the README and the claims table quote it)."""
    return (
        f"supported: every comparison the claim needs is resolved in its favour; "
        f"contradicted: one is resolved against it; inconclusive: otherwise (fewer than "
        f"{MIN_SEEDS} seeds, an interval spanning zero, or seeds that disagree). "
        f"Resolved: {rule_text()}. 'Not worse than' needs every 95% interval above "
        f"-{MARGIN_PP:g} pp."
    )


def render_claims_markdown(frame: pd.DataFrame, dataset: str | None = None) -> str:
    """Markdown of a claims frame: claim, evidence, verdict, and the rule once."""
    name = dataset or (frame["dataset"].iloc[0] if not frame.empty else "")
    lines = [f"**The paper's claims checked on {name}.**", ""]
    if frame.empty:
        lines.append("No claim's experiment is configured for this dataset.")
    else:
        lines += ["| Claim | Verdict | Why | Evidence |", "|:---|:---|:---|:---|"]
        for _, row in frame.iterrows():
            cells = [row["claim"], f"**{row['verdict']}**", row["reason"], row["evidence"]]
            lines.append("| " + " | ".join(str(c).replace("|", r"\|") for c in cells) + " |")
    lines += ["", f"*Rule: {claims_rule_text()}*"]
    return "\n".join(lines) + "\n"
