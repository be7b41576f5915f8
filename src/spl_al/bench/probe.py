"""Linear probe against the supervised CNN: ``python -m spl_al.bench probe [DATASET.npz ...]``.

How good is the embedding framework's model? For each dataset, on the validation
split (``spl_al.data.validation_split``; the test split is never read), at the
dataset's own budgets (the labeled counts of its embedding budget experiment's
rounds): validation accuracy of

- the linear probe (``spl_al.linear_probe``) on the frozen self-supervised embedding,
  fitted on the labeled groups' observed images and on every image of them (as
  the baselines and the Syn+X methods / DUIS train in the embedding framework), at
  each probe strength ``--c`` (the one the config sets is chosen here);
- the configured CNN trained as a supervised round trains it (observed images, and
  with the variants),
- a logistic regression on the raw pixels (depth and validity downsampled to 16 x 16,
  ``learnability.linear_reference``): what the probe would read without the encoder,

mean ± std over random labeled sets (``--seeds``), drawn from the fit part. The
encoder is trained on the fit part's frames alone (no validation or test image), with
the config's ``embedding.encoder`` recipe; its training time and achieved FLOP rate
are printed.

Without arguments it runs the default config's datasets that have an embedding
framework (synthesised as the pipeline makes them, cached).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from spl_al.bench.learnability import (
    default_datasets,
    learner_score,
    linear_reference,
    tuning_split,
)
from spl_al.bench.timing import markdown_table
from spl_al.data import Dataset
from spl_al.data.dataset import HEADLINE_METRICS
from spl_al.dense_probe import local_depth_features
from spl_al.experiment.encoders import encoder_recipe, encoder_seeds
from spl_al.frameworks import EMBEDDING
from spl_al.linear_probe import LinearProbe
from spl_al.pool import initial_labeled_set
from spl_al.report.display import METRIC_WORDS

SEEDS = (1, 2, 3)
C_VALUES = (0.1, 1.0, 10.0)


def probe_scores(
    dataset, embeddings: np.ndarray, labeled, held_out, *, c: float, variants: bool
) -> float:
    """Validation accuracy of the linear probe fitted on ``labeled`` (sample indices);
    ``embeddings``: (N, G, d) of every sample's images."""
    from threadpoolctl import threadpool_limits

    g = embeddings.shape[1] if variants else 1
    x = embeddings[labeled, :g].reshape(-1, embeddings.shape[-1])
    y = np.repeat(dataset.labels[labeled], g)
    with threadpool_limits(limits=1):  # as a pipeline job fits it (embedding_steps)
        probe = LinearProbe(len(dataset.classes), c).fit(x, y)
    predicted = probe.predict_proba(embeddings[held_out, 0]).argmax(axis=1)
    return float((predicted == dataset.labels[held_out]).mean())


def encode_fit_part(dataset, fit_idx, encoder_cfg: dict, *, log=print):
    """The encoder trained on the fit part's frames, the embeddings (N, G, d) of every
    sample of ``dataset``, and its training record."""
    # torch on demand (importing this module does not load it)
    from spl_al.training.contrastive import EncoderConfig, embed, train_encoder

    depth, valid = dataset.groups(fit_idx)
    encoder, record = train_encoder(depth, valid, cfg=EncoderConfig.from_dict(encoder_cfg))
    depth_all, valid_all = dataset.groups()
    n, g, h, w = depth_all.shape
    flat = embed(encoder, depth_all.reshape(n * g, h, w), valid_all.reshape(n * g, h, w))
    rate = record["flops_per_step"] * record["steps"] / record["train_seconds"] / 1e9
    log(
        f"  encoder: {record['steps']} steps in {record['train_seconds']:.1f} s, "
        f"{rate:.1f} GFLOP/s achieved (fp32)"
    )
    return flat.reshape(n, g, -1), {**record, "gflops": rate}


def probe_encoder(entry: dict) -> dict:
    """The encoder settings the bench trains: the dataset's shared recipe at its first
    encoder seed (``embedding.encoder`` without the plan's ``seeds`` and ``block``)."""
    return {**encoder_recipe(entry), "seed": encoder_seeds(entry)[0]}


