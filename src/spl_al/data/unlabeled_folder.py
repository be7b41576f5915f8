"""A folder of SPL depth images nobody has labeled yet: the pool of a human oracle.

``root/*.npz|*.npy|*.png`` with any names (``frames/frame_0001.npz``, ...): one
sample per file, read like ``load_folder`` reads its files (``depth_key`` in
``.npz``, 16-bit millimetre PNG, unusable depths made voids). No class comes from
the names: every sample is in the training pool, unlabeled (class ``UNKNOWN_CLASS``
or an all-255 mask), except the rows of an optional ``seed_labels`` CSV whose
``split`` column says ``test``: those samples form the test split, labeled. The
CSV's other rows (split ``train`` or empty) are labels for the first round; they are
read by the workflow's round 0 (``spl_al.labeling.read_label_file``), not here.

Seed CSV columns: ``file`` (relative to ``root``), ``label`` (classification: a
class name) or ``mask`` (segmentation: a mask path relative to the CSV's folder),
and optionally ``split`` (``train`` or ``test``; empty = train).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.data.dataset import LEVELS, Dataset, sensor_to_dict
from spl_al.data.external import (
    as_image,
    list_files,
    mask_unusable_depth,
    read_arrays,
    resize_nearest,
)
from spl_al.data.label_files import class_index, read_mask, read_rows
from spl_al.label_codes import IGNORE_INDEX, UNKNOWN_CLASS
from spl_al.photon import SensorParams


def load_unlabeled_folder(
    root,
    classes,
    *,
    task: str = "classification",
    seed_labels=None,
    depth_key: str = "depth_ssp",
    image_shape=None,
    depth_scale: float = 1.0,
    sensor: SensorParams | None = None,
) -> Dataset:
    """Load ``root``'s depth images as an unlabeled pool (test split from ``seed_labels``).

    Args:
        root: the folder of depth files.
        classes: the class names a person will choose from (label order).
        task: "classification" or "segmentation".
        seed_labels: optional CSV (module docstring); its ``test`` rows make the test split.
        depth_key: array of the observed depth in each ``.npz``.
        image_shape: (H, W) to resize every image to (nearest neighbour); None
            requires all images to share one shape.
        depth_scale: factor to metres of ``.npz``/``.npy`` depth (PNG is millimetres).
        sensor: SPL timing for variants; default ``SensorParams.paper_real()``.
    """
    root = Path(root)
    sensor = SensorParams.paper_real() if sensor is None else sensor
    classes = [str(c) for c in (classes or [])]
    if not classes:
        raise ValueError("an unlabeled folder needs the class names to label with (classes).")
    if not root.is_dir():
        raise ValueError(f"{root}: no such folder.")
    files = list_files(root)
    if not files:
        raise ValueError(f"{root}: no .npz/.npy/.png depth files found.")
    images, levels, msppp, sbr, report = _read_files(files, depth_key, depth_scale, sensor)
    shapes = sorted({im.shape for im in images})
    if image_shape is None and len(shapes) > 1:
        raise ValueError(f"{root}: images have different shapes {shapes}; set image_shape (H, W).")
    shape = tuple(int(v) for v in image_shape) if image_shape is not None else shapes[0]
    depth = np.stack([resize_nearest(im, shape) for im in images]).astype(np.float32)
    n = len(files)
    names = [str(p.relative_to(root)) for p in files]
    split = np.full(n, "train", dtype="<U5")
    if task == "segmentation":
        labels = np.full((n, *shape), IGNORE_INDEX, dtype=np.uint8)
    else:
        labels = np.full(n, UNKNOWN_CLASS, dtype=np.int64)
    if seed_labels is not None:
        seed_labels = Path(seed_labels)
        probe = Dataset(
            task, classes, depth[:1], labels[:1], ["test"], [np.nan], [np.nan], ["unknown"]
        )
        _mark_test_rows(seed_labels, root, names, probe, split=split, labels=labels)
    bad_levels = sorted(set(levels) - {*LEVELS, "unknown"})
    if bad_levels:
        raise ValueError(f"{root}: files hold levels {bad_levels}; expected one of {LEVELS}.")
    return Dataset(
        task=task,
        classes=classes,
        depth_m=depth,
        labels=labels,
        split=split,
        msppp=np.array(msppp),
        sbr=np.array(sbr),
        level=np.array(levels, dtype="<U7"),
        sensor=sensor,
        meta={
            "source": "unlabeled",
            "root": str(root.resolve()),
            "files": names,
            "depth_key": depth_key,
            "depth_scale": float(depth_scale),
            "image_shape": list(shape),
            "seed_labels": str(seed_labels) if seed_labels is not None else None,
            "sensor": sensor_to_dict(sensor),
            "load_report": report,
        },
    )


def _read_files(files, depth_key: str, depth_scale: float, sensor: SensorParams):
    """Each file's depth in metres (unusable pixels made voids) and its level, MSPPP and
    SBR when it names them; with a report of the voids made."""
    images, levels, msppp, sbr = [], [], [], []
    report = {"void_pixels_made": 0}
    for path in files:
        arrays = read_arrays(path, {"depth": depth_key}, ("depth",))
        scale = 1.0 if path.suffix.lower() == ".png" else depth_scale
        depth, bad = mask_unusable_depth(
            as_image(arrays["depth"], path, depth_key) * scale, sensor.max_depth_m
        )
        report["void_pixels_made"] += bad["nonfinite"] + bad["negative"] + bad["beyond_reach"]
        images.append(depth)
        levels.append(str(arrays["level"]) if "level" in arrays else "unknown")
        msppp.append(float(arrays["msppp"]) if "msppp" in arrays else np.nan)
        sbr.append(float(arrays["sbr"]) if "sbr" in arrays else np.nan)
    return images, levels, msppp, sbr, report


def _mark_test_rows(seed_labels: Path, root, names, probe: Dataset, *, split, labels) -> None:
    """The ``test`` rows of ``seed_labels``: their files' ``split`` set to "test" and
    their labels (or masks, checked against ``probe``'s classes and shape) written into
    ``labels``, both in place; ``names``: the pool's files relative to ``root``."""
    task, classes = probe.task, probe.classes
    rows, header = read_rows(seed_labels)
    column = "mask" if task == "segmentation" else "label"
    if "file" not in header or column not in header:
        raise ValueError(
            f"{seed_labels}: needs the columns 'file' and '{column}' (and optionally "
            f"'split'); found {', '.join(header) or 'none'}."
        )
    index = {name: k for k, name in enumerate(names)}
    for line, row in rows:
        name = (row.get("file") or "").strip()
        if name not in index:
            raise ValueError(f"{seed_labels} line {line}: file {name!r} is not in {root}.")
        where = (row.get("split") or "train").strip().lower() or "train"
        if where not in ("train", "test"):
            raise ValueError(
                f"{seed_labels} line {line}: split {where!r}; expected train, test or empty."
            )
        if where != "test":
            continue
        k = index[name]
        if split[k] == "test":
            raise ValueError(f"{seed_labels} line {line}: file {name!r} is listed twice.")
        split[k] = "test"
        value = (row.get(column) or "").strip()
        if task == "segmentation":
            labels[k] = read_mask(seed_labels, line, value, probe)
        else:
            labels[k] = class_index(seed_labels, line, name=name, value=value, classes=classes)
