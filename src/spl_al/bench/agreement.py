"""How well does the embedding framework speak for the supervised one?
``python -m spl_al.bench agreement EMBEDDING_RESULTS SUPERVISED_RESULTS``.

The embedding framework decides claims cheaply (a linear classifier on a frozen
self-supervised encoder, 12 encoders x 10 seeds); the supervised framework is the
paper's protocol (the network trained every round), decided by the decisive configs.
For each dataset both results folders hold, this reads the budget experiment's paired
comparisons of each framework (``EMBEDDING_RESULTS/{dataset}/embedding/tables/
comparisons.csv`` and ``SUPERVISED_RESULTS/{dataset}/tables/comparisons.csv``) and
writes every comparison both made: the same pair of methods at the same query round
(the same number of labeled groups), and over the AUBC of the query rounds. For each:

- the paired difference A − B (points) with its 95% interval in each framework;
- whether the signs agree, and how the two resolved it: both the same way ("both":
  both in A's favour or both in B's), neither ("neither"), one and not the other
  ("one only"), or in opposite directions ("opposite").

Per dataset it also gives the Spearman correlation of the methods' AUBC (each
method's mean AUBC in each framework, over the methods both ran) and draws the
methods' AUBC in one framework against the other (``--figures DIR``:
``agreement_{dataset}.png``). ``--out DIR`` writes the comparisons as
``agreement_{dataset}.csv``. The intervals come from each framework's own units
(encoders, seeds), so "both" asks both to reach the same verdict at the power each
has.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spl_al.atomic import atomic_write
from spl_al.bench.timing import markdown_table
from spl_al.frameworks import EMBEDDING, SUPERVISED

SIDES = (EMBEDDING, SUPERVISED)
"""The frameworks of the two results folders, in argument order; each one's name
prefixes its columns."""
EMB, SUP = EMBEDDING.name, SUPERVISED.name


def read_comparisons(results: Path, dataset: str, framework):
    """The budget experiment's comparisons of ``framework`` on ``dataset``, or None when
    the folder has none."""
    # pandas on demand (importing this module does not load it)
    import pandas as pd

    path = Path(framework.folder(results, dataset)) / "tables" / "comparisons.csv"
    if not path.is_file():
        return None
    cmp = pd.read_csv(path, keep_default_na=False, na_values=[""], dtype={"parameter": str})
    cmp = cmp[cmp["experiment"] == "budget"].copy()
    cmp["span"] = cmp["span"].fillna("")
    aubc = cmp["point"] == "AUBC"
    # a query round is matched by its number of labeled groups; round 0 (the same labels
    # for every method) is no comparison of acquisition
    cmp = cmp[aubc | (cmp["round"].astype(float) >= 1)]
    cmp["at"] = cmp["n_labeled"].astype("Int64").astype(str).where(~aubc, "AUBC")
    return cmp


def _resolution(row, side: str) -> str:
    """'A' or 'B' (the side a resolved difference favours), '-' when unresolved."""
    if not bool(row[f"resolved_{side}"]):
        return "-"
    return "A" if float(row[f"diff_{side}"]) > 0 else "B"


def _both_ways(embedding: str, supervised: str) -> str:
    """How the two frameworks resolved one comparison ('A', 'B' or '-' each): "both"
    (the same way), "opposite", "one only" or "neither"."""
    if "-" not in (embedding, supervised):
        return "both" if embedding == supervised else "opposite"
    return "neither" if embedding == supervised else "one only"


def _oriented(cmp):
    """Each pair as (A, B) with A the later name alphabetically, so the two frameworks'
    rows meet whatever order their methods ran in; the difference flips with them."""
    out = cmp.copy()
    flip = out["method_a"] > out["method_b"]
    out.loc[flip, ["method_a", "method_b"]] = out.loc[flip, ["method_b", "method_a"]].to_numpy()
    for col in ("diff", "ci_low", "ci_high"):
        out.loc[flip, col] = -out.loc[flip, col]
    out.loc[flip, ["ci_low", "ci_high"]] = out.loc[flip, ["ci_high", "ci_low"]].to_numpy()
    out.loc[flip, ["mean_a", "mean_b"]] = out.loc[flip, ["mean_b", "mean_a"]].to_numpy()
    return out


def method_aubc(cmp) -> dict[str, float]:
    """Each method's mean AUBC (points) from the AUBC comparisons it is part of."""
    area = cmp[cmp["at"] == "AUBC"]
    means = {}
    for side in ("a", "b"):
        for method, mean in zip(area[f"method_{side}"], area[f"mean_{side}"], strict=True):
            means.setdefault(method, float(mean))
    return means


