"""What the photon engine takes: the scene one frame images, and the condition it
images it at. Every simulation in ``spl_al.photon`` (Algorithm 1, the fuller sensor
model, SIV variants) takes one ``PhotonScene`` and one ``Condition``, so the seven
values that describe a frame travel as two.

Not to be confused with ``spl_al.scenes``, which builds 3-D street and object
scenes and renders the depth images that become ``PhotonScene`` s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spl_al.photon.sensor import SensorParams


@dataclass(frozen=True, eq=False)
class PhotonScene:
    """One depth image as the sensor sees it.

    Attributes:
        depth_m: (rows, cols) depth in metres; ignored where ``valid`` is False.
        reflectance: (rows, cols) albedo or signal intensity, any scale (only its
            shape over the valid pixels matters); None = uniform.
        valid: (rows, cols) bool mask of the pixels with a return; None = the
            pixels whose depth is finite.
    """

    depth_m: np.ndarray
    reflectance: np.ndarray | None = None
    valid: np.ndarray | None = None

    def crop(self, rows: slice, cols: slice) -> PhotonScene:
        """The scene inside a window of rows and columns (every array cut alike)."""

        def cut(a):
            return None if a is None else a[rows, cols]

        return PhotonScene(self.depth_m[rows, cols], cut(self.reflectance), cut(self.valid))


@dataclass(frozen=True)
class Condition:
    """The imaging condition of one frame: photon budget, background, sensor timing.

    Attributes:
        msppp: mean signal photons per valid pixel, finite and > 0.
        sbr: signal-to-background ratio, > 0 (``np.inf`` for no background).
        sensor: the SPL's timing (bins, jitter, reach).

    Raises ValueError at construction, naming the value, for an MSPPP that is not
    finite and positive or an SBR that is not positive.
    """

    msppp: float
    sbr: float
    sensor: SensorParams = field(default_factory=SensorParams)

    def __post_init__(self) -> None:
        msppp, sbr = check_condition(self.msppp, self.sbr)
        object.__setattr__(self, "msppp", msppp)
        object.__setattr__(self, "sbr", sbr)


def check_condition(msppp, sbr) -> tuple[float, float]:
    """(msppp, sbr) as floats; a ValueError unless MSPPP is finite and > 0 and SBR > 0."""
    msppp = float(msppp)
    sbr = float(sbr)
    if not (np.isfinite(msppp) and msppp > 0):
        raise ValueError(
            f"msppp must be a finite number > 0 signal photons per pixel, got {msppp!r}."
        )
    if not sbr > 0 or np.isnan(sbr):
        raise ValueError(f"sbr must be > 0 (np.inf for no background), got {sbr!r}.")
    return msppp, sbr


def check_scene(scene: PhotonScene, sensor: SensorParams):
    """Validate a scene for a sensor; return (depth_m, unit-mean reflectance, valid, t_obs).

    Returns float64 depth (rows, cols), float64 reflectance A normalised to unit mean
    over the valid pixels (rows, cols; 0 outside them), bool valid (rows, cols) and
    int64 t_obs = round(2 d / (c dt)) on the valid pixels (rows, cols; 0 outside).
    Raises ValueError naming the field for every malformed input.
    """
    depth = np.asarray(scene.depth_m, dtype=np.float64)
    if depth.ndim != 2:
        raise ValueError(f"depth_m must be a 2-D image (rows, cols), got shape {depth.shape}.")
    valid = np.isfinite(depth) if scene.valid is None else np.asarray(scene.valid)
    if valid.shape != depth.shape:
        raise ValueError(
            f"valid has shape {valid.shape}, expected the shape of depth_m {depth.shape}."
        )
    if valid.dtype != bool:
        if not np.isin(valid, (0, 1)).all():
            raise ValueError("valid must be a boolean mask (or 0/1 values).")
        valid = valid.astype(bool)
    if not valid.any():
        raise ValueError("valid marks no pixel: the image has no valid depth to simulate.")
    d = depth[valid]
    if not np.isfinite(d).all():
        raise ValueError(
            f"depth_m holds {int((~np.isfinite(d)).sum())} NaN or inf values on valid pixels; "
            "mark them invalid in `valid`."
        )
    if (d < 0).any():
        raise ValueError(f"depth_m holds negative depths on valid pixels (min {d.min():.3g} m).")
    t_obs = np.zeros(depth.shape, dtype=np.int64)
    t_obs[valid] = sensor.depth_to_bin(d)
    if t_obs.max() > sensor.t_max:
        raise ValueError(
            f"depth_m reaches {d.max():.3f} m, beyond the sensor's reach of "
            f"{sensor.max_depth_m:.3f} m (T_max = {sensor.t_max} bins of "
            f"{sensor.bin_width_s * 1e12:.4g} ps); use a sensor with more or wider bins."
        )
    if scene.reflectance is None:
        refl = valid.astype(np.float64)
    else:
        refl = np.asarray(scene.reflectance, dtype=np.float64)
        if refl.shape != depth.shape:
            raise ValueError(
                f"reflectance has shape {refl.shape}, expected the shape of depth_m {depth.shape}."
            )
        r = refl[valid]
        if not np.isfinite(r).all() or (r < 0).any():
            raise ValueError("reflectance must be finite and >= 0 on valid pixels.")
        mean_r = r.mean()
        if mean_r <= 0:
            raise ValueError("reflectance is zero on every valid pixel; expected a positive mean.")
        refl = np.where(valid, refl / mean_r, 0.0)
    return depth, refl, valid, t_obs
