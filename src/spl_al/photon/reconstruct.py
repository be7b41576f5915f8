"""Depth, reflectivity and background from photon events (docs/method.md section 1).

The paper turns photons back into depth with SSPI (Yao et al. 2022), a learned
sparse 3-D U-Net over the histogram cube. ``"sspi"`` runs it (``spl_al.photon.sspi``,
plain PyTorch) when given the authors' published weights; without weights spl-al
reconstructs with maximum likelihood under the measurement model:

- ``"lmf"``: per-pixel log-matched filter. Each pixel's photons are scored under a
  Gaussian IRF plus a uniform background, the ML time bin is taken among the
  photons' own bins (the mode of the likelihood lies at a photon cluster), then
  refined to sub-bin precision by a few EM steps (signal responsibilities).
- ``"pooled"`` (default): neighbourhood-aided ML in the spirit of Rapp & Goyal's
  unmixing. Every pixel's candidate depths are its 3x3 neighbours' LMF estimates,
  scored with the photons of the whole 3x3 window (a robust first estimate); a
  pixel keeps its own ML depth only when its own photons beat that estimate by a
  margin of 1.5 single-photon log-likelihoods, and is refined around the chosen
  depth with its own photons; finally pixels that fewer than two of their own
  photons support get the 3x3 median (an edge-preserving median filter).

Both are sparse: the cost grows with the number of photons, not with T, so they
run on 10,000-bin real captures as on 1024-bin simulations.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from spl_al.photon.events import PhotonEvents, Reconstruction
from spl_al.photon.sensor import SensorParams
from spl_al.photon.sspi import reconstruct_sspi

ML_METHODS = ("pooled", "lmf")  # maximum likelihood: no weights needed
METHODS = (*ML_METHODS, "sspi")
_EM_STEPS = 3
_OWN_MARGIN_PHOTONS = 1.5  # at least: own evidence must beat the neighbourhood by this many photons
_PRUNE = True
"""Skip the photons that cannot count (``_own_best``, ``_within``): the same numbers,
faster; tests/test_photon_reconstruct.py compares both ways."""


class _SortedPhotons:
    """Photon bins sorted by (pixel, bin) under one int64 key, key = pixel * stride + bin.

    The stride leaves a gap of more than one window between pixels, so a window
    search around any key never reaches another pixel's photons.
    """

    def __init__(self, events: PhotonEvents, n_bins: int, window: int):
        self.stride = n_bins + 2 * window + 2
        key = events.pixel.astype(np.int64) * self.stride + events.bin
        self.key = np.sort(key)
        pixel = self.key // self.stride
        self.bin = (self.key - pixel * self.stride).astype(np.int32)
        self.pixel = pixel.astype(np.intp)

    def window(self, pixel: np.ndarray, lo_bin: np.ndarray, hi_bin: np.ndarray):
        """(query, photon) index pairs for photons of ``pixel`` with lo_bin <= bin <= hi_bin."""
        base = pixel.astype(np.int64) * self.stride
        lo = np.searchsorted(self.key, base + lo_bin, side="left")
        hi = np.searchsorted(self.key, base + hi_bin, side="right")
        return _expand_ranges(lo, hi)


def _expand_ranges(lo: np.ndarray, hi: np.ndarray):
    """All pairs (q, j) with lo[q] <= j < hi[q], vectorised."""
    n = np.maximum(hi - lo, 0)
    q = np.repeat(np.arange(lo.size), n)
    start = np.cumsum(n) - n
    j = np.arange(q.size) - np.repeat(start - lo, n)
    return q, j


class _Near(NamedTuple):
    """The photons (pixel, bin) of ``_SortedPhotons`` that can count near some depths,
    in their sorted order: what ``_score_at`` and ``_refine`` read."""

    pixel: np.ndarray
    bin: np.ndarray


def _within(photons, lo: np.ndarray, hi: np.ndarray):
    """The photons with lo[pixel] <= bin <= hi[pixel] (``_Near``; all with ``_PRUNE``
    off). A photon outside adds nothing to a score or an EM step within that range, and
    the others keep their order, so the sums are the same numbers."""
    if not _PRUNE:
        return photons
    keep = (photons.bin >= lo[photons.pixel]) & (photons.bin <= hi[photons.pixel])
    return _Near(photons.pixel[keep], photons.bin[keep])


class _Likelihood:
    """Per-photon log-likelihood gain phi(delta) = log(1 + kappa g(delta)).

    For one pixel with signal s and background b per bin, log(s g(t - tau) + b) =
    log b + log(1 + (s / b) g(t - tau)), so up to a constant the log-likelihood of a
    depth tau is the sum of phi over the pixel's photons, and only photons within a
    few sigma of tau contribute. g is the Gaussian IRF in bins with the rounding
    variance added: sigma_eff^2 = sigma^2 + 1/12.
    """

    def __init__(self, sigma_bins: float, kappa: float):
        self.sigma = float(np.sqrt(sigma_bins**2 + 1.0 / 12.0))
        self.half_window = max(1, int(np.ceil(3.0 * self.sigma)))
        self.kappa = float(kappa)
        deltas = np.arange(-self.half_window, self.half_window + 1)
        self.table = self.phi(deltas)
        self.phi0 = float(self.phi(0.0))

    def g(self, delta):
        return np.exp(-0.5 * (np.asarray(delta) / self.sigma) ** 2) / (
            np.sqrt(2 * np.pi) * self.sigma
        )

    def phi(self, delta):
        return np.log1p(self.kappa * self.g(delta))

    def responsibility(self, delta):
        """Posterior probability that a photon at offset delta is signal."""
        kg = self.kappa * self.g(delta)
        return kg / (1.0 + kg)


def _background_fraction(bins: np.ndarray, n_bins: int) -> float:
    """Fraction of the frame's photons that are background, from the summed histogram.

    Signal occupies few bins, so the median of the summed time histogram estimates
    the background level per bin.
    """
    if bins.size == 0:
        return 0.5
    summed = np.bincount(bins, minlength=n_bins)
    return float(np.clip(np.median(summed) * n_bins / bins.size, 1e-3, 0.999))


def _significant_cluster(background_per_window: np.ndarray, n_windows: float) -> np.ndarray:
    """Smallest photon count c that background alone reaches in fewer than 5% of frames.

    Background photons fall into ~T / window windows per pixel; the expected number
    of windows holding >= c of them is n_windows * P(Poisson(mu) >= c). A pixel's own
    cluster has to be larger than that to be told from chance coincidences.
    """
    mu = np.asarray(background_per_window, dtype=np.float64)
    pmf = np.exp(-mu)
    tail = 1.0 - pmf  # P(X >= 1)
    c = np.ones(mu.shape)
    for k in range(1, 64):
        unresolved = n_windows * tail >= 0.05
        if not unresolved.any():
            break
        c[unresolved] = k + 1
        pmf = pmf * mu / k
        tail = tail - pmf
    return c


def _own_best(photons: _SortedPhotons, like: _Likelihood, n_pixels: int):
    """Each pixel's best own photon bin under the LMF score, and that score.

    Returns (best_bin, best_score), each (n_pixels,); best_bin is -1 at empty pixels.

    A photon with no other photon of its pixel within the window scores its own term
    alone, ``table[w]``; only the others' window pairs are formed (with ``_PRUNE``), in
    the same order, so the scores are the same numbers as forming every photon's pairs.
    """
    w = like.half_window
    k = photons.key.size
    best_bin = np.full(n_pixels, -1, dtype=np.int64)
    best_score = np.zeros(n_pixels)
    if k == 0:
        return best_bin, best_score
    if _PRUNE:
        # keys of two pixels lie more than a window apart (``_SortedPhotons``)
        close = np.diff(photons.key) <= w
        clustered = np.zeros(k, dtype=bool)
        clustered[:-1] |= close
        clustered[1:] |= close
        sub = np.flatnonzero(clustered)
    else:
        sub = np.arange(k)
    score = np.full(k, like.table[w])
    if sub.size:
        key, bins = photons.key[sub], photons.bin[sub]
        lo = np.searchsorted(key, key - w, side="left")
        hi = np.searchsorted(key, key + w, side="right")
        q, j = _expand_ranges(lo, hi)
        score[sub] = np.bincount(q, weights=like.table[bins[j] - bins[q] + w], minlength=sub.size)
    starts = np.flatnonzero(np.r_[True, photons.pixel[1:] != photons.pixel[:-1]])
    seg_len = np.diff(np.r_[starts, score.size])
    seg_max = np.maximum.reduceat(score, starts)
    is_max = np.flatnonzero(score >= np.repeat(seg_max, seg_len))
    first = is_max[np.r_[True, photons.pixel[is_max[1:]] != photons.pixel[is_max[:-1]]]]
    best_bin[photons.pixel[first]] = photons.bin[first]
    best_score[photons.pixel[first]] = score[first]
    return best_bin, best_score


_NO_CENTRE = np.iinfo(np.int32).min // 2  # far from every bin: no photon is "near" it


def _score_at(photons: _SortedPhotons | _Near, like: _Likelihood, centre: np.ndarray) -> np.ndarray:
    """LMF score of every pixel's own photons at its integer bin ``centre`` (n_pixels,);
    pixels with centre < 0 score 0. One pass over the photons."""
    w = like.half_window
    c = np.where(centre >= 0, centre, _NO_CENTRE).astype(np.int32)
    offset = photons.bin - c[photons.pixel] + w
    near = offset.view(np.uint32) <= 2 * w  # 0 <= offset <= 2w in one comparison
    return np.bincount(photons.pixel[near], weights=like.table[offset[near]], minlength=centre.size)


def _refine(photons: _SortedPhotons | _Near, like: _Likelihood, centre: np.ndarray):
    """Sub-bin ML depth by EM around ``centre`` (n_pixels,; < 0 = none):
    tau <- sum(r t) / sum(r) over the pixel's photons within the window, r the signal
    responsibility.

    Returns (tau in bins, NaN where centre < 0; photons in the final window).
    """
    w = like.half_window
    n_pixels = centre.size
    tau = np.where(centre >= 0, centre, np.nan).astype(np.float64)
    t = photons.bin.astype(np.float64)
    n_in = np.zeros(n_pixels, dtype=np.int64)
    for _ in range(_EM_STEPS):
        delta = t - tau[photons.pixel]
        near = np.abs(delta) <= w  # False where tau is NaN
        pix = photons.pixel[near]
        r = like.responsibility(delta[near])
        total = np.bincount(pix, weights=r, minlength=n_pixels)
        moment = np.bincount(pix, weights=r * t[near], minlength=n_pixels)
        n_in = np.bincount(pix, minlength=n_pixels)
        tau = np.where(total > 0, moment / np.maximum(total, 1e-300), tau)
    return tau, n_in


def _shift(image: np.ndarray, dy: int, dx: int, fill):
    """out[y, x] = image[y + dy, x + dx], ``fill`` outside the frame."""
    rows, cols = image.shape[-2:]
    out = np.full_like(image, fill)
    ys, yd = slice(max(dy, 0), rows + min(dy, 0)), slice(max(-dy, 0), rows + min(-dy, 0))
    xs, xd = slice(max(dx, 0), cols + min(dx, 0)), slice(max(-dx, 0), cols + min(-dx, 0))
    out[..., yd, xd] = image[..., ys, xs]
    return out


_OFFSETS_3 = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]


def _padded(image: np.ndarray, fill, r: int) -> np.ndarray:
    """``image`` inside a border of ``r`` pixels of ``fill``, for ``_at``."""
    rows, cols = image.shape
    out = np.full((rows + 2 * r, cols + 2 * r), fill, dtype=image.dtype)
    out[r : r + rows, r : r + cols] = image
    return out


def _at(padded: np.ndarray, r: int, dy: int, dx: int) -> np.ndarray:
    """``_shift(image, dy, dx, fill)`` as a view of ``_padded(image, fill, r)``, |dy|,
    |dx| <= r (no copy)."""
    rows, cols = padded.shape[0] - 2 * r, padded.shape[1] - 2 * r
    return padded[r + dy : r + dy + rows, r + dx : r + dx + cols]


def _pooled_choice(photons, like, best_bin, best_score, shape, margin_photons):
    """Neighbourhood-aided depth bin per pixel (-1 where the pixel has no photon).

    ``margin_photons`` (n_pixels,) is how many single-photon log-likelihoods a pixel's
    own best depth must beat the neighbourhood's choice by to be kept.
    """
    rows, cols = shape
    cand = best_bin.reshape(shape)
    has_photons = cand >= 0
    cand_at = _padded(cand, -1, 2)
    window = np.stack([_at(cand_at, 2, oy, ox) for oy in range(-2, 3) for ox in range(-2, 3)])
    # Every bin scored below is a candidate of the 5x5 window: only photons within a
    # window of the window's lowest to highest candidate can count.
    w, far = like.half_window, np.iinfo(np.int32).max // 4
    lo = np.where(window >= 0, window, far).min(axis=0)
    hi = np.maximum(window.max(axis=0), -far)
    photons = _within(photons, (lo - w).ravel(), np.where(hi >= 0, hi + w, -far).ravel())
    # partial[(oy, ox)][q] = score of q's photons at the candidate of pixel q + o, |o| <= 2.
    partial = {
        (oy, ox): _padded(
            _score_at(photons, like, _at(cand_at, 2, oy, ox).ravel()).reshape(shape), 0.0, 1
        )
        for oy in range(-2, 3)
        for ox in range(-2, 3)
    }
    # pooled[k][p] = score, over the 3x3 window of p, of the candidate of pixel p + o'_k.
    pooled = np.full((len(_OFFSETS_3), rows, cols), -np.inf)
    for k, (cy, cx) in enumerate(_OFFSETS_3):
        total = np.zeros(shape)
        for oy, ox in _OFFSETS_3:
            total += _at(partial[(cy - oy, cx - ox)], 1, oy, ox)
        exists = _at(cand_at, 2, cy, cx) >= 0
        pooled[k][exists] = total[exists]
    k_best = np.argmax(pooled, axis=0)
    choice = np.full(shape, -1, dtype=np.int64)
    for k, (cy, cx) in enumerate(_OFFSETS_3):
        pick = k_best == k
        choice[pick] = _at(cand_at, 2, cy, cx)[pick]
    choice[~has_photons] = -1
    # Own evidence overrides the neighbourhood only by a clear margin.
    own_at_choice = _score_at(photons, like, choice.ravel())
    keep_own = best_score - own_at_choice > margin_photons * like.phi0
    return np.where(keep_own, best_bin, choice.ravel())


def _window_support(photons: _SortedPhotons, half_window: int, centre: np.ndarray, shape):
    """Photons of each pixel's 3x3 window within +-half_window bins of the pixel's
    integer ``centre`` (n_pixels,; < 0 = none, support 0)."""
    rows, cols = shape
    c = centre.reshape(shape)
    support = np.zeros(shape)
    for dy, dx in _OFFSETS_3:
        # the photons of pixel p + o counted at p's centre: shift p's centre onto them
        at = _shift(c, -dy, -dx, -1).ravel()
        offset = photons.bin - np.where(at >= 0, at, _NO_CENTRE).astype(np.int32)[photons.pixel]
        near = (offset + half_window).view(np.uint32) <= 2 * half_window
        counted = np.bincount(photons.pixel[near], minlength=rows * cols).reshape(shape)
        support += _shift(counted, dy, dx, 0)
    return np.where(c >= 0, support, 0.0)


def _median3(image: np.ndarray) -> np.ndarray:
    """3x3 median over finite values (NaN = void is ignored; all-void windows give NaN)."""
    padded = _padded(image, np.nan, 1)
    stack = np.sort(np.stack([_at(padded, 1, dy, dx) for dy, dx in _OFFSETS_3]), axis=0)
    n = np.isfinite(stack).sum(axis=0)  # np.sort puts NaN last
    lo = np.take_along_axis(stack, np.maximum(n - 1, 0)[None] // 2, axis=0)[0]
    hi = np.take_along_axis(stack, (n // 2)[None], axis=0)[0]
    return np.where(n > 0, 0.5 * (lo + hi), np.nan)


def _mean3(image: np.ndarray, weight: np.ndarray) -> np.ndarray:
    image_at, weight_at = (
        _padded(image * weight, 0.0, 1),
        _padded(weight.astype(np.float64), 0.0, 1),
    )
    num = sum(_at(image_at, 1, dy, dx) for dy, dx in _OFFSETS_3)
    den = sum(_at(weight_at, 1, dy, dx) for dy, dx in _OFFSETS_3)
    return np.where(den > 0, num / np.maximum(den, 1e-300), 0.0)


def reconstruct(
    events: PhotonEvents,
    shape: tuple[int, int],
    sensor: SensorParams,
    *,
    method: str = "pooled",
    censor: bool = False,
    weights=None,
    device=None,
) -> Reconstruction:
    """Recover depth, reflectivity and background per pixel from photon events.

    Maximises the Poisson log-likelihood of docs/method.md section 1 with a Gaussian IRF
    (sigma from ``sensor``) and a uniform background; see the module docstring for
    what ``"lmf"`` and ``"pooled"`` do; ``"sspi"`` is the paper's learned network
    (``spl_al.photon.sspi.reconstruct_sspi``).

    Args:
        events: the photons of one frame (``is_signal`` is not read).
        shape: (rows, cols) of the frame.
        sensor: the timing the events were recorded with.
        method: ``"pooled"`` (default), ``"lmf"`` or ``"sspi"``.
        weights: ``"sspi"`` only: folder holding ssunet1.pth and ssunet2.pth
            (default ``$SPL_AL_SSPI_WEIGHTS``); without them one ValueError says
            where to get them.
        device: ``"sspi"`` only: torch device (default CUDA when available, else CPU).
        censor: ML methods only (SSPI has its own denoiser): make a pixel a void when
            the photons of its 3x3 window near its depth are no more than background
            coincidences reach in 5% of frames (``_significant_cluster`` with the
            window's background). Pixels without a return (sky, beyond range) that only
            background photons reached then stay voids instead of taking a random depth:
            the ML counterpart of the background classification of SSPI's denoiser.

    Returns:
        Reconstruction(depth_m, reflectivity, background, counts, valid), each (rows, cols).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}.")
    rows, cols = (int(shape[0]), int(shape[1]))
    if tuple(events.shape) != (rows, cols):
        raise ValueError(f"shape {shape} does not match the events' frame shape {events.shape}.")
    if events.bin.size and (events.bin.min() < 0 or events.bin.max() > sensor.t_max):
        raise ValueError(
            f"events hold time bins outside 0..{sensor.t_max}; "
            "pass the sensor they were recorded with."
        )
    if method == "sspi":
        return reconstruct_sspi(events, (rows, cols), sensor, weights=weights, device=device)
    n_pixels = rows * cols
    background_fraction = _background_fraction(events.bin, sensor.n_bins)
    # kappa = signal / (background per bin) of a pixel, from the frame's split.
    kappa = (1.0 - background_fraction) / background_fraction * sensor.n_bins
    like = _Likelihood(sensor.sigma_bins, kappa)
    photons = _SortedPhotons(events, sensor.n_bins, like.half_window)
    counts = np.bincount(photons.pixel, minlength=n_pixels)

    best_bin, best_score = _own_best(photons, like, n_pixels)
    if method == "lmf":
        centre = best_bin
    else:
        window = 2 * like.half_window + 1
        local_counts = _mean3(counts.reshape(rows, cols).astype(np.float64), np.ones((rows, cols)))
        background_per_window = background_fraction * local_counts.ravel() * window / sensor.n_bins
        margin = np.maximum(
            _OWN_MARGIN_PHOTONS,
            _significant_cluster(background_per_window, sensor.n_bins / window),
        )
        centre = _pooled_choice(photons, like, best_bin, best_score, (rows, cols), margin)
    has = centre >= 0
    # EM moves tau by at most a window a step: only photons within _EM_STEPS windows count
    reach = _EM_STEPS * like.half_window
    near = _within(photons, np.where(has, centre - reach, 1), np.where(has, centre + reach, 0))
    tau, n_in = _refine(near, like, centre)

    depth = sensor.bin_to_depth(tau).reshape(rows, cols)
    n_in = n_in.reshape(rows, cols)
    counts = counts.reshape(rows, cols)
    if method == "pooled":
        weak = has.reshape(rows, cols) & (n_in < 2)
        depth = np.where(weak, _median3(depth), depth)
    if censor:
        window = 2 * like.half_window + 1
        local_counts = _mean3(counts.reshape(rows, cols).astype(np.float64), np.ones((rows, cols)))
        background_9 = 9 * background_fraction * local_counts.ravel() * window / sensor.n_bins
        needed = _significant_cluster(background_9, sensor.n_bins / window).reshape(rows, cols)
        finite = np.isfinite(depth)
        at = np.where(finite, sensor.depth_to_bin(np.where(finite, depth, 0.0)), -1)
        support = _window_support(photons, like.half_window, at.astype(np.int64).ravel(), shape)
        depth = np.where(support >= needed, depth, np.nan)

    # Signal and background split per pixel: photons outside the peak window are
    # background, spread uniformly over the T bins.
    window = 2 * like.half_window + 1
    background = (counts - n_in) * sensor.n_bins / max(sensor.n_bins - window, 1)
    reflectivity = np.clip(n_in - background * window / sensor.n_bins, 0.0, None)
    valid = np.isfinite(depth)
    if method == "pooled":
        reflectivity = _mean3(reflectivity, valid)
        background = _mean3(background, np.ones_like(valid))
    reflectivity = np.where(valid, reflectivity, 0.0)
    return Reconstruction(depth, reflectivity, background, counts, valid)
