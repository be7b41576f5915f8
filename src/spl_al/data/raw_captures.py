"""A folder of raw photon captures as a dataset: reconstruct each, then split by level.

``source: captures`` datasets go through two steps before the usual pipeline:

1. ``reconstruct_shard``: every capture of one shard is read (``load_capture``, any
   format it knows) and reconstructed (``reconstruct_capture``) into depth, intensity
   and the frame's estimated MSPPP and SBR; the shard's results go to one ``.npz``.
2. ``write_release``: the shards' frames become a folder in the release layout
   (``spl_al.photon.release``), one ``.npz`` per capture at the capture's relative
   path (so class folders and ``{class}_{NNNN}`` names keep giving the labels) or
   under ``{label}/`` when a labels CSV names each capture's class, each with its
   MSPPP ``level``; ``conditions.csv`` lists every frame's figures.

The level split comes from the frames' own photons, as the paper's levels are MSPPP
levels: ``tertiles`` (default) puts the lowest third of the frames' estimated MSPPP in
"low", the middle third in "medium", the top third in "high"; ``edges`` [a, b] puts
MSPPP < a in low, a <= MSPPP < b in medium and the rest in high.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write, atomic_write_text
from spl_al.photon.io import READ_KEYS, SUPPORTED_FORMATS, ReadOptions, list_captures

LEVEL_SPLITS = ("tertiles", "edges")
_RELEASE_KEYS = ("depth_ssp", "intensity", "msppp", "sbr", "pulse_sigma_s", "bin_width_s")


@dataclass(frozen=True)
class CaptureOptions:
    """How a dataset's captures are read and reconstructed (config ``captures:``, one
    flat mapping: the reading keys ``READ_KEYS`` and those below).

    Attributes:
        reading: how each file is read (``spl_al.photon.io.ReadOptions``: format,
            time_unit, bin_width_ps, pulse_sigma_ps, key, time_axis, channel), the
            same options the real-capture pictures and the command line take.
        method: reconstruction method ("pooled", "lmf", or "sspi" with weights).
        level_split: "tertiles" or "edges" (module docstring).
        level_edges: [low|medium, medium|high] MSPPP edges for ``level_split: edges``.
        labels_file: CSV ``file,label`` giving each capture's class (relative paths).
        shards: reconstruction jobs.
    """

    reading: ReadOptions = field(default_factory=ReadOptions)
    method: str = "pooled"
    level_split: str = "tertiles"
    level_edges: list[float] = field(default_factory=lambda: [3.0, 7.0])
    labels_file: str | None = None
    shards: int = 2

    @classmethod
    def option_keys(cls) -> tuple[str, ...]:
        """The keys of a ``captures:`` mapping: the reading keys, then the others."""
        return (*READ_KEYS, *(k for k in cls.__dataclass_fields__ if k != "reading"))

    @classmethod
    def from_dict(cls, values: dict | None) -> CaptureOptions:
        """Options from the config's ``captures:`` mapping (missing keys take defaults)."""
        values = dict(values or {})
        unknown = sorted(set(values) - set(cls.option_keys()))
        if unknown:
            raise ValueError(
                f"config key 'captures' has unknown options {unknown}; expected among "
                f"{', '.join(cls.option_keys())}."
            )
        reading = ReadOptions(**{k: values.pop(k) for k in READ_KEYS if k in values})
        options = cls(reading=reading, **values)
        if options.level_split not in LEVEL_SPLITS:
            raise ValueError(
                f"captures.level_split must be one of {LEVEL_SPLITS}, got {options.level_split!r}."
            )
        edges = list(options.level_edges)
        if len(edges) != 2 or not 0 < edges[0] < edges[1]:
            raise ValueError(
                f"captures.level_edges must be two MSPPP values 0 < a < b, got {edges!r}."
            )
        return options

    @property
    def pulse_sigma_s(self) -> float | None:
        """The instrument response sigma given, in seconds (None: the file's or estimated)."""
        return self.reading.pulse_sigma_s

    def load(self, path):
        """The capture in ``path``, read as the pictures and the command line read theirs."""
        return self.reading.load(path)

    def missing_timing(self, path, setting: str) -> str | None:
        """``ReadOptions.missing_timing`` of these options."""
        return self.reading.missing_timing(path, setting)