def compare(dataset, entry: dict, *, seeds=SEEDS, c_values=C_VALUES, cnn=True, log=print):
    """One row per budget: probe (per C, observed / with variants) and CNN scores."""
    # pandas on demand (importing this module does not load it)
    from spl_al.experiment.plan import labeled_at

    embedding = EMBEDDING.settings(entry)
    fit_idx, held_out = tuning_split(dataset)
    embeddings, record = encode_fit_part(dataset, fit_idx, probe_encoder(entry), log=log)
    rounds = embedding["experiments"]["budget"]["rounds"]
    rows = []
    for r in range(rounds):
        n = labeled_at(entry["al"], r)
        row = {"n": n, "cnn": [], "cnn_variants": [], "pixels_linear": []}
        for seed in seeds:
            labeled = fit_idx[initial_labeled_set(len(fit_idx), n, seed)]
            # what the encoder adds: a logistic regression on the raw (downsampled) pixels
            row["pixels_linear"].append(linear_reference(dataset, labeled, held_out, seed))
            for c in c_values:
                for variants in (False, True):
                    key = f"probe_c{c:g}" + ("_variants" if variants else "")
                    row.setdefault(key, []).append(
                        probe_scores(dataset, embeddings, labeled, held_out, c=c, variants=variants)
                    )
            if cnn:
                recipe = {
                    "model_cfg": entry["train"]["model"],
                    "fit_cfg": entry["train"]["fit"],
                    "seed": seed,
                }
                row["cnn"].append(
                    learner_score(dataset, labeled, held_out, **recipe, variants=False)
                )
                row["cnn_variants"].append(
                    learner_score(dataset, labeled, held_out, **recipe, variants=True)
                )
        log(
            f"  n={n}: "
            + ", ".join(f"{k} {np.mean(v):.3f}" for k, v in row.items() if v and k != "n")
        )
        rows.append(row)
    return rows, record


def dense_embeddings(encoder, depth_m, valid, *, batch_size: int = 64) -> np.ndarray:
    """(n, H, W, c) per-pixel features of a frozen encoder: the last feature map of each
    of its SmallCNN's stages, bilinearly upsampled to the image and concatenated (fp32)."""
    # torch on demand (importing this module does not load it)
    import torch
    import torch.nn.functional as F

    from spl_al.models import model_input

    body = encoder.backbone.body
    out = []
    with torch.no_grad():
        for s in range(0, len(depth_m), batch_size):
            x = model_input(encoder, depth_m[s : s + batch_size], valid[s : s + batch_size])
            h, w = x.shape[2:]
            stages: dict[int, torch.Tensor] = {}
            for layer in body:
                x = layer(x)
                if isinstance(layer, torch.nn.ReLU):
                    stages[x.shape[1]] = x  # the last activation of each width
            maps = [F.interpolate(m, size=(h, w), mode="bilinear") for m in stages.values()]
            out.append(torch.cat(maps, 1).permute(0, 2, 3, 1).numpy())
    return np.concatenate(out)


def segmentation_probe(dataset, labeled, held_out, *, dense, seed: int) -> float:
    """Validation mIoU of a per-pixel logistic regression on a pixel's local depth
    features (``dense_probe.local_depth_features``) and the frozen encoder's ``dense``
    features (n, H, W, c) of every sample, fitted on the ``labeled`` samples' pixels."""
    # torch, scikit-learn and threadpoolctl on demand (importing this module does not load them)
    from sklearn.linear_model import LogisticRegression
    from sklearn.preprocessing import StandardScaler
    from threadpoolctl import threadpool_limits

    from spl_al.training.metrics import confusion_per_image, segmentation_summary

    def features(idx):
        local = local_depth_features(dataset.depth_m[idx], dataset.valid[idx])
        return np.concatenate([local, dense[idx]], axis=-1)

    f_tr = features(labeled)
    keep = dataset.valid[labeled] & (dataset.labels[labeled] != 255)
    x_tr, y_tr = f_tr[keep], dataset.labels[labeled][keep]
    rng = np.random.default_rng(seed)
    if len(y_tr) > 60_000:  # as the linear reference subsamples
        pick = rng.choice(len(y_tr), 60_000, replace=False)
        x_tr, y_tr = x_tr[pick], y_tr[pick]
    with threadpool_limits(limits=1):
        scaler = StandardScaler().fit(x_tr)
        clf = LogisticRegression(max_iter=500, tol=1e-3).fit(scaler.transform(x_tr), y_tr)
    f_val = features(np.asarray(held_out))
    pred = clf.predict(scaler.transform(f_val.reshape(-1, f_val.shape[-1])))
    target = np.where(dataset.valid[held_out], dataset.labels[held_out], 255)
    conf = confusion_per_image(pred.reshape(f_val.shape[:3]), target, len(dataset.classes))
    return float(segmentation_summary(conf.sum(0), dataset.classes)["miou"])


