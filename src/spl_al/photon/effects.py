"""A fuller sensor model for the *observed* images of synthetic scenes.

SIV (``simulate_photons``) is exactly the paper's Algorithm 1, and stays so. Real data
are not made by Algorithm 1, though: if the observed images of the stand-in datasets
came from the same engine as their variants, training on variants would be
in-distribution augmentation, which it is not on real frames. Observed images of
synthetic scenes therefore come from this model, each effect switchable:

    lambda[p, t] = g_p * ( sum_k w_k a_{p+k} h(t - t_d(p+k)) + b )

- ``background_everywhere``: background photons fall on every pixel, with or without
  a return (sky, beyond range), at the rate b = mean_P(msppp * A) / sbr of Algorithm 1;
  such pixels then reconstruct to spurious depths or voids, as on a real sensor.
- ``gain_sigma``: per-pixel gain g_p ~ LogNormal(0, gain_sigma^2) / E[.] (unit mean),
  drawn per frame, on signal and background alike (detector and scan non-uniformity).
- ``range_falloff``: signal ~ (r_ref / r)^2 with r_ref the median range of the frame's
  returns (clipped to [1/16, 4]), for scenes whose reflectance is range-compensated
  (street scenes' intensity channel); object scenes carry it in their reflectance.
- ``mixed_fraction`` f: the laser footprint spills onto the 4 neighbours, w_0 = 1 - f
  and w_k = f / 4 for k in {up, down, left, right}: at a depth edge a pixel returns
  photons from both surfaces, and a pixel without a return beside one gets a few.
- ``dead_time_bins`` with ``cycles``: pile-up. Each photon falls in one of ``cycles``
  laser cycles; within a cycle the detector is blind for ``dead_time_bins`` after a
  detection, so later photons of that cycle are lost (first-photon bias at high flux).
  0 (default) disables it.

A's normalisation is Algorithm 1's (unit mean over the pixels with a return), so
``msppp`` keeps its meaning: the mean signal photons of a returning pixel.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from spl_al.photon.events import PhotonEvents
from spl_al.photon.scene import Condition, PhotonScene, check_scene

_NEIGHBOURS = ((-1, 0), (1, 0), (0, -1), (0, 1))


@dataclass(frozen=True)
class ObservationModel:
    """Which real-sensor effects observed images carry (module docstring).

    ``ObservationModel.algorithm1()`` switches every effect off: then ``observe_photons``
    draws from the distribution of ``simulate_photons`` (Algorithm 1).
    """

    background_everywhere: bool = True
    gain_sigma: float = 0.2
    range_falloff: bool = True
    mixed_fraction: float = 0.2
    dead_time_bins: int = 0
    cycles: int = 100

    def __post_init__(self) -> None:
        for name in ("background_everywhere", "range_falloff"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(
                    f"observation.{name} must be true or false, got {getattr(self, name)!r}."
                )
        if not (isinstance(self.gain_sigma, int | float) and 0 <= self.gain_sigma <= 2):
            raise ValueError(f"observation.gain_sigma must be in [0, 2], got {self.gain_sigma!r}.")
        if not (isinstance(self.mixed_fraction, int | float) and 0 <= self.mixed_fraction < 1):
            raise ValueError(
                f"observation.mixed_fraction must be in [0, 1), got {self.mixed_fraction!r}."
            )
        for name in ("dead_time_bins", "cycles"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f"observation.{name} must be an integer >= 0, got {value!r}.")
        if self.dead_time_bins and self.cycles < 1:
            raise ValueError("observation.cycles must be >= 1 when dead_time_bins is set.")

    @classmethod
    def algorithm1(cls) -> ObservationModel:
        """No effect beyond Algorithm 1 (the SIV model)."""
        return cls(
            background_everywhere=False, gain_sigma=0.0, range_falloff=False, mixed_fraction=0.0
        )

    @classmethod
    def from_dict(cls, params: dict | None) -> ObservationModel:
        """The model of a dict of its fields (None or missing keys: the defaults)."""
        params = dict(params or {})
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(params) - known)
        if unknown:
            raise ValueError(
                f"unknown observation keys {unknown}; expected some of {sorted(known)}."
            )
        return cls(**params)

    def to_dict(self) -> dict:
        """The model's fields as a JSON-ready dict."""
        return asdict(self)

    @property
    def is_algorithm1(self) -> bool:
        """Whether the model adds nothing to Algorithm 1 (the SIV model)."""
        return self == ObservationModel.algorithm1()


