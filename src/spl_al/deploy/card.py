"""Model cards: what a trained model is, what it was trained on, and how well it does.

A card is one JSON record (``{stem}.card.json`` beside ``{stem}.pt`` or
``{stem}.onnx``) plus its Markdown rendering (``{stem}.card.md``). It carries all that
``predict`` and ``export`` need to rebuild and feed the model without the run's
config: the architecture and its parameters, the classes and their colours, the
input shape, units and preprocessing, how raw captures are reconstructed, and the
MSPPP / SBR range of the training images (a frame outside it gets a warning). Beside
them it records the run (method, seed, round, the labeled samples), the training
recipe and precision, the test metric overall and per MSPPP level, the robustness
map's MSPPP x SBR grid when it was run, the spl-al version and commit and a hash of
the config the model depends on. ``export`` adds the ONNX check's figures.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import spl_al
from spl_al.atomic import atomic_write_text, read_json, write_json
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.data.dataset import sensor_to_dict
from spl_al.plotting import class_colours
from spl_al.pool import read_labeled

CARD_FORMAT = "spl-al-model-card"
CARD_VERSION = 1
PREPROCESSING = {
    "normalised": (
        "valid = isfinite(depth_m) & depth_m > 0; over each image's valid pixels "
        "z = clip((depth_m - median) / max(1.4826 MAD, 0.01 |median|, 1 mm), -4, 4) "
        "(the lower median of an even count), 0 at voids; input (B, 2, H, W) = (z, valid)"
    ),
    "range_m": (
        "valid = isfinite(depth_m) & depth_m > 0; input (B, 2, H, W) = (depth_m, valid), "
        "0 m at voids; the network standardises it itself"
    ),
}


@dataclass(frozen=True)
class RunFacts:
    """What a card says of the run that made the model, beyond its files.

    Attributes:
        dataset: the dataset's name in the config.
        method: the method's name; ``strategy`` and ``method_params`` its query.
        seed, round: the run seed and the round whose model this is.
        train: the training setup (``model``: arch and parameters, ``fit``: recipe).
        reconstruction: how a raw capture becomes depth for this model (method and
            the capture options of ``spl_al.data.raw_captures.CaptureOptions``).
        config: the config the model depends on (hashed into ``config_hash``).
    """

    dataset: str
    method: str
    seed: int
    round: int
    train: dict
    strategy: str = ""
    method_params: dict = field(default_factory=dict)
    reconstruction: dict = field(default_factory=lambda: {"method": "pooled"})
    config: dict = field(default_factory=dict)


def card_path(model_path) -> Path:
    """``{stem}.card.json`` beside a model file."""
    path = Path(model_path)
    return path.with_name(f"{path.stem}.card.json")


def config_hash(config: dict) -> str:
    """sha256 (first 16 hex digits) of ``config`` as canonical JSON."""
    text = json.dumps(config, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def file_sha256(path) -> str:
    """sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def git_commit() -> str | None:
    """The commit of the spl-al checkout this code runs from (None outside git)."""
    try:
        run = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=10,
        )
    except OSError:
        return None
    return run.stdout.strip() or None if run.returncode == 0 else None


def _range(values) -> list[float] | None:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return [float(v.min()), float(v.max())] if v.size else None


def training_conditions(dataset, rows, n_variants: int) -> dict:
    """MSPPP and SBR range of the images a model trained on: the observed images of
    dataset ``rows`` and their first ``n_variants`` variants."""
    msppp, sbr = [dataset.msppp[rows]], [dataset.sbr[rows]]
    if n_variants and dataset.variant_msppp is not None:
        msppp.append(dataset.variant_msppp[rows, :n_variants].ravel())
        sbr.append(dataset.variant_sbr[rows, :n_variants].ravel())
    return {"msppp": _range(np.concatenate(msppp)), "sbr": _range(np.concatenate(sbr))}


def _model_section(dataset, facts: RunFacts, model_path) -> dict:
    # torch on demand (importing this module does not load it)
    from spl_al.models import model_class

    model_cfg = dict(facts.train.get("model", {}))
    arch = model_cfg.pop("arch", None)
    cls = model_class(dataset.task, arch)
    section = {
        "file": Path(model_path).name,
        "sha256": file_sha256(model_path),
        "task": dataset.task,
        "arch": arch or next(iter(_archs(dataset.task))),
        "params": model_cfg,
        "n_classes": len(dataset.classes),
        "input_kind": _input_kind(cls, model_cfg),
    }
    if getattr(cls, "needs_grid", False):
        section["grid"] = dataset.meta.get("grid")
    return section