def compare_segmentation(dataset, entry: dict, *, seeds=SEEDS, log=print):
    """One row per budget of a segmentation entry: its network (the config's recipe: the
    U-Net per pixel, PointNet++ per point), the per-pixel linear reference on local
    depth features alone, and the same with a frozen encoder's dense features
    (``embedding.encoder``, trained on the fit part). A point cloud's points are its
    scan's valid pixels, so the per-pixel heads are per-point heads there, scored by
    the same mIoU over valid pixels as the network."""
    # torch and pandas on demand (importing this module does not load them)
    from spl_al.experiment.plan import labeled_at
    from spl_al.training.contrastive import EncoderConfig, train_encoder

    fit_idx, held_out = tuning_split(dataset)
    cfg = EncoderConfig.from_dict(EMBEDDING.settings(entry).get("encoder"))
    depth, valid = dataset.groups(fit_idx)
    encoder, record = train_encoder(depth, valid, cfg=cfg, log=os.devnull)
    dense = dense_embeddings(encoder, dataset.depth_m, dataset.valid)
    log(f"  encoder: {record['train_seconds']:.0f} s; dense features {dense.shape[-1]}")
    rounds = entry["experiments"]["budget"]["rounds"]
    rows = []
    for r in range(rounds):
        n = labeled_at(entry["al"], r)
        network = entry["train"]["model"].get("arch", "unet")
        row = {"n": n, network: [], "pixel_linear": [], "pixel_linear_encoder": []}
        for seed in seeds:
            labeled = fit_idx[initial_labeled_set(len(fit_idx), n, seed)]
            row["pixel_linear"].append(linear_reference(dataset, labeled, held_out, seed))
            row["pixel_linear_encoder"].append(
                segmentation_probe(dataset, labeled, held_out, dense=dense, seed=seed)
            )
            recipe = {"model_cfg": entry["train"]["model"], "fit_cfg": entry["train"]["fit"]}
            row[network].append(
                learner_score(dataset, labeled, held_out, **recipe, seed=seed, variants=False)
            )
        log(f"  n={n}: " + ", ".join(f"{k} {np.mean(v):.3f}" for k, v in row.items() if k != "n"))
        rows.append(row)
    return rows, record


def _cell(values) -> str:
    return f"{100 * np.mean(values):.1f} ± {100 * np.std(values):.1f}" if values else "-"


def render(name: str, rows: list[dict], n_pool: int, metric: str = "accuracy") -> str:
    """Markdown: one row per budget, one column per learner."""
    keys = [k for k in rows[0] if k != "n" and rows[0][k]]
    header = ["labeled", *(k.replace("_", " ") for k in keys)]
    body = [
        [f"{r['n']} ({100 * r['n'] / n_pool:.1f}%)", *(_cell(r[k]) for k in keys)] for r in rows
    ]
    return (
        f"**{name}: validation {metric} (%), mean ± std over labeled sets**\n\n"
        + markdown_table(header, body)
    )


def main(argv: list[str] | None = None) -> int:
    """Run the probe benchmark; print its tables; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench probe")
    parser.add_argument("datasets", nargs="*", type=Path, help="dataset .npz files (with variants)")
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument(
        "--only", nargs="*", help="config dataset names, one per file given (default: every one)"
    )
    parser.add_argument("--seeds", type=int, nargs="*", default=list(SEEDS))
    parser.add_argument("--c", type=float, nargs="*", default=list(C_VALUES))
    parser.add_argument("--no-cnn", action="store_true", help="the probe alone (seconds)")
    args = parser.parse_args(argv)
    import yaml

    config = yaml.safe_load(args.config.read_text())
    # classification entries with an embedding framework; a segmentation one named with
    # --only is compared per pixel (an encoder with the default recipe unless it sets one)
    entries = {
        k: v
        for k, v in config["datasets"].items()
        if EMBEDDING.enabled(v) or v.get("task") == "segmentation"
    }
    with tempfile.TemporaryDirectory() as tmp:
        if args.datasets:
            # each file is read with the config entry --only names (else its file name)
            names = args.only or [p.stem for p in args.datasets]
            named = [
                (n, Dataset.load(p), entries[n]) for n, p in zip(names, args.datasets, strict=True)
            ]
        else:
            names = args.only or [k for k, v in entries.items() if EMBEDDING.enabled(v)]
            cache = Path(tmp)
            named = [
                (n, d, entries[n]) for n, d, _m, _f in default_datasets(args.config, names, cache)
            ]
        for name, data, entry in named:
            started = time.perf_counter()
            print(f"{name}:")
            if data.task == "segmentation":
                rows, _ = compare_segmentation(data, entry, seeds=args.seeds)
            else:
                rows, _ = compare(
                    data, entry, seeds=args.seeds, c_values=args.c, cnn=not args.no_cnn
                )
            print()
            metric = METRIC_WORDS[HEADLINE_METRICS[data.task]]
            print(render(name, rows, len(data.train_idx), metric))
            print(f"\n({time.perf_counter() - started:.0f} s)\n")
    return 0
