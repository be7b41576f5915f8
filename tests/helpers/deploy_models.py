"""Small trained-like models with their cards, as the pipeline's rounds leave them.

``make_round(folder, task)`` writes a dataset, a seeded (untrained) model.pt, a
labeled set, a metrics record and the model's card, the files ``spl_al.deploy`` reads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import write_json
from spl_al.data import make_classification_dataset, make_segmentation_dataset
from spl_al.data.variants import make_variants
from spl_al.deploy.card import RunFacts, build_card, card_path, write_card
from spl_al.experiment.round0 import write_initial_set
from spl_al.models.configured import model_for, save_model
from spl_al.training import evaluate

MODELS = {
    "classification": {"arch": "smallcnn", "input_pool": 2},
    "segmentation": {"arch": "unet", "absolute": True, "width": 8},
}


def make_dataset(task: str):
    if task == "classification":
        data = make_classification_dataset(
            n_per_class=4, image_shape=(32, 32), classes=["apple", "banana", "bin"], seed=0
        )
    else:
        data = make_segmentation_dataset(n_samples=8, image_shape=(16, 64), seed=0)
    return make_variants(data, n_variants=2)


def make_round(folder: Path, task: str, model_cfg: dict | None = None) -> Path:
    """The round folder's model.pt (with dataset.npz, labeled.json, metrics.json and
    model.card.json beside it); returns the model's path."""
    folder.mkdir(parents=True, exist_ok=True)
    data = make_dataset(task)
    data.save(folder / "dataset.npz")
    model_cfg = dict(model_cfg or MODELS[task])
    model = model_for(data, model_cfg).eval()
    save_model(model, folder / "model.pt")
    write_initial_set(np.arange(4), 1, folder / "labeled.json")
    test = data.test_idx
    m = evaluate(
        model, data.depth_m[test], data.valid[test], data.labels[test], levels=data.level[test]
    )
    key = "accuracy" if task == "classification" else "miou"
    per_level = {lv: v[key] for lv, v in m["per_level"].items()}
    record = {"metric": key, "value": m[key], "per_level": per_level, "train_images": 12}
    write_json({**record, "precision": "fp32", "train_steps": 3}, folder / "metrics.json")
    facts = RunFacts(
        dataset=f"tiny_{task[:3]}",
        method="duis",
        seed=1,
        round=0,
        train={"model": model_cfg, "fit": {"epochs": 1}},
        strategy="duis",
    )
    card = build_card(
        folder / "model.pt",
        folder / "dataset.npz",
        labeled_path=folder / "labeled.json",
        metrics_path=folder / "metrics.json",
        facts=facts,
    )
    write_card(card, card_path(folder / "model.pt"))
    return folder / "model.pt"
