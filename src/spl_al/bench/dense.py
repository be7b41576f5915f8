"""Dense encoder recipes for segmentation: ``python -m spl_al.bench dense DATASET.npz``.

Can a per-pixel linear classifier on a frozen dense self-supervised encoder
(``spl_al.training.dense_contrastive``, ``spl_al.dense_probe``) segment street scans
well enough for an embedding framework to judge acquisition by it? On the validation
split (``validation_split``: 20% of the training pool; the test split is never read),
at the dataset's budgets (its budget experiment's labeled counts), for each recipe
(``--recipe NAME:KEY=VALUE,...`` over ``DenseEncoderConfig``'s defaults) it trains
``--encoders`` encoders (seeds 0..K-1) on the fit part's scans and their variants, then
per budget and labeled set reports validation mIoU of

- the dense probe on the encoder's features (``DenseProbe``, balance 0.5 as the
  networks weigh classes), and on the features with the local depth features beside
  them ("+ local");
- the per-pixel linear model on local depth features alone
  (``learnability.linear_reference``);
- with ``--network``, the configured network (U-Net or PointNet++) trained as a round
  trains it (observed scans, fp32);
- with ``--units U``, the probe beside the local features as the pipeline's rounds fit
  it: U sampled pixels of each labeled scan (``dense_embedding.sample_units``, the
  encoder's ``units_rng``), at most ``dense_embedding.FIT_UNITS`` a fit, float16 features.

Each encoder's health: final loss / chance, and the effective rank of 4,000 valid
pixels' features (``contrastive.effective_rank``).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from spl_al.bench.encoders import parse_recipe
from spl_al.bench.learnability import learner_score, linear_reference, tuning_split
from spl_al.bench.timing import markdown_table
from spl_al.blas_threads import one_thread
from spl_al.data import Dataset
from spl_al.dense_probe import DenseProbe, local_depth_features
from spl_al.experiment.dense_embedding import FIT_UNITS, sample_units
from spl_al.pool import initial_labeled_set
from spl_al.seeding import units_rng

IGNORE = 255


def probe_miou(
    dataset, features, labeled, held_out, *, seed: int, c: float, balance: float, units=None
):
    """Validation mIoU of the dense probe fitted on the ``labeled`` scans' valid pixels;
    ``features``: (N, H, W, d) of every scan. ``units``: (N, U) flat pixel indices of
    every scan: the probe reads those of the labeled scans alone, at most
    ``dense_embedding.FIT_UNITS``, as the pipeline's rounds fit it (float16 features)."""
    # torch on demand (importing this module does not load it)
    from spl_al.training.metrics import confusion_per_image, segmentation_summary

    keep = dataset.valid[labeled] & (dataset.labels[labeled] != IGNORE)
    x, y = features[labeled][keep], dataset.labels[labeled][keep]
    cap = {}
    if units is not None:
        at = units[labeled].astype(np.int64)
        n, d = len(labeled), features.shape[-1]
        x = np.take_along_axis(features[labeled].reshape(n, -1, d), at[..., None], axis=1)
        x = x.astype(np.float16)
        y = np.take_along_axis(dataset.labels[labeled].reshape(n, -1), at, axis=1)
        held = np.take_along_axis(keep.reshape(n, -1), at, axis=1)
        x, y, cap = x[held], y[held], {"max_pixels": FIT_UNITS}
    with one_thread():  # as a pipeline job fits it
        probe = DenseProbe(len(dataset.classes), c, balance=balance, **cap)
        probe.fit(x, y, np.random.default_rng(seed))
        f_val = features[held_out]
        pred = probe.predict_proba(f_val.reshape(-1, f_val.shape[-1])).argmax(axis=1)
    target = np.where(dataset.valid[held_out], dataset.labels[held_out], IGNORE)
    conf = confusion_per_image(pred.reshape(f_val.shape[:3]), target, len(dataset.classes))
    return float(segmentation_summary(conf.sum(0), dataset.classes)["miou"])


