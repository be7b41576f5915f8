"""External SPL depth data: the authors' released real dataset and generic folders.

Layouts ``load_folder`` reads (it tells them apart by what ``root`` holds):

- flat, the authors' release: ``root/{class}_{NNNN}.npz``, each with ``depth_ssp``
  (SPL-reconstructed depth) and ``Z_true`` (ground truth), 55x55; the class is the
  file name without its trailing ``_NNNN``.
- per class: ``root/{class}/*.npz|*.npy|*.png``; the class is the folder name.
- segmentation: ``root/depth/NAME.*`` with ``root/labels/NAME.npy|.png`` paired by
  name, or any layout above with ``label_key`` naming a per-pixel label array in
  each ``.npz``. Class names from ``classes`` or ``root/classes.txt`` (one per line).

File types: ``.npz`` (arrays by key: ``depth_key``, ``clean_key``, ``reflectance_key``,
``label_key``; optional scalars ``msppp``, ``sbr``, ``level``), ``.npy`` (one depth
array), ``.png`` (16-bit, depth in millimetres; 8-bit PNGs are refused).

Conditions: files may hold ``level`` (high / medium / low), ``msppp`` and ``sbr``; the
authors' release holds none. A ``levels_file`` CSV (``file,level[,msppp,sbr]``, file
names relative to ``root``) assigns them instead; without either, every image has
level "unknown" and per-level results cannot be made.

Subsets: ``n_per_class`` keeps a seeded, stratified subset of N files per class
before anything is read (the release has 400 per class; the paper used 100).

Depth is in metres after ``depth_scale``; zero or non-finite depth is a void.
Negative, NaN / inf depths and depths beyond the sensor's reach become voids too;
they are counted per file, reported with a warning, and recorded in
``meta["load_report"]``. Every other problem (unreadable or truncated file, missing
key, wrong dimensionality, mixed shapes without ``image_shape``, a class folder
without files, a folder without data) is a ValueError naming the file.
"""

from __future__ import annotations

import re
import warnings
import zipfile
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spl_al.data.dataset import LEVELS, Dataset, sensor_to_dict
from spl_al.data.procedural import stratified_split
from spl_al.data.seeds import STREAM_SPLIT, STREAM_SUBSET, sample_rng
from spl_al.label_codes import IGNORE_INDEX
from spl_al.photon import SensorParams

DATA_SUFFIXES = (".npz", ".npy", ".png")
_FLAT_NAME = re.compile(r"^(?P<cls>.+)_(?P<num>\d+)$")


