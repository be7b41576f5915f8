"""The embedding framework for segmentation: a dense encoder's features of sampled
units, and every round of one method's runs on them.

``encode_scans`` trains a dataset's dense self-supervised encoder
(``spl_al.training.dense_contrastive``) on its training scans and their SIV variants
(no label, no test scan) and keeps what the runs read: the features of
``UNITS_PER_SCAN`` units of every training scan, the same pixels in each image of its
group, drawn once per encoder from the observed scan's valid pixels
(``seeding.units_rng``), and the features of every valid pixel of the test split. A
unit's features are the encoder's beside the nine ``dense_probe.local_depth_features``.
A scan's points are its valid pixels (street_pc's clouds are street_seg's scans), so the
same units serve per-pixel and per-point segmentation.

``dense_run`` plays one (method, seed) run: each round fits ``DenseProbe`` on the
labeled scans' units (every image of a group for the Syn family, the observed ones for
the baselines, as the networks train), measures mIoU on the test split's valid pixels,
and queries from ``dense_probe_inputs``: DUIS's margin and inconsistency averaged over
a scan's units, the diversity on the units' features pooled per scan.

Why a sample of units: a scan holds ~3,000 valid pixels of 41 features each, so every
pixel of street_seg's 210 training scans' 5 images is 700 MB an encoder at fp32, and a
round's fit on every labeled pixel takes ~1 s. 512 units a scan keep 44 MB (float16)
and a fit at most ``FIT_UNITS`` in 0.1-0.3 s, for 0.3-1.4 mIoU points below the probe
fitted on every pixel at 6-36 scans (docs/benchmarks.md#segmentation-in-the-embedding-framework).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from spl_al.dense_probe import (
    DEFAULT_BALANCE,
    DEFAULT_C,
    DenseProbe,
    dense_probe_inputs,
    local_depth_features,
)
from spl_al.experiment.encoders import check_split
from spl_al.label_codes import IGNORE_INDEX
from spl_al.seeding import units_rng

UNITS_PER_SCAN = 512
"""Units (pixels) kept of each training scan."""
FIT_UNITS = 10_000
"""Labeled units a round's fit reads at most (a uniform draw of them)."""
HEALTH_UNITS = 4000
"""Observed units whose encoder features give the effective rank of the health check."""


def sample_units(valid: np.ndarray, n_units: int, rng: np.random.Generator) -> np.ndarray:
    """(N, n_units) flat pixel indices of N scans' (N, H, W) ``valid`` masks: a uniform
    draw without replacement of each scan's valid pixels, in pixel order; a scan with
    fewer valid pixels than ``n_units`` keeps them all and pads with void ones."""
    flat = np.asarray(valid, dtype=bool).reshape(len(valid), -1)
    key = rng.random(flat.shape)
    key[~flat] = 2.0  # voids sort after every valid pixel
    units = np.argsort(key, axis=1, kind="stable")[:, : int(n_units)]
    return np.sort(units, axis=1).astype(np.int32)


def _features(encoder, depth_m, valid, device) -> np.ndarray:
    """(n, H * W, d + 9) float32: the encoder's features and the local depth ones."""
    # torch on demand: the probe runs read the saved features without it
    from spl_al.training.dense_contrastive import dense_features

    f = dense_features(encoder, depth_m, valid, device=device)
    both = np.concatenate([f, local_depth_features(depth_m, valid).astype(np.float32)], axis=-1)
    return both.reshape(len(depth_m), -1, both.shape[-1])


def encode_scans(data, cfg, *, device=None, log=None, chunk: int = 32):
    """Train the dense encoder of ``cfg`` (``DenseEncoderConfig``) on ``data``'s
    training scans and keep its features of their units and of the test split.

    Returns (encoder, record, arrays, health_features): ``arrays`` are the embeddings
    file's (``train`` (N, G, U, D) float16, ``train_valid`` (N, G, U), ``train_units``
    (N, U) flat pixel indices, ``test`` (T, D) float16 of the test split's T valid
    pixels, ``test_units`` (T,) their flat indices into (n_test, H * W)), and
    ``health_features`` (n, d) the encoder's own features of observed units.
    """
    # torch on demand: the probe runs read the saved features without it
    from spl_al.training.dense_contrastive import train_dense_encoder

    depth, valid = data.groups(data.train_idx)
    n, g, h, w = depth.shape
    model, record = train_dense_encoder(depth, valid, cfg=cfg, device=device, log=log)
    started = time.perf_counter()
    rng = units_rng(cfg.seed)
    units = sample_units(valid[:, 0], UNITS_PER_SCAN, rng)
    train = None
    for s in range(0, n, chunk):
        b = min(chunk, n - s)
        f = _features(
            model, depth[s : s + b].reshape(b * g, h, w), valid[s : s + b].reshape(-1, h, w), device
        )
        at = np.repeat(units[s : s + b], g, axis=0)[..., None]
        kept = np.take_along_axis(f, at, axis=1).reshape(b, g, -1, f.shape[-1])
        if train is None:
            train = np.empty((n, g, units.shape[1], f.shape[-1]), dtype=np.float16)
        train[s : s + b] = kept
    flat_valid = valid.reshape(n, g, -1)
    train_valid = np.take_along_axis(flat_valid, np.repeat(units[:, None], g, axis=1), axis=2)
    test_depth = data.depth_m[data.test_idx]
    test_valid = np.isfinite(test_depth)
    test = [
        _features(model, test_depth[s : s + chunk], test_valid[s : s + chunk], device)[
            test_valid[s : s + chunk].reshape(min(chunk, len(test_depth) - s), -1)
        ].astype(np.float16)
        for s in range(0, len(test_depth), chunk)
    ]
    record["embed_seconds"] = round(time.perf_counter() - started, 3)
    record["units_per_scan"] = int(units.shape[1])
    d = int(record["feature_dim"])
    obs = train[:, 0][train_valid[:, 0]][:, :d].astype(np.float32)
    health = obs[rng.choice(len(obs), min(HEALTH_UNITS, len(obs)), replace=False)]
    arrays = {
        "train": train,
        "train_valid": train_valid,
        "train_units": units,
        "test": np.concatenate(test) if test else np.zeros((0, train.shape[-1]), np.float16),
        "test_units": np.flatnonzero(test_valid.reshape(len(test_depth), -1)),
    }
    return model, record, arrays, health