def _archs(task: str) -> dict:
    # torch on demand (importing this module does not load it)
    from spl_al.models import ARCHS

    return ARCHS[task]


def _input_kind(cls, params: dict) -> str:
    kind = getattr(cls, "input_kind", "normalised")
    return "range_m" if params.get("absolute") else kind


def _data_section(dataset, facts: RunFacts, rows, n_variants: int) -> dict:

    return {
        "name": facts.dataset,
        "task": dataset.task,
        "classes": list(dataset.classes),
        "colours": class_colours(dataset.classes),
        "image_shape": list(dataset.image_shape),
        "n_train": len(dataset.train_idx),
        "n_test": len(dataset.test_idx),
        "synthetic_standin": bool(dataset.meta.get("synthetic_standin", False)),
        "sensor": sensor_to_dict(dataset.sensor),
        "reconstruction": facts.reconstruction,
        "trained_conditions": training_conditions(dataset, rows, n_variants),
    }


def _metrics_section(metrics: dict) -> dict:
    per_level = metrics.get("per_level", {})
    return {
        "split": "test",
        "metric": metrics["metric"],
        "value": metrics["value"],
        "per_level": per_level,
        "per_level_metric": f"{metrics['metric']} per MSPPP level (high / medium / low)",
    }


def robustness_cells(records, seed: int) -> dict | None:
    """The robustness map's cells of ``seed`` from an ``evaluate_grid`` record list."""
    for record in records or []:
        if int(record["seed"]) == int(seed):
            return {
                "metric": record["metric"],
                "source": record["source"],
                "n_test": record["n_test"],
                "cells": record["cells"],
            }
    return None