def capture_files(root, flat: bool = False) -> list[str]:
    """Capture files under ``root`` (and its class folders), as sorted relative paths.

    ``flat``: the files must lie directly in ``root`` (an unlabeled pool for a human
    oracle); a file in a subfolder is refused before any reconstruction runs.
    """
    if not root:
        raise ValueError("a captures dataset needs 'path', the folder of its capture files.")
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"captures folder {root} does not exist (config key 'path').")
    files = [str(p.relative_to(root)) for p in list_captures(root)[0]]
    if not files:
        raise ValueError(
            f"captures folder {root} holds no capture file (expected {SUPPORTED_FORMATS})."
        )
    nested = [f for f in files if Path(f).parent != Path(".")]
    if flat and nested:
        raise ValueError(
            f"config key 'path': with oracle: human the captures must lie directly in "
            f"{root} (an unlabeled pool is read flat); found {Path(nested[0]).parent}/."
        )
    return files


def not_read(root, recursive: bool = True) -> list[str]:
    """One line for each file in ``root`` that is not a capture format (so not read),
    naming the supported formats: nothing in a captures folder is skipped without a word."""
    root = Path(root)
    return [
        f"{root}: {p.relative_to(root)} is not read, not a capture format "
        f"(supported: {SUPPORTED_FORMATS})."
        for p in list_captures(root, recursive)[1]
    ]


def check_timing(root, files, options: ReadOptions | CaptureOptions, setting: str) -> None:
    """Raise ValueError (one sentence naming ``setting``) for the first of ``files``
    (relative to ``root``) that is a count cube stating no bin width when ``options``
    give none: before any reconstruction job runs, not in one."""
    for name in files:
        problem = options.missing_timing(Path(root) / name, setting)
        if problem:
            raise ValueError(problem)


def picture_files(folder, options: ReadOptions, setting: str) -> dict[str, str]:
    """{name: file} of the real captures in ``folder`` to picture, named by their stem:
    every file ``load_capture`` reads with ``options`` (.mat, .ptu, HDF5, .npy/.npz),
    as for a ``source: captures`` dataset. Files of other formats are left out (name
    them with ``not_read(folder, recursive=False)``).

    Raises:
        ValueError: one sentence, for a count cube that states no bin width when
            ``options`` give none (naming ``setting``), or for two files of one name.
    """
    folder = Path(folder)
    files = list_captures(folder, recursive=False)[0]
    check_timing(folder, [p.name for p in files], options, setting)
    stems = [p.stem for p in files]
    twins = sorted({s for s in stems if stems.count(s) > 1})
    if twins:
        raise ValueError(f"real captures {twins[0]}.* exist in two formats in {folder}.")
    return {p.stem: str(p) for p in files}


def shard_count(options: CaptureOptions, n_files: int) -> int:
    """Reconstruction jobs for ``n_files`` captures: ``options.shards``, at most one per file."""
    return max(1, min(int(options.shards), n_files))


def shard_of(files: list[str], n_shards: int, shard: int) -> list[str]:
    """The files of shard ``shard`` of ``n_shards`` (every n-th file, in order)."""
    return files[shard::n_shards]


def reconstruct_shard(root, files: list[str], *, out_path, options: CaptureOptions, weights=None):
    """Reconstruct ``files`` (relative to ``root``) and save them to one ``.npz``.

    The file holds, per frame k, ``{k}/{name}`` for every release array and ``files``,
    the relative paths in order. Returns the number of frames.
    """
    # scipy on demand (importing this module does not load it)
    from spl_al.photon.release import reconstruct_capture

    root = Path(root)
    arrays: dict[str, np.ndarray] = {"files": np.array(files, dtype=str)}
    for k, name in enumerate(files):
        capture = options.load(root / name)
        result = reconstruct_capture(
            capture, method=options.method, pulse_sigma_s=options.pulse_sigma_s, weights=weights
        )
        print(f"{name}: {capture.describe()}; {result.summary()}", flush=True)
        for key, value in result.release_arrays().items():
            arrays[f"{k}/{key}"] = value

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)

    atomic_write(out_path, write)
    return len(files)


