"""Condition robustness map: final-round models evaluated over a grid of MSPPP x SBR.

Three steps, one per workflow rule:

1. ``make_grid_shard``: the test split re-observed at every grid condition, once per
   dataset (sharded: each shard takes a cost-balanced share of the conditions).
   Data with clean depth (the synthetic generators) go through the photon engine
   from their clean scenes, exactly as the observed images were made
   (``spl_al.data.observe`` with the dataset's sensor model); data without clean
   depth (real folders) are re-imaged by SIV from the observed image and its
   reconstructed reflectivity (``spl_al.data.variants``): what the grid then shows is the
   model under SIV's imitation of a condition, and every output says so
   (``source``: "clean" or "siv").
2. ``evaluate_grid``: one method, every seed: each seed's final-round ``model.pt`` on
   every cell (forward passes only, one pass over the whole grid per model; one job
   per method, so the dataset, grid and torch load once for all its seeds).
3. ``robustness_report``: ``tables/robustness.csv`` (mean, std, n per method and cell),
   ``tables/robustness_diff.csv`` (DUIS minus the best baseline per cell, paired over
   seeds, ``spl_al.report.stats``), a heatmap per method and the difference map.

Photon draws of cell (msppp, sbr) come from a seed derived from the grid's ``seed``
and the condition's values, keyed per sample uid, so a cell is the same whatever the
shard count or the other cells of the grid.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from spl_al.atomic import read_json, write_json
from spl_al.data import SCENE_FIELDS, Dataset, storage
from spl_al.data.dataset import HEADLINE_METRICS
from spl_al.data.observe import image_through_photons, observation_of, observe
from spl_al.data.seeds import STREAM_VARIANT, sample_rng
from spl_al.photon import Condition, PhotonScene
from spl_al.plotting import fit_texts, new_figure
from spl_al.report.display import FULL_METHOD
from spl_al.report.stat_figures import difference_figure, heatmap_figure
from spl_al.report.stats import paired_test
from spl_al.report.writers import atomic_write
from spl_al.seeding import grid_seed
from spl_al.training.compute import LOCAL, Compute

GRID_FORMAT = "spl-al-robustness-grid"


def grid_conditions(msppp, sbr) -> list[tuple[float, float]]:
    """Every (msppp, sbr) cell, MSPPP-major; one clear ValueError for a bad list."""
    for name, values in (("msppp", msppp), ("sbr", sbr)):
        v = np.asarray(values, dtype=float)
        if v.ndim != 1 or v.size == 0 or not np.all(np.isfinite(v) & (v > 0)):
            raise ValueError(
                f"robustness.{name} must be a non-empty list of values > 0, got {values!r}."
            )
        if np.unique(v).size != v.size:
            raise ValueError(f"robustness.{name} lists a value twice: {values!r}.")
    return [(float(m), float(s)) for m in msppp for s in sbr]


def shard_conditions(conditions, shard: int, shards: int) -> list[int]:
    """Indices of the conditions shard ``shard`` of ``shards`` makes.

    Greedy balance by expected photon count (msppp x (1 + 1/sbr) per pixel): the
    costliest remaining condition goes to the lightest shard.
    """
    if not (0 <= shard < shards):
        raise ValueError(f"shard must be in 0..{shards - 1}, got {shard}.")
    cost = np.array([m * (1 + 1 / s) for m, s in conditions])
    load = np.zeros(shards)
    owner = np.empty(len(conditions), dtype=int)
    for c in np.argsort(-cost, kind="stable"):
        owner[c] = int(np.argmin(load))
        load[owner[c]] += cost[c]
    return [int(c) for c in np.flatnonzero(owner == shard)]


def grid_samples(dataset, test_samples: int | None) -> np.ndarray:
    """Test-split indices the grid uses: all, or ``test_samples`` spread evenly over
    the split (which the generators order by class, so classes stay mixed)."""
    test = dataset.test_idx
    if test_samples is None or test_samples >= test.size:
        return test
    pick = np.unique(np.linspace(0, test.size - 1, int(test_samples)).round().astype(int))
    return test[pick]


def reimage(dataset, idx: np.ndarray, *, msppp: float, sbr: float, seed: int):
    """The samples ``idx`` imaged at (msppp, sbr): (depth (n, H, W) float32, source)."""
    n = idx.size
    if dataset.clean_depth_m is not None:
        refl = None if dataset.clean_reflectance is None else dataset.clean_reflectance[idx]
        model, compensated = observation_of(dataset)  # as the observed images were made
        depth, _ = observe(
            dataset.clean_depth_m[idx],
            refl,
            msppp=np.full(n, msppp),
            sbr=np.full(n, sbr),
            sensor=dataset.sensor,
            seed=seed,
            uid=dataset.uid[idx],
            model=model,
            range_compensated=compensated,
        )
        return depth, "clean"
    # SIV (Algorithm 1) of each observed image at (msppp, sbr), as spl_al.data.variants does:
    # its reconstructed depth and reflectivity through the photon engine again.
    out = np.full((n, *dataset.image_shape), np.nan, np.float32)
    for k, i in enumerate(idx):
        valid = np.isfinite(dataset.depth_m[i])
        if not valid.any():
            continue
        refl = None if dataset.reflectance is None else dataset.reflectance[i]
        if refl is not None:
            refl = np.where(valid, refl, 0.0) if (refl[valid] > 0).any() else None
        rng = sample_rng(seed, STREAM_VARIANT, int(dataset.uid[i]))
        scene = PhotonScene(dataset.depth_m[i], refl, valid)
        out[k] = image_through_photons(scene, Condition(msppp, sbr, dataset.sensor), rng)[0]
    return out, "siv"


def make_grid_shard(observed_path, grid: dict, shard: int, out_path) -> dict:
    """Shard ``shard`` of the dataset's robustness grid (``grid``: the config's
    msppp, sbr, shards, seed, test_samples), saved as one .npz of uint16 depth codes."""
    started = time.perf_counter()
    dataset = Dataset.load(observed_path)
    if dataset.sensor is None:
        raise ValueError(f"{observed_path}: the dataset records no sensor to re-image it with.")
    conditions = grid_conditions(grid["msppp"], grid["sbr"])
    mine = shard_conditions(conditions, int(shard), int(grid["shards"]))
    idx = grid_samples(dataset, grid.get("test_samples"))
    depth = np.empty((len(mine), idx.size, *dataset.image_shape), np.float32)
    source = "clean"
    for k, c in enumerate(mine):
        m, s = conditions[c]
        depth[k], source = reimage(dataset, idx, msppp=m, sbr=s, seed=grid_seed(grid["seed"], m, s))
    finite = depth[np.isfinite(depth)]
    step = storage.choose_depth_step(float(finite.max()) if finite.size else 0.0)
    arrays = {
        "depth_code": storage.encode_depth(depth, step),
        "condition": np.asarray(mine, dtype=np.int64),
        "msppp": np.array([conditions[c][0] for c in mine]),
        "sbr": np.array([conditions[c][1] for c in mine]),
        "sample_idx": idx.astype(np.int64),
    }
    seconds = round(time.perf_counter() - started, 3)
    meta = {"format": GRID_FORMAT, "step_m": step, "source": source, "seconds": seconds}
    storage.atomic_savez(out_path, arrays, meta)
    return {
        "conditions": len(mine),
        "images": int(depth.shape[0] * depth.shape[1]),
        "seconds": seconds,
    }


def load_grid(shard_paths) -> dict:
    """All shards of a grid: depth (C, n, H, W) float32 in condition order, msppp (C,),
    sbr (C,), sample_idx (n,), source."""
    parts = [storage.read_npz(p, GRID_FORMAT) for p in shard_paths]
    if not parts:
        raise ValueError("no robustness grid shard given.")
    idx = parts[0][0]["sample_idx"]
    for path, (arrays, _) in zip(shard_paths, parts, strict=True):
        if not np.array_equal(arrays["sample_idx"], idx):
            raise ValueError(f"{path}: holds other test samples than the grid's other shards.")
    order = np.argsort(np.concatenate([a["condition"] for a, _ in parts]))
    depth = np.concatenate([storage.decode_depth(a["depth_code"], m["step_m"]) for a, m in parts])
    return {
        "depth": depth[order],
        "msppp": np.concatenate([a["msppp"] for a, _ in parts])[order],
        "sbr": np.concatenate([a["sbr"] for a, _ in parts])[order],
        "sample_idx": idx,
        "source": parts[0][1]["source"],
    }


def evaluate_grid(
    observed_path,
    shard_paths,
    *,
    model_paths,
    model_cfg: dict,
    names: dict,
    out_path,
    compute: Compute = LOCAL,
    batch_size: int = 256,
) -> list[dict]:
    """Metric of saved models on every cell of the grid, written as a JSON list.

    ``model_paths``: one model per seed of ``names["seeds"]`` (same order);
    ``names``: dataset, method, seeds, round (recorded as they are). Each model's
    cells are evaluated in one pass (condition ids stand in for MSPPP levels in
    ``evaluate``) on ``compute``'s device at ``MEASURE_PRECISION`` (fp32); one record per
    seed, with the precision its model was trained at.
    """
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import load_model, resolved_for
    from spl_al.training import evaluate

    model_paths = [model_paths] if isinstance(model_paths, str | Path) else list(model_paths)
    seeds = [int(s) for s in names["seeds"]]
    if len(seeds) != len(model_paths):
        raise ValueError(
            f"evaluate_grid got {len(model_paths)} models for {len(seeds)} seeds {seeds}; "
            "give one model per seed."
        )
    compute.apply()
    dataset = Dataset.load(observed_path, skip=SCENE_FIELDS)
    compute = resolved_for(compute, dataset, model_cfg)
    grid = load_grid(shard_paths)
    c, n = grid["depth"].shape[:2]
    depth = grid["depth"].reshape(c * n, *grid["depth"].shape[2:])
    targets = np.tile(dataset.labels[grid["sample_idx"]], (c,) + (1,) * (dataset.labels.ndim - 1))
    cell = np.repeat(np.arange(c), n).astype(str)
    key = HEADLINE_METRICS[dataset.task]
    records = []
    for seed, model_path in zip(seeds, model_paths, strict=True):
        started = time.perf_counter()
        model = load_model(dataset, model_cfg, model_path)  # (evaluate runs it in eval mode)
        metrics = evaluate(
            model,
            depth,
            np.isfinite(depth),
            targets,
            levels=cell,
            classes=dataset.classes,
            compute=compute.measuring(),
            batch_size=batch_size,
        )
        per_cell = metrics["per_level"]
        records.append(
            {
                "dataset": names["dataset"],
                "method": names["method"],
                "seed": seed,
                "round": names["round"],
                "metric": key,
                "source": grid["source"],
                "n_test": int(n),
                "precision": compute.precision,
                "cells": [
                    {
                        "msppp": float(grid["msppp"][k]),
                        "sbr": float(grid["sbr"][k]),
                        "value": per_cell[str(k)][key],
                    }
                    for k in range(c)
                ],
                "seconds": round(time.perf_counter() - started, 3),
            }
        )
    write_json(records, out_path)
    return records


def training_range(observed_path) -> dict:
    """MSPPP and SBR range of the training split's observed images."""
    d = Dataset.load(observed_path, skip=SCENE_FIELDS)
    tr = d.train_idx
    return {
        "msppp": [float(np.nanmin(d.msppp[tr])), float(np.nanmax(d.msppp[tr]))],
        "sbr": [float(np.nanmin(d.sbr[tr])), float(np.nanmax(d.sbr[tr]))],
    }


