"""Verdicts at two precisions: does a claim's verdict depend on the CPU's bf16?

``config/precision.yaml`` is the decisive real_cls subset (seeds 1-8; Syn+TypiClust,
Syn+Diversity, DUIS; rounds 0-3) that once reached opposite verdicts at bf16 and fp32
on one CPU. This benchmark compares two finished runs of it, one trained in bf16 and
one in fp32, pair by pair (AUBC over the query rounds, paired over seeds: the
difference, its 95% interval and p) and claim by claim, and says whether each verdict
agrees:

    python -m spl_al.bench precision --run                  # both runs, then the table
    python -m spl_al.bench precision RESULTS_BF16 RESULTS_FP32

``--run`` runs Snakemake on this checkout's workflow twice, into
``results-precision/bf16`` and ``results-precision/fp32`` (~15 min on a 2-core EPYC
with AVX512-BF16), from the folder it is started in.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from functools import partial
from pathlib import Path

import pandas as pd

from spl_al import layout
from spl_al.bench.estimate import cpu_name
from spl_al.bench.timing import markdown_table
from spl_al.data import Dataset
from spl_al.experiment.plan import batch_of, dataset_method, round0_start
from spl_al.frameworks import get_feature_space
from spl_al.pool import read_labeled
from spl_al.strategies import get
from spl_al.strategies.inputs import GROUP_NEEDS
from spl_al.training.compute import Compute

ROOT = Path(__file__).resolve().parents[3]
CONFIG = ROOT / "config" / "precision.yaml"
PRECISIONS = ("bf16", "fp32")


def run_both(folder: Path, jobs: int) -> dict[str, Path]:
    """Run ``config/precision.yaml`` once per precision into ``folder/PRECISION``; the
    folders by precision (a failed run raises)."""
    out = {}
    for precision in PRECISIONS:
        results = folder / precision
        cmd = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), f"-j{jobs}"]
        cmd += ["--configfile", str(CONFIG)]
        cmd += ["--config", f"precision={precision}", f"results={results}"]
        started = time.perf_counter()
        subprocess.run(cmd, check=True)
        print(f"{precision}: {(time.perf_counter() - started) / 60:.1f} min", file=sys.stderr)
        out[precision] = results
    return out


def _verdict(row) -> str:
    """A paired comparison's verdict: which side it resolves for, or unresolved."""
    if not bool(row["resolved"]):
        return "unresolved"
    return f"{row['method_a']} ahead" if row["diff"] > 0 else f"{row['method_b']} ahead"


def pair_rows(tables: dict[str, Path]) -> list[list[str]]:
    """One row per pair of methods: AUBC difference [95% CI], p and verdict at each
    precision, and whether the verdicts agree."""
    frames = {}
    for precision, folder in tables.items():
        cmp = pd.read_csv(folder / "comparisons.csv")
        frames[precision] = cmp[(cmp["experiment"] == "budget") & (cmp["point"] == "AUBC")]
    rows = []
    first, second = (frames[p] for p in PRECISIONS)
    for _, a in first.iterrows():
        match = second[
            (second["method_a"] == a["method_a"]) & (second["method_b"] == a["method_b"])
        ]
        if match.empty:
            continue
        b = match.iloc[0]
        cells = [f"{a['method_a']} − {a['method_b']}"]
        for row in (a, b):
            cells.append(
                f"{row['diff']:+.1f} [{row['ci_low']:+.1f}, {row['ci_high']:+.1f}], "
                f"p = {row['p_value']:.2g}: {_verdict(row)}"
            )
        cells.append(f"{b['diff'] - a['diff']:+.1f}")
        cells.append("yes" if _verdict(a) == _verdict(b) else "**no**")
        rows.append(cells)
    return rows


def claim_rows(tables: dict[str, Path]) -> list[list[str]]:
    """One row per claim both runs judged: what each run's seeds read, agreement."""
    frames = {p: pd.read_csv(folder / "claims.csv") for p, folder in tables.items()}
    first, second = (frames[p].set_index("claim_id") for p in PRECISIONS)
    # what each run's seeds read (a bf16 run decides no claim: its verdicts are
    # inconclusive by rule, report.claims.at_precision)
    column = "seeds_read" if "seeds_read" in first and "seeds_read" in second else "verdict"
    rows = []
    for claim_id in [c for c in first.index if c in second.index]:
        a, b = first.loc[claim_id, column], second.loc[claim_id, column]
        rows.append([first.loc[claim_id, "claim"], a, b, "yes" if a == b else "**no**"])
    return rows


def _interval(aubc: dict) -> str:
    """mean [low, high] in percent (the mean alone without an interval: one seed)."""
    if aubc.get("ci_low") is None:
        return f"{100 * aubc['mean']:.1f}"
    return f"{100 * aubc['mean']:.1f} [{100 * aubc['ci_low']:.1f}, {100 * aubc['ci_high']:.1f}]"


def aubc_rows(tables: dict[str, Path]) -> list[list[str]]:
    """Each method's AUBC over the query rounds, mean [95% CI], at each precision."""
    summaries = {
        p: json.loads((folder / "summary.json").read_text()) for p, folder in tables.items()
    }
    rows = []
    for method in summaries[PRECISIONS[0]]["methods"]:
        cells = [method]
        for precision in PRECISIONS:
            aubc = summaries[precision]["methods"].get(method, {}).get("aubc")
            cells.append(_interval(aubc) if aubc else "-")
        rows.append(cells)
    return rows


