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

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace

import numpy as np

from spl_al.data.dataset import Dataset, sensor_to_dict
from spl_al.data.observe import (
    DEFAULT_LEVELS,
    DEFAULT_SBR,
    Imaging,
    assign_conditions,
    check_levels,
    check_sbr_values,
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
from spl_al.photon.effects import ObservationModel
from spl_al.scenes.objects import CATEGORIES, ObjectView, render_view
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


def _check_reach(max_range_m: float, sensor: SensorParams) -> None:
    if max_range_m > sensor.max_depth_m:
        raise ValueError(
            f"max_range_m={max_range_m} m is beyond the sensor's reach "
            f"of {sensor.max_depth_m:.1f} m."
        )


def _check_classes(classes) -> list[str]:
    classes = list(classes)
    unknown = sorted(set(classes) - set(CATEGORIES))
    if unknown or not classes:
        raise ValueError(
            f"classes must be a non-empty subset of {CATEGORIES}, got unknown {unknown}."
        )
    return classes


@dataclass(frozen=True)
class SynthesisProtocol:
    """How a synthetic set is drawn and seen: the keyword options every maker shares.

    seed: the seed of every random draw.
    test_fraction: fraction of each class in the test split.
    levels: MSPPP level name -> signal photons per pixel (or a (low, high) range).
    sbr_values: signal-to-background ratios drawn uniformly per sample.
    sensor: SPL timing; None: the maker's default.
    reconstruct_method: ``spl_al.photon.reconstruct`` method of the observed images.
    observation: the sensor model of the observed images, an
        ``spl_al.photon.ObservationModel`` or a dict of its fields (None: the default
        model, every effect on; ``ObservationModel.algorithm1()``: none).
    workers: processes (None = all cores; the result does not depend on it).
    """

    seed: int = 0
    test_fraction: float = 0.3
    levels: Mapping = field(default_factory=lambda: DEFAULT_LEVELS)
    sbr_values: object = DEFAULT_SBR
    sensor: SensorParams | None = None
    reconstruct_method: str = "pooled"
    observation: ObservationModel | Mapping | None = None
    workers: int | None = None

    @classmethod
    def take(cls, options: Mapping) -> tuple[SynthesisProtocol, dict]:
        """The protocol named by ``options``, and the other options (in their order)."""
        names = {f.name for f in fields(cls)}
        mine = {k: v for k, v in options.items() if k in names}
        return cls(**mine), {k: v for k, v in options.items() if k not in names}

    def checked(self, n, default_sensor: SensorParams) -> SynthesisProtocol:
        """This protocol validated for ``n`` samples, with its defaults filled in."""
        if int(n) != n or n < 1:
            raise ValueError(f"the number of samples must be a positive integer, got {n!r}.")
        if int(self.seed) != self.seed or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed!r}.")
        if self.reconstruct_method not in METHODS:
            raise ValueError(
                f"reconstruct_method must be one of {METHODS}, got {self.reconstruct_method!r}."
            )
        observation = self.observation
        if not isinstance(observation, ObservationModel):
            observation = ObservationModel.from_dict(observation)
        return replace(
            self,
            levels=check_levels(self.levels),
            sbr_values=check_sbr_values(self.sbr_values),
            sensor=default_sensor if self.sensor is None else self.sensor,
            observation=observation,
            workers=default_workers() if self.workers is None else int(self.workers),
        )

    def imaging(self, range_compensated: bool) -> Imaging:
        """How every sample's clean scene is seen (Algorithm 1 as ``model`` None)."""
        model = None if self.observation.is_algorithm1 else self.observation
        return Imaging(self.sensor, self.reconstruct_method, model, range_compensated)

    def draw(self, groups: np.ndarray) -> Draw:
        """Split and conditions of samples of (N,) int ``groups``, from the split stream."""
        split_rng = sample_rng(self.seed, STREAM_SPLIT)
        split = stratified_split(groups, self.test_fraction, split_rng)
        msppp, sbr, level = assign_conditions(
            groups, split, levels=self.levels, sbr_values=self.sbr_values, rng=split_rng
        )
        uid = np.arange(len(groups), dtype=np.int64)
        return Draw(uid, split, msppp, sbr, level)

    def meta(self) -> dict:
        """What ``Dataset.meta`` records of the protocol (after ``seed``)."""
        return {
            "test_fraction": float(self.test_fraction),
            "levels": self.levels,
            "sbr_values": self.sbr_values,
            "reconstruct_method": self.reconstruct_method,
            "observation": self.observation.to_dict(),
        }


