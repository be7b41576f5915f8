"""Classify or segment new frames with a trained model (``.pt`` or ``.onnx``, with card).

``predict(model, inputs, out)`` writes into the folder ``out``:

- classification: ``predictions.csv``, one row per frame: file, class, probability,
  top-3 (``name:p;name:p;name:p``), the frame's estimated MSPPP and SBR, its shape and
  a warning;
- segmentation: ``masks/{file}.png`` (palette PNG in the classes' colours, black at
  voids), ``masks/{file}.npz`` (``labels`` (H, W) uint8 with 255 at voids,
  ``probability`` of the chosen class), and ``predictions.csv`` with each class's
  fraction of the frame's valid pixels, MSPPP, SBR, shape and a warning.

A frame outside the model's training conditions (MSPPP or SBR outside the range of
its training images, unknown conditions, another image shape) is predicted but its
``warning`` says so. The whole folder is written beside ``out`` and renamed into place
at the end, so a failure leaves nothing partial (an earlier prediction folder at
``out`` is replaced only then).
"""

from __future__ import annotations

import csv
import io
import shutil
import tempfile
from pathlib import Path

import numpy as np

from spl_al.deploy.bundle import open_model
from spl_al.deploy.frames import RELEASE_DEPTH_KEY, Frame, capture_options, read_frames
from spl_al.label_codes import IGNORE_INDEX

CSV_NAME = "predictions.csv"


def condition_warning(frame: Frame, card: dict) -> str:
    """Why ``frame`` lies outside what the model trained on ("" when it does not)."""
    trained = card["data"]["trained_conditions"]
    notes = []
    for key, value in (("msppp", frame.msppp), ("sbr", frame.sbr)):
        span = trained.get(key)
        if not np.isfinite(value):
            notes.append(f"{key.upper()} unknown")
        elif span and not span[0] <= value <= span[1]:
            notes.append(f"{key.upper()} {value:.3g} outside trained {span[0]:g}-{span[1]:g}")
    shape = list(frame.depth_m.shape)
    if shape != list(card["data"]["image_shape"]):
        h, w = card["data"]["image_shape"]
        notes.append(f"shape {shape[0]}x{shape[1]} not the trained {h}x{w}")
    return "; ".join(notes)


def _check_frames(frames: list[Frame], deployed) -> None:
    fixed = deployed.fixed_shape() or deployed.card["model"]["arch"] == "pointnet2"
    for frame in frames:
        if frame.depth_m.ndim != 2 or min(frame.depth_m.shape) < 1:
            raise ValueError(
                f"{frame.name}: depth must be one (H, W) image, got {frame.depth_m.shape}."
            )
        if fixed and tuple(frame.depth_m.shape) != deployed.image_shape:
            raise ValueError(
                f"{frame.name}: image shape {frame.depth_m.shape} is one {deployed.path.name} "
                f"cannot take; it takes {tuple(deployed.image_shape)} only."
            )


def run_frames(deployed, frames: list[Frame], batch_size: int = 32) -> list[np.ndarray]:
    """Probabilities of every frame ((C,) or (C, H, W)), batched by image shape."""
    probs: list[np.ndarray | None] = [None] * len(frames)
    by_shape: dict[tuple, list[int]] = {}
    for i, frame in enumerate(frames):
        by_shape.setdefault(frame.depth_m.shape, []).append(i)
    n_classes = len(deployed.classes)
    for shape, idx in by_shape.items():
        for s in range(0, len(idx), batch_size):
            part = idx[s : s + batch_size]
            try:
                p = deployed.run(np.stack([frames[i].depth_m for i in part]))[1]
            except RuntimeError as exc:  # torch: a shape the layers cannot take
                first = str(exc).splitlines()[0]
                raise ValueError(
                    f"{frames[part[0]].name}: image shape {shape} is one the model cannot "
                    f"take ({first})."
                ) from None
            if p.shape[1] != n_classes:
                raise ValueError(
                    f"{deployed.path}: gives {p.shape[1]} classes but its card names "
                    f"{n_classes} ({deployed.classes}); the class set is unknown."
                )
            for i, row in zip(part, p, strict=True):
                probs[i] = row
    return probs


