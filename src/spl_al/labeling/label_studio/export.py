"""A Label Studio JSON export read as a label file.

``read_export`` gives the labels of a batch from the JSON export of the Label Studio
project it was imported into (Export > JSON), with the same checks as a filled
``to_label.csv``; every problem is one ValueError naming the file, the task (Label
Studio's task id and the sample id) and the value. A task's sample is its
``data.sample`` (written by ``write_import``).

Which annotation counts:

- skipped (cancelled) annotations are ignored, and so are predictions: a
  pre-annotation is a label only once an annotator submits it;
- an annotation marked as ground truth wins over the others (two ground-truth
  annotations must agree);
- otherwise every submitted annotation of a task must give the same label (the same
  class, or the same mask pixel for pixel); if two disagree the file is refused,
  naming both, until one is deleted or marked as ground truth in Label Studio.

Segmentation: every brush region of an annotation paints its class (its
``brushlabels``) into the mask; where regions of different classes overlap, the
region listed later wins (Label Studio lists regions in the order they were created,
so a region drawn over a pre-annotated one wins); pixels no region covers are 255
(no label), like the unpainted pixels of a CSV's mask file.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from spl_al.data.dataset import Dataset
from spl_al.label_codes import IGNORE_INDEX
from spl_al.labeling.label_studio.brush import RLEError, rle_to_mask


def _load(path: Path) -> list[dict]:
    try:
        tasks = json.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: cannot be read as a JSON file ({exc}).") from None
    if not isinstance(tasks, list) or not all(
        isinstance(t, dict) and isinstance(t.get("data"), dict) for t in tasks
    ):
        raise ValueError(
            f"{path}: is not a Label Studio JSON export (a list of tasks, each with 'data' "
            "and 'annotations'); export the project with the format JSON, not JSON-MIN or CSV."
        )
    return tasks


def _where(path: Path, task: dict) -> str:
    sample = task["data"].get("sample")
    return f"{path} task {task.get('id', '?')} (sample {sample})"


def _annotations(task: dict, where: str) -> list[dict]:
    """The submitted, not skipped, annotations of a task; ground truth ones if any."""
    annotations = task.get("annotations")
    if annotations is None:
        annotations = []
    if not isinstance(annotations, list) or not all(isinstance(a, dict) for a in annotations):
        raise ValueError(f"{where}: 'annotations' is not a list of annotations.")
    kept = [a for a in annotations if not a.get("was_cancelled")]
    truth = [a for a in kept if a.get("ground_truth")]
    return truth or kept


def _results(annotation: dict, kind: str, where: str) -> list[dict]:
    result = annotation.get("result")
    if not isinstance(result, list):
        raise ValueError(f"{where}: its 'result' is not a list of regions.")
    return [r for r in result if isinstance(r, dict) and r.get("type") == kind]


def _class_of(annotation: dict, where: str, classes: list[str]) -> int:
    regions = _results(annotation, "choices", where)
    choices = [c for r in regions for c in (r.get("value") or {}).get("choices") or []]
    if not choices:
        raise ValueError(f"{where}: no class chosen; expected one of: {', '.join(classes)}.")
    if len(set(choices)) > 1:
        raise ValueError(
            f"{where}: {len(set(choices))} classes chosen ({', '.join(map(repr, choices))}); "
            "expected one."
        )
    if choices[0] not in classes:
        raise ValueError(
            f"{where}: {choices[0]!r} is not a class; expected one of: {', '.join(classes)}."
        )
    return classes.index(choices[0])


def _mask_of(annotation: dict, where: str, classes: list[str], shape) -> np.ndarray:
    h, w = shape
    mask = np.full(shape, IGNORE_INDEX, np.uint8)
    for region in _results(annotation, "brushlabels", where):
        value = region.get("value") or {}
        names = value.get("brushlabels") or []
        if len(names) != 1:
            raise ValueError(
                f"{where}: a brush region has {len(names)} labels ({', '.join(names)}); "
                "expected one class per region."
            )
        if names[0] not in classes:
            raise ValueError(
                f"{where}: {names[0]!r} is not a class; expected one of: {', '.join(classes)}."
            )
        size = (region.get("original_height"), region.get("original_width"))
        if size != (h, w):
            raise ValueError(
                f"{where}: a brush mask of {size[1]}x{size[0]} pixels (width x height); "
                f"the image is {w}x{h}."
            )
        if value.get("format", "rle") != "rle" or "rle" not in value:
            raise ValueError(f"{where}: a brush region has no RLE mask ('value.rle').")
        try:
            painted = rle_to_mask(value["rle"], h, w)
        except RLEError as exc:
            raise ValueError(f"{where}: {exc}") from None
        mask[painted] = classes.index(names[0])
    return mask


def _label(task: dict, where: str, dataset: Dataset):
    """The task's label, or None when it has no annotation that counts."""
    chosen = _annotations(task, where)
    values = []
    for annotation in chosen:
        at = f"{where} annotation {annotation.get('id', '?')}"
        if dataset.task == "segmentation":
            values.append(_mask_of(annotation, at, dataset.classes, dataset.image_shape))
        else:
            values.append(_class_of(annotation, at, dataset.classes))
    for annotation, value in zip(chosen[1:], values[1:], strict=True):
        if np.array_equal(value, values[0]):
            continue
        if dataset.task == "segmentation":
            what = f"their masks differ at {int((value != values[0]).sum())} pixels"
        else:
            what = f"{dataset.classes[values[0]]!r} and {dataset.classes[value]!r}"
        raise ValueError(
            f"{where}: annotations {chosen[0].get('id', '?')} and {annotation.get('id', '?')} "
            f"disagree ({what}); delete one or mark the right one as ground truth in Label "
            "Studio, then export again."
        )
    return values[0] if values else None


