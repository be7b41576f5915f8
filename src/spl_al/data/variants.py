"""Synthetic imaging variants (SIV, the paper's Algorithm 1) over a whole dataset.

For every observed image I_obs,i, M variants I_syn,i,j = ``synthesize_variant`` of
the observed image's own reconstructed depth and reflectivity (not the clean
scene) at conditions (msppp_j, sbr_j); with the observed image they form the sample
group S_i (``Dataset.groups``).

Conditions are systematic: variant j of *every* group is made at the same condition
j of one ordered list, so the inconsistency d_i of DUIS compares like with like
across groups, and the first m variants of a group are exactly the variants an
M = m run would make (the M sweep is nested). The default list orders the dataset's
MSPPP levels x SBR values so that every prefix spreads over the grid
(``spread_conditions``): with the default levels (10, 5, 2) and SBR (0.2, 1, 5) the
order is (5, 1), (2, 0.2), (2, 5), (10, 0.2), (10, 5), (2, 1), (5, 0.2), (10, 1),
(5, 5), so M = 4 takes the centre and the four corners of the grid. The photons
are simulated and reconstructed on the bounding box of the observed image's
returns (``spl_al.photon.synthesize_variants``): bit-identical to
``synthesize_variant`` on the whole frame, and faster.

Seeding: sample i's photons come from ``sample_rng(seed, STREAM_VARIANT, uid_i)``.
A sample's variants therefore do not depend on the shard, the worker count, or the
other samples: shards can be generated anywhere (one cluster job each) and merged
with ``attach_variants``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spl_al.data import storage
from spl_al.data.dataset import Dataset
from spl_al.data.observe import DEFAULT_LEVELS, DEFAULT_SBR, condition_set
from spl_al.data.parallel import chunk_indices, default_workers, run_chunks
from spl_al.data.seeds import STREAM_VARIANT, sample_rng
from spl_al.photon import METHODS, SensorParams, synthesize_variants

SHARD_FORMAT = "spl-al-variant-shard"


@dataclass
class VariantShard:
    """The variants of one shard of a dataset.

    Attributes:
        indices: (n,) int64 positions of the shard's samples in the dataset.
        uid: (n,) int64 their sample ids (checked against the dataset when attaching).
        depth_m: (n, M, H, W) float32 variant depth, NaN at voids.
        msppp, sbr: (n, M) float64 condition of each variant.
        settings: n_variants, conditions, seed, method, shard, n_samples.
    """

    indices: np.ndarray
    uid: np.ndarray
    depth_m: np.ndarray
    msppp: np.ndarray
    sbr: np.ndarray
    settings: dict

    def save(self, path) -> Path:
        """Write the shard atomically to one ``.npz`` (depth as uint16 codes)."""
        finite = self.depth_m[np.isfinite(self.depth_m)]
        step = storage.choose_depth_step(float(finite.max()) if finite.size else 0.0)
        arrays = {
            "indices": self.indices,
            "uid": self.uid,
            "depth": storage.encode_depth(self.depth_m, step),
            "msppp": self.msppp,
            "sbr": self.sbr,
        }
        meta = {
            "format": SHARD_FORMAT,
            "version": 1,
            "depth_step_m": step,
            "settings": self.settings,
        }
        return storage.atomic_savez(path, arrays, meta)

    @classmethod
    def load(cls, path) -> VariantShard:
        """Read a shard written by ``save``."""
        arrays, meta = storage.read_npz(path, SHARD_FORMAT)
        return cls(
            arrays["indices"],
            arrays["uid"],
            storage.decode_depth(arrays["depth"], meta["depth_step_m"]),
            arrays["msppp"],
            arrays["sbr"],
            meta["settings"],
        )


def _check_conditions(conditions) -> list[tuple[float, float]]:
    try:
        out = [(float(m), float(s)) for m, s in conditions]
    except (TypeError, ValueError):
        raise ValueError(
            f"conditions must be a list of (msppp, sbr) pairs, got {conditions!r}."
        ) from None
    if not out:
        raise ValueError("conditions must hold at least one (msppp, sbr) pair.")
    for m, s in out:
        if not (np.isfinite(m) and m > 0 and s > 0):
            raise ValueError(f"condition ({m}, {s}) must have msppp > 0 and sbr > 0.")
    return out


def spread_conditions(conditions) -> list[tuple[float, float]]:
    """``conditions`` reordered so that every prefix spreads over them.

    In (log msppp, log sbr), each scaled to [0, 1] over the set: first the condition
    nearest the centre, then repeatedly the one farthest from all chosen so far (ties:
    the harsher, lower msppp * sbr, first). Deterministic; a permutation of the input.
    """
    conds = _check_conditions(conditions)
    pts = np.log(np.array(conds))
    span = np.ptp(pts, axis=0)
    pts = (pts - pts.min(axis=0)) / np.where(span > 0, span, 1.0)
    harsh = np.array([m * s for m, s in conds])
    order = [int(np.lexsort((harsh, np.linalg.norm(pts - 0.5, axis=1)))[0])]
    while len(order) < len(conds):
        dist = np.min(np.linalg.norm(pts[:, None] - pts[order][None], axis=2), axis=1)
        dist[order] = -1.0
        order.append(int(np.lexsort((harsh, -np.round(dist, 9)))[0]))
    return [conds[k] for k in order]


def default_conditions(dataset: Dataset) -> list[tuple[float, float]]:
    """The dataset's own levels x SBR values (``meta``), else the defaults (9
    conditions), in ``spread_conditions`` order."""
    return spread_conditions(
        condition_set(
            dataset.meta.get("levels", DEFAULT_LEVELS),
            dataset.meta.get("sbr_values", DEFAULT_SBR),
        )
    )


def variant_conditions(dataset: Dataset, n_variants: int, conditions=None):
    """The M conditions, in order: variant j of every group is made at entry j.

    ``conditions`` (a list of at least M (msppp, sbr) pairs, used in its order) or the
    dataset's ``default_conditions``, repeated when M exceeds them (the repeats are
    new photon draws at the same conditions).
    """
    if conditions is None:
        base = default_conditions(dataset)
        return [base[j % len(base)] for j in range(int(n_variants))]
    conds = _check_conditions(conditions)
    if len(conds) < n_variants:
        raise ValueError(
            f"conditions list {len(conds)} (msppp, sbr) pairs for M = {n_variants} variants; "
            "give at least M (variant j uses entry j)."
        )
    return conds[: int(n_variants)]


def variants_of_image(
    depth_m, reflectance, *, conditions, sensor: SensorParams, rng, method="pooled"
):
    """The M variants of one observed image, variant j at ``conditions[j]``
    (``spl_al.photon.synthesize_variants`` of the one frame).

    Returns depth (M, H, W) float32, NaN at voids. An observed image without valid
    pixels gives void variants; a reflectance that is zero on every valid pixel is
    replaced by uniform reflectance.
    """
    depth = np.asarray(depth_m)
    refl = None if reflectance is None else np.asarray(reflectance)[None]
    return synthesize_variants(
        depth[None],
        np.isfinite(depth)[None],
        conditions,
        rng=rng,
        sensor=sensor,
        reflectance=refl,
        method=method,
    )[0]


def _variant_chunk(depth, reflectance, uid, *, conditions, sensor, seed, method):
    out = np.empty((len(depth), len(conditions), *depth.shape[1:]), np.float32)
    for k in range(len(depth)):
        rng = sample_rng(seed, STREAM_VARIANT, uid[k])
        refl = None if reflectance is None else reflectance[k]
        out[k] = variants_of_image(
            depth[k], refl, conditions=conditions, sensor=sensor, rng=rng, method=method
        )
    return out


def shard_indices(n_samples: int, shard: tuple[int, int]) -> np.ndarray:
    """Positions of shard (index, count): contiguous blocks of 0..n_samples-1."""
    try:
        index, count = (int(v) for v in shard)
    except (TypeError, ValueError):
        raise ValueError(f"shard must be (index, count), got {shard!r}.") from None
    if count < 1 or not 0 <= index < count:
        raise ValueError(f"shard must be (index, count) with 0 <= index < count, got {shard!r}.")
    return np.array_split(np.arange(n_samples), count)[index]


def generate_variants(
    dataset: Dataset,
    *,
    n_variants: int = 4,
    conditions=None,
    seed: int = 0,
    shard: tuple[int, int] = (0, 1),
    workers: int | None = 1,
    method: str | None = None,
    sensor: SensorParams | None = None,
) -> VariantShard:
    """SIV variants of the samples in one shard of ``dataset``.

    Args:
        dataset: observed images with their reflectivity (``dataset.reflectance``;
            None = uniform) and the sensor they were observed with.
        n_variants: M, variants per observed image.
        conditions: at least M (msppp, sbr) pairs, variant j at entry j; default
            ``default_conditions`` (``variant_conditions``).
        seed: variant seed (independent of the dataset's seed).
        shard: (index, count): this call makes block ``index`` of ``count`` blocks.
        workers: processes (None = all cores); results do not depend on it.
        method: reconstruction method; default the dataset's (meta) or "pooled".
        sensor: default ``dataset.sensor``.

    Returns:
        VariantShard for the shard's samples.
    """
    if int(n_variants) != n_variants or n_variants < 1:
        raise ValueError(f"n_variants must be a positive integer, got {n_variants!r}.")
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}.")
    sensor = dataset.sensor if sensor is None else sensor
    if sensor is None:
        raise ValueError(
            "the dataset records no sensor; pass sensor=SensorParams(...) to generate_variants."
        )
    method = dataset.meta.get("reconstruct_method", "pooled") if method is None else method
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}.")
    conditions = variant_conditions(dataset, int(n_variants), conditions)
    far = np.nanmax(dataset.depth_m) if dataset.valid.any() else 0.0
    # The last bin reaches half a bin past max_depth_m; stored depths round by < 1.25 mm.
    if sensor.depth_to_bin(far) > sensor.t_max:
        raise ValueError(
            f"observed depths reach {far:.1f} m, "
            f"beyond the sensor's reach of {sensor.max_depth_m:.1f} m."
        )
    idx = shard_indices(len(dataset), shard)
    workers = default_workers() if workers is None else int(workers)
    refl = dataset.reflectance
    args = [
        (
            dataset.depth_m[idx[c]],
            None if refl is None else refl[idx[c]],
            dataset.uid[idx[c]],
        )
        for c in chunk_indices(len(idx), workers)
    ]
    parts = run_chunks(
        _variant_chunk,
        args,
        workers,
        conditions=conditions,
        sensor=sensor,
        seed=int(seed),
        method=method,
    )
    h, w = dataset.image_shape
    depth = np.concatenate(parts) if parts else np.empty((0, n_variants, h, w), np.float32)
    msppp = np.tile([m for m, _ in conditions], (len(idx), 1))
    sbr = np.tile([s for _, s in conditions], (len(idx), 1))
    settings = {
        "n_variants": int(n_variants),
        "conditions": [list(c) for c in conditions],
        "seed": int(seed),
        "method": method,
        "shard": [int(shard[0]), int(shard[1])],
        "n_samples": len(dataset),
    }
    return VariantShard(idx.astype(np.int64), dataset.uid[idx], depth, msppp, sbr, settings)


def attach_variants(dataset: Dataset, shards) -> Dataset:
    """A copy of ``dataset`` with the variants of ``shards`` (VariantShard or paths).

    The shards must come from the same settings (M, conditions, seed, method) and
    together cover every sample exactly once; their sample ids must match the
    dataset's. Otherwise ValueError says which samples are missing or repeated.
    """
    shards = [VariantShard.load(s) if isinstance(s, str | Path) else s for s in shards]
    if not shards:
        raise ValueError("attach_variants needs at least one shard.")
    keys = ("n_variants", "conditions", "seed", "method")
    first = {k: shards[0].settings[k] for k in keys}
    for k, s in enumerate(shards[1:], start=1):
        other = {key: s.settings[key] for key in keys}
        if other != first:
            raise ValueError(
                f"shard {k} was made with settings {other}, shard 0 with {first}; "
                "regenerate them alike."
            )
    n = len(dataset)
    idx = np.concatenate([s.indices for s in shards])
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(
            f"shards hold sample positions outside 0..{n - 1}: they belong to another dataset."
        )
    count = np.bincount(idx, minlength=n)
    if (count > 1).any():
        raise ValueError(
            f"shards overlap: samples {np.flatnonzero(count > 1)[:10].tolist()} "
            "appear more than once."
        )
    if (count == 0).any():
        missing = np.flatnonzero(count == 0)
        raise ValueError(
            f"shards miss {missing.size} samples (first: {missing[:10].tolist()}); "
            "generate every shard."
        )
    uid = np.concatenate([s.uid for s in shards])
    if not np.array_equal(dataset.uid[idx], uid):
        raise ValueError(
            "shard sample ids do not match the dataset's: the shards belong to another dataset."
        )
    m = first["n_variants"]
    h, w = dataset.image_shape
    depth = np.empty((n, m, h, w), np.float32)
    msppp = np.empty((n, m))
    sbr = np.empty((n, m))
    for s in shards:
        if s.depth_m.shape[1:] != (m, h, w):
            raise ValueError(
                f"a shard holds variants of shape {s.depth_m.shape[1:]}, expected {(m, h, w)}."
            )
        depth[s.indices], msppp[s.indices], sbr[s.indices] = s.depth_m, s.msppp, s.sbr
    settings = {k: v for k, v in shards[0].settings.items() if k not in ("shard",)}
    settings["n_shards"] = len(shards)
    return dataset.with_variants(depth, msppp, sbr, settings)


def make_variants(
    dataset: Dataset, *, n_variants: int = 4, conditions=None, seed: int = 0, workers=None, **kw
) -> Dataset:
    """``attach_variants(dataset, [generate_variants(dataset, ...)])`` in one call."""
    shard = generate_variants(
        dataset,
        n_variants=n_variants,
        conditions=conditions,
        seed=seed,
        shard=(0, 1),
        workers=workers,
        **kw,
    )
    return attach_variants(dataset, [shard])
