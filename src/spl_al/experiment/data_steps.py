"""Data steps of the workflow: synthesize or import a dataset, make its SIV variants
in shards, merge them, draw its pictures.

Heavy imports (torch for SSPI, matplotlib) happen inside the steps that need them.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np


def make_dataset(entry: dict, out_path, release_dir=None) -> dict:
    """Synthesize (or import) a dataset's observed images and save them to ``out_path``.

    ``entry`` is the dataset's config: ``task``, ``source`` ("synthetic", "folder",
    "unlabeled" or "captures"), ``path``, ``depth_key``, ``reflectance_key``,
    ``levels_file`` and ``n_per_class`` for folders (``spl_al.data.load_folder``),
    ``standin`` (synthesize when the folder is not given) and ``synthesis`` (keyword
    arguments of the generator). A captures dataset is read from ``release_dir``, the
    release-layout folder ``release_captures`` made of its captures.
    """
    from spl_al.data import load_folder, make_classification_dataset, make_segmentation_dataset

    if entry["source"] == "captures":
        entry = _captures_as_folder(entry, release_dir)
    synthesis = dict(entry.get("synthesis", {}))
    if "image_shape" in synthesis:
        synthesis["image_shape"] = tuple(synthesis["image_shape"])
    standin = False
    if entry["source"] == "unlabeled":
        dataset = _unlabeled_dataset(entry, synthesis)
    elif entry["source"] == "folder" and entry.get("path"):
        root = Path(entry["path"])
        if not root.is_dir():
            raise ValueError(f"dataset folder {root} does not exist (config key 'path').")
        dataset = load_folder(
            root,
            depth_key=entry.get("depth_key", "depth_ssp"),
            reflectance_key=entry.get("reflectance_key"),
            image_shape=synthesis.get("image_shape"),
            test_fraction=synthesis.get("test_fraction", 0.3),
            seed=synthesis.get("seed", 0),
            levels_file=entry.get("levels_file"),
            n_per_class=entry.get("n_per_class"),
        )
    elif entry["source"] == "folder" and not entry.get("standin", False):
        raise ValueError(
            "dataset source is 'folder' but no 'path' is given; set 'path' or 'standin: true'."
        )
    else:
        standin = entry["source"] == "folder"
        make = (
            make_classification_dataset
            if entry["task"] == "classification"
            else make_segmentation_dataset
        )
        dataset = make(**synthesis)
    dataset.meta["synthetic_standin"] = standin
    dataset.save(out_path)
    return {"samples": len(dataset), "standin": standin}


def _captures_as_folder(entry: dict, release_dir) -> dict:
    """A captures entry as the folder entry of its reconstructions (labeled or not).

    With ``oracle: human`` the reconstructions are an unlabeled folder, read flat: its
    ``seed_labels`` name the frames ``{capture stem}.npz``.
    """
    if release_dir is None:
        raise ValueError("a captures dataset needs the folder of its reconstructions.")
    nested = sorted(p for p in Path(release_dir).rglob("*.npz") if p.parent != Path(release_dir))
    if entry.get("oracle") == "human" and nested:
        raise ValueError(
            f"config key 'path': with oracle: human the captures must lie directly in "
            f"{entry['path']} (an unlabeled pool is read flat); found "
            f"{nested[0].relative_to(release_dir).parent}/."
        )
    return {
        **entry,
        "source": "unlabeled" if entry.get("oracle") == "human" else "folder",
        "path": str(release_dir),
        "depth_key": "depth_ssp",
        "reflectance_key": "intensity",
        "levels_file": None,
    }


def reconstruct_captures(entry: dict, shard: int, out_path, sspi_weights=None) -> dict:
    """Reconstruct shard ``shard`` of a captures dataset's files (``spl_al.data.captures``)."""
    from spl_al.data import captures

    options = captures.CaptureOptions.from_dict(entry.get("captures"))
    every = captures.capture_files(entry["path"])
    files = captures.shard_of(every, captures.shard_count(options, len(every)), shard)
    start = time.perf_counter()
    n = captures.reconstruct_shard(entry["path"], files, out_path, options, sspi_weights)
    return {"captures": n, "seconds": round(time.perf_counter() - start, 2)}


def release_captures(entry: dict, shard_paths, out_dir) -> dict:
    """The release-layout folder of a captures dataset's reconstructions, levels split."""
    from spl_al.data.captures import CaptureOptions, write_release

    options = CaptureOptions.from_dict(entry.get("captures"))
    write_release(shard_paths, out_dir, options)
    return {"frames": sum(1 for _ in Path(out_dir).rglob("*.npz"))}


def _unlabeled_dataset(entry: dict, synthesis: dict):
    """An unlabeled folder (human oracle); its seed labels' test rows are the test split."""
    from spl_al.data.unlabeled import load_unlabeled_folder

    if not entry.get("path") or not Path(entry["path"]).is_dir():
        raise ValueError(
            f"config key 'path': {entry.get('path')!r} is not a folder of depth files."
        )
    dataset = load_unlabeled_folder(
        entry["path"],
        entry.get("classes"),
        task=entry["task"],
        seed_labels=entry.get("seed_labels"),
        depth_key=entry.get("depth_key", "depth_ssp"),
        image_shape=synthesis.get("image_shape"),
    )
    if not dataset.test_idx.size:
        raise ValueError(
            "config key 'seed_labels': no row has split 'test'; label a few samples as test "
            "there, they measure the model every round."
        )
    return dataset


def make_variant_shard(
    observed_path, variants: dict, shard: int, out_path, sspi_weights=None
) -> dict:
    """SIV variants of one shard of the observed images (shards can run anywhere).

    ``variants.reconstruct_method`` picks the reconstruction of the variants (default:
    the dataset's own). With ``"sspi"`` the weights folder is ``sspi_weights`` (config
    ``photon.sspi_weights``) or ``$SPL_AL_SSPI_WEIGHTS``; it is exported to that
    variable so worker processes find it, and the expected time of the shard
    (one timed frame x the shard's variants) is printed first, into the job log.
    """
    from spl_al.data import Dataset
    from spl_al.data.variants import generate_variants, shard_indices
    from spl_al.photon import SensorParams

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
    import os

    from spl_al.data.variants import default_conditions, variants_of_image
    from spl_al.photon.sspi.weights import ENV_VAR, weights_folder

    os.environ[ENV_VAR] = str(weights_folder(sspi_weights).resolve())
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
        variants_of_image(dataset.depth_m[0], refl, [condition], 1, sensor, rng, "sspi")

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
    from spl_al.data import Dataset
    from spl_al.data.variants import VariantShard, attach_variants

    dataset = attach_variants(
        Dataset.load(observed_path), [VariantShard.load(p) for p in shard_paths]
    )
    dataset.save(out_path)
    return {"samples": len(dataset), "variants": dataset.n_variants}


def data_pictures(dataset_path, contact_path, variants_path) -> None:
    """Contact sheet (clean vs observed per class) and one sample's variants sheet."""
    from spl_al.data import Dataset, contact_sheet, variants_sheet

    dataset = Dataset.load(dataset_path)
    contact_sheet(dataset, contact_path)
    variants_sheet(dataset, int(dataset.test_idx[0]), variants_path)
