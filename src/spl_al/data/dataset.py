"""The dataset container every experiment runs on, and its on-disk format.

A ``Dataset`` holds N observed SPL images (depth with NaN voids), their targets,
split, imaging condition and MSPPP level, optionally the clean depth they were
observed from, the reflectivity reconstructed with them, and M synthetic variants
per image (SIV). ``groups`` stacks each observed image with its variants: the
sample groups S_i of the active-learning loop.

On disk (``save`` / ``load``): one ``.npz`` (zip of ``.npy`` arrays, compressed),
written atomically. Depth arrays are uint16 codes (see ``spl_al.data.storage``:
``code * depth_step_m`` metres, 65535 = void) unless saved with
``precision="float32"``; reflectances are float16. Entries:

==================== ================== ==============================================
key                  shape / dtype      content
==================== ================== ==============================================
meta_json            (bytes,) uint8     JSON: format, version, task, classes, sensor,
                                        depth encoding, ``meta`` (seed, source, grid,
                                        levels, variant settings)
depth                (N, H, W)          observed depth (codes or float32)
labels               (N,) int64 or      class index, or per-pixel class (uint8) with
                     (N, H, W) uint8    255 = ignore
split, level         (N,) str           "train"/"test"; "high"/"medium"/"low"/"unknown"
msppp, sbr           (N,) float64       imaging condition of each observed image (NaN
                                        if unknown)
uid                  (N,) int64         sample id: the key of every per-sample seed
reflectance          (N, H, W) float16  observed reconstructed reflectivity (optional)
clean_depth          (N, H, W)          ground-truth depth (optional)
clean_reflectance    (N, H, W) float16  scene reflectance before imaging (optional)
object_mask          (N, H, W) bool     pixels of the object (optional)
variant_depth        (N, M, H, W)       SIV variants (optional)
variant_msppp/_sbr   (N, M) float64     condition of each variant (with variants)
==================== ================== ==============================================
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from spl_al.data import storage
from spl_al.label_codes import IGNORE_INDEX, UNKNOWN_CLASS
from spl_al.photon import SensorParams
from spl_al.scenes.raycast import ScanGrid
from spl_al.scenes.street import range_image_to_points

FORMAT = "spl-al-dataset"
VERSION = 1
TASKS = ("classification", "segmentation")
LEVELS = ("high", "medium", "low")
HEADLINE_METRICS = {"classification": "accuracy", "segmentation": "miou"}
"""Per task, the metric the experiments report: its key in ``spl_al.training.evaluate``'s
result."""
SPLITS = ("train", "test")

_DEPTH_FIELDS = {
    "depth_m": "depth",
    "clean_depth_m": "clean_depth",
    "variant_depth_m": "variant_depth",
}
_HALF_FIELDS = {"reflectance": "reflectance", "clean_reflectance": "clean_reflectance"}
_PLAIN_FIELDS = (
    "labels",
    "split",
    "level",
    "msppp",
    "sbr",
    "uid",
    "object_mask",
    "variant_msppp",
    "variant_sbr",
)


# What the clean scene adds to the observed images: only data synthesis, SIV, the
# robustness grid and the pictures read it; training and scoring jobs load without it.
SCENE_FIELDS = ("clean_depth_m", "reflectance", "clean_reflectance", "object_mask")


CONDITION_FIELDS = ("split", "level", "msppp", "sbr")
"""What ``load_conditions`` reads of a dataset file."""


def load_conditions(path) -> tuple[dict[str, np.ndarray], dict]:
    """Each image's split, MSPPP level, MSPPP and SBR (``CONDITION_FIELDS``) of a
    dataset file, and its ``meta`` record, without reading or decompressing any image:
    what a report of the queried frames' conditions needs."""
    arrays, meta = storage.read_npz(path, FORMAT, only=CONDITION_FIELDS)
    missing = set(CONDITION_FIELDS) - arrays.keys()
    if missing:
        raise ValueError(f"{path}: dataset file lacks {sorted(missing)}.")
    return arrays, meta.get("meta", {})


def sensor_to_dict(sensor: SensorParams | None) -> dict | None:
    """A JSON-ready dict of ``sensor``'s fields (None stays None)."""
    return None if sensor is None else dataclasses.asdict(sensor)


def sensor_from_dict(d: dict | None) -> SensorParams | None:
    """The ``SensorParams`` of a ``sensor_to_dict`` dict (None stays None)."""
    return None if d is None else SensorParams(**d)