def _shifted(a: np.ndarray, dr: int, dc: int, fill) -> np.ndarray:
    """out[r, c] = a[r + dr, c + dc] (``fill`` outside the frame)."""
    out = np.full_like(a, fill)
    rows, cols = a.shape
    out[max(-dr, 0) : rows - max(dr, 0), max(-dc, 0) : cols - max(dc, 0)] = a[
        max(dr, 0) : rows - max(-dr, 0), max(dc, 0) : cols - max(-dc, 0)
    ]
    return out


def _dead_time(events: PhotonEvents, model: ObservationModel, rng) -> PhotonEvents:
    """Drop photons that arrive within the dead time after another of the same pixel
    and laser cycle (each photon's cycle uniform over ``model.cycles``)."""
    if not model.dead_time_bins or len(events) == 0:
        return events
    cycle = rng.integers(0, model.cycles, size=len(events))
    order = np.lexsort((events.bin, cycle, events.pixel))
    pix, cyc, b = events.pixel[order], cycle[order], events.bin[order]
    same = np.r_[False, (pix[1:] == pix[:-1]) & (cyc[1:] == cyc[:-1])]
    blind = same & (np.r_[0, np.diff(b)] < model.dead_time_bins)
    keep = np.sort(order[~blind])
    return PhotonEvents(events.pixel[keep], events.bin[keep], events.is_signal[keep], events.shape)


def observe_photons(
    scene: PhotonScene,
    condition: Condition,
    rng: np.random.Generator,
    *,
    model: ObservationModel | None = None,
    range_compensated: bool = False,
) -> PhotonEvents:
    """The photons a real SPL detects from a scene (module docstring for the model).

    Args:
        scene, condition, rng: as ``simulate_photons``.
        model: the effects; default ``ObservationModel()``.
        range_compensated: the reflectance holds no range falloff (apply the model's).

    Returns:
        PhotonEvents (signal first, then background) over the whole frame.
    """
    model = ObservationModel() if model is None else model
    msppp, sbr, sensor = condition.msppp, condition.sbr, condition.sensor
    depth, refl, valid, t_obs = check_scene(scene, sensor)
    shape = valid.shape
    rate = msppp * refl  # (rows, cols), 0 without a return
    mean_signal = rate[valid].mean()  # Algorithm 1's level, before the effects below
    if model.range_falloff and range_compensated:
        r_ref = np.median(depth[valid])
        falloff = np.clip((r_ref / np.where(valid, depth, r_ref)) ** 2, 1 / 16, 4.0)
        rate = rate * falloff
        rate *= mean_signal / rate[valid].mean()  # keep msppp's meaning
    gain = np.ones(shape)
    if model.gain_sigma > 0:
        s = model.gain_sigma
        gain = rng.lognormal(-0.5 * s * s, s, size=shape)  # unit mean
    f = model.mixed_fraction
    sources = [((0, 0), 1.0 - f)] + ([(k, f / 4) for k in _NEIGHBOURS] if f > 0 else [])
    sig_pixel, sig_bin = [], []
    for (dr, dc), weight in sources:
        src_rate = _shifted(rate, dr, dc, 0.0) * weight * gain
        src_bin = _shifted(t_obs, dr, dc, 0)
        pix = np.flatnonzero(src_rate > 0)
        n = rng.poisson(src_rate.ravel()[pix])
        p = np.repeat(pix, n)
        jitter = rng.standard_normal(p.size) * sensor.sigma_bins
        b = np.rint(np.repeat(src_bin.ravel()[pix], n) + jitter)
        sig_pixel.append(p)
        sig_bin.append(np.clip(b, 0, sensor.t_max))
    sig_pixel, sig_bin = np.concatenate(sig_pixel), np.concatenate(sig_bin)

    bkg_mask = np.ones(shape, bool) if model.background_everywhere else valid
    pix = np.flatnonzero(bkg_mask)
    n_bkg = rng.poisson(mean_signal / sbr * gain.ravel()[pix])
    bkg_pixel = np.repeat(pix, n_bkg)
    bkg_bin = rng.integers(0, sensor.t_max + 1, size=bkg_pixel.size)
    events = PhotonEvents(
        pixel=np.concatenate([sig_pixel, bkg_pixel]).astype(np.int32),
        bin=np.concatenate([sig_bin, bkg_bin]).astype(np.int32),
        is_signal=np.concatenate([np.ones(sig_pixel.size, bool), np.zeros(bkg_pixel.size, bool)]),
        shape=(int(shape[0]), int(shape[1])),
    )
    return _dead_time(events, model, rng)