def compare(embedding_results: Path, supervised_results: Path, dataset: str):
    """(the comparisons both frameworks made, per-dataset facts) for one dataset; None
    when either folder lacks its comparisons."""
    # pandas and scipy on demand (importing this module does not load them)
    from scipy.stats import spearmanr

    frames = {}
    for kind, results in zip(SIDES, (embedding_results, supervised_results), strict=True):
        cmp = read_comparisons(results, dataset, kind)
        if cmp is None:
            return None
        frames[kind.name] = cmp
    key = ["at", "method_a", "method_b"]
    cols = [*key, "point", "span", "diff", "ci_low", "ci_high", "resolved", "unit", "n"]
    emb, sup = (_oriented(frames[kind.name])[cols] for kind in SIDES)
    both = emb.merge(sup, on=key, suffixes=(f"_{EMB}", f"_{SUP}"))
    both["signs_agree"] = (both[f"diff_{EMB}"] > 0) == (both[f"diff_{SUP}"] > 0)
    res_e = both.apply(_resolution, axis=1, side=EMB)
    res_s = both.apply(_resolution, axis=1, side=SUP)
    both["resolution"] = [_both_ways(e, s) for e, s in zip(res_e, res_s, strict=True)]
    both["dataset"] = dataset
    means = {kind.name: method_aubc(frames[kind.name]) for kind in SIDES}
    shared = sorted(set(means[EMB]) & set(means[SUP]))
    x = [means[EMB][m] for m in shared]
    y = [means[SUP][m] for m in shared]
    rho = float(spearmanr(x, y).statistic) if len(shared) >= 3 else float("nan")
    aubc = both[both["at"] == "AUBC"]
    facts = {
        "dataset": dataset,
        "comparisons": len(both),
        "aubc_comparisons": len(aubc),
        "signs_agree": int(both["signs_agree"].sum()),
        "both": int((both["resolution"] == "both").sum()),
        "neither": int((both["resolution"] == "neither").sum()),
        "one_only": int((both["resolution"] == "one only").sum()),
        "opposite": int((both["resolution"] == "opposite").sum()),
        "aubc_signs_agree": int(aubc["signs_agree"].sum()),
        "aubc_both": int((aubc["resolution"] == "both").sum()),
        "spearman": rho,
        "methods": shared,
        "aubc": {EMB: x, SUP: y},
        "units": {
            kind.name: f"{int(both[f'n_{kind.name}'].max())} {both[f'unit_{kind.name}'].iloc[0]}s"
            if len(both)
            else ""
            for kind in SIDES
        },
    }
    return both, facts


def _interval(row, side: str) -> str:
    return (
        f"{row[f'diff_{side}']:+.1f} [{row[f'ci_low_{side}']:+.1f}, "
        f"{row[f'ci_high_{side}']:+.1f}]{' ✓' if row[f'resolved_{side}'] else ''}"
    )


def render(both, facts: dict) -> str:
    """One dataset's agreement as Markdown: the summary, then every comparison."""
    # display on demand (importing this module does not load pandas)
    from spl_al.report.display import method_label

    n, na = facts["comparisons"], facts["aubc_comparisons"]
    units = facts["units"]
    head = (
        f"**{facts['dataset']}: {n} comparisons both frameworks made ({na} over the AUBC); "
        f"{EMB} over {units[EMB]}, {SUP} over {units[SUP]}.** "
        f"Signs agree in {facts['signs_agree']} of {n} ({facts['aubc_signs_agree']} of {na} "
        f"AUBC); resolved the same way by both in {facts['both']} of {n} "
        f"({facts['aubc_both']} of {na} AUBC), by one framework only in "
        f"{facts['one_only']}, by neither in {facts['neither']}, in opposite directions in "
        f"{facts['opposite']}. Spearman correlation of the {len(facts['methods'])} "
        f"methods' AUBC: {facts['spearman']:+.2f}."
    )
    rows = [
        [
            "AUBC" if r["at"] == "AUBC" else f"{r['at']} labeled",
            f"{method_label(r['method_a'])} − {method_label(r['method_b'])}",
            _interval(r, EMB),
            _interval(r, SUP),
            "yes" if r["signs_agree"] else "no",
            r["resolution"],
        ]
        for _, r in both.sort_values(["at", "method_a", "method_b"], key=_at_order).iterrows()
    ]
    table = markdown_table(
        ["point", "A − B", f"{EMB} (pp)", f"{SUP} (pp)", "signs agree", "resolved"],
        rows,
    )
    return f"{head}\n\n{table}\n\n✓: resolved at 5% (each framework's comparisons table rule)."


