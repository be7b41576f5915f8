"""A labeling batch out to a person, and its label file back in.

With a human oracle a round's query reveals nothing; it writes a *labeling batch*
(``write_batch``): one picture per queried sample (its observed image and SIV
variants), a contact sheet of the whole batch, ``classes.csv`` and ``to_label.csv``
with one row per sample and an empty label column. The annotator fills the column
and saves the file where the workflow asks for it; ``read_label_file`` checks it
against the batch before anything is written. The label file's format, and the
labels a run keeps (``save_labels`` / ``load_labels``), are
``spl_al.data.label_files``'s.

Label Studio: every batch is also a Label Studio import (``label_studio.xml`` and
``label_studio.json``, with the model's predictions as pre-annotations when
``write_batch`` is given them), and a label file ending in ``.json`` is read as the
project's JSON export (``spl_al.labeling.label_studio``), with the same checks.
"""

from __future__ import annotations

import csv
import os
import shutil
from pathlib import Path

import numpy as np

from spl_al.data.dataset import Dataset
from spl_al.data.label_files import read_label_csv, sample_file
from spl_al.label_codes import IGNORE_INDEX
from spl_al.labeling.label_studio import read_export, write_import
from spl_al.plotting import (
    class_colours,
    condition_title,
    depth_range,
    figure,
    save_png,
    show_image,
)