def train_one(dataset, fit_idx, recipe: dict, seed: int, *, levels: int = 1):
    """One encoder on the fit part: (features (N, H, W, d) of every scan's observed
    image, its record with its health, ``contrastive.encoder_health`` on 4,000 of the
    fit part's valid pixels)."""
    # torch on demand (importing this module does not load it)
    from spl_al.training.contrastive import encoder_health
    from spl_al.training.dense_contrastive import (
        DenseEncoderConfig,
        dense_features,
        train_dense_encoder,
    )

    depth, valid = dataset.groups(fit_idx)
    cfg = DenseEncoderConfig.from_dict({**recipe, "seed": seed})
    encoder, record = train_dense_encoder(depth, valid, cfg=cfg, log=os.devnull)
    feats = dense_features(encoder, dataset.depth_m, dataset.valid, levels=levels)
    px = feats[fit_idx][dataset.valid[fit_idx]]
    sample = px[np.random.default_rng(0).choice(len(px), min(4000, len(px)), replace=False)]
    return feats, {**record, "health": encoder_health(record, sample)}


def references(data, entry: dict, sets: dict, held_out, *, network: bool) -> dict:
    """The local-feature model's and (``network``) the configured network's scores,
    {"local": {n: [...]}, "network": {n: [...]}}, one per labeled set."""
    out: dict = {"local": {}, "network": {}}
    recipe = {"model_cfg": entry["train"]["model"], "fit_cfg": entry["train"]["fit"]}
    for n, labeled_sets in sets.items():
        out["local"][n] = [
            linear_reference(data, lab, held_out, s) for s, lab in enumerate(labeled_sets, 1)
        ]
        if network:
            out["network"][n] = [
                learner_score(data, lab, held_out, **recipe, seed=s, variants=False)
                for s, lab in enumerate(labeled_sets, 1)
            ]
    return out


def recipe_rows(data, split, sets: dict, *, local_px, recipe: dict, args, name: str) -> list:
    """Each of ``args.encoders`` encoders of one recipe: its record and its probes'
    scores per budget, alone ("dense") and beside the local features ``local_px`` (N, H,
    W, 9) ("dense_local"); ``split``: (fit, validation) scan indices."""
    fit_idx, held_out = split
    rows = []
    for k in range(args.encoders):
        started = time.perf_counter()
        feats, record = train_one(data, fit_idx, recipe, k, levels=args.levels)
        both = np.concatenate([feats, local_px], axis=-1)
        row = {"seed": k, "record": record, "dense": {}, "dense_local": {}}
        probes = {"dense": (feats, None), "dense_local": (both, None)}
        if args.units:  # the pipeline's sample of each scan's valid pixels
            units = sample_units(data.valid, args.units, units_rng(k))
            probes["dense_units"] = (both, units)
        for n, labeled_sets in sets.items():
            for key, (x, at) in probes.items():
                row.setdefault(key, {})[n] = [
                    probe_miou(
                        data, x, lab, held_out, seed=s, c=args.c, balance=args.balance, units=at
                    )
                    for s, lab in enumerate(labeled_sets, 1)
                ]
        health = record["health"]
        print(
            f"{name} encoder {k}: {record['train_seconds']:.0f} s, {health['verdict']} (loss/"
            f"chance {health['loss_ratio']:.2f}, eff. rank {health['effective_rank']:.1f}); "
            + ", ".join(f"{n}: {100 * np.mean(row['dense_local'][n]):.1f}" for n in sets)
            + f" ({time.perf_counter() - started:.0f} s)",
            flush=True,
        )
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the dense recipes; print their tables; the exit code."""
    # yaml and pandas on demand (importing this module does not load them)
    import yaml

    from spl_al.experiment.plan import labeled_at

    parser = argparse.ArgumentParser(prog="python -m spl_al.bench dense", description=__doc__)
    parser.add_argument("dataset", type=Path, help="the dataset .npz (with variants)")
    parser.add_argument("--only", default="street_seg", help="its config entry")
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument("--recipe", action="append", default=[], help="NAME:KEY=VALUE,...")
    parser.add_argument("--encoders", type=int, default=3, help="encoders per recipe (0: none)")
    parser.add_argument("--labeled-sets", type=int, default=3, help="labeled sets per budget")
    parser.add_argument("--c", type=float, default=1.0, help="the probe's inverse L2 strength")
    parser.add_argument("--balance", type=float, default=0.5, help="class weighting power")
    parser.add_argument("--network", action="store_true", help="train the configured network")
    parser.add_argument("--levels", type=int, default=1, help="decoder levels the probe reads")
    parser.add_argument(
        "--units",
        type=int,
        default=0,
        help="also probe (+ local) as the pipeline fits it: this many sampled pixels a scan",
    )
    parser.add_argument("--out", type=Path, help="write every score here (JSON)")
    args = parser.parse_args(argv)
    entry = yaml.safe_load(args.config.read_text())["datasets"][args.only]
    data = Dataset.load(args.dataset)
    fit_idx, held_out = tuning_split(data)
    rounds = entry["experiments"]["budget"]["rounds"]
    draws = range(1, args.labeled_sets + 1)
    sets = {
        n: [fit_idx[initial_labeled_set(len(fit_idx), n, s)] for s in draws]
        for n in (labeled_at(entry["al"], r) for r in range(rounds))
    }
    scores = {"budgets": list(sets), "recipes": {}}
    scores |= references(data, entry, sets, held_out, network=args.network)
    recipes = [parse_recipe(r) for r in (args.recipe or ["default:"])] if args.encoders else []
    local_px = (
        local_depth_features(data.depth_m, data.valid).astype(np.float32) if recipes else None
    )
    for name, recipe in recipes:
        scores["recipes"][name] = recipe_rows(
            data, (fit_idx, held_out), sets, local_px=local_px, recipe=recipe, args=args, name=name
        )
    print()
    print(render(scores, args.only, len(data.train_idx)))
    if args.out:
        args.out.write_text(json.dumps(scores, indent=1, default=str))
    return 0


def _cell(values) -> str:
    return f"{100 * np.mean(values):.1f} ± {100 * np.std(values):.1f}" if len(values) else "-"


def _per_encoder(rows: list, key: str, n: int) -> list[float]:
    """Each encoder's mean over the labeled sets: the encoder is the unit."""
    return [float(np.mean(r[key][n])) for r in rows]