def _at_order(col):
    """AUBC first, then the rounds by labeled count (a sort key for ``at``)."""
    if col.name != "at":
        return col
    return col.map(lambda at: -1 if at == "AUBC" else int(at))


def scatter(facts: dict, path) -> None:
    """The methods' AUBC, embedding against supervised, one labeled dot per method."""
    # matplotlib on demand (importing this module does not load it)
    from spl_al.plotting import fit_texts, new_figure, save_png
    from spl_al.report.display import method_colors, method_label

    fig = new_figure(5.2, 4.6)
    ax = fig.add_subplot()
    colors = method_colors(facts["methods"])
    x, y = facts["aubc"][EMB], facts["aubc"][SUP]
    for method, xi, yi in zip(facts["methods"], x, y, strict=True):
        ax.scatter(xi, yi, color=colors[method], s=28)
        ax.annotate(
            method_label(method), (xi, yi), fontsize=7, xytext=(3, 2), textcoords="offset points"
        )
    ax.set_xlabel(f"{EMB} framework AUBC (%), {facts['units'][EMB]}")
    ax.set_ylabel(f"{SUP} framework AUBC (%), {facts['units'][SUP]}")
    ax.set_title(
        f"{facts['dataset']}: the methods' AUBC in both frameworks "
        f"(Spearman {facts['spearman']:+.2f})",
        fontsize=9,
    )
    ax.grid(alpha=0.3)
    fit_texts(fig)
    save_png(fig, path)


def main(argv: list[str] | None = None) -> int:
    """Print the agreement of an embedding and a supervised results folder per dataset."""
    parser = argparse.ArgumentParser(
        prog="python -m spl_al.bench agreement",
        description="Every comparison the embedding framework (EMBEDDING_RESULTS) and the "
        "supervised framework (SUPERVISED_RESULTS) both made on a dataset, side by side: "
        "effect and interval in each, whether the signs agree and whether both resolved "
        "it the same way; and the Spearman correlation of the methods' AUBC.",
    )
    parser.add_argument("embedding_results", type=Path, metavar="EMBEDDING_RESULTS")
    parser.add_argument("supervised_results", type=Path, metavar="SUPERVISED_RESULTS")
    parser.add_argument(
        "--datasets", nargs="*", default=["real_cls", "synth_cls", "street_seg", "street_pc"]
    )
    parser.add_argument("--out", type=Path, help="folder for agreement_{dataset}.csv")
    parser.add_argument("--figures", type=Path, help="folder for agreement_{dataset}.png")
    args = parser.parse_args(argv)
    found = 0
    for dataset in args.datasets:
        result = compare(args.embedding_results, args.supervised_results, dataset)
        if result is None:
            print(f"{dataset}: skipped, one of the folders has no comparisons for it.\n")
            continue
        both, facts = result
        found += 1
        print(render(both, facts) + "\n")
        if args.out:
            args.out.mkdir(parents=True, exist_ok=True)
            path = args.out / f"agreement_{dataset}.csv"
            atomic_write(path, lambda tmp, b=both: b.to_csv(tmp, index=False))
        if args.figures and len(facts["methods"]) >= 2:
            args.figures.mkdir(parents=True, exist_ok=True)
            scatter(facts, args.figures / f"agreement_{dataset}.png")
    if not found:
        print(
            "error: no dataset has comparisons in both folders; give an embedding run's "
            "results folder and a supervised one's (their tables/comparisons.csv).",
            file=sys.stderr,
        )
        return 2
    return 0