# meta entries that hold one value per sample (kept aligned by ``subset``)
PER_SAMPLE_META = ("files",)


@dataclass(eq=False, repr=False)
class Dataset:
    """N observed SPL depth images with targets, conditions and optional variants.

    Attributes:
        task: "classification" or "segmentation".
        classes: class names; ``labels`` index into them.
        depth_m: (N, H, W) float32 observed depth, metres, NaN at voids.
        labels: (N,) int64 class indices, or (N, H, W) uint8 per-pixel classes with
            ``IGNORE_INDEX`` (255) where there is no label (sky, no return). A sample
            of an unlabeled pool has ``UNKNOWN_CLASS`` (-1) or an all-255 mask.
        split: (N,) str, "train" or "test".
        msppp, sbr: (N,) float64 imaging condition of each observed image (NaN if unknown).
        level: (N,) str MSPPP level, "high" / "medium" / "low", or "unknown".
        valid: (N, H, W) bool, isfinite(depth_m); computed when not given.
        uid: (N,) int64 sample ids, unique; per-sample seeds are keyed by them, so a
            subset keeps its samples' variants. Default 0..N-1.
        clean_depth_m: (N, H, W) float32 ground-truth depth, or None.
        reflectance: (N, H, W) float32 reflectivity reconstructed with the observed
            image (the SIV input), or None for uniform.
        clean_reflectance: (N, H, W) float32 scene reflectance before imaging, or None.
        object_mask: (N, H, W) bool pixels of the object (synthetic classification), or None.
        sensor: the SPL timing used to observe and to make variants, or None.
        variant_depth_m: (N, M, H, W) float32 SIV variants, NaN at voids, or None.
        variant_msppp, variant_sbr: (N, M) condition of each variant, or None.
        meta: JSON-serialisable record: seed, source, grid, levels, variant settings
            (per-sample lists only under the keys of ``PER_SAMPLE_META``).
    """

    task: str
    classes: list[str]
    depth_m: np.ndarray
    labels: np.ndarray
    split: np.ndarray
    msppp: np.ndarray
    sbr: np.ndarray
    level: np.ndarray
    valid: np.ndarray | None = None
    uid: np.ndarray | None = None
    clean_depth_m: np.ndarray | None = None
    reflectance: np.ndarray | None = None
    clean_reflectance: np.ndarray | None = None
    object_mask: np.ndarray | None = None
    sensor: SensorParams | None = None
    variant_depth_m: np.ndarray | None = None
    variant_msppp: np.ndarray | None = None
    variant_sbr: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise ValueError(f"task must be one of {TASKS}, got {self.task!r}.")
        self.classes = [str(c) for c in self.classes]
        self.depth_m = np.asarray(self.depth_m, dtype=np.float32)
        if self.depth_m.ndim != 3:
            raise ValueError(f"depth_m must be (N, H, W), got shape {self.depth_m.shape}.")
        n, h, w = self.depth_m.shape
        self.valid = (
            np.isfinite(self.depth_m) if self.valid is None else np.asarray(self.valid, dtype=bool)
        )
        if self.valid.shape != self.depth_m.shape or np.any(
            self.valid != np.isfinite(self.depth_m)
        ):
            raise ValueError("valid must equal isfinite(depth_m): voids are NaN in depth_m.")
        self.uid = (
            np.arange(n, dtype=np.int64)
            if self.uid is None
            else np.asarray(self.uid, dtype=np.int64)
        )
        self.split = np.asarray(self.split, dtype="<U5")
        self.level = np.asarray(self.level, dtype="<U7")
        self.msppp = np.asarray(self.msppp, dtype=np.float64)
        self.sbr = np.asarray(self.sbr, dtype=np.float64)
        for name in ("uid", "split", "level", "msppp", "sbr"):
            if getattr(self, name).shape != (n,):
                raise ValueError(f"{name} must have shape ({n},), got {getattr(self, name).shape}.")
        if np.unique(self.uid).size != n:
            raise ValueError("uid must hold N distinct sample ids.")
        if not np.isin(self.split, SPLITS).all():
            raise ValueError(
                f"split values must be in {SPLITS}, got {sorted(set(self.split) - set(SPLITS))}."
            )
        if not np.isin(self.level, (*LEVELS, "unknown")).all():
            raise ValueError(f"level values must be in {(*LEVELS, 'unknown')}.")
        self._check_labels(n, h, w)
        self._check_scene_fields(n, h, w)

    def _check_scene_fields(self, n: int, h: int, w: int) -> None:
        """The optional per-pixel fields (clean depth, reflectances, object masks) and the
        variants: each as float32 / bool of its documented shape, or a ValueError."""
        for name in ("clean_depth_m", "reflectance", "clean_reflectance"):
            value = getattr(self, name)
            if value is not None:
                value = np.asarray(value, dtype=np.float32)
                if value.shape != (n, h, w):
                    raise ValueError(f"{name} must have shape {(n, h, w)}, got {value.shape}.")
                setattr(self, name, value)
        if self.object_mask is not None:
            self.object_mask = np.asarray(self.object_mask, dtype=bool)
            if self.object_mask.shape != (n, h, w):
                raise ValueError(
                    f"object_mask must have shape {(n, h, w)}, got {self.object_mask.shape}."
                )
        if self.variant_depth_m is not None:
            v = np.asarray(self.variant_depth_m, dtype=np.float32)
            if v.ndim != 4 or v.shape[0] != n or v.shape[2:] != (h, w):
                raise ValueError(
                    f"variant_depth_m must have shape ({n}, M, {h}, {w}), got {v.shape}."
                )
            self.variant_depth_m = v
            for name in ("variant_msppp", "variant_sbr"):
                value = getattr(self, name)
                if value is None or np.shape(value) != v.shape[:2]:
                    raise ValueError(
                        f"{name} must have shape {v.shape[:2]} when variants are present."
                    )
                setattr(self, name, np.asarray(value, dtype=np.float64))

    def _check_labels(self, n: int, h: int, w: int) -> None:
        k = len(self.classes)
        labels = np.asarray(self.labels)
        if self.task == "classification":
            if labels.shape != (n,):
                raise ValueError(
                    f"classification labels must have shape ({n},), got {labels.shape}."
                )
            labels = labels.astype(np.int64)
            if labels.size and (labels.min() < UNKNOWN_CLASS or labels.max() >= k):
                raise ValueError(
                    f"labels must index classes (0..{k - 1}, or {UNKNOWN_CLASS} = unknown), "
                    f"got range {labels.min()}..{labels.max()}."
                )
        else:
            if labels.shape != (n, h, w):
                raise ValueError(
                    f"segmentation labels must have shape {(n, h, w)}, got {labels.shape}."
                )
            labels = labels.astype(np.uint8)
            bad = (labels >= k) & (labels != IGNORE_INDEX)
            if bad.any():
                raise ValueError(
                    f"segmentation labels must be < {k} or {IGNORE_INDEX}; "
                    f"found {np.unique(labels[bad])}."
                )
        self.labels = labels

    # -- views ------------------------------------------------------------------------

    def __repr__(self) -> str:
        return (
            f"Dataset({self.task}, {len(self)} images {self.image_shape}, "
            f"{len(self.classes)} classes, {self.n_variants} variants, "
            f"source={self.meta.get('source', '?')!r})"
        )

    def __len__(self) -> int:
        return int(self.depth_m.shape[0])

    @property
    def image_shape(self) -> tuple[int, int]:
        """(H, W) of every image."""
        return (int(self.depth_m.shape[1]), int(self.depth_m.shape[2]))

    @property
    def n_variants(self) -> int:
        """Variants per sample (M); 0 before ``spl_al.data.variants`` adds them."""
        return 0 if self.variant_depth_m is None else int(self.variant_depth_m.shape[1])

    @property
    def variant_valid(self) -> np.ndarray | None:
        """(N, M, H, W) bool, isfinite(variant_depth_m), or None without variants."""
        return None if self.variant_depth_m is None else np.isfinite(self.variant_depth_m)

    @property
    def train_idx(self) -> np.ndarray:
        """Indices of the training split's samples, ascending."""
        return np.flatnonzero(self.split == "train")

    @property
    def test_idx(self) -> np.ndarray:
        """Indices of the test split's samples, ascending."""
        return np.flatnonzero(self.split == "test")

    def level_idx(self, level: str, split: str | None = "test") -> np.ndarray:
        """Indices of the samples at MSPPP ``level`` (in ``split``; None = all splits)."""
        if level not in (*LEVELS, "unknown"):
            raise ValueError(f"level must be one of {(*LEVELS, 'unknown')}, got {level!r}.")
        keep = self.level == level
        if split is not None:
            keep &= self.split == split
        return np.flatnonzero(keep)

    def groups(self, indices=None, n_variants: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Sample groups S_i = observed image + its first ``n_variants`` variants.

        Returns (depth (n, G, H, W) float32 with NaN voids, valid (n, G, H, W) bool),
        G = 1 + n_variants, observed image first. ``n_variants=None`` takes all
        variants present (none when the dataset has none).
        """
        idx = np.arange(len(self)) if indices is None else np.asarray(indices, dtype=np.int64)
        m = self.n_variants if n_variants is None else int(n_variants)
        if m < 0 or m > self.n_variants:
            have = (
                "has no variants"
                if self.n_variants == 0
                else f"has {self.n_variants} variants per image"
            )
            raise ValueError(
                f"n_variants={m} requested but the dataset {have}; run spl_al.data.variants first."
            )
        parts = [self.depth_m[idx][:, None]]
        if m:
            parts.append(self.variant_depth_m[idx, :m])
        depth = np.concatenate(parts, axis=1)
        return depth, np.isfinite(depth)

    def subset(self, indices) -> Dataset:
        """The samples at ``indices`` (in that order), with every per-sample field."""
        idx = np.asarray(indices, dtype=np.int64)
        if idx.ndim != 1:
            raise ValueError(f"indices must be 1-D, got shape {idx.shape}.")
        if idx.size and (idx.min() < -len(self) or idx.max() >= len(self)):
            raise ValueError(f"indices must lie in 0..{len(self) - 1}.")
        per_sample = {
            f.name: (None if getattr(self, f.name) is None else getattr(self, f.name)[idx])
            for f in dataclasses.fields(self)
            if f.name not in ("task", "classes", "sensor", "meta")
        }
        meta = dict(self.meta)
        for key in PER_SAMPLE_META:
            if isinstance(meta.get(key), list) and len(meta[key]) == len(self):
                meta[key] = [meta[key][i] for i in idx]
        return Dataset(
            task=self.task, classes=list(self.classes), sensor=self.sensor, meta=meta, **per_sample
        )

    def grid(self):
        """The scan grid of the images (``ScanGrid``), from ``meta["grid"]``."""
        g = self.meta.get("grid")
        if g is None:
            raise ValueError("this dataset records no scan grid (meta['grid']); points need one.")
        return ScanGrid(self.image_shape, tuple(g["elevation_deg"]), tuple(g["azimuth_deg"]))

    def points(self, index: int, source: str = "observed") -> tuple[np.ndarray, np.ndarray]:
        """Point cloud of one image: (xyz (P, 3) float32 in the sensor frame, labels (P,)).

        ``source`` is "observed", "clean" or "variant:j". Points are the valid pixels
        of that image; labels are the per-pixel labels (segmentation) or the image's
        class repeated (classification). X right, Y forward, Z up, metres.
        """
        if source == "observed":
            depth = self.depth_m[index]
        elif source == "clean":
            if self.clean_depth_m is None:
                raise ValueError("source='clean' but this dataset has no clean depth.")
            depth = self.clean_depth_m[index]
        elif source.startswith("variant:"):
            j = int(source.split(":", 1)[1])
            if not 0 <= j < self.n_variants:
                raise ValueError(
                    f"source={source!r} but the dataset has {self.n_variants} variants per image."
                )
            depth = self.variant_depth_m[index, j]
        else:
            raise ValueError(f"source must be 'observed', 'clean' or 'variant:j', got {source!r}.")
        xyz = range_image_to_points(depth, self.grid())
        keep = np.isfinite(depth)
        if self.task == "segmentation":
            lab = self.labels[index][keep]
        else:
            lab = np.full(int(keep.sum()), self.labels[index], dtype=np.int64)
        return xyz[keep].astype(np.float32), lab

    def with_variants(self, depth_m, msppp, sbr, meta: dict) -> Dataset:
        """A copy carrying ``depth_m`` (N, M, H, W) variants and their conditions."""
        out = dataclasses.replace(
            self,
            variant_depth_m=depth_m,
            variant_msppp=msppp,
            variant_sbr=sbr,
            meta={**self.meta, "variants": meta},
        )
        return out

    def summary(self) -> str:
        """One line per split and level: sample counts, void fraction, mean MSPPP, median SBR."""
        lines = [
            f"{self.task} dataset: {len(self)} images {self.image_shape}, "
            f"{len(self.classes)} classes, {self.n_variants} variants per image"
        ]
        for split in SPLITS:
            for level in (*LEVELS, "unknown"):
                idx = np.flatnonzero((self.split == split) & (self.level == level))
                if not idx.size:
                    continue
                known = np.isfinite(self.msppp[idx])
                msppp = self.msppp[idx][known].mean() if known.any() else float("nan")
                sbr = np.median(self.sbr[idx][known]) if known.any() else float("nan")
                voids = 1 - self.valid[idx].mean()
                lines.append(
                    f"  {split:5s} {level:7s} n={idx.size:5d} voids={voids:.1%} "
                    f"msppp={msppp:.3g} sbr={sbr:.3g}"
                )
        return "\n".join(lines)

    # -- disk -------------------------------------------------------------------------

    def save(self, path, precision: str = "uint16") -> Path:
        """Write the dataset to one ``.npz`` atomically (temporary file + rename).

        ``precision="uint16"`` stores depth as uint16 codes (at most 1.25 mm rounding
        up to 163 m); ``"float32"`` stores it losslessly.
        """
        if precision not in ("uint16", "float32"):
            raise ValueError(f"precision must be 'uint16' or 'float32', got {precision!r}.")
        arrays: dict[str, np.ndarray] = {}
        depths = {k: getattr(self, k) for k in _DEPTH_FIELDS if getattr(self, k) is not None}
        step = None
        if precision == "uint16":
            finite_max = [float(np.nanmax(v)) for v in depths.values() if np.isfinite(v).any()]
            step = storage.choose_depth_step(max(finite_max, default=0.0))
        for attr, key in _DEPTH_FIELDS.items():
            if attr in depths:
                arrays[key] = storage.encode_depth(depths[attr], step) if step else depths[attr]
        for attr, key in _HALF_FIELDS.items():
            if getattr(self, attr) is not None:
                arrays[key] = getattr(self, attr).astype(np.float16)
        for name in _PLAIN_FIELDS:
            if getattr(self, name) is not None:
                arrays[name] = getattr(self, name)
        meta = {
            "format": FORMAT,
            "version": VERSION,
            "task": self.task,
            "classes": self.classes,
            "sensor": sensor_to_dict(self.sensor),
            "depth_encoding": {
                "dtype": precision,
                "step_m": step,
                "void_code": int(storage.VOID_CODE),
            },
            "meta": self.meta,
        }
        return storage.atomic_savez(path, arrays, meta)

    @classmethod
    def load(cls, path, skip=()) -> Dataset:
        """Read a dataset written by ``save``.

        ``skip``: optional fields to leave out (None in the result), e.g.
        ``SCENE_FIELDS``; they are not even decompressed, which is most of a load.
        """
        unknown = set(skip) - set(SCENE_FIELDS)
        if unknown:
            raise ValueError(
                f"Dataset.load can skip the scene fields {list(SCENE_FIELDS)}, "
                f"not {sorted(unknown)}."
            )
        keys = {**_DEPTH_FIELDS, **_HALF_FIELDS, **{n: n for n in _PLAIN_FIELDS}}
        arrays, meta = storage.read_npz(path, FORMAT, skip={keys[a] for a in skip})
        if meta.get("version") != VERSION:
            raise ValueError(
                f"{path}: dataset format version {meta.get('version')}, expected {VERSION}."
            )
        enc = meta["depth_encoding"]
        fields = {}
        for attr, key in _DEPTH_FIELDS.items():
            if key in arrays:
                a = arrays[key]
                fields[attr] = (
                    storage.decode_depth(a, enc["step_m"]) if enc["dtype"] == "uint16" else a
                )
        for attr, key in _HALF_FIELDS.items():
            if key in arrays:
                fields[attr] = arrays[key].astype(np.float32)
        for name in _PLAIN_FIELDS:
            if name in arrays:
                fields[name] = arrays[name]
        missing = {"depth_m", "labels", "split", "level", "msppp", "sbr"} - fields.keys()
        if missing:
            raise ValueError(f"{path}: dataset file lacks {sorted(missing)}.")
        return cls(
            task=meta["task"],
            classes=meta["classes"],
            sensor=sensor_from_dict(meta["sensor"]),
            meta=meta["meta"],
            **fields,
        )