def _csv_text(header: list[str], rows: list[list]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


def _fmt(value: float) -> str:
    return "" if not np.isfinite(value) else f"{value:.4g}"


def _tail(frame: Frame, card: dict) -> list:
    """The condition columns every row ends with: msppp, sbr, height, width, warning."""
    h, w = frame.depth_m.shape
    return [_fmt(frame.msppp), _fmt(frame.sbr), h, w, condition_warning(frame, card)]


def classification_rows(frames, probs, card) -> tuple[list[str], list[list]]:
    """The header and rows of a classification ``predictions.csv``."""
    classes = card["data"]["classes"]
    header = ["file", "class", "probability", "top3", "msppp", "sbr", "height", "width"]
    rows = []
    for frame, p in zip(frames, probs, strict=True):
        order = np.argsort(-p, kind="stable")
        top3 = ";".join(f"{classes[k]}:{p[k]:.4f}" for k in order[:3])
        rows.append(
            [frame.name, classes[order[0]], f"{p[order[0]]:.4f}", top3, *_tail(frame, card)]
        )
    return [*header, "warning"], rows


def _palette(colours: list[str]) -> list[int]:
    palette = [0] * 768
    for k, colour in enumerate(colours):
        palette[3 * k : 3 * k + 3] = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    return palette  # index 255 (voids) stays black


def _mask_name(name: str) -> str:
    return str(Path(name).with_suffix("")).replace("/", "__").replace("\\", "__")


def write_masks(folder: Path, frames, probs, card) -> tuple[list[str], list[list]]:
    """Masks (PNG + .npz) under ``folder/masks``; the rows of the fractions CSV."""
    from PIL import Image

    classes, palette = card["data"]["classes"], _palette(card["data"]["colours"])
    (folder / "masks").mkdir()
    rows = []
    for frame, p in zip(frames, probs, strict=True):
        valid = np.isfinite(frame.depth_m)
        labels = np.where(valid, p.argmax(0), IGNORE_INDEX).astype(np.uint8)
        stem = folder / "masks" / _mask_name(frame.name)
        image = Image.fromarray(labels, mode="P")
        image.putpalette(palette)
        image.save(stem.with_suffix(".png"))
        np.savez_compressed(
            stem.with_suffix(".npz"), labels=labels, probability=p.max(0).astype(np.float16)
        )
        n = max(int(valid.sum()), 1)
        fractions = [f"{(labels == k).sum() / n:.4f}" for k in range(len(classes))]
        void = f"{1 - valid.mean():.4f}"
        rows.append([frame.name, f"masks/{stem.name}.png", *fractions, void, *_tail(frame, card)])
    header = ["file", "mask", *[f"fraction_{c}" for c in classes], "void_fraction"]
    return [*header, "msppp", "sbr", "height", "width", "warning"], rows


def _write_folder(out: Path, fill) -> Path:
    """Fill a fresh folder beside ``out`` with ``fill(folder)``, then put it at ``out``."""
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.exists() and not (out / CSV_NAME).is_file() and any(out.iterdir()):
        raise ValueError(f"{out}: exists and holds no {CSV_NAME}; give an empty or new folder.")
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        fill(tmp)
        tmp.chmod(0o755)
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
            out.rename(old / "previous")
            tmp.rename(out)
            shutil.rmtree(old)
        else:
            tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def predict(
    model_path,
    inputs,
    out,
    *,
    card=None,
    overrides: dict | None = None,
    depth_key: str = RELEASE_DEPTH_KEY,
    weights=None,
    log=print,
) -> Path:
    """Predict on ``inputs`` (files and folders) with ``model_path``; write ``out``.

    ``overrides``: capture options replacing the card's reconstruction settings
    (``CaptureOptions`` fields); ``weights``: SSPI weights folder when reconstructing
    with sspi. Returns ``out``.

    Raises:
        ValueError: one sentence for a model without a matching card, an unreadable
            input, an image shape the model cannot take or an unknown class set.
    """
    deployed = open_model(model_path, card)
    options = capture_options(deployed.card["data"].get("reconstruction"), overrides)
    frames = read_frames(inputs, options, depth_key, weights)
    _check_frames(frames, deployed)
    probs = run_frames(deployed, frames)
    card_ = deployed.card

    def fill(folder: Path) -> None:
        if card_["model"]["task"] == "classification":
            header, rows = classification_rows(frames, probs, card_)
        else:
            header, rows = write_masks(folder, frames, probs, card_)
        (folder / CSV_NAME).write_text(_csv_text(header, rows), encoding="utf-8")

    _write_folder(Path(out), fill)
    flagged = sum(bool(condition_warning(f, card_)) for f in frames)
    log(
        f"{out}: {len(frames)} frames predicted with {deployed.path.name} "
        f"({deployed.backend}); {flagged} outside the training conditions (warning column)"
    )
    return Path(out)
