"""Evaluation: accuracy (classification) and mIoU (segmentation), overall and per level."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from torch import nn

from spl_al.data.dataset import LEVELS
from spl_al.label_codes import IGNORE_INDEX
from spl_al.training.compute import Compute
from spl_al.training.fit import check_targets
from spl_al.training.forward import iter_forward


def confusion_per_image(pred: np.ndarray, target: np.ndarray, n_classes: int) -> np.ndarray:
    """Confusion counts of each image: (n, C, C), [i, true, predicted].

    Args:
        pred: (n,) or (n, H, W) predicted class indices.
        target: same shape, true class indices; IGNORE_INDEX (or any value outside
            [0, C)) marks units that are not counted.
    """
    n = pred.shape[0]
    pred = pred.reshape(n, -1).astype(np.int64)
    target = target.reshape(n, -1).astype(np.int64)
    keep = (target >= 0) & (target < n_classes)
    image = np.broadcast_to(np.arange(n)[:, None], pred.shape)
    code = (image * n_classes + target) * n_classes + pred
    counts = np.bincount(code[keep], minlength=n * n_classes * n_classes)
    return counts.reshape(n, n_classes, n_classes)


def _ratio(num: float, den: float) -> float | None:
    return float(num) / float(den) if den > 0 else None


def classification_summary(conf: np.ndarray, classes: Sequence[str]) -> dict:
    """Accuracy, per-class accuracy (recall; None for absent classes) and balanced accuracy."""
    per_class = {c: _ratio(conf[k, k], conf[k].sum()) for k, c in enumerate(classes)}
    present = [v for v in per_class.values() if v is not None]
    return {
        "n_images": int(conf.sum()),
        "accuracy": _ratio(np.trace(conf), conf.sum()),
        "balanced_accuracy": float(np.mean(present)) if present else None,
        "per_class": per_class,
    }


def segmentation_summary(conf: np.ndarray, classes: Sequence[str]) -> dict:
    """IoU_c = TP / (TP + FP + FN) over all counted pixels; mIoU = mean over classes
    that occur in the targets or the predictions (others have IoU None)."""
    tp = np.diag(conf).astype(np.float64)
    union = conf.sum(0) + conf.sum(1) - tp
    per_class = {c: _ratio(tp[k], union[k]) for k, c in enumerate(classes)}
    present = [v for v in per_class.values() if v is not None]
    return {
        "n_pixels": int(conf.sum()),
        "miou": float(np.mean(present)) if present else None,
        "pixel_accuracy": _ratio(tp.sum(), conf.sum()),
        "per_class_iou": per_class,
    }


def summarise(
    conf_images: np.ndarray,
    task: str,
    levels: Sequence[str] | None = None,
    classes: Sequence[str] | None = None,
) -> dict:
    """Metrics dict (JSON-serialisable) from per-image confusions (n, C, C)."""
    n, n_classes = conf_images.shape[:2]
    classes = [str(k) for k in range(n_classes)] if classes is None else [str(c) for c in classes]
    if len(classes) != n_classes:
        raise ValueError(f"classes must name {n_classes} classes, got {len(classes)}.")
    summary = classification_summary if task == "classification" else segmentation_summary
    conf = conf_images.sum(0)
    out = {"task": task, "n_images": n, **summary(conf, classes)}
    out["classes"] = classes
    out["confusion"] = conf.tolist()
    if levels is not None:
        levels = np.asarray(levels).astype(str)
        if levels.shape != (n,):
            raise ValueError(
                f"levels must have one entry per image ({n}), got shape {levels.shape}."
            )
        names = [lv for lv in LEVELS if lv in levels] + sorted(set(levels) - set(LEVELS))
        out["per_level"] = {}
        for lv in names:
            sel = levels == lv
            out["per_level"][lv] = {
                "n_images": int(sel.sum()),
                **summary(conf_images[sel].sum(0), classes),
            }
    return out


def evaluate(
    model: nn.Module,
    depth_m,
    valid,
    targets,
    *,
    levels: Sequence[str] | None = None,
    classes: Sequence[str] | None = None,
    compute: Compute | None = None,
    batch_size: int = 256,
) -> dict:
    """Evaluate ``model`` on (n, H, W) images against their targets.

    Classification: "accuracy", "balanced_accuracy", "per_class" accuracy, "confusion"
    ([true][predicted]). Segmentation: "miou" over classes (IoU from the confusion of
    all counted pixels), "pixel_accuracy", "per_class_iou", "confusion"; invalid
    pixels and IGNORE_INDEX are not counted. With ``levels`` (one MSPPP level per
    image) the same metrics per level under "per_level". Undefined values are None.
    ``compute``: device and precision of the forward passes (``iter_forward``).
    """
    task = model.task
    depth_m = np.asarray(depth_m)
    if depth_m.ndim != 3:
        raise ValueError(f"depth_m must have shape (n, H, W), got {depth_m.shape}.")
    t = check_targets(
        task,
        targets,
        n_images=len(depth_m),
        image_shape=depth_m.shape[1:],
        n_classes=model.n_classes,
    )
    confs = []
    for start, probs, _, v in iter_forward(
        model, depth_m, valid, compute=compute, batch_size=batch_size
    ):
        pred = probs.argmax(1).cpu().numpy()
        tb = t[start : start + len(pred)]
        if task == "segmentation":
            tb = np.where(v.cpu().numpy(), tb, IGNORE_INDEX)
        confs.append(confusion_per_image(pred, tb, model.n_classes))
    if not confs:
        raise ValueError("depth_m holds no image to evaluate.")
    return summarise(np.concatenate(confs), task, levels, classes)
