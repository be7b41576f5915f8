"""The README's answer: the headline questions against both frameworks, in one table.

``python -m spl_al.docs.answer EMBEDDING_RESULTS SUPERVISED_RESULTS`` reads each
dataset's ``claims.csv`` from the embedding framework's run (the default run:
``EMBEDDING_RESULTS/{dataset}/embedding/tables``) and from the supervised framework's
decisive runs (``SUPERVISED_RESULTS/{dataset}/tables``) and rewrites the README's
``answer`` block: one row per question (``QUESTIONS``, each a declared claim of
``spl_al.report.claim_registry``), one column per framework and dataset, each cell the
claim's verdict and the effect its evidence quotes, A − B in points of AUBC with its
95% interval (for a claim with several comparators, the weakest of them, named). A
claim a run does not make is "-".
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

from spl_al.atomic import atomic_write_text
from spl_al.config import is_standin
from spl_al.docs.markers import replace_block
from spl_al.experiment.shared_embedding import SHARED
from spl_al.frameworks import EMBEDDING, SUPERVISED
from spl_al.layout import table_file
from spl_al.report.display import method_label
from spl_al.report.writers import read_rows

COMMAND = "python -m spl_al.docs.answer"
BLOCK = "answer"
DATASETS = ("real_cls", "synth_cls", "street_seg", "street_pc")
"""The datasets of the answer, in its column order (those a results folder holds)."""

QUESTIONS = (
    ("Does DUIS beat the paper's five baselines, as the paper compares?", "duis_best_aubc"),
    (
        "... under matched training (each baseline's twin trained on the variants too)?",
        "duis_best_aubc_matched",
    ),
    (
        "Does DUIS beat each low-budget baseline (TypiClust, ProbCover, MaxHerding), matched?",
        "duis_over_low_budget_matched",
    ),
    (
        "Does DUIS beat DropQuery (dropout instead of photon conditions), matched?",
        "condition_over_dropout_inconsistency",
    ),
    ("Does DUIS's inconsistency term help (DUIS − Syn+Diversity)?", "inconsistency_over_diversity"),
    ("Does training on the variants help (Syn+Random − Random)?", "variant_training"),
    (
        "Does a cold start help (round 0 chosen by TypiClust on the encoder, no label)?",
        "typical_first_batch_typiclust",
    ),
)
"""(question, claim id) of the answer table, in its order."""


def _claims(results: Path, dataset: str, framework) -> dict[str, dict]:
    """{claim id: its claims.csv row} of one run and dataset ({} when it has none)."""
    path = Path(table_file(framework.folder(results, dataset), "claims.csv"))
    return {row["claim_id"]: row for row in read_rows(path)} if path.is_file() else {}


def _run_entry(results: Path, dataset: str) -> dict:
    """The dataset's entry in the run's effective config (``RESULTS/config.yaml``; {}
    without one)."""
    path = Path(results) / "config.yaml"
    if not path.is_file():
        return {}
    import yaml

    return ((yaml.safe_load(path.read_text()) or {}).get("datasets") or {}).get(dataset) or {}


def _standin(results: Path, dataset: str, framework) -> bool:
    """Whether the run's dataset is a procedural stand-in: synthesised (``source:
    synthetic`` in the run's effective config, ``RESULTS/config.yaml``), or standing in
    for real data (its summary's ``synthetic_standin``; a folder shared by several
    configs keeps only the last one's config)."""
    summary = Path(table_file(framework.folder(results, dataset), "summary.json"))
    if summary.is_file() and json.loads(summary.read_text()).get("synthetic_standin"):
        return True
    entry = _run_entry(results, dataset)
    return bool(entry) and (entry.get("source") == "synthetic" or is_standin(entry))


def _shared_from(results: Path, dataset: str) -> str | None:
    """The dataset whose embedding runs ``dataset`` shares in the run's effective
    config (``embedding: {shared: SOURCE}``), or None: its claims are the source's."""
    return (_run_entry(results, dataset).get(EMBEDDING.block) or {}).get(SHARED)


def _units(rows: dict[str, dict]) -> str:
    """'12 encoders' or '24 seeds': the units the run's claims count."""
    if not rows:
        return ""
    units = {row["unit"] for row in rows.values()}
    n = max(int(row["min_n"]) for row in rows.values())
    return f"{n} {units.pop()}s" if len(units) == 1 else f"{n} units"


def cell(row: dict | None) -> str:
    """A claim's verdict and effect: '**contradicted**: −1.1 [−1.7, −0.5] vs Margin', and
    '(vs Random only)' where the run lacks some of the claim's declared comparators."""
    if row is None:
        return "-"
    text = f"**{row['verdict']}**"
    try:
        effect, low, high = (float(row[k]) for k in ("effect", "effect_low", "effect_high"))
    except (KeyError, TypeError, ValueError):
        return text
    text += f": {effect:+.1f} [{low:+.1f}, {high:+.1f}]".replace("-", "−")
    several = int(row.get("n_comparisons") or 1) > 1
    if several:
        text += f" vs {method_label(row['effect_pair'].split(' - ')[-1])}"
    # a claim whose declared comparators the run lacks in part says so
    only = re.search(r"\(against (.+?) only\b", row.get("claim") or "")
    if only:
        text += f" ({'of' if several else 'vs'} {only.group(1)} only)"
    return text


def _column_name(results: Path, kind, datasets: list[str]) -> str:
    """'street_seg and street_pc (stand-in)': the datasets one column answers for."""
    name = " and ".join(datasets)
    return f"{name} (stand-in)" if _standin(results, datasets[0], kind) else name


def answer_table(embedding_results, supervised_results: Path) -> str:
    """The answer block: the generated-by line, the table and its legend.

    ``embedding_results``: a results folder, or several (the default run's and
    config/street.yaml's): each dataset's claims come from the first that holds them."""
    folders = (
        [embedding_results] if isinstance(embedding_results, str | Path) else embedding_results
    )
    folders = [Path(f) for f in folders]
    columns = []
    for kind, runs in ((EMBEDDING, folders), (SUPERVISED, [Path(supervised_results)])):
        names: dict[str, list[str]] = {}  # dataset -> the datasets its column answers for
        for dataset in DATASETS:
            found = [(r, rows) for r in runs if (rows := _claims(r, dataset, kind))]
            results, rows = found[0] if found else (None, {})
            source = _shared_from(results, dataset) if rows and kind is EMBEDDING else None
            if source in names:  # the same runs as the source's column: named there
                names[source].append(dataset)
            elif rows:
                names[dataset] = [dataset]
                columns.append((results, kind, names[dataset], rows))
    columns = [
        (f"{kind.name}: {_column_name(results, kind, datasets)}, {_units(rows)}", rows)
        for results, kind, datasets, rows in columns
    ]
    if not columns:
        raise ValueError(
            f"none of {', '.join(map(str, folders))} nor {supervised_results} holds claims of "
            f"{' or '.join(DATASETS)}; give the default run's results folder and the "
            "decisive runs' (their tables/claims.csv)."
        )
    lines = [
        f"<!-- generated by `{COMMAND} EMBEDDING_RESULTS SUPERVISED_RESULTS "
        "[--also-embedding MORE_RESULTS]`: edit the generator, not this block -->",
        "",
        "| Question | " + " | ".join(header for header, _ in columns) + " |",
        "|:---|" + ":---|" * len(columns),
    ]
    for question, claim_id in QUESTIONS:
        cells = [cell(rows.get(claim_id)) for _, rows in columns]
        if any(c != "-" for c in cells):
            lines.append(f"| {question} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Each cell: the verdict at 5%, and DUIS − X (or A − B) in points of AUBC with its "
        "95% interval, over the units its column names (encoders' means in the embedding "
        "framework, seeds in the supervised one); where a claim has several comparators, "
        "the weakest comparison, named.",
    ]
    return "\n".join(lines)


def update(embedding_results, supervised_results: Path, readme: Path) -> Path:
    """Rewrite ``readme``'s answer block (``answer_table``); the README is written once,
    whole, or not at all (a ValueError naming what is missing)."""
    body = answer_table(embedding_results, Path(supervised_results))
    text = replace_block(Path(readme).read_text(), BLOCK, body)
    atomic_write_text(readme, text)
    return Path(readme)


def main(argv: list[str] | None = None) -> int:
    """Command line: rewrite the README's answer block."""
    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.splitlines()[0])
    parser.add_argument("embedding_results", type=Path, metavar="EMBEDDING_RESULTS")
    parser.add_argument("supervised_results", type=Path, metavar="SUPERVISED_RESULTS")
    parser.add_argument(
        "--also-embedding",
        type=Path,
        action="append",
        default=[],
        metavar="MORE_RESULTS",
        help="another embedding-framework run's results folder (config/street.yaml's), "
        "for the datasets EMBEDDING_RESULTS does not hold; repeatable",
    )
    parser.add_argument("--readme", type=Path, default=Path("README.md"))
    args = parser.parse_args(argv)
    folders = [args.embedding_results, *args.also_embedding]
    try:
        written = update(folders, args.supervised_results, args.readme)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {written}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