def write_batch(
    dataset: Dataset,
    pool_indices,
    *,
    out_dir,
    labels_file,
    mask_dir=None,
    export_file=None,
    probs=None,
    model_version: str = "",
    chosen_by: str = "",
    then: str = "run Snakemake again",
) -> Path:
    """Write the labeling batch of the training-pool groups ``pool_indices`` to ``out_dir``.

    ``labels_file`` is where the filled ``to_label.csv`` must be saved (named in the
    batch's README.txt); ``mask_dir`` (segmentation) the folder, relative to it,
    that ``to_label.csv`` proposes for the masks; ``export_file`` where a Label Studio
    JSON export may be saved instead (default: ``labels_file`` ending in ``.json``).
    ``probs``: the probabilities the current model gives each sample ((n, C), or
    (n, C, H, W) for segmentation), which become the Label Studio tasks'
    pre-annotations, tagged ``model_version``; None writes tasks without them.
    ``chosen_by``: a sentence on how the batch was chosen, for its README.txt; ``then``:
    what to do once the file is saved (the README's words). The folder appears complete
    or not at all (written beside it, then renamed).
    """
    out_dir = Path(out_dir)
    pool_indices = np.asarray(pool_indices, dtype=np.int64)
    samples = dataset.train_idx[pool_indices]
    tmp = out_dir.with_name(f".{out_dir.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    for i in samples:
        _sample_picture(dataset, int(i), tmp / f"sample{dataset.uid[i]}.png")
    _batch_sheet(dataset, samples, tmp / "contact_sheet.png")
    _write_classes(dataset, tmp / "classes.csv")
    write_import(dataset, samples, out_dir=tmp, probs=probs, model_version=model_version)
    export_file = export_file or Path(labels_file).with_suffix(".json")
    seg = dataset.task == "segmentation"
    mask_dir = mask_dir or f"{Path(labels_file).stem}_masks"
    with open(tmp / "to_label.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(["sample", "file", "mask" if seg else "label"])
        for i in samples:
            uid = int(dataset.uid[i])
            writer.writerow(
                [uid, sample_file(dataset, int(i)), f"{mask_dir}/sample{uid}.png" if seg else ""]
            )
    what = (
        "in column mask, the path (relative to that file's folder) of an 8-bit greyscale PNG "
        "of each sample's image size whose pixels hold class indices (classes.csv) or 255 "
        "where you give no label"
        if seg
        else "in column label, one class name of classes.csv per sample"
    )
    (tmp / "README.txt").write_text(
        f"{len(samples)} samples to label: sample{{id}}.png shows each one's observed SPL "
        "depth image and its synthetic variants (colour: depth in metres, black: no "
        f"return); contact_sheet.png shows the whole batch.\nFill in to_label.csv ({what}) "
        f"and save it as {labels_file}, then {then}.\nOr label the batch in "
        "Label Studio: create a project whose labeling interface is label_studio.xml, import "
        "label_studio.json (the tasks"
        + (", with the model's predictions to correct" if probs is not None else "")
        + f"), label every task, export the project as JSON and save the export as "
        f"{export_file}.\n" + (f"{chosen_by}\n" if chosen_by else ""),
        encoding="utf-8",
    )
    if out_dir.exists():
        shutil.rmtree(out_dir)
    os.replace(tmp, out_dir)
    return out_dir


def _write_classes(dataset: Dataset, path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        if dataset.task == "segmentation":
            writer.writerow(["index", "name", "colour"])
            for k, (name, colour) in enumerate(
                zip(dataset.classes, class_colours(dataset.classes), strict=True)
            ):
                writer.writerow([k, name, colour])
            writer.writerow([IGNORE_INDEX, "(no label)", "#000000"])
        else:
            writer.writerow(["index", "name"])
            for k, name in enumerate(dataset.classes):
                writer.writerow([k, name])


def _sample_picture(dataset: Dataset, i: int, path: Path) -> None:
    """The observed image and its variants on one depth scale, with a colour bar.
    Nothing of the sample's label is shown."""
    images = [
        (f"observed\n{condition_title(dataset.msppp[i], dataset.sbr[i])}", dataset.depth_m[i])
    ]
    for j in range(dataset.n_variants):
        cond = condition_title(dataset.variant_msppp[i, j], dataset.variant_sbr[i, j])
        images.append((f"variant {j + 1}\n{cond}", dataset.variant_depth_m[i, j]))
    h, w = dataset.image_shape
    per_row = len(images) if w <= 1.5 * h else 1
    rows = -(-len(images) // per_row)
    cell = 1.8
    fig = figure(cell * per_row * w / h + 1.2, cell * rows + 0.6)
    axes = fig.subplots(rows, per_row, squeeze=False).ravel()
    lo, hi = depth_range(dataset.depth_m[i])
    for ax, (title, img) in zip(axes, images, strict=False):
        show_image(ax, img, vmin=lo, vmax=hi, title=title)
    for ax in axes[len(images) :]:
        ax.axis("off")
    fig.colorbar(axes[0].images[0], ax=list(axes), label="depth (m); black: no return")
    name = sample_file(dataset, i)
    fig.suptitle(f"sample {dataset.uid[i]}" + (f" ({name})" if name else ""), fontsize=9)
    save_png(fig, path)


def _batch_sheet(dataset: Dataset, samples, path: Path) -> None:
    n = max(len(samples), 1)
    h, w = dataset.image_shape
    cols = min(n, 6 if w <= 1.5 * h else 2)
    rows = -(-n // cols)
    cell = 1.3
    fig = figure(cell * cols * w / h + 0.4, cell * rows + 0.6)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax, i in zip(axes, samples, strict=False):
        lo, hi = depth_range(dataset.depth_m[i])
        show_image(ax, dataset.depth_m[i], vmin=lo, vmax=hi, title=f"sample {dataset.uid[i]}")
    for ax in axes[len(samples) :]:
        ax.axis("off")
    fig.suptitle(
        f"{len(samples)} samples to label: observed depth (colour: near blue to far red "
        "per sample, black: no return)",
        fontsize=9,
    )
    save_png(fig, path)


def read_label_file(path, dataset: Dataset, pool_indices) -> np.ndarray:
    """The labels a filled label file gives the training-pool groups ``pool_indices``.

    Returns them in the order of ``pool_indices``: (n,) int64 class indices or
    (n, H, W) uint8 masks. A CSV is read by ``spl_al.data.label_files.read_label_csv``,
    a ``.json`` file as a Label Studio JSON export (``label_studio.read_export``), both
    checked the same way: every problem is a ValueError naming the file, its line (or
    task) and the value.
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        return read_export(path, dataset, pool_indices)
    return read_label_csv(path, dataset, pool_indices)