def assign_levels(msppp: np.ndarray, split: str = "tertiles", edges=(3.0, 7.0)) -> np.ndarray:
    """(N,) MSPPP level per frame: "low" / "medium" / "high" (module docstring)."""
    msppp = np.asarray(msppp, dtype=np.float64)
    if split == "edges":
        index = np.searchsorted(np.asarray(edges, dtype=np.float64), msppp, side="right")
    else:
        ranks = np.empty(msppp.size, dtype=np.int64)
        ranks[np.argsort(msppp, kind="stable")] = np.arange(msppp.size)
        index = (3 * ranks) // max(msppp.size, 1)
    return np.array(["low", "medium", "high"], dtype="<U6")[index]


def _read_labels(path, files: list[str]) -> dict[str, str]:
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"{path}: labels_file cannot be read ({exc}).") from None
    if not rows or not {"file", "label"} <= set(rows[0]):
        raise ValueError(f"{path}: labels_file needs a header file,label and one row per capture.")
    labels = {}
    for line, row in enumerate(rows, start=2):
        name, label = (row["file"] or "").strip(), (row["label"] or "").strip()
        if name not in files:
            raise ValueError(f"{path}, line {line}: {name!r} is not a capture of the folder.")
        if not label or "/" in label:
            raise ValueError(f"{path}, line {line}: label {label!r} is not a class name.")
        labels[name] = label
    missing = [f for f in files if f not in labels]
    if missing:
        raise ValueError(
            f"{path}: no label for {len(missing)} captures (e.g. {missing[0]}); "
            "give one row per capture."
        )
    return labels


def write_release(shard_paths, out_dir, options: CaptureOptions) -> Path:
    """The release-layout folder of every shard's frames, with their MSPPP levels."""
    frames = []
    for shard_path in shard_paths:
        with np.load(shard_path, allow_pickle=False) as z:
            for k, name in enumerate(z["files"].tolist()):
                frames.append((name, {key: z[f"{k}/{key}"] for key in _RELEASE_KEYS}))
    frames.sort(key=lambda frame: frame[0])
    names = [name for name, _ in frames]
    levels = assign_levels(
        [arrays["msppp"] for _, arrays in frames], options.level_split, options.level_edges
    )
    labels = _read_labels(options.labels_file, names) if options.labels_file else None
    relatives = [
        (Path(labels[name]) / Path(name).name if labels else Path(name)).with_suffix(".npz")
        for name in names
    ]
    seen: dict[Path, str] = {}
    for name, relative in zip(names, relatives, strict=True):
        if relative in seen:
            raise ValueError(
                f"captures {seen[relative]} and {name} would both be {relative} in the "
                "release folder; give each frame its own name."
            )
        seen[relative] = name
    out_dir = Path(out_dir)
    rows = ["file,capture,level,msppp,sbr,pulse_sigma_ps,voids"]
    for (name, arrays), level, relative in zip(frames, levels, relatives, strict=True):
        arrays = {**arrays, "level": np.str_(level)}

        def write(tmp: Path, arrays=arrays) -> None:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **arrays)

        atomic_write(out_dir / relative, write)
        voids = float(np.mean(arrays["depth_ssp"] == 0))
        rows.append(
            f"{relative},{name},{level},{float(arrays['msppp']):.4f},{float(arrays['sbr']):.4f},"
            f"{float(arrays['pulse_sigma_s']) * 1e12:.1f},{voids:.4f}"
        )
    atomic_write_text(out_dir / "conditions.csv", "\n".join(rows) + "\n")
    return out_dir
