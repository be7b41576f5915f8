"""Synthetic datasets: procedural scenes observed through the photon engine.

``make_classification_dataset``: the 11 object categories (``spl_al.scenes.objects``),
64x64 by default (the paper's real frames; its synthetic set is 72x128).
``make_segmentation_dataset``: street scenes (``spl_al.scenes.street``) as 64-row
range images with per-pixel labels.

Every sample k has an id uid = k; its scene comes from ``sample_rng(seed,
STREAM_SCENE, uid)`` and its photons from ``sample_rng(seed, STREAM_OBSERVE, uid)``,
so the same arguments give bit-identical datasets for any number of workers.
Split (stratified per class) and conditions (levels balanced per class and split)
come from ``sample_rng(seed, STREAM_SPLIT)``.
"""

from __future__ import annotations

import numpy as np

from spl_al.data.dataset import Dataset, sensor_to_dict
from spl_al.data.observe import (
    DEFAULT_LEVELS,
    DEFAULT_SBR,
    assign_conditions,
    check_levels,
    check_sbr_values,
    observe_image,
)
from spl_al.data.parallel import chunk_indices, default_workers, run_chunks
from spl_al.data.seeds import (
    STREAM_INSTANCE,
    STREAM_OBSERVE,
    STREAM_SCENE,
    STREAM_SPLIT,
    sample_rng,
)
from spl_al.photon import METHODS, SensorParams
from spl_al.photon.observation import ObservationModel
from spl_al.scenes.objects import CATEGORIES, render_object
from spl_al.scenes.raycast import ScanGrid
from spl_al.scenes.street import STREET_CLASSES, default_grid, render_street


def stratified_split(
    labels: np.ndarray, test_fraction: float, rng: np.random.Generator
) -> np.ndarray:
    """(N,) "train"/"test": round(test_fraction * n_c) random samples of each class c go to test."""
    if not 0 <= test_fraction < 1:
        raise ValueError(f"test_fraction must be in [0, 1), got {test_fraction!r}.")
    split = np.full(len(labels), "train", dtype="<U5")
    for c in np.unique(labels):
        idx = np.flatnonzero(labels == c)
        n_test = round(test_fraction * idx.size)
        split[rng.permutation(idx)[:n_test]] = "test"
    return split


def _check_shape(image_shape) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in image_shape)
    except (TypeError, ValueError):
        raise ValueError(f"image_shape must be (rows, cols), got {image_shape!r}.") from None
    if rows < 4 or cols < 4:
        raise ValueError(f"image_shape must be at least (4, 4), got {image_shape!r}.")
    return rows, cols


def _check_common(n, seed, method, workers):
    if int(n) != n or n < 1:
        raise ValueError(f"the number of samples must be a positive integer, got {n!r}.")
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}.")
    if method not in METHODS:
        raise ValueError(f"reconstruct_method must be one of {METHODS}, got {method!r}.")
    return default_workers() if workers is None else int(workers)


def _observation(observation) -> ObservationModel:
    if isinstance(observation, ObservationModel):
        return observation
    return ObservationModel.from_dict(observation)


def _observe_into(out, k, img, msppp, sbr, sensor, seed, uid, method, model, compensated):
    """Row k of out["depth"] / out["refl"]: the clean scene ``img`` seen through the
    sensor model at (msppp, sbr), seeded by the sample's uid."""
    out["depth"][k], out["refl"][k] = observe_image(
        img.depth_m,
        img.reflectance,
        msppp,
        sbr,
        sensor,
        sample_rng(seed, STREAM_OBSERVE, uid),
        method,
        model=None if model.is_algorithm1 else model,
        range_compensated=compensated,
    )


def _object_chunk(uids, categories, msppp, sbr, seed, sensor, method, model, scene_kw):
    n = len(uids)
    rows, cols = scene_kw["image_shape"]
    out = {
        "clean": np.empty((n, rows, cols), np.float32),
        "clean_refl": np.empty((n, rows, cols), np.float32),
        "mask": np.empty((n, rows, cols), bool),
        "depth": np.empty((n, rows, cols), np.float32),
        "refl": np.empty((n, rows, cols), np.float32),
        "distance": np.empty(n),
    }
    options = dict(scene_kw)
    instances = options.pop("instances_per_class", None)
    for k, uid in enumerate(uids):
        rng = sample_rng(seed, STREAM_SCENE, uid)
        instance_rng = None
        if instances:
            # instance i of class c: the same object whichever sample shows it
            key = CATEGORIES.index(categories[k]) * 1_000_000 + int(rng.integers(instances))
            instance_rng = sample_rng(seed, STREAM_INSTANCE, key)
        img = render_object(categories[k], rng, instance_rng=instance_rng, **options)
        out["clean"][k], out["clean_refl"][k], out["mask"][k] = (
            img.depth_m,
            img.reflectance,
            img.object_mask,
        )
        out["distance"][k] = img.distance_m
        _observe_into(out, k, img, msppp[k], sbr[k], sensor, seed, uid, method, model, False)
    return out


