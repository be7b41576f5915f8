"""Encoder recipes across encoder seeds: ``python -m spl_al.bench encoders``.

The embedding framework's verdicts average over several encoders (a cluster design,
docs/method.md §7), so a recipe must be cheap enough to train many of and stable
across their seeds. For each dataset with an embedding framework and each recipe
(the config's ``embedding.encoder``, updated by ``--recipe NAME:KEY=VALUE,...``), this
trains ``--encoders`` encoders (seeds 0..K-1) on the fit part of the validation split
(``spl_al.bench.learnability.tuning_split``: the test split is never read) and
prints, per recipe:

- cost: seconds an encoder (one thread unless ``--threads``) and its achieved fp32
  GFLOP/s;
- health, read without a label (``spl_al.training.contrastive.encoder_health``): the
  final loss as a share of chance, the embeddings' effective rank, the verdicts;
- the linear probe's validation accuracy at the dataset's embedding budgets, fitted on
  observed images and on every image of a group, over ``--labeled-sets`` random labeled
  sets per encoder;
- what DUIS's inconsistency term has left to read: over the unlabeled fit-part groups,
  with the probe fitted on the first query round's labels (with variants), the
  coefficient of variation of the inconsistency d and its Spearman correlation with the
  margin gamma (d = 0 everywhere: CV 0; d a copy of the margin's ranking: rho = -1);

and, against ``--baseline`` (the first recipe), the paired difference in probe
accuracy per budget: averaged over the labeled sets within each encoder seed, then the
95% t-interval over the K seeds (non-inferiority: its lower bound above -1 point).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from spl_al.bench.learnability import default_datasets, tuning_split
from spl_al.bench.probe import probe_scores
from spl_al.bench.timing import markdown_table
from spl_al.blas_threads import one_thread
from spl_al.data import Dataset
from spl_al.frameworks import EMBEDDING
from spl_al.linear_probe import LinearProbe
from spl_al.pool import initial_labeled_set
from spl_al.strategies.duis import margin_and_inconsistency

NON_INFERIORITY_PP = -1.0
"""The lower 95% bound (points) a cheaper recipe's probe accuracy must stay above."""


def parse_recipe(text: str) -> tuple[str, dict]:
    """``"cheap:steps=150,batch_size=64"`` -> ("cheap", {"steps": 150, "batch_size": 64})
    (values read as YAML); ``"today:"`` is the config's recipe unchanged."""
    import yaml

    name, sep, rest = text.partition(":")
    if not sep or not name:
        raise ValueError(f"--recipe takes NAME:KEY=VALUE,... (e.g. cheap:steps=150), got {text!r}.")
    out = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        if not eq or not key:
            raise ValueError(f"--recipe {name}: expected KEY=VALUE, got {item!r}.")
        out[key.strip()] = yaml.safe_load(value)
    return name, out


def _inconsistency_signal(dataset, emb, labeled, unlabeled, c: float) -> dict:
    """CV of DUIS's inconsistency over ``unlabeled`` groups and its Spearman rho with the
    margin, the probe fitted on ``labeled`` groups' every image."""
    from scipy.stats import spearmanr  # 0.7 s to import: on demand

    g = emb.shape[1]
    probe = LinearProbe(len(dataset.classes), c).fit(
        emb[labeled].reshape(-1, emb.shape[-1]), np.repeat(dataset.labels[labeled], g)
    )
    b = len(unlabeled)
    probs = probe.predict_proba(emb[unlabeled].reshape(b * g, -1)).reshape(b, g, 1, -1)
    gamma, d = margin_and_inconsistency(probs)
    cv = float(d.std() / d.mean()) if d.mean() > 0 else 0.0
    rho = float(spearmanr(d, gamma).statistic) if d.std() > 0 else math.nan
    return {"d_mean": float(d.mean()), "d_cv": cv, "rho_margin": rho}


