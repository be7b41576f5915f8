"""Labels from a person: labeling batches to look at, and label files to read back.

With a human oracle a round's query reveals nothing; it writes a *labeling batch*
(``write_batch``): one picture per queried sample (its observed image and SIV
variants), a contact sheet of the whole batch, ``classes.csv`` and ``to_label.csv``
with one row per sample and an empty label column. The annotator fills the column
and saves the file where the workflow asks for it; ``read_label_file`` checks it
against the batch before anything is written; ``save_labels`` / ``load_labels`` keep
the labels a run has been given (the only labels its training ever sees).

Label file: CSV with a header row. ``sample`` (the id in to_label.csv) or ``file``
(the source file, relative to the dataset folder) names the sample of a row.
Classification: ``label`` holds a class name. Segmentation: ``mask`` holds the path
of a mask, relative to the label file's folder: an 8-bit greyscale PNG or a ``.npy``
of the image's shape, each pixel a class index (``classes.csv``) or 255 = no label.
Rows whose ``split`` column says ``test`` are skipped (they label the test split of
an unlabeled folder, see ``spl_al.data.unlabeled``); other columns are ignored.

Label Studio: every batch is also a Label Studio import (``label_studio.xml`` and
``label_studio.json``, with the model's predictions as pre-annotations when
``write_batch`` is given them), and a label file ending in ``.json`` is read as the
project's JSON export (``spl_al.label_studio``), with the same checks.
"""

from __future__ import annotations

import csv
import os
import shutil
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write
from spl_al.data.dataset import Dataset
from spl_al.labels import IGNORE_INDEX
from spl_al.plotting import (
    class_colours,
    condition_title,
    depth_range,
    figure,
    save_png,
    show_image,
)

LABELS_FORMAT = "spl-al-labels"


# ---------------------------------------------------------------- batches


def sample_file(dataset: Dataset, index: int) -> str:
    """The source file of sample ``index`` ("" for synthesized data)."""
    files = dataset.meta.get("files")
    return str(files[index]) if isinstance(files, list) and len(files) == len(dataset) else ""


def write_batch(
    dataset: Dataset,
    pool_indices,
    out_dir,
    labels_file,
    mask_dir=None,
    export_file=None,
    probs=None,
    model_version: str = "",
) -> Path:
    """Write the labeling batch of the training-pool groups ``pool_indices`` to ``out_dir``.

    ``labels_file`` is where the filled ``to_label.csv`` must be saved (named in the
    batch's README.txt); ``mask_dir`` (segmentation) the folder, relative to it,
    that ``to_label.csv`` proposes for the masks; ``export_file`` where a Label Studio
    JSON export may be saved instead (default: ``labels_file`` ending in ``.json``).
    ``probs``: the probabilities the current model gives each sample ((n, C), or
    (n, C, H, W) for segmentation), which become the Label Studio tasks'
    pre-annotations, tagged ``model_version``; None writes tasks without them. The
    folder appears complete or not at all (written beside it, then renamed).
    """
    from spl_al.label_studio import write_import

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
    write_import(dataset, samples, tmp, probs, model_version)
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
        f"and save it as {labels_file}, then run Snakemake again.\nOr label the batch in "
        "Label Studio: create a project whose labeling interface is label_studio.xml, import "
        "label_studio.json (the tasks"
        + (", with the model's predictions to correct" if probs is not None else "")
        + f"), label every task, export the project as JSON and save the export as "
        f"{export_file}.\n",
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
        show_image(ax, img, lo, hi, title)
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
        show_image(ax, dataset.depth_m[i], lo, hi, f"sample {dataset.uid[i]}")
    for ax in axes[len(samples) :]:
        ax.axis("off")
    fig.suptitle(
        f"{len(samples)} samples to label: observed depth (colour: near blue to far red "
        "per sample, black: no return)",
        fontsize=9,
    )
    save_png(fig, path)


# ---------------------------------------------------------------- label files