def _read_png(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            mode = img.mode
            if mode not in ("I;16", "I;16B", "I;16L", "I"):
                raise ValueError(
                    f"{path}: PNG mode {mode!r}; expected a 16-bit greyscale PNG "
                    "of depth in millimetres."
                )
            arr = np.array(img)
    except (OSError, UnidentifiedImageError) as exc:
        raise ValueError(f"{path}: cannot be read as a PNG ({exc}).") from None
    return arr.astype(np.float64) / 1000.0


def read_arrays(
    path: Path, keys: dict[str, str | None], required: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """Arrays of one file by role ("depth", "clean", ...); ``required`` roles must exist."""
    suffix = path.suffix.lower()
    if suffix == ".png":
        return {"depth": _read_png(path)}
    try:
        if suffix == ".npy":
            return {"depth": np.load(path, allow_pickle=False)}
        with np.load(path, allow_pickle=False) as z:
            files = set(z.files)
            out = {}
            for role, key in keys.items():
                if key is None:
                    continue
                if key in files:
                    out[role] = z[key]
                elif role in required:
                    raise ValueError(
                        f"{path}: has no array {key!r} "
                        f"(keys: {', '.join(sorted(files)) or 'none'})."
                    )
            for scalar in ("msppp", "sbr", "level"):
                if scalar in files:
                    out[scalar] = z[scalar]
            return out
    except ValueError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: cannot be read ({exc}).") from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(
            f"{path}: cannot be read, the file is truncated or not a numpy file ({exc})."
        ) from None


def as_image(arr: np.ndarray, path: Path, what: str) -> np.ndarray:
    """``arr`` as a 2-D numeric image (singleton axes dropped); else a ValueError naming
    ``path`` and ``what``."""
    a = np.asarray(arr)
    if a.ndim == 3 and 1 in (a.shape[0], a.shape[-1]):
        a = a.reshape([s for s in a.shape if s != 1] if a.shape.count(1) < 3 else a.shape[:2])
    if a.ndim != 2:
        raise ValueError(f"{path}: {what} has shape {a.shape}; expected a 2-D image (H, W).")
    if not (np.issubdtype(a.dtype, np.number) or a.dtype == bool):
        raise ValueError(f"{path}: {what} has dtype {a.dtype}; expected numbers.")
    return a


def resize_nearest(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour resize (depth is never blended across edges; voids stay voids)."""
    h, w = image.shape
    rows = np.minimum(((np.arange(shape[0]) + 0.5) * h / shape[0]).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(shape[1]) + 0.5) * w / shape[1]).astype(np.int64), w - 1)
    return image[rows[:, None], cols[None, :]]


def list_files(folder: Path) -> list[Path]:
    """The data files of ``folder`` (``DATA_SUFFIXES``, not hidden), sorted."""
    return sorted(
        p
        for p in folder.iterdir()
        if p.is_file() and p.suffix.lower() in DATA_SUFFIXES and not p.name.startswith(".")
    )


def _read_levels_file(path, root: Path, names: list[str]) -> dict[str, dict]:
    """{file name: {"level", optional "msppp", "sbr"}} from a ``file,level[,msppp,sbr]`` CSV,
    checked against the loaded files ``names`` (paths relative to ``root``)."""
    import csv

    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
            header = [] if not rows else list(rows[0])
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"{path}: levels_file cannot be read ({exc}).") from None
    if not rows or not {"file", "level"} <= set(header):
        raise ValueError(
            f"{path}: levels_file needs a header with columns file,level[,msppp,sbr] "
            f"and one row per file; found columns {header or 'none'}."
        )
    known = set(names)
    out: dict[str, dict] = {}
    for line, row in enumerate(rows, start=2):
        name = (row.get("file") or "").strip()
        if name in out:
            raise ValueError(f"{path}, line {line}: file {name!r} is listed twice.")
        if name not in known:
            raise ValueError(
                f"{path}, line {line}: file {name!r} is not among the loaded files of {root}."
            )
        level = (row.get("level") or "").strip()
        if level not in LEVELS:
            raise ValueError(
                f"{path}, line {line}: level {level!r}; expected one of {', '.join(LEVELS)}."
            )
        entry = {"level": level}
        for key in ("msppp", "sbr"):
            text = (row.get(key) or "").strip()
            if not text:
                continue
            try:
                value = float(text)
            except ValueError:
                value = float("nan")
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{path}, line {line}: {key} {text!r}; expected a number > 0.")
            entry[key] = value
        out[name] = entry
    missing = [n for n in names if n not in out]
    if missing:
        raise ValueError(
            f"{path}: no level for {len(missing)} loaded files (e.g. {missing[0]}); "
            "list every file once."
        )
    return out


def _subset_per_class(entries, n_per_class: int, seed: int, root: Path):
    """A seeded subset of ``n_per_class`` entries of every class (file order kept)."""
    if int(n_per_class) != n_per_class or n_per_class < 1:
        raise ValueError(f"n_per_class must be an integer >= 1, got {n_per_class!r}.")
    rng = sample_rng(seed, STREAM_SUBSET)
    keep = []
    for cls in sorted({e[1] for e in entries}):
        members = [k for k, e in enumerate(entries) if e[1] == cls]
        if len(members) < n_per_class:
            raise ValueError(
                f"{root}: class {cls!r} has {len(members)} files; n_per_class={n_per_class} "
                "needs at least that many in every class."
            )
        keep += rng.choice(members, size=int(n_per_class), replace=False).tolist()
    return [entries[k] for k in sorted(keep)]


def _discover(root: Path, label_key) -> tuple[str, list[tuple[Path, str, Path | None]]]:
    """(layout, [(file, class name or "", label file or None)])."""
    if not root.is_dir():
        raise ValueError(f"{root}: no such folder.")
    subdirs = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    files = list_files(root)
    names = {p.name for p in subdirs}
    if {"depth", "labels"} <= names and label_key is None:
        depth_files = list_files(root / "depth")
        if not depth_files:
            raise ValueError(f"{root / 'depth'}: holds no .npz/.npy/.png files.")
        labels = {p.stem: p for p in list_files(root / "labels")}
        out = []
        for f in depth_files:
            if f.stem not in labels:
                raise ValueError(
                    f"{f}: no label file {f.stem}.npy or {f.stem}.png in {root / 'labels'}."
                )
            out.append((f, "", labels[f.stem]))
        extra = sorted(set(labels) - {f.stem for f in depth_files})
        if extra:
            raise ValueError(
                f"{root / 'labels'}: label files without depth: {', '.join(extra[:5])}."
            )
        return "segmentation-pairs", out
    if files and subdirs:
        data_dirs = [d for d in subdirs if list_files(d)]
        if data_dirs:
            raise ValueError(
                f"{root}: holds both data files and class folders ({data_dirs[0].name}/); "
                "use one layout: {class}_{NNNN}.npz files or {class}/ folders."
            )
    if files:
        out = []
        for f in files:
            m = _FLAT_NAME.match(f.stem)
            if m is None:
                raise ValueError(
                    f"{f}: name does not follow {{class}}_{{NNNN}}{f.suffix} "
                    f"(e.g. bike_0001{f.suffix})."
                )
            out.append((f, m["cls"], None))
        return "flat", out
    if subdirs:
        out = []
        for d in subdirs:
            class_files = list_files(d)
            if not class_files:
                raise ValueError(f"{d}: class folder holds no .npz/.npy/.png files.")
            out += [(f, d.name, None) for f in class_files]
        return "per-class", out
    raise ValueError(
        f"{root}: no .npz/.npy/.png files found (expected {{class}}_{{NNNN}}.npz files, "
        "{class}/ subfolders, or depth/ and labels/ folders)."
    )


@dataclass(frozen=True)
class FolderOptions:
    """How ``load_folder`` reads a folder; every field a keyword of ``load_folder``.

    depth_key: array of the observed (SPL-reconstructed) depth in each ``.npz``.
    label_key: per-pixel label array in each ``.npz``: makes it a segmentation
        dataset (values < len(classes), 255 = ignore).
    clean_key: ground-truth depth in each ``.npz`` (kept as ``clean_depth_m``
        when every file has it); None to skip.
    reflectance_key: reflectivity array (SIV input); absent = uniform reflectance.
    classes: class names in label order. Classification: default the sorted
        names found (a name not in ``classes`` is an error). Segmentation:
        default ``root/classes.txt``, else class_0..class_{K-1}.
    image_shape: (H, W) to resize every image to (nearest neighbour); None
        requires all images to share one shape.
    depth_scale: factor to metres of ``.npz``/``.npy`` depth (PNG is millimetres).
    test_fraction, seed: stratified split (per class for classification).
    sensor: SPL timing for variants; None: ``SensorParams.paper_real()``.
    levels_file: CSV ``file,level[,msppp,sbr]`` assigning every loaded file its
        MSPPP level (and condition); it overrides levels stored in the files.
    n_per_class: keep a seeded (``seed``), stratified subset of this many files per
        class (classification only); None keeps every file.
    """

    depth_key: str = "depth_ssp"
    label_key: str | None = None
    clean_key: str | None = "Z_true"
    reflectance_key: str | None = None
    classes: object = None
    image_shape: object = None
    depth_scale: float = 1.0
    test_fraction: float = 0.3
    seed: int = 0
    sensor: SensorParams | None = None
    levels_file: object = None
    n_per_class: int | None = None

    @property
    def keys(self) -> dict[str, str | None]:
        """The array key of each role ("depth", "clean", "reflectance", "labels")."""
        return {
            "depth": self.depth_key,
            "clean": self.clean_key,
            "reflectance": self.reflectance_key,
            "labels": self.label_key,
        }


def load_folder(root, **options) -> Dataset:
    """Load a folder of SPL depth images as a Dataset of observed images.

    Args:
        root: the folder (layouts in the module docstring).
        **options: the fields of ``FolderOptions`` (``depth_key``, ``label_key``,
            ``clean_key``, ``reflectance_key``, ``classes``, ``image_shape``,
            ``depth_scale``, ``test_fraction``, ``seed``, ``sensor``, ``levels_file``,
            ``n_per_class``).

    Returns:
        Dataset (level "unknown" and NaN conditions unless the files or
        ``levels_file`` give them), with ``meta["load_report"]`` of the pixels made void.
    """
    return load_folder_with(root, FolderOptions(**options))


def load_folder_with(root, opts: FolderOptions) -> Dataset:
    """``load_folder`` with its options as one ``FolderOptions``."""
    root = Path(root)
    sensor = SensorParams.paper_real() if opts.sensor is None else opts.sensor
    if not (np.isfinite(opts.depth_scale) and opts.depth_scale > 0):
        raise ValueError(f"depth_scale must be > 0, got {opts.depth_scale!r}.")
    layout, entries = _discover(root, opts.label_key)
    segmentation = opts.label_key is not None or layout == "segmentation-pairs"
    if opts.n_per_class is not None:
        if segmentation:
            raise ValueError("n_per_class applies to classification folders only.")
        entries = _subset_per_class(entries, opts.n_per_class, opts.seed, root)
    records = [_read_record(path, cls, label_path, opts) for path, cls, label_path in entries]
    shapes = Counter(r["depth"].shape for r in records)
    shape = _target_shape(root, records, shapes, opts.image_shape)
    images, report = _resized_images(root, records, shape, sensor.max_depth_m)
    _warn_voids(root, report, sensor.max_depth_m)
    if segmentation:
        task, classes, labels, groups = _segmentation_targets(root, records, images, opts)
    else:
        task, classes, labels, groups = _classification_targets(root, records, opts.classes)
    msppp, sbr, level = _conditions(root, records, opts.levels_file)
    n = len(records)
    has = {role: len(images[role]) == n for role in ("clean", "reflectance")}
    return Dataset(
        task=task,
        classes=classes,
        depth_m=np.stack(images["depth"]).astype(np.float32),
        labels=labels,
        split=stratified_split(groups, opts.test_fraction, sample_rng(opts.seed, STREAM_SPLIT)),
        msppp=msppp,
        sbr=sbr,
        level=level,
        clean_depth_m=np.stack(images["clean"]).astype(np.float32) if has["clean"] else None,
        reflectance=(
            np.stack(images["reflectance"]).astype(np.float32) if has["reflectance"] else None
        ),
        sensor=sensor,
        meta={
            "source": "external",
            "root": str(root.resolve()),
            "layout": layout,
            "files": [str(r["path"].relative_to(root)) for r in records],
            "depth_key": opts.depth_key,
            "clean_key": opts.clean_key if has["clean"] else None,
            "reflectance_key": opts.reflectance_key if has["reflectance"] else None,
            "depth_scale": float(opts.depth_scale),
            "levels_file": None
            if opts.levels_file is None
            else str(Path(opts.levels_file).resolve()),
            "n_per_class": None if opts.n_per_class is None else int(opts.n_per_class),
            "image_shape": list(shape),
            "resized_from": {str(list(s)): c for s, c in shapes.items()}
            if opts.image_shape is not None
            else None,
            "seed": int(opts.seed),
            "test_fraction": float(opts.test_fraction),
            "sensor": sensor_to_dict(sensor),
            "load_report": report,
        },
    )


def _read_record(path: Path, cls: str, label_path: Path | None, opts: FolderOptions) -> dict:
    """One file's images by role (depth in metres, clean, reflectance, labels), its
    class and its stored conditions; every image checked to be (H, W) like the depth."""
    keys = opts.keys
    required = ("depth", "labels") if opts.label_key else ("depth",)
    arrays = read_arrays(path, keys, required)
    rec = {"path": path, "class": cls}
    scale = 1.0 if path.suffix.lower() == ".png" else opts.depth_scale
    what = opts.depth_key if path.suffix == ".npz" else "depth"
    rec["depth"] = as_image(arrays["depth"], path, what) * scale
    for role in ("clean", "reflectance"):
        if role in arrays:
            rec[role] = as_image(arrays[role], path, keys[role]).astype(np.float64) * (
                scale if role == "clean" else 1
            )
    if label_path is not None:
        lab = (
            _read_png_labels(label_path)
            if label_path.suffix.lower() == ".png"
            else read_arrays(label_path, {}, ())["depth"]
        )
        rec["labels"] = as_image(lab, label_path, "labels")
    elif "labels" in arrays:
        rec["labels"] = as_image(arrays["labels"], path, opts.label_key)
    for scalar in ("msppp", "sbr", "level"):
        if scalar in arrays:
            rec[scalar] = arrays[scalar]
    for role in ("clean", "reflectance", "labels"):
        if role in rec and rec[role].shape != rec["depth"].shape:
            raise ValueError(
                f"{path}: {role} has shape {rec[role].shape}, depth has {rec['depth'].shape}."
            )
    return rec


def _target_shape(root: Path, records, shapes: Counter, image_shape) -> tuple[int, int]:
    """The (H, W) every image is resized to: ``image_shape``, else the one shape found."""
    if image_shape is None:
        if len(shapes) > 1:
            found = ", ".join(
                f"{s} in {c} files (e.g. {_first_with_shape(records, s)})"
                for s, c in shapes.most_common()
            )
            raise ValueError(
                f"{root}: images have different shapes: {found}; "
                "pass image_shape=(H, W) to resize them."
            )
        return next(iter(shapes))
    try:
        shape = tuple(int(v) for v in image_shape)
    except (TypeError, ValueError):
        raise ValueError(f"image_shape must be (H, W), got {image_shape!r}.") from None
    if len(shape) != 2 or min(shape) < 1:
        raise ValueError(f"image_shape must be (H, W) with H, W >= 1, got {image_shape!r}.")
    return shape


def _resized_images(root: Path, records, shape, max_depth_m: float):
    """({role: [(H, W) image per record that has it]}, report of the depth pixels made
    void); depth in metres with NaN voids, reflectance 0 where unusable."""
    report = {
        "nonfinite": 0,
        "negative": 0,
        "zero": 0,
        "beyond_reach": 0,
        "files_with_bad_pixels": [],
    }
    images = {"depth": [], "clean": [], "reflectance": [], "labels": []}
    for r in records:
        d, bad = mask_unusable_depth(r["depth"], max_depth_m)
        for k in ("nonfinite", "negative", "zero", "beyond_reach"):
            report[k] += bad[k]
        if bad["nonfinite"] or bad["negative"] or bad["beyond_reach"]:
            report["files_with_bad_pixels"].append(str(r["path"].relative_to(root)))
        images["depth"].append(resize_nearest(d, shape))
        if "clean" in r:
            images["clean"].append(
                resize_nearest(mask_unusable_depth(r["clean"], np.inf)[0], shape)
            )
        if "reflectance" in r:
            rf = np.where(
                np.isfinite(r["reflectance"]) & (r["reflectance"] > 0), r["reflectance"], 0.0
            )
            images["reflectance"].append(resize_nearest(rf, shape))
        if "labels" in r:
            images["labels"].append(resize_nearest(r["labels"], shape))
    return images, report


def _warn_voids(root: Path, report: dict, max_depth_m: float) -> None:
    n_bad = report["nonfinite"] + report["negative"] + report["beyond_reach"]
    if n_bad:
        warnings.warn(
            f"{root}: {report['nonfinite']} NaN/inf, {report['negative']} negative and "
            f"{report['beyond_reach']} beyond-reach ({max_depth_m:.0f} m) depth pixels in "
            f"{len(report['files_with_bad_pixels'])} files were made voids "
            f"(e.g. {report['files_with_bad_pixels'][0]}).",
            stacklevel=4,  # the caller of load_folder
        )


def _segmentation_targets(root: Path, records, images, opts: FolderOptions):
    """(task, classes, (N, H, W) uint8 labels, (N,) split groups) of a segmentation folder."""
    n = len(records)
    if len(images["labels"]) != n:
        raise ValueError(
            f"{root}: segmentation needs labels for every image; "
            f"{n - len(images['labels'])} have none."
        )
    labels = _segmentation_labels(np.stack(images["labels"]), records, root)
    classes = _segmentation_classes(opts.classes, root, labels)
    bad = (labels != IGNORE_INDEX) & (labels >= len(classes))
    if bad.any():
        raise ValueError(
            f"{root}: labels hold values {np.unique(labels[bad])[:5].tolist()} "
            f">= {len(classes)} classes."
        )
    return "segmentation", classes, labels, np.zeros(n, np.int64)


def _classification_targets(root: Path, records, classes):
    """(task, classes, (N,) int64 labels, the same labels as split groups)."""
    found = sorted({r["class"] for r in records})
    if classes is None:
        classes = found
    else:
        classes = [str(c) for c in classes]
        unknown = sorted(set(found) - set(classes))
        if unknown:
            raise ValueError(f"{root}: files of classes {unknown} are not in classes={classes}.")
        empty = [c for c in classes if c not in found]
        if empty:
            raise ValueError(f"{root}: no files for classes {empty} (found {found}).")
    labels = np.array([classes.index(r["class"]) for r in records], dtype=np.int64)
    return "classification", classes, labels, labels


def _conditions(root: Path, records, levels_file):
    """(msppp (N,), sbr (N,), level (N,)) from the files or ``levels_file`` (which
    updates ``records``); NaN and "unknown" where neither gives them."""
    if levels_file is not None:
        given = _read_levels_file(
            levels_file, root, [str(r["path"].relative_to(root)) for r in records]
        )
        for r in records:
            r.update(given[str(r["path"].relative_to(root))])
    msppp = np.array([float(r.get("msppp", np.nan)) for r in records])
    sbr = np.array([float(r.get("sbr", np.nan)) for r in records])
    level = np.array([str(r.get("level", "unknown")) for r in records], dtype="<U7")
    bad_level = sorted(set(level) - {*LEVELS, "unknown"})
    if bad_level:
        raise ValueError(f"{root}: files hold levels {bad_level}; expected one of {LEVELS}.")
    return msppp, sbr, level


def folder_has_levels(root, depth_key: str = "depth_ssp") -> bool:
    """Whether a folder's files carry MSPPP levels (looks at the first ``.npz`` only;
    ``.npy`` and ``.png`` files never do). False for a folder that does not exist."""
    root = Path(root)
    if not root.is_dir():
        return False
    first = next(iter(sorted(root.rglob("*.npz"))), None)
    if first is None:
        return False
    try:
        with np.load(first, allow_pickle=False) as z:
            return "level" in z.files
    except (OSError, ValueError, EOFError, zipfile.BadZipFile):
        return False


def _first_with_shape(records, shape) -> str:
    return next(r["path"].name for r in records if r["depth"].shape == shape)


def _read_png_labels(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            return np.array(img)
    except (OSError, UnidentifiedImageError) as exc:
        raise ValueError(f"{path}: cannot be read as a PNG ({exc}).") from None


def mask_unusable_depth(depth: np.ndarray, max_depth_m: float) -> tuple[np.ndarray, dict[str, int]]:
    """Depth with every unusable pixel set to NaN, and the counts of each kind."""
    d = np.asarray(depth, dtype=np.float64)
    finite = np.isfinite(d)
    negative = finite & (d < 0)
    zero = finite & (d == 0)
    beyond = finite & (d > max_depth_m)
    counts = {
        "nonfinite": int((~finite).sum()),
        "negative": int(negative.sum()),
        "zero": int(zero.sum()),
        "beyond_reach": int(beyond.sum()),
    }
    return np.where(finite & ~negative & ~zero & ~beyond, d, np.nan), counts


def _segmentation_labels(labels: np.ndarray, records, root: Path) -> np.ndarray:
    lab = np.asarray(labels)
    if not np.issubdtype(lab.dtype, np.integer) and (
        not np.all(np.isfinite(lab)) or not np.all(lab == np.rint(lab))
    ):
        raise ValueError(f"{root}: label arrays must hold integers (class index, 255 = ignore).")
    lab = lab.astype(np.int64)
    if (lab < 0).any() or (lab > IGNORE_INDEX).any():
        raise ValueError(
            f"{root}: label values must be in 0..{IGNORE_INDEX} ({IGNORE_INDEX} = ignore)."
        )
    return lab.astype(np.uint8)


def _segmentation_classes(classes, root: Path, labels: np.ndarray) -> list[str]:
    if classes is not None:
        return [str(c) for c in classes]
    listing = root / "classes.txt"
    if listing.is_file():
        names = [line.strip() for line in listing.read_text().splitlines() if line.strip()]
        if not names:
            raise ValueError(f"{listing}: holds no class names.")
        return names
    used = labels[labels != IGNORE_INDEX]
    k = int(used.max()) + 1 if used.size else 1
    return [f"class_{i}" for i in range(k)]
