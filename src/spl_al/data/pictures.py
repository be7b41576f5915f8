"""Pictures of a dataset, for a person judging whether the data look like SPL data.

- ``contact_sheet``: a few samples per class, clean depth beside the observed SPL
  image (segmentation: clean depth, observed depth and labels per scene).
- ``variants_sheet``: one sample's clean depth, observed image and its M variants,
  each titled with its condition (MSPPP, SBR) and void fraction.

Depth is coloured per sample over a range shared by all its images (2nd to 98th
percentile of the clean depth), voids are black; the figures, colours and ranges are
``spl_al.plotting``'s (matplotlib imported only when a sheet is drawn).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.data.dataset import Dataset
from spl_al.label_codes import IGNORE_INDEX
from spl_al.plotting import (
    condition_title,
    depth_range,
    figure,
    label_cmap,
    save_png,
    show_image,
)


def _pick(dataset: Dataset, idx: np.ndarray, k: int, rng) -> np.ndarray:
    return np.sort(rng.choice(idx, size=min(k, idx.size), replace=False)) if idx.size else idx


def contact_sheet(dataset: Dataset, path, per_class: int = 4, seed: int = 0) -> Path:
    """PNG of ``per_class`` random samples of every class: clean depth | observed image.

    For segmentation, ``per_class`` * 2 scenes, one per row: clean depth, observed
    depth, labels. Titles give the MSPPP level (H/M/L), MSPPP and SBR.
    """
    if per_class < 1:
        raise ValueError(f"per_class must be >= 1, got {per_class!r}.")
    rng = np.random.default_rng(seed)
    if dataset.task == "segmentation":
        return _segmentation_sheet(dataset, path, per_class * 2, rng)
    has_clean = dataset.clean_depth_m is not None
    per_sample = 2 if has_clean else 1
    h, w = dataset.image_shape
    cell = 1.0
    n_rows = len(dataset.classes)
    fig = figure(cell * per_class * per_sample * w / h + 1.0, cell * n_rows + 0.4)
    axes = fig.subplots(n_rows, per_class * per_sample, squeeze=False)
    for c, name in enumerate(dataset.classes):
        chosen = _pick(dataset, np.flatnonzero(dataset.labels == c), per_class, rng)
        for k in range(per_class):
            cells = axes[c, k * per_sample : (k + 1) * per_sample]
            if k >= chosen.size:
                for ax in cells:
                    ax.axis("off")
                continue
            i = chosen[k]
            clean = dataset.clean_depth_m[i] if has_clean else None
            lo, hi = depth_range(clean, dataset.depth_m[i])
            if has_clean:
                show_image(
                    cells[0], clean, vmin=lo, vmax=hi, title=f"clean {np.nanmedian(clean):.3g} m"
                )
            obs_title = condition_title(dataset.msppp[i], dataset.sbr[i], dataset.level[i])
            show_image(cells[-1], dataset.depth_m[i], vmin=lo, vmax=hi, title=obs_title)
        axes[c, 0].set_ylabel(name, fontsize=8)
    fig.suptitle(
        f"{dataset.meta.get('source', '')} {dataset.task}: clean depth | observed SPL image "
        "(colour: depth per sample, black: void)",
        fontsize=9,
    )
    return save_png(fig, path)


def _segmentation_sheet(dataset: Dataset, path, n: int, rng) -> Path:
    chosen = _pick(dataset, np.arange(len(dataset)), n, rng)
    h, w = dataset.image_shape
    has_clean = dataset.clean_depth_m is not None
    cols = 3 if has_clean else 2
    cell = 1.1
    fig = figure(cell * cols * w / h + 0.6, cell * max(len(chosen), 1) + 0.9)
    axes = fig.subplots(max(len(chosen), 1), cols, squeeze=False)
    cmap = label_cmap(len(dataset.classes))
    for r, i in enumerate(chosen):
        clean = dataset.clean_depth_m[i] if has_clean else None
        lo, hi = depth_range(clean, dataset.depth_m[i])
        if has_clean:
            show_image(axes[r, 0], clean, vmin=lo, vmax=hi, title="clean depth" if r == 0 else None)
        obs = condition_title(dataset.msppp[i], dataset.sbr[i], dataset.level[i])
        show_image(
            axes[r, cols - 2], dataset.depth_m[i], vmin=lo, vmax=hi, title=f"observed: {obs}"
        )
        labels = np.where(
            dataset.labels[i] == IGNORE_INDEX, np.nan, dataset.labels[i].astype(float)
        )
        show_image(
            axes[r, cols - 1],
            labels,
            vmin=-0.5,
            vmax=len(dataset.classes) - 0.5,
            title="labels" if r == 0 else None,
            cmap=cmap,
        )
    _legend(fig, dataset.classes, cmap)
    fig.suptitle(
        f"{dataset.meta.get('source', '')} segmentation: depth (black: void) and labels", fontsize=9
    )
    return save_png(fig, path)


def _legend(fig, classes, cmap) -> None:
    from matplotlib.patches import Patch

    handles = [Patch(color=cmap(k), label=name) for k, name in enumerate(classes)]
    handles.append(Patch(color="black", label="void / ignore"))
    fig.legend(
        handles=handles, loc="outside lower center", ncol=len(handles), fontsize=7, frameon=False
    )


def variants_sheet(dataset: Dataset, index: int, path) -> Path:
    """PNG of one sample: clean depth, the observed image and its M variants, with
    each image's condition and void fraction (segmentation: plus the labels)."""
    if not 0 <= index < len(dataset):
        raise ValueError(f"index must be in 0..{len(dataset) - 1}, got {index!r}.")
    if dataset.n_variants == 0:
        raise ValueError(
            "the dataset has no variants; attach them with spl_al.data.variants first."
        )
    i = int(index)
    clean = dataset.clean_depth_m[i] if dataset.clean_depth_m is not None else None
    images = ([("clean depth", clean)] if clean is not None else []) + [
        (
            f"observed\n{condition_title(dataset.msppp[i], dataset.sbr[i], dataset.level[i])}",
            dataset.depth_m[i],
        )
    ]
    for j in range(dataset.n_variants):
        cond = condition_title(dataset.variant_msppp[i, j], dataset.variant_sbr[i, j])
        images.append((f"variant {j + 1}\n{cond}", dataset.variant_depth_m[i, j]))
    seg = dataset.task == "segmentation"
    h, w = dataset.image_shape
    n = len(images) + int(seg)
    per_row = n if w <= 1.5 * h else 2
    rows = -(-n // per_row)
    cell = 1.6
    fig = figure(cell * per_row * w / h, cell * rows + 0.6)
    axes = fig.subplots(rows, per_row, squeeze=False).ravel()
    lo, hi = depth_range(clean, dataset.depth_m[i])
    for ax, (title, img) in zip(axes, images, strict=False):
        voids = 1 - np.isfinite(img).mean()
        show_image(ax, img, vmin=lo, vmax=hi, title=f"{title}, {voids:.0%} void")
    if seg:
        cmap = label_cmap(len(dataset.classes))
        labels = np.where(
            dataset.labels[i] == IGNORE_INDEX, np.nan, dataset.labels[i].astype(float)
        )
        show_image(
            axes[len(images)],
            labels,
            vmin=-0.5,
            vmax=len(dataset.classes) - 0.5,
            title="labels",
            cmap=cmap,
        )
        _legend(fig, dataset.classes, cmap)
    for ax in axes[n:]:
        ax.axis("off")
    name = dataset.classes[dataset.labels[i]] if dataset.task == "classification" else f"scene {i}"
    fig.suptitle(
        f"sample {i} ({name}): observed image and its {dataset.n_variants} SIV variants", fontsize=9
    )
    return save_png(fig, path)