def pick_agreement(results: Path, dataset: str) -> list[list[str]]:
    """Scoring precision alone: every query of a finished run redone from the round's
    own weights, the pool scored once under bf16 autocast and once in fp32, the same
    strategy and random stream picking from each. Per method: the share of picked groups
    the two have in common (mean and lowest over the queries) and the queries that pick
    the very same groups. Methods that select on the self-supervised embedding
    (``features: embedding``) are left out: their selection reads no model output."""
    # torch and yaml on demand (importing this module does not load them)
    import numpy as np
    import yaml

    from spl_al.models.configured import load_model
    from spl_al.scoring import compute_inputs

    config = yaml.safe_load((results / "config.yaml").read_text())
    entry = config["datasets"][dataset]
    data = Dataset.load(layout.data_file(results, dataset))
    budget = entry["experiments"]["budget"]
    rows = []
    for name in budget["methods"]:
        method = dataset_method(config, dataset, name)
        start = round0_start(config, dataset, name)
        if get_feature_space(method.features).needs_encoder:
            continue  # selects on the fp32 self-supervised embedding: no model to rescore
        strategy = get(method.strategy, **method.params)
        m = method.variants_seen(data.n_variants) if strategy.needs & GROUP_NEEDS else 0
        depth, valid = data.groups(data.train_idx, n_variants=m)
        shares = []
        for seed in budget["seeds"]:
            for r in range(int(budget["rounds"]) - 1):
                run = layout.run_folder(results, dataset, name, seed)
                round_file = partial(layout.round_file, run, r)
                labeled_path = (
                    round_file("labeled.json")
                    if r
                    else layout.initial_file(results, dataset, seed, start)
                )
                labeled = read_labeled(labeled_path)
                unlabeled = np.setdiff1d(np.arange(len(data.train_idx)), labeled)
                model = load_model(data, entry["train"]["model"], round_file("model.pt"))
                picks = []
                for precision in PRECISIONS:
                    inputs = compute_inputs(
                        model,
                        strategy.needs,
                        depth_m=depth,
                        valid=valid,
                        unlabeled_idx=unlabeled,
                        labeled_idx=labeled,
                        compute=Compute("cpu", precision=precision),
                    )
                    rng = np.random.default_rng([seed, r])
                    batch = batch_of(entry["al"], r + 1, f"datasets.{dataset}.al.batch")
                    picks.append(set(strategy.select(inputs, int(batch), rng)))
                shares.append(len(picks[0] & picks[1]) / len(picks[1]))
        same = sum(share == 1.0 for share in shares)
        rows.append(
            [
                name,
                f"{100 * np.mean(shares):.0f}%",
                f"{100 * min(shares):.0f}%",
                f"{same} of {len(shares)}",
            ]
        )
    return rows


def report(folders: dict[str, Path], dataset: str) -> str:
    """The benchmark's Markdown: AUBC per method, pairs and claims side by side."""
    tables = {p: Path(f) / dataset / "tables" for p, f in folders.items()}
    for precision, folder in tables.items():
        summary = json.loads((folder / "summary.json").read_text())
        trained = summary.get("precision")
        if trained not in (None, precision):
            raise ValueError(
                f"{folder}: its models were trained in {trained}, not {precision}; "
                "give the bf16 run's results folder first, then the fp32 run's."
            )
    n = json.loads((tables["fp32"] / "summary.json").read_text())["n_seeds"]
    head = (
        f"## Verdicts at bf16 and at fp32: {dataset}, {n} seeds ({cpu_name()}, "
        f"{os.cpu_count()} cores, {time.strftime('%Y-%m-%d')})\n\n"
        "AUBC over the query rounds (%), mean [95% CI]:\n\n"
    )
    parts = [
        head + markdown_table(["method", "bf16", "fp32"], aubc_rows(tables)),
        "Paired AUBC differences (points) [95% CI], p, and what they resolve:\n\n"
        + markdown_table(
            ["pair", "bf16", "fp32", "fp32 − bf16", "same verdict"], pair_rows(tables)
        ),
        "Claims:\n\n"
        + markdown_table(["claim", "bf16", "fp32", "same verdict"], claim_rows(tables)),
    ]
    return "\n\n".join(parts) + "\n"


def main(argv: list[str]) -> int:
    """Compare (or with ``--run`` make and compare) a bf16 and an fp32 run."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench precision", description=__doc__)
    parser.add_argument("results", nargs="*", type=Path, help="RESULTS_BF16 RESULTS_FP32")
    parser.add_argument("--run", action="store_true", help="run both precisions first")
    parser.add_argument("--folder", type=Path, default=Path("results-precision"))
    parser.add_argument("--jobs", "-j", type=int, default=2)
    parser.add_argument("--dataset", default="real_cls")
    parser.add_argument(
        "--picks",
        action="store_true",
        help="also redo each query of the bf16 run scored in bf16 and in fp32 (minutes)",
    )
    args = parser.parse_args(argv)
    if args.run:
        folders = run_both(args.folder, args.jobs)
    elif len(args.results) == 2:
        folders = dict(zip(PRECISIONS, args.results, strict=True))
    else:
        parser.error("give RESULTS_BF16 RESULTS_FP32 (two results folders), or --run")
    missing = [str(f) for f in folders.values() if not (f / args.dataset / "tables").is_dir()]
    if missing:
        parser.error(f"{', '.join(missing)}: no {args.dataset}/tables/ (a finished run's folder)")
    print(report(folders, args.dataset))
    if args.picks:
        rows = pick_agreement(folders["bf16"], args.dataset)
        print(
            "The bf16 run's queries redone from the same weights, the pool scored in bf16 "
            "and in fp32 (groups picked in common):\n\n"
            + markdown_table(["method", "mean", "lowest", "same groups"], rows)
        )
    return 0
