"""A labeling batch as a Label Studio import: the labeling config and the tasks.

``write_import`` writes two files into a batch folder:

- ``label_studio.xml``: the labeling config. Classification: ``<Choices name="label">``
  (one class per sample) on ``<Image name="image">``; segmentation:
  ``<BrushLabels name="label">`` with each class's name and colour (``classes.csv``).
  A second, unlabeled ``<Image name="variants">`` shows the synthetic variants.
- ``label_studio.json``: one task per sample. ``data.image`` is the observed depth
  image, one picture pixel per image pixel (so a brush mask has the image's size),
  colour from near (blue) to far (red), black where there is no return;
  ``data.variants`` the observed image beside its variants on the same colour scale;
  ``data.sample`` the sample id, ``data.file`` its source file, ``data.condition``
  its imaging condition. The pictures are embedded as ``data:image/png;base64`` URLs,
  so a Label Studio started anywhere shows them without serving any folder.

With the probabilities of the model that chose the batch, each task also carries a
``predictions`` entry (Label Studio's pre-annotations, which annotators correct):
the predicted class and its probability, or one brush region per predicted class
over the pixels with a return, each with its mean probability as ``score``.
"""

from __future__ import annotations

import base64
import io
import json
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from spl_al.atomic import atomic_write_text
from spl_al.data.dataset import Dataset
from spl_al.data.label_files import sample_file
from spl_al.labeling.label_studio.brush import mask_to_rle
from spl_al.plotting import class_colours, depth_cmap, depth_range

CONFIG_FILE = "label_studio.xml"
TASKS_FILE = "label_studio.json"
CONTROL = "label"  # the name of the Choices / BrushLabels tag
IMAGE = "image"  # the name of the Image tag that is labeled
_GAP_PX = 2  # white columns between the pictures of the variants strip


def labeling_config(task: str, classes, variants: bool = True) -> str:
    """Label Studio's labeling config (XML) for ``task`` with these class names."""
    header = (
        "Sample $sample $file ($condition): observed SPL depth, near (blue) to far (red), "
        "black: no return"
    )
    lines = ["<View>", f"  <Header value={quoteattr(header)}/>"]
    image = f'  <Image name="{IMAGE}" value="$image" smoothing="false" zoomControl="true"/>'
    if task == "segmentation":
        lines.append(f'  <BrushLabels name="{CONTROL}" toName="{IMAGE}">')
        for name, colour in zip(classes, class_colours(classes), strict=True):
            lines.append(f"    <Label value={quoteattr(name)} background={quoteattr(colour)}/>")
        lines += ["  </BrushLabels>", image]
    else:
        lines.append(image)
        lines.append(
            f'  <Choices name="{CONTROL}" toName="{IMAGE}" choice="single" '
            'showInline="true" required="true">'
        )
        lines += [f"    <Choice value={quoteattr(name)}/>" for name in classes]
        lines.append("  </Choices>")
    if variants:
        lines += [
            '  <Header value="The observed image and its synthetic variants (same colours)" '
            'size="6"/>',
            '  <Image name="variants" value="$variants" smoothing="false"/>',
        ]
    lines.append("</View>")
    return "\n".join(lines) + "\n"


def _colourise(depth: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """(H, W) depth -> (H, W, 3) uint8 RGB: turbo from ``lo`` to ``hi``, black no return."""
    valid = np.isfinite(depth) & (depth > 0)
    scaled = np.clip((np.where(valid, depth, lo) - lo) / (hi - lo), 0.0, 1.0)
    rgb = (depth_cmap()(scaled)[..., :3] * 255).round().astype(np.uint8)
    rgb[~valid] = 0
    return rgb


def _png_url(rgb: np.ndarray) -> str:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb, mode="RGB").save(buf, format="PNG", optimize=True)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _pictures(dataset: Dataset, i: int) -> tuple[str, str | None]:
    """Data URLs of sample ``i``'s observed image and of its variants strip (or None)."""
    lo, hi = depth_range(dataset.depth_m[i])
    observed = _colourise(np.asarray(dataset.depth_m[i], np.float32), lo, hi)
    if not dataset.n_variants:
        return _png_url(observed), None
    gap = np.full((observed.shape[0], _GAP_PX, 3), 255, np.uint8)
    parts = [observed]
    for j in range(dataset.n_variants):
        variant = np.asarray(dataset.variant_depth_m[i, j], np.float32)
        parts += [gap, _colourise(variant, lo, hi)]
    return _png_url(observed), _png_url(np.concatenate(parts, axis=1))