@dataclass(frozen=True)
class DenseProbeData:
    """What every run of a segmentation dataset reads: the units' features, the
    oracle's unit classes (read for labeled scans only), the test split's pixel classes
    and levels, and record facts."""

    train: np.ndarray  # (N, G, U, D) float32 (float16 on disk)
    train_valid: np.ndarray  # (N, G, U) bool
    unit_labels: np.ndarray  # (N, U)
    test: np.ndarray  # (T, D) float32, the test split's labeled valid pixels
    test_labels: np.ndarray  # (T,)
    test_levels: np.ndarray  # (T,) the level of each pixel's scan
    classes: tuple
    n_total: int
    standin: bool
    encoder: tuple[int, str] = (0, "healthy")


def load_dense(path, data, *, n_total: int, encoder: tuple[int, str]) -> DenseProbeData:
    """``encode_scans``'s file as a run reads it, checked against ``data``'s split."""
    with np.load(path, allow_pickle=False) as f:
        if "train_units" not in f.files:
            raise ValueError(
                f"{path}: embeddings of a classification encoder, but the dataset segments; "
                "train the encoder again (remove it and rerun)."
            )
        check_split(f, data, path)
        arrays = {k: f[k] for k in ("train", "train_valid", "train_units", "test", "test_units")}
    n_train = len(data.train_idx)
    train_labels = data.labels[data.train_idx].reshape(n_train, -1)
    test_labels = data.labels[data.test_idx].reshape(-1)[arrays["test_units"]]
    pixels = int(np.prod(data.depth_m.shape[1:]))
    counted = test_labels != IGNORE_INDEX  # a test pixel without a label is never scored
    return DenseProbeData(
        train=arrays["train"].astype(np.float32),  # read every round: converted once
        train_valid=arrays["train_valid"],
        unit_labels=np.take_along_axis(train_labels, arrays["train_units"].astype(np.int64), 1),
        test=arrays["test"][counted].astype(np.float32),  # read every round: converted once
        test_labels=test_labels[counted],
        test_levels=data.level[data.test_idx][arrays["test_units"][counted] // pixels],
        classes=tuple(data.classes),
        n_total=int(n_total),
        standin=bool(data.meta.get("synthetic_standin", False)),
        encoder=encoder,
    )


def fit_probe(
    facts: DenseProbeData, labeled, n_images: int, *, probe: dict, rng, start=None
) -> tuple:
    """(``DenseProbe`` fitted on the ``labeled`` scans' valid units of their first
    ``n_images`` images, and the x (n, D) and y (n,) it read before its draw of
    ``FIT_UNITS``); ``start``: the run's previous probe (``DenseProbe.fit``)."""
    v = facts.train_valid[labeled, :n_images]
    y = np.broadcast_to(facts.unit_labels[labeled][:, None], v.shape)
    keep = v & (y != IGNORE_INDEX)
    x = facts.train[labeled, :n_images][keep]
    model = DenseProbe(
        len(facts.classes),
        float(probe.get("c", DEFAULT_C)),
        balance=float(probe.get("balance", DEFAULT_BALANCE)),
        max_pixels=FIT_UNITS,
    )
    return model.fit(x, y[keep], rng, start=start), x, y[keep]


def test_miou(facts: DenseProbeData, model: DenseProbe) -> tuple[float, dict]:
    """(mIoU over the test split's labeled valid pixels, level -> mIoU of that MSPPP
    level's scans), ``training.metrics.segmentation_summary``'s definition."""
    # torch (under training.metrics) on demand: loaded once per job
    from spl_al.data.dataset import LEVELS
    from spl_al.training.metrics import segmentation_summary

    c = len(facts.classes)
    cells = facts.test_labels.astype(np.int64) * c + model.predict(facts.test)
    levels = facts.test_levels

    def miou(mask):
        conf = np.bincount(cells[mask], minlength=c * c).reshape(c, c)
        return segmentation_summary(conf, facts.classes)["miou"]

    per_level = {lv: miou(levels == lv) for lv in LEVELS if (levels == lv).any()}
    return miou(np.ones(len(cells), dtype=bool)), per_level


def query_inputs(facts: DenseProbeData, model, needs, pool, *, n_images: int, head=None):
    """``dense_probe_inputs`` of the run's pool (``spl_al.pool.Pool``)."""
    return dense_probe_inputs(
        model,
        facts.train,
        facts.train_valid,
        needs,
        unlabeled_idx=pool.unlabeled_idx,
        labeled_idx=pool.labeled_idx,
        n_images=n_images,
        head=head,
    )