@dataclass(frozen=True)
class Draw:
    """Every sample's id, split and imaging condition; each field (N,)."""

    uid: np.ndarray
    split: np.ndarray
    msppp: np.ndarray
    sbr: np.ndarray
    level: np.ndarray

    def chunks(self, workers: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(uid, msppp, sbr) of each chunk of samples a worker renders."""
        n = len(self.uid)
        return [(self.uid[c], self.msppp[c], self.sbr[c]) for c in chunk_indices(n, workers)]


def _chunk_arrays(n: int, shape: tuple[int, int], extra: dict) -> dict[str, np.ndarray]:
    """Empty outputs of a chunk of n samples: clean and observed images, and ``extra``."""
    rows, cols = shape
    out = {
        "clean": np.empty((n, rows, cols), np.float32),
        "clean_refl": np.empty((n, rows, cols), np.float32),
    }
    out.update({k: np.empty((n, rows, cols), dtype) for k, dtype in extra.items()})
    out["depth"] = np.empty((n, rows, cols), np.float32)
    out["refl"] = np.empty((n, rows, cols), np.float32)
    return out


def _observe_into(out: dict, k: int, img, *, msppp: float, sbr: float, imaging, rng) -> None:
    """Row k of out["depth"] / out["refl"]: the clean scene ``img`` seen through
    ``imaging`` at (msppp, sbr)."""
    out["depth"][k], out["refl"][k] = imaging.observe(
        img.depth_m, img.reflectance, msppp=msppp, sbr=sbr, rng=rng
    )


@dataclass(frozen=True)
class _ObjectJob:
    """What every object chunk shares: seed, imaging, view and instances per class."""

    seed: int
    imaging: Imaging
    view: ObjectView
    instances: int | None


def _object_chunk(chunk, categories, job: _ObjectJob):
    uids, msppp, sbr = chunk
    out = _chunk_arrays(len(uids), job.view.image_shape, {"mask": bool})
    out["distance"] = np.empty(len(uids))
    for k, uid in enumerate(uids):
        rng = sample_rng(job.seed, STREAM_SCENE, uid)
        instance_rng = None
        if job.instances:
            # instance i of class c: the same object whichever sample shows it
            key = CATEGORIES.index(categories[k]) * 1_000_000 + int(rng.integers(job.instances))
            instance_rng = sample_rng(job.seed, STREAM_INSTANCE, key)
        img = render_view(categories[k], rng, job.view, instance_rng)
        out["clean"][k], out["clean_refl"][k], out["mask"][k] = (
            img.depth_m,
            img.reflectance,
            img.object_mask,
        )
        out["distance"][k] = img.distance_m
        obs_rng = sample_rng(job.seed, STREAM_OBSERVE, uid)
        _observe_into(out, k, img, msppp=msppp[k], sbr=sbr[k], imaging=job.imaging, rng=obs_rng)
    return out


def _assemble(
    task, classes, *, parts, labels, draw: Draw, sensor, grid, generator, meta
) -> Dataset:
    """One Dataset from the chunks of a generator: observed and clean depth and
    reflectance (and object masks or per-pixel labels when the chunks carry them)."""
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return Dataset(
        task=task,
        classes=classes,
        depth_m=cat["depth"],
        labels=cat["labels"] if labels is None else labels,
        split=draw.split,
        msppp=draw.msppp,
        sbr=draw.sbr,
        level=draw.level,
        uid=draw.uid,
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
    n_per_class: int = 100, image_shape=(64, 64), classes=CATEGORIES, **options
) -> Dataset:
    """Procedural object scenes of ``classes`` and their observed SPL images.

    Args:
        n_per_class: samples per class (uids class by class: class c holds
            c * n_per_class .. (c + 1) * n_per_class - 1).
        image_shape: (rows, cols); rows span ``fov_deg``, pixels square in angle.
        classes: subset of ``spl_al.scenes.objects.CATEGORIES``.
        **options: the fields of ``SynthesisProtocol`` (``seed``, ``test_fraction``, ``levels``,
            ``sbr_values``, ``sensor`` (default ``SensorParams.paper_real()``: 80 ps
            bins, 520 ps jitter, 150 m, the paper's sensor with the reach for
            buildings and ships), ``reconstruct_method``, ``observation``,
            ``workers``); the fields of ``spl_al.scenes.objects.ObjectView``
            (``fov_deg`` 30, ``max_range_m`` 140, ``fill``, ``elevation_deg``,
            ``azimuth_deg``, ``p_ground``, ``p_wall``, ``min_return``,
            ``object_size_m``); and ``instances_per_class``: how many physical objects
            each class has (None: every sample its own object); each sample shows one
            of them, drawn at random, in its own pose, view and distance.

    Returns:
        Dataset with observed depth and reflectivity, clean depth and reflectance,
        object masks, and no variants yet (``spl_al.data.variants`` adds them).
    """
    classes = _check_classes(classes)
    protocol, scene_options = SynthesisProtocol.take(options)
    protocol = protocol.checked(n_per_class, SensorParams.paper_real())
    render_options = {k: v for k, v in scene_options.items() if k != "instances_per_class"}
    view = ObjectView(image_shape=_check_shape(image_shape), **render_options)
    _check_reach(view.max_range_m, protocol.sensor)

    labels = np.repeat(np.arange(len(classes)), n_per_class).astype(np.int64)
    draw = protocol.draw(labels)
    job = _ObjectJob(
        protocol.seed, protocol.imaging(False), view, scene_options.get("instances_per_class")
    )
    cats = np.asarray(classes)[labels]
    # uids are 0..N-1, so a chunk's uids index its categories
    args = [(chunk, cats[chunk[0]], job) for chunk in draw.chunks(protocol.workers)]
    return _assemble(
        "classification",
        classes,
        parts=run_chunks(_object_chunk, args, protocol.workers),
        labels=labels,
        draw=draw,
        sensor=protocol.sensor,
        grid=ScanGrid.square_pixels(view.image_shape, view.fov_deg),
        generator="spl_al.scenes.objects",
        meta={
            "seed": int(protocol.seed),
            "n_per_class": int(n_per_class),
            **protocol.meta(),
            "fov_deg": float(view.fov_deg),
            "max_range_m": float(view.max_range_m),
            "scene_options": {
                k: (list(v) if isinstance(v, tuple) else v)
                for k, v in scene_options.items()
                if k not in ("fov_deg", "max_range_m")
            },
        },
    )


@dataclass(frozen=True)
class _StreetJob:
    """What every street chunk shares: seed, imaging, scan grid and range limit (m)."""

    seed: int
    imaging: Imaging
    grid: ScanGrid
    max_range_m: float


def _street_chunk(chunk, job: _StreetJob):
    uids, msppp, sbr = chunk
    out = _chunk_arrays(len(uids), job.grid.shape, {"labels": np.uint8})
    for k, uid in enumerate(uids):
        rng = sample_rng(job.seed, STREAM_SCENE, uid)
        img = render_street(rng, grid=job.grid, max_range_m=job.max_range_m)
        out["clean"][k], out["clean_refl"][k], out["labels"][k] = (
            img.depth_m,
            img.reflectance,
            img.labels,
        )
        obs_rng = sample_rng(job.seed, STREAM_OBSERVE, uid)
        _observe_into(out, k, img, msppp=msppp[k], sbr=sbr[k], imaging=job.imaging, rng=obs_rng)
    return out


def make_segmentation_dataset(
    n_samples: int = 300,
    *,
    image_shape=(64, 256),
    elevation_deg=(8.0, -22.0),
    azimuth_deg=(-45.0, 45.0),
    max_range_m: float = 120.0,
    **options,
) -> Dataset:
    """Procedural street scenes as range images with per-pixel labels, and their
    observed SPL images.

    Args:
        n_samples: number of scenes.
        image_shape: (rows, cols) of the range image (64 beams by default).
        elevation_deg, azimuth_deg: (first, last) row / column centre angles, degrees.
        max_range_m: nothing beyond returns (labels there are 255).
        **options: the fields of ``SynthesisProtocol``, as ``make_classification_dataset``
            (``sensor`` default ``SensorParams.street()``: 1024 bins of 1 ns, 153 m; the
            street scenes' reflectance is range-compensated, so the observation model
            applies the range falloff).

    Returns:
        Dataset with classes ``STREET_CLASSES``, (N, H, W) uint8 labels (255 = no
        return), observed and clean depth; ``points(i)`` gives the point cloud.
    """
    protocol = SynthesisProtocol(**options).checked(n_samples, SensorParams.street())
    shape = _check_shape(image_shape)
    _check_reach(max_range_m, protocol.sensor)
    grid = (
        ScanGrid(shape, tuple(elevation_deg), tuple(azimuth_deg))
        if elevation_deg
        else default_grid(shape)
    )
    draw = protocol.draw(np.zeros(int(n_samples), np.int64))
    job = _StreetJob(protocol.seed, protocol.imaging(True), grid, max_range_m)
    args = [(chunk, job) for chunk in draw.chunks(protocol.workers)]
    return _assemble(
        "segmentation",
        list(STREET_CLASSES),
        parts=run_chunks(_street_chunk, args, protocol.workers),
        labels=None,  # the per-pixel labels come with the scenes
        draw=draw,
        sensor=protocol.sensor,
        grid=grid,
        generator="spl_al.scenes.street",
        meta={
            "seed": int(protocol.seed),
            **protocol.meta(),
            "max_range_m": float(max_range_m),
        },
    )