def robustness_frame(eval_paths) -> pd.DataFrame:
    """One row per (method, seed, cell) of the evaluation records: dataset, metric,
    source, method, seed, round, msppp, sbr, value (in [0, 1])."""
    rows = []
    records = []
    for path in eval_paths:
        got = read_json(path)  # a list (evaluate_grid), or one record
        records += got if isinstance(got, list) else [got]
    for rec in records:
        for cell in rec["cells"]:
            rows.append(
                {
                    **{
                        k: rec[k]
                        for k in ("dataset", "metric", "source", "method", "seed", "round")
                    },
                    "msppp": cell["msppp"],
                    "sbr": cell["sbr"],
                    "value": np.nan if cell["value"] is None else float(cell["value"]),
                }
            )
    if not rows:
        raise ValueError("no robustness evaluation record given.")
    return pd.DataFrame(rows)


def _in_range(frame: pd.DataFrame, trained: dict) -> pd.Series:
    (m0, m1), (s0, s1) = trained["msppp"], trained["sbr"]
    return frame["msppp"].between(m0, m1) & frame["sbr"].between(s0, s1)


def robustness_table(frame: pd.DataFrame, trained: dict, scale: float = 100) -> pd.DataFrame:
    """Mean, std and n over seeds per method and cell (metric x ``scale``).

    Columns: dataset, metric, source, method, msppp, sbr, mean, std, n_seeds,
    trained_range (the cell lies inside the training split's MSPPP and SBR range).
    """
    keys = ["dataset", "metric", "source", "method", "msppp", "sbr"]
    out = (
        frame.groupby(keys, sort=True)["value"]
        .agg(mean="mean", std="std", n_seeds="count")
        .reset_index()
    )
    out["mean"] *= scale
    out["std"] *= scale
    out["trained_range"] = _in_range(out, trained)
    return out


