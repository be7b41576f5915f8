"""The condition robustness grid: cells, shards, determinism, evaluation, tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from spl_al.experiment.robustness import (
    difference_table,
    evaluate_grid,
    grid_conditions,
    grid_samples,
    load_grid,
    make_grid_shard,
    robustness_frame,
    robustness_table,
    shard_conditions,
)

GRID = {"msppp": [1, 5], "sbr": [0.1, 1, 5], "shards": 2, "seed": 0, "test_samples": 6}


@pytest.fixture(scope="module")
def observed(tmp_path_factory):
    from spl_al.data import make_classification_dataset

    path = tmp_path_factory.mktemp("rob") / "observed.npz"
    make_classification_dataset(
        n_per_class=2, image_shape=(24, 24), test_fraction=0.5, seed=0, workers=1
    ).save(path)
    return path


def test_conditions_and_balanced_shards():
    cells = grid_conditions([1, 5], [0.1, 1, 5])
    assert cells == [(1, 0.1), (1, 1), (1, 5), (5, 0.1), (5, 1), (5, 5)]
    parts = [shard_conditions(cells, k, 2) for k in range(2)]
    assert sorted(parts[0] + parts[1]) == list(range(6)) and not set(parts[0]) & set(parts[1])
    with pytest.raises(ValueError, match=r"robustness\.sbr must be a non-empty list"):
        grid_conditions([1], [])
    with pytest.raises(ValueError, match="lists a value twice"):
        grid_conditions([1, 1], [1])


def test_grid_shapes_determinism_and_shard_independence(observed, tmp_path):
    from spl_al.data import Dataset

    paths = [tmp_path / f"shard{k}.npz" for k in range(2)]
    for k, p in enumerate(paths):
        make_grid_shard(observed, GRID, k, p)
    grid = load_grid(paths)
    n = grid_samples(Dataset.load(observed), 6).size
    assert grid["depth"].shape == (6, n, 24, 24) and grid["source"] == "clean"
    assert grid["msppp"].tolist() == [1, 1, 1, 5, 5, 5]
    assert grid["sbr"].tolist() == [0.1, 1, 5, 0.1, 1, 5]

    # Same config, one shard instead of two: every cell bit-identical.
    one = tmp_path / "one.npz"
    make_grid_shard(observed, {**GRID, "shards": 1}, 0, one)
    again = load_grid([one])
    np.testing.assert_array_equal(again["depth"], grid["depth"])

    # Harsher cells are worse images: depth error vs the clean scene (voids count as
    # 1 m) is largest at MSPPP 1, SBR 0.1 and smallest at MSPPP 5, SBR 5.
    clean = Dataset.load(observed).clean_depth_m[grid["sample_idx"]]
    has = np.isfinite(clean)
    err = np.abs(np.nan_to_num(grid["depth"] - clean, nan=1.0))[:, has].mean(axis=1)
    assert err.argmax() == 0 and err.argmin() == 5


def test_folder_data_without_clean_depth_goes_through_siv(observed, tmp_path):
    from spl_al.data import Dataset

    d = Dataset.load(observed)
    d.clean_depth_m = None
    d.clean_reflectance = None
    path = tmp_path / "noclean.npz"
    d.save(path)
    out = tmp_path / "g.npz"
    make_grid_shard(path, {**GRID, "shards": 1}, 0, out)
    assert load_grid([out])["source"] == "siv"


def test_evaluate_grid_and_tables(observed, tmp_path):
    import torch

    from spl_al.data import Dataset
    from spl_al.models.configured import model_for

    shard = tmp_path / "grid.npz"
    make_grid_shard(observed, {**GRID, "shards": 1}, 0, shard)
    model = model_for(Dataset.load(observed), {"arch": "smallcnn"})
    torch.save(model.state_dict(), tmp_path / "model.pt")
    evals = []
    for method in ("random", "duis"):
        names = {"dataset": "d", "method": method, "seeds": [1, 2], "round": 1}
        out = tmp_path / f"{method}.json"
        models = [tmp_path / "model.pt"] * 2
        recs = evaluate_grid(
            observed, [shard], model_paths=models, model_cfg={"arch": "smallcnn"},
            names=names, out_path=out,
        )  # fmt: skip
        assert [r["seed"] for r in recs] == [1, 2]
        assert all(len(r["cells"]) == 6 and all(0 <= c["value"] <= 1 for c in r["cells"])
                   for r in recs)  # fmt: skip
        evals.append(out)
    with pytest.raises(ValueError, match="got 1 models for 2 seeds"):
        evaluate_grid(
            observed, [shard], model_paths=models[:1], model_cfg={"arch": "smallcnn"},
            names=names, out_path=out,
        )  # fmt: skip
    frame = robustness_frame(evals)
    trained = {"msppp": [2, 10], "sbr": [0.2, 5]}
    table = robustness_table(frame, trained)
    assert len(table) == 12 and (table["n_seeds"] == 2).all()
    assert table.loc[(table["msppp"] == 5) & (table["sbr"] == 1), "trained_range"].all()
    assert not table.loc[table["msppp"] == 1, "trained_range"].any()
    diff = difference_table(frame, trained)
    # The same model for both methods: every difference is exactly zero and spans zero.
    assert len(diff) == 6 and (diff["diff"] == 0).all() and diff["spans_zero"].all()
    assert (diff["baseline"] == "random").all()


def test_difference_table_marks_resolved_cells():
    rows = []
    for seed, noise in zip((1, 2, 3), (0.0, 0.01, -0.01), strict=True):
        for m, s in ((1, 0.1), (5, 1)):
            base = 0.5 + noise
            rows.append(("random", seed, m, s, base))
            gain = 0.2 + 0.001 * seed if m == 5 else (0.01, -0.02, 0.015)[seed - 1]
            rows.append(("duis", seed, m, s, base + gain))
    frame = pd.DataFrame(rows, columns=["method", "seed", "msppp", "sbr", "value"]).assign(
        dataset="d", metric="accuracy", source="clean", round=1
    )
    diff = difference_table(frame, {"msppp": [2, 10], "sbr": [0.2, 5]}).set_index("msppp")
    assert not diff.loc[5, "spans_zero"] and diff.loc[5, "resolved"]
    assert diff.loc[1, "spans_zero"] and not diff.loc[1, "resolved"]
    assert diff.loc[5, "diff"] == pytest.approx(20.2)


def test_config_schema_checks_the_grid_keys():
    import yaml

    from spl_al.config import check_config

    root = Path(__file__).resolve().parents[1]
    config = yaml.safe_load((root / "config/config.yaml").read_text())
    check_config(config, root / "config/schema.yaml")
    config["robustness"]["sbr"] = [0.05, 0]
    with pytest.raises(ValueError, match=r"config key 'robustness\.sbr\.1': 0 is less than or"):
        check_config(config, root / "config/schema.yaml")
    config["robustness"]["sbr"] = [1]
    config["datasets"]["real_cls"]["robustness"] = {"grid": 3}
    with pytest.raises(ValueError, match="'grid' was unexpected"):
        check_config(config, root / "config/schema.yaml")
