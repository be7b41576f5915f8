"""Do two draws of encoders agree? ``python -m spl_al.bench draws RESULTS_A RESULTS_B``.

The embedding framework's verdicts count encoders (docs/method.md §7), so a rerun that
draws other encoders (other seeds, or the same seeds trained on another CPU's kernels)
must not reverse them. Given two results folders of the same config but for the
encoders (``embedding.encoder.seeds``, or the machine), this reads each dataset's
``embedding/tables/claims.csv`` and ``comparisons.csv`` and prints, per dataset:

- claims: how many each draw supports, contradicts and leaves inconclusive, and every
  claim supported in one draw and contradicted in the other (there must be none);
- comparisons: how many each draw resolves, how many both resolve the same way, how
  many one resolves and the other not, and every one resolved in opposite directions
  (there must be none), so an agreement reached by resolving nothing shows;
- the shift of the paired differences between the draws (|diff_A - diff_B|, points):
  its median over every comparison and over the AUBC ones, and its largest;
- the headline comparisons (``HEADLINES``): each draw's difference and whether it is
  resolved.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from spl_al.bench.timing import markdown_table
from spl_al.frameworks import EMBEDDING

KEY = ["experiment", "point", "parameter", "method_a", "method_b"]
HEADLINES = (("syn_maxherding", "duis"), ("syn_random", "random"))
"""AUBC comparisons both frameworks resolved before (DUIS trails Syn+MaxHerding;
training on the variants helps); each draw should still resolve them."""


def _read(results: Path, dataset: str):
    # pandas on demand (importing this module does not load it)
    import pandas as pd

    tables = Path(EMBEDDING.folder(results, dataset)) / "tables"
    for name in ("claims.csv", "comparisons.csv"):
        if not (tables / name).is_file():
            raise SystemExit(
                f"{tables / name} does not exist: give a results folder whose {dataset} "
                "embedding framework has run (its stats job writes it)."
            )
    claims = pd.read_csv(tables / "claims.csv")
    # "parameter" is text, empty for most rows: read as such, not as an all-NaN float
    cmp = pd.read_csv(
        tables / "comparisons.csv",
        keep_default_na=False,
        na_values=[""],
        dtype={"parameter": str},
    )
    cmp["parameter"] = cmp["parameter"].fillna("")
    return claims, cmp


def compare(results_a: Path, results_b: Path, dataset: str) -> dict:
    """The agreement of two draws on one dataset (module docstring), as a dict."""
    # claims (and pandas) on demand (importing this module does not load them)
    from spl_al.report.claims import CONTRADICTED, SUPPORTED

    claims_a, cmp_a = _read(results_a, dataset)
    claims_b, cmp_b = _read(results_b, dataset)
    verdicts = claims_a.merge(claims_b, on="claim_id", suffixes=("_a", "_b"))
    a, b = verdicts["verdict_a"], verdicts["verdict_b"]
    opposite_claims = verdicts[
        ((a == SUPPORTED) & (b == CONTRADICTED)) | ((a == CONTRADICTED) & (b == SUPPORTED))
    ]
    both = cmp_a.merge(cmp_b, on=KEY, suffixes=("_a", "_b"))
    ra, rb = both["resolved_a"].astype(bool), both["resolved_b"].astype(bool)
    da, db = both["direction_a"], both["direction_b"]
    shift = (both["diff_a"] - both["diff_b"]).abs()
    aubc = both["point"] == "AUBC"
    heads = []
    for a, b in HEADLINES:
        row = both[aubc & (both["method_a"] == a) & (both["method_b"] == b)]
        if row.empty:
            row = both[aubc & (both["method_a"] == b) & (both["method_b"] == a)]
        if not row.empty:
            r = row.iloc[0]
            heads.append({
                "comparison": f"{r['method_a']} - {r['method_b']}",
                "a": (float(r["diff_a"]), bool(r["resolved_a"])),
                "b": (float(r["diff_b"]), bool(r["resolved_b"])),
            })  # fmt: skip
    return {
        "dataset": dataset,
        "claims": {
            name: claims["verdict"].value_counts().to_dict()
            for name, claims in (("a", claims_a), ("b", claims_b))
        },
        "opposite_claims": opposite_claims["claim_id"].tolist(),
        "comparisons": len(both),
        "resolved_a": int(ra.sum()),
        "resolved_b": int(rb.sum()),
        "same_way": int((ra & rb & (da == db)).sum()),
        "one_only": int((ra ^ rb).sum()),
        "opposite": both.loc[ra & rb & (da != db), KEY].to_dict("records"),
        "shift_median": float(shift.median()),
        "shift_median_aubc": float(shift[aubc].median()) if aubc.any() else float("nan"),
        "shift_max": float(shift.max()),
        "headlines": heads,
    }


def render(result: dict) -> str:
    """One dataset's agreement as Markdown."""
    c = result["claims"]
    verdict_row = [
        f"{c[k].get('supported', 0)} / {c[k].get('contradicted', 0)} / "
        f"{c[k].get('inconclusive', 0)}"
        for k in ("a", "b")
    ]
    rows = [
        ["claims supported / contradicted / inconclusive", *verdict_row],
        ["claims supported in one draw, contradicted in the other",
         ", ".join(result["opposite_claims"]) or "none", ""],
        ["comparisons resolved", str(result["resolved_a"]), str(result["resolved_b"])],
        ["... both, the same way / one draw only / opposite ways",
         f"{result['same_way']} / {result['one_only']} / {len(result['opposite'])}",
         f"of {result['comparisons']}"],
        ["shift of a paired difference, median (AUBC) / largest, points",
         f"{result['shift_median']:.2f} ({result['shift_median_aubc']:.2f}) / "
         f"{result['shift_max']:.2f}", ""],
    ]  # fmt: skip
    for h in result["headlines"]:
        cells = [f"{v:+.1f} ({'resolved' if ok else 'not resolved'})" for v, ok in (h["a"], h["b"])]
        rows.append([f"AUBC {h['comparison']}", *cells])
    text = f"**{result['dataset']}: draw A against draw B**\n\n"
    text += markdown_table(["", "draw A", "draw B"], rows)
    for o in result["opposite"]:
        text += f"\n\nOpposite: {o['experiment']} {o['point']} {o['method_a']} - {o['method_b']}"
    return text


def main(argv: list[str] | None = None) -> int:
    """Print the agreement of two results folders' embedding frameworks; exit 1 when a
    claim or a comparison is reversed."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench draws")
    parser.add_argument("results_a", type=Path)
    parser.add_argument("results_b", type=Path)
    parser.add_argument("--datasets", nargs="*", default=["real_cls", "synth_cls"])
    args = parser.parse_args(argv)
    reversed_any = False
    for dataset in args.datasets:
        result = compare(args.results_a, args.results_b, dataset)
        print(render(result) + "\n")
        reversed_any |= bool(result["opposite_claims"] or result["opposite"])
    return 1 if reversed_any else 0
