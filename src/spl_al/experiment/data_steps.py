"""Data steps of the workflow: synthesize or import a dataset, make its SIV variants
in shards, merge them, draw its pictures.

Heavy imports (torch for SSPI, matplotlib) happen inside the steps that need them.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from spl_al.data import Dataset, contact_sheet, raw_captures, variants_sheet
from spl_al.data.raw_captures import CaptureOptions, write_release
from spl_al.data.sources import build_dataset
from spl_al.data.variants import (
    VariantShard,
    attach_variants,
    default_conditions,
    generate_variants,
    shard_indices,
    variants_of_image,
)
from spl_al.photon import SensorParams


def make_dataset(entry: dict, out_path, release_dir=None) -> dict:
    """Build a dataset's observed images from its source and save them to ``out_path``.

    ``entry`` is the dataset's config; its ``source`` names one of
    ``spl_al.data.sources`` (synthetic, folder, unlabeled, captures: the keys each
    reads are in its module). A captures dataset is read from ``release_dir``, the
    release-layout folder ``release_captures`` made of its captures.
    """
    dataset = build_dataset(entry, release_dir=release_dir)
    dataset.save(out_path)
    return {"samples": len(dataset), "standin": dataset.meta["synthetic_standin"]}


def reconstruct_captures(entry: dict, shard: int, out_path, sspi_weights=None) -> dict:
    """Reconstruct shard ``shard`` of a captures dataset's files (``spl_al.data.raw_captures``)."""
    options = raw_captures.CaptureOptions.from_dict(entry.get("captures"))
    every = raw_captures.capture_files(entry["path"])
    files = raw_captures.shard_of(every, raw_captures.shard_count(options, len(every)), shard)
    start = time.perf_counter()
    n = raw_captures.reconstruct_shard(
        entry["path"], files, out_path=out_path, options=options, weights=sspi_weights
    )
    return {"captures": n, "seconds": round(time.perf_counter() - start, 2)}


def release_captures(entry: dict, shard_paths, out_dir) -> dict:
    """The release-layout folder of a captures dataset's reconstructions, levels split."""
    options = CaptureOptions.from_dict(entry.get("captures"))
    write_release(shard_paths, out_dir, options)
    return {"frames": sum(1 for _ in Path(out_dir).rglob("*.npz"))}


def make_variant_shard(
    observed_path, variants: dict, *, shard: int, out_path, sspi_weights=None
) -> dict:
    """SIV variants of one shard of the observed images (shards can run anywhere).

    ``variants.reconstruct_method`` picks the reconstruction of the variants (default:
    the dataset's own). With ``"sspi"`` the weights folder is ``sspi_weights`` (config
    ``photon.sspi_weights``) or ``$SPL_AL_SSPI_WEIGHTS``; it is exported to that
    variable so worker processes find it, and the expected time of the shard
    (one timed frame x the shard's variants) is printed first, into the job log.
    """
    dataset = Dataset.load(observed_path)
    sensor = getattr(SensorParams, variants["sensor"])() if variants.get("sensor") else None
    conditions = [tuple(c) for c in variants["conditions"]] if variants.get("conditions") else None
    method = variants.get("reconstruct_method")
    if method == "sspi":
        _announce_sspi_shard(
            dataset,
            sensor or dataset.sensor,
            conditions,
            len(shard_indices(len(dataset), (int(shard), int(variants["shards"]))))
            * int(variants["n"]),
            sspi_weights,
        )
    part = generate_variants(
        dataset,
        n_variants=int(variants["n"]),
        conditions=conditions,
        seed=int(variants["seed"]),
        shard=(int(shard), int(variants["shards"])),
        workers=1,
        sensor=sensor,
        method=method,
    )
    part.save(out_path)
    return {"shard": shard}


def _announce_sspi_shard(dataset, sensor, conditions, n_frames: int, sspi_weights) -> None:
    """Export the SSPI weights folder and print the shard's expected time: one frame (sample 0,
    the condition of median photon budget) timed, times the shard's variants. Variants are
    reconstructed on their returns' bounding box, so small objects take less."""
    # torch on demand (importing this module does not load it)
    import os

    from spl_al.config import SSPI_WEIGHTS_ENV
    from spl_al.photon.sspi.weights import weights_folder

    os.environ[SSPI_WEIGHTS_ENV] = str(weights_folder(sspi_weights).resolve())
    if n_frames == 0:
        return
    # The condition with the median photon budget msppp (1 + 1 / sbr): a typical frame.
    candidates = sorted(
        conditions or default_conditions(dataset), key=lambda c: c[0] * (1 + 1 / c[1])
    )
    condition = candidates[len(candidates) // 2]
    refl = None if dataset.reflectance is None else dataset.reflectance[0]

    def one_frame():
        rng = np.random.default_rng(0)
        variants_of_image(
            dataset.depth_m[0], refl, conditions=[condition], sensor=sensor, rng=rng, method="sspi"
        )

    one_frame()  # loads the weights once
    start = time.perf_counter()
    one_frame()
    per_frame = time.perf_counter() - start
    rows, cols = dataset.image_shape
    print(
        f"SSPI: {per_frame:.2f} s per {rows}x{cols}x{sensor.n_bins} frame (sample 0 at "
        f"MSPPP {condition[0]:g}, SBR {condition[1]:g}); this shard reconstructs {n_frames} "
        f"variants: expected about {per_frame * n_frames / 60:.1f} min",
        flush=True,
    )


def merge_variants(observed_path, shard_paths, out_path) -> dict:
    """Attach every shard's variants to the observed dataset and save the whole."""
    dataset = attach_variants(
        Dataset.load(observed_path), [VariantShard.load(p) for p in shard_paths]
    )
    dataset.save(out_path)
    return {"samples": len(dataset), "variants": dataset.n_variants}


def data_pictures(dataset_path, contact_path, variants_path) -> None:
    """Contact sheet (clean vs observed per class) and one sample's variants sheet."""
    dataset = Dataset.load(dataset_path)
    contact_sheet(dataset, contact_path)
    variants_sheet(dataset, int(dataset.test_idx[0]), variants_path)