def _assemble(task, classes, parts, labels, conditions, sensor, grid, generator, meta) -> Dataset:
    """One Dataset from the chunks of a generator: observed and clean depth and
    reflectance (and object masks or per-pixel labels when the chunks carry them)."""
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    split, msppp, sbr, level, uid = conditions
    return Dataset(
        task=task,
        classes=classes,
        depth_m=cat["depth"],
        labels=cat["labels"] if labels is None else labels,
        split=split,
        msppp=msppp,
        sbr=sbr,
        level=level,
        uid=uid,
        clean_depth_m=cat["clean"],
        reflectance=cat["refl"],
        clean_reflectance=cat["clean_refl"],
        object_mask=cat.get("mask"),
        sensor=sensor,
        meta={
            "source": "synthetic",
            "generator": generator,
            **meta,
            "sensor": sensor_to_dict(sensor),
            "grid": {
                "elevation_deg": list(grid.elevation_deg),
                "azimuth_deg": list(grid.azimuth_deg),
            },
        },
    )


def make_classification_dataset(
    n_per_class: int = 100,
    image_shape=(64, 64),
    levels=DEFAULT_LEVELS,
    sbr_values=DEFAULT_SBR,
    seed: int = 0,
    test_fraction: float = 0.3,
    sensor: SensorParams | None = None,
    reconstruct_method: str = "pooled",
    classes=CATEGORIES,
    fov_deg: float = 30.0,
    max_range_m: float = 140.0,
    workers: int | None = None,
    observation=None,
    **scene_options,
) -> Dataset:
    """Procedural object scenes of ``classes`` and their observed SPL images.

    Args:
        n_per_class: samples per class (uids class by class: class c holds
            c * n_per_class .. (c + 1) * n_per_class - 1).
        image_shape: (rows, cols); rows span ``fov_deg``, pixels square in angle.
        levels: MSPPP level name -> signal photons per pixel (or a (low, high) range).
        sbr_values: signal-to-background ratios drawn uniformly per sample.
        seed: the seed of every random draw.
        test_fraction: fraction of each class in the test split.
        sensor: SPL timing; default ``SensorParams.paper_real()`` (80 ps bins, 520 ps
            jitter, 150 m): the paper's sensor, with the reach for buildings and ships.
        reconstruct_method: ``spl_al.photon.reconstruct`` method of the observed images.
        classes: subset of ``spl_al.scenes.objects.CATEGORIES``.
        fov_deg, max_range_m, **scene_options: passed to ``render_object``
            (``fill``, ``elevation_deg``, ``azimuth_deg``, ``p_ground``, ``p_wall``,
            ``min_return``), and ``instances_per_class``: how many physical objects
            each class has (None: every sample its own object); each sample shows one
            of them, drawn at random, in its own pose, view and distance.
        workers: processes (None = all cores; the result does not depend on it).
        observation: the sensor model of the observed images, an
            ``spl_al.photon.ObservationModel`` or a dict of its fields (None: the default
            model, every effect on; ``ObservationModel.algorithm1()``: none).

    Returns:
        Dataset with observed depth and reflectivity, clean depth and reflectance,
        object masks, and no variants yet (``spl_al.variants`` adds them).
    """
    classes = list(classes)
    unknown = sorted(set(classes) - set(CATEGORIES))
    if unknown or not classes:
        raise ValueError(
            f"classes must be a non-empty subset of {CATEGORIES}, got unknown {unknown}."
        )
    workers = _check_common(n_per_class, seed, reconstruct_method, workers)
    shape = _check_shape(image_shape)
    sensor = SensorParams.paper_real() if sensor is None else sensor
    if max_range_m > sensor.max_depth_m:
        raise ValueError(
            f"max_range_m={max_range_m} m is beyond the sensor's reach "
            f"of {sensor.max_depth_m:.1f} m."
        )
    levels, sbr_values = check_levels(levels), check_sbr_values(sbr_values)
    model = _observation(observation)

    labels = np.repeat(np.arange(len(classes)), n_per_class).astype(np.int64)
    n = labels.size
    uid = np.arange(n, dtype=np.int64)
    split_rng = sample_rng(seed, STREAM_SPLIT)
    split = stratified_split(labels, test_fraction, split_rng)
    msppp, sbr, level = assign_conditions(labels, split, levels, sbr_values, split_rng)

    scene_kw = {
        "image_shape": shape,
        "fov_deg": fov_deg,
        "max_range_m": max_range_m,
        **scene_options,
    }
    cats = np.asarray(classes)[labels]
    args = [
        (uid[c], cats[c], msppp[c], sbr[c], seed, sensor, reconstruct_method, model, scene_kw)
        for c in chunk_indices(n, workers)
    ]
    grid = ScanGrid.square_pixels(shape, fov_deg)
    return _assemble(
        "classification",
        classes,
        run_chunks(_object_chunk, args, workers),
        labels,
        (split, msppp, sbr, level, uid),
        sensor,
        grid,
        generator="spl_al.scenes.objects",
        meta={
            "seed": int(seed),
            "n_per_class": int(n_per_class),
            "test_fraction": float(test_fraction),
            "levels": levels,
            "sbr_values": sbr_values,
            "reconstruct_method": reconstruct_method,
            "observation": model.to_dict(),
            "fov_deg": float(fov_deg),
            "max_range_m": float(max_range_m),
            "scene_options": {
                k: (list(v) if isinstance(v, tuple) else v) for k, v in scene_options.items()
            },
        },
    )