def run_recipe(
    dataset, entry: dict, recipe: dict, *, encoders, labeled_sets, log=print, saved=None
):
    """One recipe's encoders on one dataset: a list of per-encoder results (``saved``,
    called with it after every encoder, keeps a run cut short)."""
    # torch and pandas on demand (importing this module does not load them)
    from spl_al.experiment.plan import labeled_at
    from spl_al.training.contrastive import EncoderConfig, embed, encoder_health, train_encoder

    embedding = EMBEDDING.settings(entry)
    c = float((embedding.get("probe") or {}).get("c", 1.0))
    fit_idx, held_out = tuning_split(dataset)
    rounds = int(embedding["experiments"]["budget"]["rounds"])
    budgets = [labeled_at(entry["al"], r) for r in range(rounds)]
    depth, valid = dataset.groups(fit_idx)
    depth_all, valid_all = dataset.groups()
    n, g, h, w = depth_all.shape
    out = []
    for seed in encoders:
        cfg = EncoderConfig.from_dict({**recipe, "seed": int(seed)})
        encoder, record = train_encoder(depth, valid, cfg=cfg, log=os.devnull)
        emb = embed(encoder, depth_all.reshape(n * g, h, w), valid_all.reshape(n * g, h, w))
        emb = emb.reshape(n, g, -1)
        health = encoder_health(record, emb[fit_idx, 0])
        rate = record["flops_per_step"] * record["steps"] / record["train_seconds"] / 1e9
        result = {
            "seed": int(seed),
            "seconds": record["train_seconds"],
            "gflops": rate,
            **health,
            "probe": {},
            "probe_variants": {},
        }
        with one_thread():
            for n_lab in budgets:
                for key, variants in (("probe", False), ("probe_variants", True)):
                    result[key][n_lab] = [
                        probe_scores(
                            dataset,
                            emb,
                            fit_idx[initial_labeled_set(len(fit_idx), n_lab, j)],
                            held_out,
                            c=c,
                            variants=variants,
                        )
                        for j in range(1, labeled_sets + 1)
                    ]
            signal = []
            for j in range(1, labeled_sets + 1):
                pick = initial_labeled_set(len(fit_idx), budgets[min(1, len(budgets) - 1)], j)
                rest = np.setdiff1d(np.arange(len(fit_idx)), pick)
                signal.append(_inconsistency_signal(dataset, emb, fit_idx[pick], fit_idx[rest], c))
        result.update({k: float(np.nanmean([s[k] for s in signal])) for k in signal[0]})
        log(
            f"  seed {seed}: {result['seconds']:.1f} s, {rate:.1f} GFLOP/s, loss "
            f"{result['loss_ratio']:.2f} of chance, rank {result['effective_rank']:.1f} "
            f"({result['verdict']}), probe "
            + " / ".join(f"{100 * np.mean(v):.1f}" for v in result["probe"].values())
            + f", d CV {result['d_cv']:.2f}, rho {result['rho_margin']:.2f}"
        )
        out.append(result)
        if saved is not None:
            saved(out)
    return out


def _paired(new: list[dict], base: list[dict], key: str, n_lab) -> tuple[float, float, float]:
    """Mean and 95% t-interval (points) of new - base probe accuracy at ``n_lab``,
    averaged over labeled sets within each encoder seed, then over the seeds."""
    # pandas on demand (importing this module does not load it)
    from spl_al.report.stats import t_interval

    by_seed = {r["seed"]: np.mean(r[key][n_lab]) for r in base}
    d = np.array(
        [100 * (np.mean(r[key][n_lab]) - by_seed[r["seed"]]) for r in new if r["seed"] in by_seed]
    )
    low, high = t_interval(d)
    return float(d.mean()), low, high


