"""Frames to predict on: release-layout files and raw photon captures, or folders of them.

A release-layout ``.npz`` (``spl_al.photon.release``: ``depth_ssp`` in metres, 0 = no
return, with the frame's estimated ``msppp`` and ``sbr`` when it was made from
photons) is read as it is. Any other capture file ``load_capture`` reads (.mat,
.ptu, a count cube in .npy/.npz/.h5) is reconstructed like
``python -m spl_al.photon reconstruct`` with the options the model's card records for
its dataset (``CaptureOptions``: method, format, timing), which the command line may
override; its MSPPP and SBR are estimated from its photons. Every frame is read before
any prediction is written, so an unreadable one stops the run with one sentence and
nothing is written.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spl_al.data.raw_captures import CaptureOptions
from spl_al.photon.io import SUPPORTED_FORMATS, list_captures

RELEASE_DEPTH_KEY = "depth_ssp"


@dataclass(frozen=True)
class Frame:
    """One depth image to predict on.

    Attributes:
        name: the file it came from, as given (relative to a folder given as input).
        depth_m: (H, W) float32 depth in metres, NaN at voids.
        msppp, sbr: the frame's estimated condition (NaN when the file states none).
        source: "release" or "capture" (reconstructed here with ``method``).
    """

    name: str
    depth_m: np.ndarray
    msppp: float
    sbr: float
    source: str


def input_files(inputs) -> list[tuple[Path, str]]:
    """(path, name) of every file to read: files as given, folders searched recursively
    by ``list_captures`` (the listing of every capture reader; hidden files skipped),
    sorted per folder. A folder's other files are left alone: a README is no frame."""
    found = []
    for given in map(Path, inputs):
        if given.is_dir():
            files, _ = list_captures(given)
            if not files:
                raise ValueError(
                    f"{given}: holds no release-layout or capture file; supported: "
                    f"{SUPPORTED_FORMATS}."
                )
            found += [(p, str(p.relative_to(given))) for p in files]
        elif given.is_file():
            found.append((given, given.name))
        else:
            raise ValueError(f"{given}: no such file or folder.")
    return found


def _release_frame(path: Path, name: str, arrays, depth_key: str) -> Frame:
    depth = np.asarray(arrays[depth_key], dtype=np.float32)
    if depth.ndim != 2:
        raise ValueError(
            f"{path}: {depth_key!r} must be one (H, W) depth image, got {depth.shape}."
        )
    depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan).astype(np.float32)

    def scalar(key):
        return float(np.asarray(arrays[key]).reshape(-1)[0]) if key in arrays else float("nan")

    return Frame(name, depth, scalar("msppp"), scalar("sbr"), "release")


def _capture_frame(path: Path, name: str, options: CaptureOptions, weights) -> Frame:
    # scipy on demand (importing this module does not load it)
    from spl_al.photon.release import reconstruct_capture

    rec = reconstruct_capture(
        options.load(path),
        method=options.method,
        pulse_sigma_s=options.pulse_sigma_s,
        weights=weights,
    )
    return Frame(name, rec.depth_m.astype(np.float32), rec.msppp, rec.sbr, "capture")


def read_frame(
    path: Path, name: str, *, options: CaptureOptions, depth_key=RELEASE_DEPTH_KEY, weights=None
) -> Frame:
    """One frame: a release-layout ``.npz`` (it holds ``depth_key``) or a raw capture."""
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path, allow_pickle=False) as f:
                arrays = {k: f[k] for k in f.files}
        except (OSError, ValueError) as exc:
            raise ValueError(f"{path}: not a readable .npz file ({exc}).") from None
        if depth_key in arrays:
            return _release_frame(path, name, arrays, depth_key)
    return _capture_frame(path, name, options, weights)


def read_frames(inputs, options: CaptureOptions, depth_key=RELEASE_DEPTH_KEY, weights=None):
    """Every frame of ``inputs`` (files and folders), read before anything is written."""
    return [
        read_frame(p, n, options=options, depth_key=depth_key, weights=weights)
        for p, n in input_files(inputs)
    ]


def capture_options(reconstruction: dict | None, overrides: dict | None = None) -> CaptureOptions:
    """The card's reconstruction settings with the command line's ``overrides`` on top
    (None values leave the card's)."""
    values = {k: v for k, v in (reconstruction or {}).items() if k in CaptureOptions.option_keys()}
    values.update({k: v for k, v in (overrides or {}).items() if v is not None})
    return CaptureOptions.from_dict(values)
