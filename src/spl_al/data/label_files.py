"""Label files: the labels a person gives, read, checked and kept.

Label file: CSV with a header row. ``sample`` (the id in a batch's to_label.csv) or
``file`` (the source file, relative to the dataset folder) names the sample of a
row. Classification: ``label`` holds a class name. Segmentation: ``mask`` holds the
path of a mask, relative to the label file's folder: an 8-bit greyscale PNG or a
``.npy`` of the image's shape, each pixel a class index (``classes.csv``) or 255 = no
label. Rows whose ``split`` column says ``test`` are skipped (they label the test
split of an unlabeled folder, see ``spl_al.data.unlabeled_folder``); other columns are
ignored.

- ``read_label_csv`` checks a filled CSV against the samples it must label (every
  problem a ValueError naming the file, its line and the value); ``listed_samples``
  and ``lists_training_rows`` say which samples a CSV has rows for; ``read_rows``,
  ``class_index`` and ``read_mask`` are its parts, shared with ``data.unlabeled_folder``.
- ``save_labels`` / ``load_labels`` / ``labels_for``: the labels a run has been given
  (``labels.npz``), the only labels its training ever sees.

A labeling batch and a Label Studio export read back as a label file live above, in
``spl_al.labeling``.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write
from spl_al.data.dataset import Dataset
from spl_al.label_codes import IGNORE_INDEX

LABELS_FORMAT = "spl-al-labels"


def sample_file(dataset: Dataset, index: int) -> str:
    """The source file of sample ``index`` ("" for synthesized data)."""
    files = dataset.meta.get("files")
    return str(files[index]) if isinstance(files, list) and len(files) == len(dataset) else ""


def read_label_csv(path, dataset: Dataset, pool_indices) -> np.ndarray:
    """The labels a filled label CSV gives the training-pool groups ``pool_indices``.

    Returns them in the order of ``pool_indices``: (n,) int64 class indices or
    (n, H, W) uint8 masks. Every problem (unreadable file, missing column, a sample
    that is unknown, not in the batch, listed twice or missing, an unknown class, a
    mask that is missing, of the wrong shape or with values outside the classes) is a
    ValueError naming the file, its line and the value.
    """
    path = Path(path)
    rows, header = read_rows(path)
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
            labels[wanted[pool]] = read_mask(path, line, value, dataset)
        else:
            labels[wanted[pool]] = class_index(
                path, line, name=name, value=value, classes=dataset.classes
            )
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
    rows, header = read_rows(path)
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
    rows, _ = read_rows(Path(seed_labels))
    return any(
        ((row.get("split") or "train").strip().lower() or "train") == "train" for _, row in rows
    )


def read_rows(path: Path) -> tuple[list[tuple[int, dict]], list[str]]:
    """(line number, row) of every non-empty row of a CSV, and its stripped header; a file
    that is no readable CSV is a ValueError naming it."""
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


def class_index(path: Path, line: int, *, name: str, value: str, classes: list[str]) -> int:
    """The index of class name ``value`` in ``classes``; an empty or unknown name is a
    ValueError naming ``path``, ``line`` and the sample ``name``."""
    if not value:
        raise ValueError(
            f"{path} line {line}: {name} has no label; expected one of: {', '.join(classes)}."
        )
    if value not in classes:
        raise ValueError(
            f"{path} line {line}: {value!r} is not a class; expected one of: {', '.join(classes)}."
        )
    return classes.index(value)


def read_mask(path: Path, line: int, value: str, dataset: Dataset) -> np.ndarray:
    """The (H, W) uint8 mask of file ``value`` (relative to ``path``'s folder: 8-bit PNG or
    ``.npy``), checked against ``dataset``'s image shape and classes (255: no label)."""
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