def read_export(path, dataset: Dataset, pool_indices) -> np.ndarray:
    """The labels a Label Studio JSON export gives the training-pool groups ``pool_indices``.

    Same contract as ``spl_al.labeling.read_label_file``: (n,) int64 class indices or
    (n, H, W) uint8 masks in the order of ``pool_indices``. Refused with one ValueError:
    a file that is no JSON export, a task without ``data.sample`` or whose sample is no
    sample id, not in the batch or in two tasks, a sample of the batch without a task
    or without a submitted annotation, annotations that disagree, an unknown class, a
    brush mask of the wrong size or an unreadable RLE.
    """
    path = Path(path)
    pool_of = {int(dataset.uid[i]): p for p, i in enumerate(dataset.train_idx)}
    wanted = {int(p): n for n, p in enumerate(np.asarray(pool_indices, dtype=np.int64))}
    labels: list = [None] * len(wanted)
    task_of: dict[int, object] = {}
    for task in _load(path):
        where = _where(path, task)
        sample = task["data"].get("sample")
        if sample is None:
            raise ValueError(
                f"{where}: has no data.sample; import the batch's label_studio.json, whose "
                "tasks name their sample."
            )
        try:
            pool = pool_of.get(int(sample))
        except (TypeError, ValueError):
            pool = None
        if pool is None:
            raise ValueError(f"{where}: sample {sample!r} is not a sample id of the dataset.")
        if pool not in wanted:
            raise ValueError(
                f"{where}: sample {sample} was not asked for in this batch (only the tasks of "
                "its label_studio.json can be labeled)."
            )
        if pool in task_of:
            raise ValueError(
                f"{where}: sample {sample} is also task {task_of[pool]}; import each batch "
                "into its project once."
            )
        task_of[pool] = task.get("id", "?")
        labels[wanted[pool]] = _label(task, where, dataset)
    missing = [p for p in wanted if labels[wanted[p]] is None]
    if missing:
        names = [
            f"{int(dataset.uid[dataset.train_idx[p]])}"
            + (f" (task {task_of[p]})" if p in task_of else " (no task)")
            for p in missing
        ]
        raise ValueError(
            f"{path}: no submitted annotation for {len(missing)} sample(s) of the batch "
            f"(sample {', '.join(names[:10])}); every task of label_studio.json needs one."
        )
    if dataset.task == "segmentation":
        return (
            np.stack(labels).astype(np.uint8)
            if labels
            else np.zeros((0, *dataset.image_shape), np.uint8)
        )
    return np.asarray(labels, dtype=np.int64)