def difference_table(
    frame: pd.DataFrame, trained: dict, full: str = FULL_METHOD, scale: float = 100
) -> pd.DataFrame:
    """DUIS minus the best baseline per cell, paired over seeds.

    The best baseline is the method (other than ``full``) with the highest mean over
    all cells and seeds. Columns: dataset, metric, source, method, baseline, msppp, sbr,
    n, diff, ci_low, ci_high, p_value, resolved, spans_zero (the 95% interval contains
    zero or is undefined), trained_range. Empty when ``full`` or every baseline is missing.
    """
    methods = set(frame["method"])
    baselines = sorted(methods - {full})
    if full not in methods or not baselines:
        return pd.DataFrame()
    means = frame[frame["method"].isin(baselines)].groupby("method")["value"].mean()
    best = str(means.sort_values(ascending=False, kind="stable").index[0])
    rows = []
    for (m, s), cell in frame.groupby(["msppp", "sbr"], sort=True):
        wide = cell.pivot_table(index="seed", columns="method", values="value")
        if full not in wide or best not in wide:
            continue
        test = paired_test(wide[full], wide[best])
        rows.append({"msppp": m, "sbr": s, **test})
    out = pd.DataFrame(rows)
    for col in ("diff", "ci_low", "ci_high"):
        out[col] = out[col] * scale
    out["spans_zero"] = ~((out["ci_low"] > 0) | (out["ci_high"] < 0))
    first = frame.iloc[0]
    out.insert(0, "baseline", best)
    out.insert(0, "method", full)
    for col in ("source", "metric", "dataset"):
        out.insert(0, col, first[col])
    out["trained_range"] = _in_range(out, trained)
    cols = [
        "dataset",
        "metric",
        "source",
        "method",
        "baseline",
        "msppp",
        "sbr",
        "n",
        "diff",
        "ci_low",
        "ci_high",
        "p_value",
        "resolved",
        "spans_zero",
        "trained_range",
    ]
    return out[cols]