def prediction(task: str, probs, *, valid, classes, model_version: str) -> dict:
    """Label Studio pre-annotation of one sample from the model's probabilities.

    Args:
        probs: (C,) class probabilities, or (C, H, W) per pixel for segmentation.
        valid: (H, W) bool, the pixels with a return (segmentation only).
    """
    probs = np.asarray(probs, dtype=np.float64)
    base = {"from_name": CONTROL, "to_name": IMAGE, "origin": "prediction"}
    if task != "segmentation":
        k = int(np.argmax(probs))
        item = {**base, "id": "p0", "type": "choices", "value": {"choices": [classes[k]]}}
        score = float(probs[k])
        return {"model_version": model_version, "score": score, "result": [{**item}]}
    c, h, w = probs.shape
    best = probs.argmax(axis=0)
    valid = np.asarray(valid, dtype=bool)
    result = []
    for k in range(c):
        region = (best == k) & valid
        if not region.any():
            continue
        result.append(
            {
                **base,
                "id": f"p{k}",
                "type": "brushlabels",
                "original_width": w,
                "original_height": h,
                "image_rotation": 0,
                "value": {"format": "rle", "rle": mask_to_rle(region), "brushlabels": [classes[k]]},
                "score": round(float(probs[k][region].mean()), 4),
            }
        )
    top = probs.max(axis=0)[valid]
    score = round(float(top.mean()), 4) if top.size else 0.0
    return {"model_version": model_version, "score": score, "result": result}


def batch_tasks(dataset: Dataset, samples, probs=None, model_version: str = "") -> list[dict]:
    """Label Studio tasks of dataset rows ``samples`` (``probs``: the model's
    probabilities of each, in the same order, for the pre-annotations; or None)."""
    tasks = []
    for n, i in enumerate(np.asarray(samples, dtype=np.int64)):
        i = int(i)
        image, variants = _pictures(dataset, i)
        msppp, sbr = float(dataset.msppp[i]), float(dataset.sbr[i])
        condition = f"{msppp:.3g} ppp, SBR {sbr:.3g}" if np.isfinite(msppp) else "unknown"
        data = {"image": image, "sample": int(dataset.uid[i]), "file": sample_file(dataset, i)}
        data["condition"] = condition
        if variants is not None:
            data["variants"] = variants
        task = {"data": data}
        if probs is not None:
            valid = np.isfinite(dataset.depth_m[i]) & (np.asarray(dataset.depth_m[i]) > 0)
            task["predictions"] = [
                prediction(
                    dataset.task,
                    probs[n],
                    valid=valid,
                    classes=dataset.classes,
                    model_version=model_version,
                )
            ]
        tasks.append(task)
    return tasks


def write_import(
    dataset: Dataset, samples, *, out_dir, probs=None, model_version: str = ""
) -> tuple[Path, Path]:
    """Write ``label_studio.xml`` and ``label_studio.json`` of a batch into ``out_dir``."""
    out_dir = Path(out_dir)
    config = labeling_config(dataset.task, dataset.classes, variants=dataset.n_variants > 0)
    tasks = batch_tasks(dataset, samples, probs, model_version)
    text = "[\n" + ",\n".join(json.dumps(t, allow_nan=False) for t in tasks) + "\n]\n"
    return (
        atomic_write_text(out_dir / CONFIG_FILE, config),
        atomic_write_text(out_dir / TASKS_FILE, text),
    )