def render(scores: dict, name: str, n_pool: int) -> str:
    """Markdown: per budget, the local reference, the network and every recipe's probes
    (mean ± sd over encoders, each encoder's mean over its labeled sets), then each
    recipe's probe beside the local features minus the references (points)."""
    header = ["labeled scans", "local features"]
    if scores["network"]:
        header.append("network")
    for recipe, rows in scores["recipes"].items():
        header += [f"{recipe}", f"{recipe} + local"]
        if rows and "dense_units" in rows[0]:
            header.append(f"{recipe} + local, sampled pixels")
    body = []
    for n in scores["budgets"]:
        row = [f"{n} ({100 * n / n_pool:.1f}%)", _cell(scores["local"][n])]
        if scores["network"]:
            row.append(_cell(scores["network"][n]))
        for rows in scores["recipes"].values():
            row += [
                _cell(_per_encoder(rows, "dense", n)),
                _cell(_per_encoder(rows, "dense_local", n)),
            ]
            if rows and "dense_units" in rows[0]:
                row.append(_cell(_per_encoder(rows, "dense_units", n)))
        body.append(row)
    text = f"**{name}: validation mIoU (%)**\n\n" + markdown_table(header, body)
    for recipe, rows in scores["recipes"].items():
        diffs = []
        for n in scores["budgets"]:
            probe = np.mean(_per_encoder(rows, "dense_local", n))
            local = np.mean(scores["local"][n])
            cell = [
                str(n),
                f"{100 * (probe - local):+.1f}",
                f"{100 * min(_per_encoder(rows, 'dense_local', n)) - 100 * local:+.1f}",
            ]
            if scores["network"]:
                cell.append(f"{100 * (probe - np.mean(scores['network'][n])):+.1f}")
            diffs.append(cell)
        head = ["labeled scans", "- local", "- local, worst encoder"]
        if scores["network"]:
            head.append("- network")
        verdicts = [r["record"]["health"]["verdict"] for r in rows]
        text += (
            f"\n\n**{recipe} + local minus the references (points); {len(rows)} encoders: "
            + ", ".join(f"{verdicts.count(v)} {v}" for v in sorted(set(verdicts)))
            + "**\n\n"
            + markdown_table(head, diffs)
        )
    return text
