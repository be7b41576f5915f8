"""The small datasets behind the recorded Label Studio exports (tests/fixtures/label_studio).

``scripts/label-studio-roundtrip.py --record`` wrote the segmentation export from the
batch of ``segmentation_dataset()`` (training groups 0, 2, 3) with the pre-annotations
of ``probabilities``; the tests rebuild the same dataset to read it back.
"""

from __future__ import annotations

import numpy as np

from spl_al.data import Dataset

CLASSES = ["road", "car", "building"]
SHAPE = (24, 32)


def segmentation_dataset(n: int = 6) -> Dataset:
    """Street-like masks: building on top, road at the bottom, one car per image."""
    rng = np.random.default_rng(7)
    h, w = SHAPE
    labels = np.zeros((n, h, w), np.uint8)
    labels[:, : h // 3] = 2
    depth = np.empty((n, h, w), np.float32)
    rows = np.linspace(30.0, 4.0, h, dtype=np.float32)[:, None]
    for i in range(n):
        x = 3 + 4 * i
        labels[i, h // 2 : h // 2 + 6, x : x + 8] = 1
        depth[i] = np.where(labels[i] == 2, 20.0, rows) + rng.normal(0, 0.1, (h, w))
        depth[i][labels[i] == 1] = 9.0
    depth[:, 0, :4] = np.nan  # no return
    labels[:, 0, :4] = 255
    return Dataset(
        "segmentation",
        CLASSES,
        depth,
        labels,
        ["train"] * (n - 1) + ["test"],
        np.full(n, 3.0),
        np.full(n, 0.5),
        ["medium"] * n,
        uid=np.arange(n) + 500,
        variant_depth_m=depth[:, None] + 0.5,
        variant_msppp=np.full((n, 1), 1.0),
        variant_sbr=np.full((n, 1), 0.2),
    )


def probabilities(data: Dataset, pool) -> np.ndarray:
    """(n, C, H, W) probabilities of a stand-in model that is right on most pixels."""
    rng = np.random.default_rng(3)
    labels = data.labels[data.train_idx[np.asarray(pool)]].astype(np.int64)
    k = len(data.classes)
    logits = rng.normal(0, 1.0, (len(labels), k, *SHAPE))
    onehot = np.eye(k)[np.minimum(labels, k - 1)].transpose(0, 3, 1, 2)
    logits += 2.5 * onehot
    e = np.exp(logits - logits.max(axis=1, keepdims=True))
    return (e / e.sum(axis=1, keepdims=True)).astype(np.float32)