def build_card(
    model_path, dataset_path, *, labeled_path, metrics_path, facts: RunFacts, robustness_path=None
) -> dict:
    """The card of one round's ``model.pt`` (files of the pipeline's round folder).

    Args:
        model_path: the round's weights; its sha256 goes into the card.
        dataset_path: the dataset it trained on (``dataset.npz``).
        labeled_path: the round's labeled set (``labeled.json`` or the initial set).
        metrics_path: the round's metrics record (``metrics.json``).
        facts: what the config says of the run (``RunFacts``).
        robustness_path: the method's ``robustness/{method}.json``, or None.
    """
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    pool_idx = read_labeled(labeled_path)
    rows = dataset.train_idx[pool_idx]
    metrics = read_json(metrics_path)
    n_variants = max(int(metrics.get("train_images", rows.size)) // max(rows.size, 1) - 1, 0)
    uid = dataset.uid if dataset.uid is not None else np.arange(len(dataset))
    model = _model_section(dataset, facts, model_path)
    return {
        "format": CARD_FORMAT,
        "version": CARD_VERSION,
        "model": model,
        "data": {"path": str(dataset_path), **_data_section(dataset, facts, rows, n_variants)},
        "preprocessing": PREPROCESSING[model["input_kind"]],
        "run": {
            "method": facts.method,
            "strategy": facts.strategy,
            "method_params": facts.method_params,
            "seed": int(facts.seed),
            "round": int(facts.round),
            "n_labeled": int(rows.size),
            "labeled_uids": uid[rows].tolist(),
            "variants_per_group": n_variants,
        },
        "training": {
            "recipe": facts.train.get("fit", {}),
            "precision": metrics.get("precision"),
            "train_steps": metrics.get("train_steps"),
            "images_seen": metrics.get("images_seen"),
        },
        "test": _metrics_section(metrics),
        "robustness": robustness_cells(
            read_json(robustness_path) if robustness_path else None, facts.seed
        ),
        "provenance": {
            "spl_al_version": spl_al.__version__,
            "commit": git_commit(),
            "config_hash": config_hash(facts.config or facts.train),
        },
    }


def write_card(card: dict, json_path) -> tuple[Path, Path]:
    """Write ``card`` to ``json_path`` and its Markdown beside it (``.card.md``)."""
    json_path = Path(json_path)
    md_path = json_path.with_name(json_path.name.removesuffix(".json") + ".md")
    write_json(card, json_path)
    atomic_write_text(md_path, render_markdown(card))
    return json_path, md_path


def read_card(path) -> dict:
    """A card written by ``write_card``; another file is one ValueError naming it."""
    card = read_json(path)
    if not isinstance(card, dict) or card.get("format") != CARD_FORMAT:
        raise ValueError(f"{path}: not an spl-al model card (expected format {CARD_FORMAT!r}).")
    if card.get("version") != CARD_VERSION:
        raise ValueError(
            f"{path}: model card version {card.get('version')!r}, expected {CARD_VERSION} "
            "(made by another spl-al version; rebuild it with this one)."
        )
    return card


def _pct(value) -> str:
    return "n/a" if value is None else f"{100 * float(value):.1f}%"


def _markdown_head(card: dict) -> list[str]:
    model, data, run = card["model"], card["data"], card["run"]
    cond = data["trained_conditions"]
    return [
        f"# Model card: {data['name']} / {run['method']} / seed {run['seed']} / "
        f"round {run['round']}",
        "",
        f"- **Task**: {model['task']}, {model['arch']} {json.dumps(model['params'])}",
        f"- **Classes** ({model['n_classes']}): "
        + ", ".join(f"{c} `{h}`" for c, h in zip(data["classes"], data["colours"], strict=True)),
        f"- **Input**: depth in metres from the sensor, shape {data['image_shape']} "
        f"(H, W), NaN / 0 at voids; {card['preprocessing']}",
        f"- **Raw captures**: reconstructed with {json.dumps(data['reconstruction'])}",
        f"- **Trained conditions**: MSPPP {cond['msppp']}, SBR {cond['sbr']}",
        f"- **Labels**: {run['n_labeled']} labeled samples (uids in the JSON card), "
        f"{run['variants_per_group']} SIV variants per sample in training",
        f"- **Method**: {run['method']} (strategy {run['strategy'] or 'n/a'}), "
        f"seed {run['seed']}, round {run['round']}",
        f"- **Training**: {json.dumps(card['training']['recipe'])}, precision "
        f"{card['training']['precision']}, {card['training']['train_steps']} steps",
    ]


def _markdown_metrics(card: dict) -> list[str]:
    test = card["test"]
    lines = ["", f"## Test {test['metric']}", "", "| split | value |", "|---|---|"]
    lines.append(f"| all | {_pct(test['value'])} |")
    lines += [f"| MSPPP {lv} | {_pct(v)} |" for lv, v in test["per_level"].items()]
    robust = card.get("robustness")
    if robust:
        sbrs = sorted({c["sbr"] for c in robust["cells"]})
        msppps = sorted({c["msppp"] for c in robust["cells"]})
        value = {(c["msppp"], c["sbr"]): c["value"] for c in robust["cells"]}
        lines += ["", f"## Robustness map ({robust['metric']}, {robust['source']})", ""]
        lines.append("| MSPPP \\ SBR | " + " | ".join(f"{s:g}" for s in sbrs) + " |")
        lines.append("|---" * (len(sbrs) + 1) + "|")
        for m in msppps:
            cells = " | ".join(_pct(value.get((m, s))) for s in sbrs)
            lines.append(f"| {m:g} | {cells} |")
    return lines


def _markdown_export(card: dict) -> list[str]:
    onnx = card.get("onnx")
    if not onnx:
        return []
    check = onnx["check"]
    return [
        "",
        "## ONNX export",
        "",
        f"- file `{onnx['file']}`, opset {onnx['opset']}, input `{onnx['input']}` "
        f"(batch, {', '.join(map(str, card['data']['image_shape']))}) float32, outputs "
        f"{', '.join(f'`{o}`' for o in onnx['outputs'])}",
        f"- onnxruntime {check['onnxruntime']} against torch on the test split "
        f"({check['n_samples']} samples, {check['n_units']} {check['unit']}s): max |logit "
        f"difference| {check['max_abs_logit_diff']:.3g} (bound {check['bound_logit']:g}), "
        f"argmax agreement {100 * check['argmax_agreement']:.3f}% "
        f"(bound {100 * check['bound_agreement']:g}%)",
    ]


def render_markdown(card: dict) -> str:
    """The card as Markdown: facts, the test metric per level, the grid, the export."""
    prov = card["provenance"]
    lines = [*_markdown_head(card), *_markdown_metrics(card), *_markdown_export(card)]
    lines += [
        "",
        f"spl-al {prov['spl_al_version']}, commit {prov['commit'] or 'unknown'}, "
        f"config hash {prov['config_hash']}; weights sha256 {card['model']['sha256'][:16]}.",
        "",
    ]
    return "\n".join(lines)
