"""Where a workflow run's time went: ``python -m spl_al.bench pipeline RESULTS --wall S``.

Reads every Snakemake benchmark file under RESULTS/benchmarks (a job's wall time) and
the ``compute_seconds`` line its log ends with (time after the job's heavy imports),
and prints per rule: jobs, job wall, compute, start-up (job wall - compute). Against
the run's wall time on C cores it splits the machine's time into compute, job
start-up (interpreter and imports) and the rest (scheduler, idle cores).

``--rounds`` adds, per dataset and method of the embedding framework, what its rounds
cost: the mean seconds of a round's fit and of a whole round (fit, test, query), from
the records of ``RESULTS/{dataset}/embedding/runs/{method}.json``.
"""

from __future__ import annotations

import argparse
import json
import re
from collections import defaultdict
from pathlib import Path

from spl_al.bench.timing import markdown_table
from spl_al.frameworks import EMBEDDING

_RULE_OF = (
    # a simulated oracle's round 0 copies the shared fit (train_initial): no training
    (re.compile(r"round0_train$"), "train, round 0"),
    (re.compile(r"round\d+_train$"), "train"),
    (re.compile(r"initial(_[a-z]+)?_seed\d+_m\d+_train$"), "train_initial"),
    (re.compile(r"robustness_grid_shard\d+$"), "robustness_grid"),
    (re.compile(r"round\d+_query$"), "query"),
    (re.compile(r"variants_shard\d+$"), "variants_shard"),
    (re.compile(r"table_\w+$"), "table"),
    (re.compile(r"initial(_[a-z]+)?_seed\d+$"), "initial_set"),
    (re.compile(r"real_.+$"), "photon_real_capture"),
)


def rule_of(stem: str) -> str:
    """The Snakemake rule a benchmark file's ``stem`` belongs to."""
    for pattern, rule in _RULE_OF:
        if pattern.search(stem):
            return rule
    return stem


_EMBEDDING_REPORTS = ("table", "curves", "level_curves", "summary", "stats", "batch_conditions")


def embedding_rule_of(stem: str) -> str:
    """The rule of a benchmark file under an embedding framework's folder: an encoder,
    a report rule, else a method's probe runs (their files are named by the method)."""
    if re.fullmatch(r"encoder_seed\d+", stem):
        return "encoder"
    rule = rule_of(stem)
    return f"embedding_{rule}" if rule in _EMBEDDING_REPORTS else "probe_runs"


def job_times(results: Path):
    """Yield (rule, job wall s, compute s or None) for every benchmarked job."""
    for tsv in sorted((results / "benchmarks").rglob("*.tsv")):
        lines = tsv.read_text().splitlines()
        if len(lines) < 2:
            continue
        wall = float(lines[-1].split("\t")[0])
        log = results / "logs" / tsv.relative_to(results / "benchmarks").with_suffix(".log")
        compute = None
        if log.exists():
            match = re.search(r"^compute_seconds: ([0-9.]+)$", log.read_text(), re.M)
            compute = float(match.group(1)) if match else None
        embedded = tsv.parent.name == EMBEDDING.subfolder
        yield (embedding_rule_of if embedded else rule_of)(tsv.stem), wall, compute


def round_rows(results: Path) -> list[list]:
    """[dataset, method, rounds, fit s, round s] of every embedding framework's runs
    file: the mean over its rounds with a query of the fit (``train_seconds``) and of
    the whole round (``seconds``: fit, test, query)."""
    rows = []
    for path in sorted(results.glob(f"*/{EMBEDDING.subfolder}/runs/*.json")):
        records = json.loads(path.read_text())
        queried = [r for r in records if "seconds" in r and "train_seconds" in r]
        if not queried:
            continue
        fits = [r["train_seconds"] for r in queried]
        whole = [r["seconds"] for r in queried]
        rows.append(
            [
                path.parents[2].name,
                path.stem,
                len(records),
                f"{sum(fits) / len(fits):.3f}",
                f"{sum(whole) / len(whole):.3f}",
            ]
        )
    return rows


def rule_totals(results: Path) -> dict:
    """rule -> [jobs, job wall s, compute s] of a run's benchmarked jobs."""
    per_rule = defaultdict(lambda: [0, 0.0, 0.0])
    for rule, wall, compute in job_times(results):
        row = per_rule[rule]
        row[0] += 1
        row[1] += wall
        row[2] += wall if compute is None else min(compute, wall)
    return per_rule


def main(argv: list[str]) -> int:
    """Summarise a run's per-rule benchmark files; print the table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench pipeline")
    parser.add_argument("results", type=Path, help="the run's results folder")
    parser.add_argument("--wall", type=float, required=True, help="the run's wall time, s")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument(
        "--rounds", action="store_true", help="also the embedding framework's round costs"
    )
    args = parser.parse_args(argv)
    if not (args.results / "benchmarks").is_dir():
        print(f"error: {args.results}/benchmarks does not exist; run the workflow first.")
        return 2

    per_rule = rule_totals(args.results)
    rows = []
    for rule, (n, wall, compute) in sorted(per_rule.items(), key=lambda kv: -kv[1][1]):
        rows.append(
            [
                rule,
                n,
                f"{wall:.0f}",
                f"{compute:.0f}",
                f"{wall - compute:.0f}",
                f"{(wall - compute) / n:.2f}",
            ]
        )
    jobs = sum(r[0] for r in per_rule.values())
    job_wall = sum(r[1] for r in per_rule.values())
    compute = sum(r[2] for r in per_rule.values())
    machine = args.wall * args.cores
    rows.append(
        [
            "**all**",
            jobs,
            f"{job_wall:.0f}",
            f"{compute:.0f}",
            f"{job_wall - compute:.0f}",
            f"{(job_wall - compute) / max(jobs, 1):.2f}",
        ]
    )
    print(
        markdown_table(
            ["rule", "jobs", "job wall s", "compute s", "start-up s", "start-up s/job"], rows
        )
    )
    print()
    print(
        f"wall {args.wall:.0f} s x {args.cores} cores = {machine:.0f} core-s: "
        f"compute {compute / machine:.1%}, job start-up {(job_wall - compute) / machine:.1%}, "
        f"scheduler and idle cores {(machine - job_wall) / machine:.1%}; "
        f"scheduler + start-up + idle = {(machine - compute) / machine:.1%}"
    )
    if args.rounds:
        print()
        header = ["dataset", "method", "rounds", "fit s", "round s (fit, test, query)"]
        print("The embedding framework's rounds that queried, mean seconds:\n")
        print(markdown_table(header, round_rows(args.results)))
    return 0