def robustness_report(
    eval_paths, observed_path, *, table_csv, diff_csv, heatmap_png, diff_png
) -> dict:
    """Tables and figures of the robustness map of one dataset (see module docstring)."""
    frame = robustness_frame(eval_paths)
    trained = training_range(observed_path)
    table = robustness_table(frame, trained)
    diff = difference_table(frame, trained)
    atomic_write(table_csv, lambda tmp: table.to_csv(tmp, index=False))
    atomic_write(diff_csv, lambda tmp: diff.to_csv(tmp, index=False))
    source = frame["source"].iloc[0]
    note = (
        "\n(re-imaged by SIV from the observed test images: no clean depth)"
        if source == "siv"
        else "\n(test scenes re-observed through the photon engine)"
    )
    note += "; dashed: the training conditions' range"
    fig = heatmap_figure(table, note=note)
    atomic_write(heatmap_png, lambda tmp: fig.savefig(tmp, format="png", dpi=130))
    if diff.empty:
        fig = _empty_figure("No DUIS run or no baseline: no difference map.")
    else:
        fig = difference_figure(diff, note=" (SIV re-imaged)" if source == "siv" else "")
    atomic_write(diff_png, lambda tmp: fig.savefig(tmp, format="png", dpi=130))
    return {"cells": len(table), "source": source}


def _empty_figure(text: str):

    fig = new_figure(4, 1.5)
    fig.text(0.5, 0.5, text, ha="center", va="center")
    return fit_texts(fig)