def read_label_file(path, dataset: Dataset, pool_indices) -> np.ndarray:
    """The labels a filled label file gives the training-pool groups ``pool_indices``.

    Returns them in the order of ``pool_indices``: (n,) int64 class indices or
    (n, H, W) uint8 masks. Every problem (unreadable file, missing column, a sample
    that is unknown, not in the batch, listed twice or missing, an unknown class, a
    mask that is missing, of the wrong shape or with values outside the classes) is a
    ValueError naming the file, its line and the value. A ``.json`` file is a Label
    Studio JSON export (``spl_al.label_studio.read_export``, checked the same way).
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        from spl_al.label_studio import read_export

        return read_export(path, dataset, pool_indices)
    rows, header = _read_rows(path)
    seg = dataset.task == "segmentation"
    value_column = "mask" if seg else "label"
    key = "sample" if "sample" in header else "file" if "file" in header else None
    if key is None or value_column not in header:
        need = f"'sample' (or 'file') and '{value_column}'"
        raise ValueError(f"{path}: needs the columns {need}; found {', '.join(header) or 'none'}.")
    pool_of = _pool_lookup(dataset, key)
    wanted = {int(p): n for n, p in enumerate(np.asarray(pool_indices, dtype=np.int64))}
    labels: list = [None] * len(wanted)
    first_line: dict[int, int] = {}
    for line, row in rows:
        if (row.get("split") or "").strip().lower() == "test":
            continue
        name = (row.get(key) or "").strip()
        pool = pool_of.get(name)
        if pool is None:
            what = "sample id of to_label.csv" if key == "sample" else "file of the dataset"
            raise ValueError(f"{path} line {line}: {key} {name!r} is not a {what}.")
        if pool not in wanted:
            raise ValueError(
                f"{path} line {line}: {key} {name!r} was not asked for in this batch "
                "(only the samples of to_label.csv can be labeled)."
            )
        if pool in first_line:
            raise ValueError(
                f"{path} line {line}: {key} {name!r} is listed twice (first on line "
                f"{first_line[pool]})."
            )
        first_line[pool] = line
        value = (row.get(value_column) or "").strip()
        if seg:
            labels[wanted[pool]] = _read_mask(path, line, value, dataset)
        else:
            labels[wanted[pool]] = _class_index(path, line, name, value, dataset.classes)
    missing = [p for p in wanted if p not in first_line]
    if missing:
        names = [_sample_key(dataset, p, key) for p in missing]
        raise ValueError(
            f"{path}: no row for {len(missing)} sample(s) of the batch ({key} "
            f"{', '.join(names[:10])}); every sample of to_label.csv needs one."
        )
    if seg:
        return (
            np.stack(labels).astype(np.uint8)
            if labels
            else np.zeros((0, *dataset.image_shape), np.uint8)
        )
    return np.asarray(labels, dtype=np.int64)


def listed_samples(path, dataset: Dataset) -> np.ndarray:
    """Training-pool indices of the samples a label file has rows for (``test`` rows
    skipped), in file order; a name that is no sample of the pool is a ValueError."""
    path = Path(path)
    rows, header = _read_rows(path)
    key = "sample" if "sample" in header else "file" if "file" in header else None
    if key is None:
        raise ValueError(
            f"{path}: needs a column 'sample' or 'file'; found {', '.join(header) or 'none'}."
        )
    pool_of = _pool_lookup(dataset, key)
    out = []
    for line, row in rows:
        if (row.get("split") or "").strip().lower() == "test":
            continue
        name = (row.get(key) or "").strip()
        if name not in pool_of:
            raise ValueError(f"{path} line {line}: {key} {name!r} is not in the training pool.")
        out.append(pool_of[name])
    return np.asarray(out, dtype=np.int64)


def lists_training_rows(seed_labels) -> bool:
    """Whether a ``seed_labels`` CSV labels training samples (a row with ``split`` train
    or empty): then they are round 0's labels; else round 0 is a batch to label."""
    rows, _ = _read_rows(Path(seed_labels))
    return any(
        ((row.get("split") or "train").strip().lower() or "train") == "train" for _, row in rows
    )


def _read_rows(path: Path) -> tuple[list[tuple[int, dict]], list[str]]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.DictReader(f)
            header = [h.strip() for h in (reader.fieldnames or [])]
            reader.fieldnames = header
            rows = [
                (reader.line_num, row)
                for row in reader
                if any((v or "").strip() for v in row.values() if isinstance(v, str))
            ]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"{path}: cannot be read as a CSV file ({exc}).") from None
    return rows, header


