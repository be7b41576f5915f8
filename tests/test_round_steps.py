"""Round steps: round 0 fitted once and shared gives what training in place gives."""

from __future__ import annotations

import numpy as np
import pytest
from al_synthetic import shapes_groups

from spl_al.atomic import read_json
from spl_al.data import Dataset
from spl_al.experiment.steps import train_initial, train_round, write_initial_set
from spl_al.strategies import StrategyInputs

SETUP = {
    "train": {
        "model": {"arch": "smallcnn", "width": 4, "stages": 2},
        "fit": {"epochs": 2, "batch_size": 8, "log_every": 0},
    },
    "ratio_of": "train",
}


def _dataset(tmp_path):
    depth, _, labels = shapes_groups(30, n_groups=3, seed=1)
    n = len(labels)
    data = Dataset(
        "classification",
        ["small", "medium", "large"],
        depth[:, 0],
        labels.astype(np.int64),
        ["train"] * 24 + ["test"] * 6,
        np.full(n, 5.0),
        np.full(n, 1.0),
        ["high"] * n,
        variant_depth_m=depth[:, 1:],
        variant_msppp=np.full((n, 2), 2.0),
        variant_sbr=np.full((n, 2), 1.0),
    )
    path = tmp_path / "dataset.npz"
    data.save(path)
    labeled = tmp_path / "initial.json"
    write_initial_set(np.arange(6), 1, labeled)
    return path, labeled


@pytest.mark.parametrize(
    ("method", "m"),
    [({"strategy": "margin"}, 0), ({"strategy": "duis", "use_variants": True}, 2)],
)
def test_shared_round0_fit_equals_training_in_place(tmp_path, method, m):
    data, labeled = _dataset(tmp_path)
    setup = {**SETUP, "method": method}
    own = train_round(
        data, labeled, setup, "toy", "own", 1, 0, tmp_path / "own.pt", tmp_path / "own.json",
        tmp_path / "own.npz", device="cpu", log=tmp_path / "own.log",
    )  # fmt: skip
    train_initial(
        data, labeled, SETUP, m, 1, tmp_path / "init.pt", tmp_path / "fit.json",
        device="cpu", log=tmp_path / "init.log",
    )  # fmt: skip
    shared = train_round(
        data, labeled, setup, "toy", "own", 1, 0, tmp_path / "shared.pt",
        tmp_path / "shared.json", tmp_path / "shared.npz", device="cpu",
        initial_fit=(tmp_path / "init.pt", tmp_path / "fit.json"),
    )  # fmt: skip
    assert shared["value"] == own["value"]
    assert shared["train_images"] == own["train_images"] == 6 * (m + 1)
    assert read_json(tmp_path / "shared.json")["details"] == own["details"]
    a, b = StrategyInputs.load(tmp_path / "own.npz"), StrategyInputs.load(tmp_path / "shared.npz")
    for name in ("margin", "gamma", "inconsistency", "group_features"):
        if getattr(a, name) is not None:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.margin is not None or a.inconsistency is not None


def test_a_shared_fit_of_other_images_is_refused(tmp_path):
    data, labeled = _dataset(tmp_path)
    train_initial(data, labeled, SETUP, 0, 1, tmp_path / "init.pt", tmp_path / "fit.json",
                  device="cpu", log=tmp_path / "init.log")  # fmt: skip
    setup = {**SETUP, "method": {"strategy": "duis", "use_variants": True}}
    with pytest.raises(ValueError, match="trained on 6 images, but round 0 of duis trains on 18"):
        train_round(
            data, labeled, setup, "toy", "duis", 1, 0, tmp_path / "m.pt", tmp_path / "m.json",
            tmp_path / "s.npz", device="cpu",
            initial_fit=(tmp_path / "init.pt", tmp_path / "fit.json"),
        )  # fmt: skip
