"""SPL digits: handwritten digits as depth relief, observed through the photon engine.

A second, unrelated classification set in the authors' released folder layout
(``{class}_{NNNN}.npz`` holding ``depth_ssp``, no condition keys), used to check that
the default learner and the folder path work on data nothing was tuned on. The 1,797
8x8 digits of scikit-learn (UCI optical digits) are embossed on a board:

    depth_m(p) = d_board(p) - relief_m * ink(p) / 16

with the board a plane at ``distance_m`` tilted by a few degrees, the digit upsampled
bilinearly to ``digit_px`` pixels and placed at a random offset, then seen through
``spl_al.data.observe.observe_image`` under the fuller sensor model (``ObservationModel``) at a
random MSPPP level and SBR, like every synthetic set.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write
from spl_al.data.observe import DEFAULT_LEVELS, DEFAULT_SBR, observe_image
from spl_al.data.seeds import STREAM_OBSERVE, STREAM_SCENE, sample_rng
from spl_al.photon import Condition, ObservationModel, SensorParams


def _upsample(img: np.ndarray, size: int) -> np.ndarray:
    """Bilinear resize of a (h, w) image to (size, size), pixel centres aligned."""
    h, w = img.shape
    r = np.clip((np.arange(size) + 0.5) * h / size - 0.5, 0, h - 1)
    c = np.clip((np.arange(size) + 0.5) * w / size - 0.5, 0, w - 1)
    r0, c0 = np.floor(r).astype(int), np.floor(c).astype(int)
    r1, c1 = np.minimum(r0 + 1, h - 1), np.minimum(c0 + 1, w - 1)
    fr, fc = (r - r0)[:, None], (c - c0)[None, :]
    top = img[r0][:, c0] * (1 - fc) + img[r0][:, c1] * fc
    bottom = img[r1][:, c0] * (1 - fc) + img[r1][:, c1] * fc
    return top * (1 - fr) + bottom * fr


def digit_scene(
    ink: np.ndarray,
    rng: np.random.Generator,
    *,
    image_px: int = 32,
    digit_px: int = 28,
    distance_m=(15.0, 40.0),
    relief_m=(0.3, 0.6),
    tilt_deg: float = 3.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Clean depth (image_px, image_px) and reflectance of one embossed digit.

    Args:
        ink: (8, 8) digit intensities 0..16.
        rng: draws offset, distance, relief, tilt and albedo.
    """
    digit = _upsample(np.asarray(ink, np.float64) / 16.0, digit_px)
    canvas = np.zeros((image_px, image_px))
    r0, c0 = rng.integers(0, image_px - digit_px + 1, size=2)
    canvas[r0 : r0 + digit_px, c0 : c0 + digit_px] = digit
    rows, cols = np.mgrid[0:image_px, 0:image_px] / image_px - 0.5
    slope = np.tan(np.deg2rad(rng.uniform(-tilt_deg, tilt_deg, 2)))
    board = rng.uniform(*distance_m) * (1 + 0.2 * (slope[0] * rows + slope[1] * cols))
    depth = board - rng.uniform(*relief_m) * canvas
    albedo = rng.uniform(0.3, 0.8) * (1 + 0.3 * canvas)
    return depth.astype(np.float32), albedo.astype(np.float32)


def _save_npz(path: Path, **arrays) -> None:
    with open(path, "wb") as f:  # a file object: np.savez would append ".npz" to a name
        np.savez(f, **arrays)


def write_digits_folder(
    root,
    *,
    n_per_class: int = 100,
    image_px: int = 32,
    seed: int = 0,
    sensor: SensorParams | None = None,
    levels=DEFAULT_LEVELS,
    sbr_values=DEFAULT_SBR,
) -> Path:
    """Write ``root/digit{k}_{NNNN}.npz`` (``depth_ssp`` observed, ``Z_true`` clean depth,
    metres, 0 = void as in the authors' files) for the first ``n_per_class`` digits of
    each class; returns ``root``.

    Conditions (an MSPPP level and an SBR per file) are drawn per sample and not stored,
    as in the authors' release.
    """
    from sklearn.datasets import load_digits

    sensor = SensorParams.paper_real() if sensor is None else sensor
    digits = load_digits()
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    level_values = list(levels.values())
    for k in range(10):
        members = np.flatnonzero(digits.target == k)[:n_per_class]
        if members.size < n_per_class:
            raise ValueError(f"only {members.size} digits of class {k}; asked {n_per_class}.")
        for j, i in enumerate(members):
            scene_rng = sample_rng(seed, STREAM_SCENE, int(i))
            clean, albedo = digit_scene(digits.images[i], scene_rng, image_px=image_px)
            msppp = level_values[scene_rng.integers(len(level_values))]
            sbr = sbr_values[scene_rng.integers(len(sbr_values))]
            observed, _ = observe_image(
                clean,
                albedo,
                condition=Condition(msppp, sbr, sensor),
                rng=sample_rng(seed, STREAM_OBSERVE, int(i)),
                model=ObservationModel(),
            )
            arrays = {"depth_ssp": np.nan_to_num(observed, nan=0.0), "Z_true": clean}
            atomic_write(root / f"digit{k}_{j:04d}.npz", lambda tmp, a=arrays: _save_npz(tmp, **a))
    return root