def _pool_lookup(dataset: Dataset, key: str) -> dict[str, int]:
    """Text of the key column -> training-pool index."""
    train = dataset.train_idx
    if key == "sample":
        return {str(int(dataset.uid[i])): p for p, i in enumerate(train)}
    return {
        sample_file(dataset, int(i)): p for p, i in enumerate(train) if sample_file(dataset, int(i))
    }


def _sample_key(dataset: Dataset, pool: int, key: str) -> str:
    i = int(dataset.train_idx[pool])
    return str(int(dataset.uid[i])) if key == "sample" else sample_file(dataset, i)


def _class_index(path: Path, line: int, name: str, value: str, classes: list[str]) -> int:
    if not value:
        raise ValueError(
            f"{path} line {line}: {name} has no label; expected one of: {', '.join(classes)}."
        )
    if value not in classes:
        raise ValueError(
            f"{path} line {line}: {value!r} is not a class; expected one of: {', '.join(classes)}."
        )
    return classes.index(value)


def _read_mask(path: Path, line: int, value: str, dataset: Dataset) -> np.ndarray:
    where = f"{path} line {line}"
    if not value:
        raise ValueError(f"{where}: no mask file given (column mask).")
    mask_path = path.parent / value
    if not mask_path.is_file():
        raise ValueError(f"{where}: mask file {mask_path} does not exist.")
    try:
        if mask_path.suffix.lower() == ".npy":
            mask = np.load(mask_path, allow_pickle=False)
        else:
            from PIL import Image

            with Image.open(mask_path) as img:
                if img.mode not in ("L", "P"):
                    raise ValueError(
                        f"{where}: mask {mask_path} is a {img.mode!r} image; expected 8-bit "
                        "greyscale (or palette) whose values are class indices."
                    )
                mask = np.array(img)
    except ValueError as exc:
        if str(exc).startswith(where):
            raise
        raise ValueError(f"{where}: mask {mask_path} cannot be read ({exc}).") from None
    except OSError as exc:
        raise ValueError(f"{where}: mask {mask_path} cannot be read ({exc}).") from None
    if mask.shape != dataset.image_shape:
        raise ValueError(
            f"{where}: mask {mask_path} has shape {mask.shape}; the image is {dataset.image_shape}."
        )
    k = len(dataset.classes)
    if not np.issubdtype(mask.dtype, np.integer):
        raise ValueError(f"{where}: mask {mask_path} holds {mask.dtype} values; expected integers.")
    bad = np.unique(mask[(mask != IGNORE_INDEX) & ((mask < 0) | (mask >= k))])
    if bad.size:
        raise ValueError(
            f"{where}: mask {mask_path} holds values {bad[:10].tolist()}; expected class "
            f"indices 0..{k - 1} (classes.csv) or {IGNORE_INDEX} (no label)."
        )
    return mask.astype(np.uint8)


# ---------------------------------------------------------------- labels given so far


def save_labels(path, pool_indices, labels) -> Path:
    """The labels a run has been given: training-pool indices and their labels (.npz)."""
    pool_indices = np.asarray(pool_indices, dtype=np.int64)
    labels = np.asarray(labels)
    if len(labels) != len(pool_indices):
        raise ValueError(f"{len(pool_indices)} indices but {len(labels)} labels.")

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, format=np.array(LABELS_FORMAT), pool_indices=pool_indices, labels=labels)

    return atomic_write(path, write)


def load_labels(path) -> tuple[np.ndarray, np.ndarray]:
    """(training-pool indices, labels) written by ``save_labels``."""
    try:
        with np.load(path, allow_pickle=False) as z:
            if str(z["format"]) != LABELS_FORMAT:
                raise KeyError("format")
            return z["pool_indices"], z["labels"]
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"{path}: not a labels file written by save_labels ({exc}).") from None


def labels_for(path, pool_indices) -> np.ndarray:
    """The given labels of ``pool_indices``, in that order; every one must have been given."""
    given, labels = load_labels(path)
    position = {int(p): n for n, p in enumerate(given)}
    missing = [int(p) for p in pool_indices if int(p) not in position]
    if missing:
        raise ValueError(f"{path}: no label was given for training groups {missing[:10]}.")
    return labels[[position[int(p)] for p in pool_indices]]