def _street_chunk(uids, msppp, sbr, seed, sensor, method, model, grid, max_range_m):
    n = len(uids)
    rows, cols = grid.shape
    out = {
        "clean": np.empty((n, rows, cols), np.float32),
        "clean_refl": np.empty((n, rows, cols), np.float32),
        "labels": np.empty((n, rows, cols), np.uint8),
        "depth": np.empty((n, rows, cols), np.float32),
        "refl": np.empty((n, rows, cols), np.float32),
    }
    for k, uid in enumerate(uids):
        img = render_street(sample_rng(seed, STREAM_SCENE, uid), grid=grid, max_range_m=max_range_m)
        out["clean"][k], out["clean_refl"][k], out["labels"][k] = (
            img.depth_m,
            img.reflectance,
            img.labels,
        )
        _observe_into(out, k, img, msppp[k], sbr[k], sensor, seed, uid, method, model, True)
    return out


def make_segmentation_dataset(
    n_samples: int = 300,
    image_shape=(64, 256),
    levels=DEFAULT_LEVELS,
    sbr_values=DEFAULT_SBR,
    seed: int = 0,
    test_fraction: float = 0.3,
    sensor: SensorParams | None = None,
    reconstruct_method: str = "pooled",
    elevation_deg=(8.0, -22.0),
    azimuth_deg=(-45.0, 45.0),
    max_range_m: float = 120.0,
    workers: int | None = None,
    observation=None,
) -> Dataset:
    """Procedural street scenes as range images with per-pixel labels, and their
    observed SPL images.

    Args:
        n_samples: number of scenes.
        image_shape: (rows, cols) of the range image (64 beams by default).
        elevation_deg, azimuth_deg: (first, last) row / column centre angles.
        max_range_m: nothing beyond returns (labels there are 255).
        sensor: default ``SensorParams.street()`` (1024 bins of 1 ns, 153 m).
        others: as ``make_classification_dataset`` (the street scenes' reflectance is
            range-compensated, so the observation model applies the range falloff).

    Returns:
        Dataset with classes ``STREET_CLASSES``, (N, H, W) uint8 labels (255 = no
        return), observed and clean depth; ``points(i)`` gives the point cloud.
    """
    workers = _check_common(n_samples, seed, reconstruct_method, workers)
    shape = _check_shape(image_shape)
    sensor = SensorParams.street() if sensor is None else sensor
    if max_range_m > sensor.max_depth_m:
        raise ValueError(
            f"max_range_m={max_range_m} m is beyond the sensor's reach "
            f"of {sensor.max_depth_m:.1f} m."
        )
    levels, sbr_values = check_levels(levels), check_sbr_values(sbr_values)
    model = _observation(observation)
    grid = (
        ScanGrid(shape, tuple(elevation_deg), tuple(azimuth_deg))
        if elevation_deg
        else default_grid(shape)
    )
    n = int(n_samples)
    uid = np.arange(n, dtype=np.int64)
    split_rng = sample_rng(seed, STREAM_SPLIT)
    split = stratified_split(np.zeros(n, np.int64), test_fraction, split_rng)
    msppp, sbr, level = assign_conditions(
        np.zeros(n, np.int64), split, levels, sbr_values, split_rng
    )
    args = [
        (uid[c], msppp[c], sbr[c], seed, sensor, reconstruct_method, model, grid, max_range_m)
        for c in chunk_indices(n, workers)
    ]
    parts = run_chunks(_street_chunk, args, workers)
    return _assemble(
        "segmentation",
        list(STREET_CLASSES),
        parts,
        None,  # the per-pixel labels come with the scenes
        (split, msppp, sbr, level, uid),
        sensor,
        grid,
        generator="spl_al.scenes.street",
        meta={
            "seed": int(seed),
            "test_fraction": float(test_fraction),
            "levels": levels,
            "sbr_values": sbr_values,
            "reconstruct_method": reconstruct_method,
            "observation": model.to_dict(),
            "max_range_m": float(max_range_m),
        },
    )