def render(name: str, results: dict[str, list[dict]], baseline: str) -> str:
    """The recipe table and the non-inferiority table of one dataset (Markdown)."""
    first = next(iter(results.values()))[0]
    budgets = list(first["probe"])
    header = ["recipe", "s / encoder", "GFLOP/s", "loss / chance", "eff. rank", "verdicts"]
    header += [f"probe {n} (obs / var)" for n in budgets] + ["d CV", "rho(d, margin)"]
    rows = []
    for recipe, res in results.items():

        def span(key, res=res):
            v = np.array([r[key] for r in res], dtype=float)
            return f"{v.mean():.2f} [{v.min():.2f}, {v.max():.2f}]"

        verdicts = {}
        for r in res:
            verdicts[r["verdict"]] = verdicts.get(r["verdict"], 0) + 1
        row = [
            recipe,
            f"{np.mean([r['seconds'] for r in res]):.1f}",
            f"{np.mean([r['gflops'] for r in res]):.0f}",
            span("loss_ratio"),
            span("effective_rank"),
            ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items())),
        ]
        for n in budgets:
            obs = [100 * np.mean(r["probe"][n]) for r in res]
            var = [100 * np.mean(r["probe_variants"][n]) for r in res]
            row.append(f"{np.mean(obs):.1f} ± {np.std(obs, ddof=1):.1f} / {np.mean(var):.1f}")
        row += [span("d_cv"), span("rho_margin")]
        rows.append(row)
    sets, k = len(first["probe"][budgets[0]]), len(next(iter(results.values())))
    text = f"**{name}: {sets} labeled sets x {k} encoders per recipe**\n\n"
    text += markdown_table(header, rows)
    others = [r for r in results if r != baseline]
    if others:
        header = ["recipe - " + baseline] + [f"{n} labeled: obs / var" for n in budgets]
        rows = []
        for recipe in others:
            row = [recipe]
            for n in budgets:
                cells = []
                for key in ("probe", "probe_variants"):
                    mean, low, high = _paired(results[recipe], results[baseline], key, n)
                    ok = "" if low > NON_INFERIORITY_PP else " ✗"
                    cells.append(f"{mean:+.1f} [{low:+.1f}, {high:+.1f}]{ok}")
                row.append(" / ".join(cells))
            rows.append(row)
        text += (
            f"\n\n**{name}: probe accuracy, recipe - {baseline} (points, 95% t-interval over "
            f"encoder seeds; ✗: lower bound at or below {NON_INFERIORITY_PP:+g})**\n\n"
        )
        text += markdown_table(header, rows)
    return text


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench encoders")
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument("--only", nargs="*", help="config dataset names (default: every one)")
    parser.add_argument(
        "--dataset-file", type=Path, nargs="*", help="dataset .npz files, one per --only name"
    )
    parser.add_argument(
        "--recipe",
        action="append",
        default=None,
        help="NAME:KEY=VALUE,... over the config's recipe (repeatable; default 'config:')",
    )
    parser.add_argument("--encoders", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=0, help="encoder seeds start here")
    parser.add_argument("--labeled-sets", type=int, default=10)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", type=Path, help="write every per-encoder result as JSON")
    parser.add_argument(
        "--merge",
        type=Path,
        nargs="*",
        help="print the tables of --out files (e.g. of runs in parallel) instead of training",
    )
    parser.add_argument("--baseline", help="the recipe the others are paired with (default: first)")
    return parser


def merged_tables(paths, baseline: str | None = None) -> str:
    """The tables of ``--out`` files, the same recipe's encoders of every file pooled."""
    merged: dict = {}
    for path in paths:
        for name, results in json.loads(Path(path).read_text()).items():
            for recipe, rows in results.items():
                merged.setdefault(name, {}).setdefault(recipe, []).extend(rows)
    return "\n".join(
        render(name, results, baseline or next(iter(results))) + "\n"
        for name, results in merged.items()
    )


def _datasets(args, config: dict, tmp: Path):
    names = args.only or [k for k, v in config["datasets"].items() if EMBEDDING.enabled(v)]
    if args.dataset_file:
        return [
            (n, Dataset.load(p), config["datasets"][n])
            for n, p in zip(names, args.dataset_file, strict=True)
        ]
    return [
        (n, d, config["datasets"][n]) for n, d, _m, _f in default_datasets(args.config, names, tmp)
    ]


def main(argv: list[str] | None = None) -> int:
    """Run the encoder benchmark; print its tables; the exit code."""
    args = _parser().parse_args(argv)
    if args.merge:
        print(merged_tables(args.merge, args.baseline))
        return 0
    import torch
    import yaml

    torch.set_num_threads(args.threads)
    config = yaml.safe_load(args.config.read_text())
    recipes = [parse_recipe(r) for r in (args.recipe or ["config:"])]
    everything: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, data, entry in _datasets(args, config, Path(tmp)):
            base = {
                k: v
                for k, v in (EMBEDDING.settings(entry).get("encoder") or {}).items()
                if k not in ("seed", "seeds", "block")
            }
            results = everything.setdefault(name, {})
            for recipe, overrides in recipes:
                print(f"{name} / {recipe}: {json.dumps({**base, **overrides})}", flush=True)
                started = time.perf_counter()

                def save(rows, recipe=recipe, results=results):  # a cut run keeps them
                    results[recipe] = rows
                    if args.out:
                        args.out.write_text(json.dumps(everything, indent=1, default=str))

                run_recipe(
                    data,
                    entry,
                    {**base, **overrides},
                    encoders=range(args.first_seed, args.first_seed + args.encoders),
                    labeled_sets=args.labeled_sets,
                    log=lambda line: print(line, flush=True),
                    saved=save,
                )
                print(f"  ({time.perf_counter() - started:.0f} s)", flush=True)
            print(f"\n{render(name, results, args.baseline or recipes[0][0])}\n")
    return 0
