"""The sensor and the imaging conditions of a capture, from its photons alone.

Two estimators for captures whose files do not say everything (issue 24, section 2):

- ``estimate_pulse_sigma``: the width of the instrument response (IRF) in time bins.
  Two photons of the same pixel that are both laser returns lie sigma * sqrt(2) apart
  (rms); a background photon lies anywhere in the gate. So the lags |t_i - t_j| between the
  photons of each pixel, pooled over the frame, are a peak at 0 of the pulse's shape
  on a smooth floor, and the peak's width is the IRF's. Nothing has to find a pixel's
  return first: no centring bias, no depth estimate, no threshold. Counts of pairs per
  lag come from searchsorted over the photons sorted by (pixel, bin), so the cost
  grows with the photons, not with the bins or the pairs.
- ``estimate_conditions``: MSPPP and SBR of one frame, from the background level of
  the summed time histograms of tiles of the frame (or from a reconstruction's
  per-pixel split).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr, pdtr

from spl_al.photon.events import PhotonEvents, Reconstruction

_MAX_PHOTONS = 400_000  # above this, a random subset of pixels is used (pairs stay whole)
_WINDOW_SIGMAS = 5.0  # the fine fit sees lags up to this many lag standard deviations
_FINE_CELLS = 96  # at most this many lag cells in the fine fit
_GROUPS = 64  # pixel groups the bootstrap resamples
_BOOTSTRAP = 64  # bootstrap replicates for the standard error
_MIN_LR = 25.0  # 2 x log-likelihood ratio of pulse + floor over floor alone / pairs per photon
_QUANTISATION = 1.0 / 12.0  # variance of rounding to whole bins, bins^2


@dataclass(frozen=True)
class PulseEstimate:
    """The instrument response width estimated from a capture's photons.

    Attributes:
        sigma_bins: standard deviation sigma of the Gaussian IRF, in time bins, with the
            variance of rounding to whole bins removed (sigma^2 = var(a return's bin) - 1/12
            about its true time), so that
            ``SensorParams(pulse_sigma_s=sigma_bins * bin_width_s)`` simulates captures
            like this one.
        stderr_bins: standard error of ``sigma_bins``, in bins (bootstrap over pixels).
        n_pixels: pixels whose photons took part (at least one pair within the fit window).
        n_photons: photons that took part (at least one partner within the fit window).
    """

    sigma_bins: float
    stderr_bins: float
    n_pixels: int
    n_photons: int

    def sigma_s(self, bin_width_s: float) -> float:
        """The IRF standard deviation in seconds, sigma_bins * bin_width_s."""
        return float(self.sigma_bins * bin_width_s)


@dataclass(frozen=True)
class FrameConditions:
    """Imaging conditions of one frame, estimated from its photons.

    Attributes:
        msppp: signal photons per pixel, signal_photons / (rows * cols): the mean over
            ALL pixels of the frame. Algorithm 1's msppp is a mean over the pixels with a
            return; for a frame whose pixels all return the two agree, otherwise this one
            is msppp times the fraction of pixels with a return.
        sbr: signal_photons / background_photons over the whole gate (``inf`` when the
            frame holds no background photon).
        signal_photons: estimated laser-return photons of the frame.
        background_photons: estimated background photons of the frame, over all bins.
        background_per_bin: background photons of the whole frame per time bin,
            background_photons / n_bins.
    """

    msppp: float
    sbr: float
    signal_photons: float
    background_photons: float
    background_per_bin: float


# ---------------------------------------------------------------------------------------
# The pulse width
# ---------------------------------------------------------------------------------------


def _check_events(events: PhotonEvents, n_bins: int, what: str) -> int:
    if isinstance(n_bins, bool) or int(n_bins) != n_bins or n_bins < 2:
        raise ValueError(f"{what}: n_bins must be an integer >= 2, got {n_bins!r}.")
    n_bins = int(n_bins)
    if len(events) and (int(events.bin.min()) < 0 or int(events.bin.max()) >= n_bins):
        raise ValueError(
            f"{what}: the events hold time bins {int(events.bin.min())}..."
            f"{int(events.bin.max())}, outside 0..{n_bins - 1} of the n_bins = {n_bins} given."
        )
    return n_bins


class _LagModel:
    """Lags |t_i - t_j| of photon pairs of one pixel, in cells [lo, hi] of whole lags.

    Three shapes, each normalised over lags 0..L:

    - pulse: both photons signal. With the arrival times continuous and the bins their
      rounding, the lag of two returns has variance 2 (sigma^2 + 1/12). It is modelled as
      a Gaussian of variance 2 s^2 integrated over each lag's unit cell, whose variance is
      2 s^2 + 1/12 (Sheppard). So P(|lag| <= k) = 2 Phi((k + 1/2) /
      (sqrt(2) s)) - 1, with 2 s^2 + 1/12 = 2 (sigma^2 + 1/12): sigma^2 = s^2 - 1/24.
    - triangle: both photons uniform over the T bins: P(lag = k) ~ (T - k) (twice for k > 0).
    - flat: one photon signal, one uniform: P(lag = k) ~ 1 (twice for k > 0), as long as
      the return is not within L of the ends of the gate.
    """

    def __init__(self, lo: np.ndarray, hi: np.ndarray, n_bins: int):
        self.lo = lo.astype(np.float64)
        self.hi = hi.astype(np.float64)
        self.window = float(hi[-1])
        t = float(n_bins)
        self.triangle = self._norm(self._cum_triangle(self.hi, t) - self._cum_triangle(lo - 1, t))
        self.flat = self._norm(self._cum_flat(self.hi) - self._cum_flat(self.lo - 1))

    @staticmethod
    def _norm(p):
        return p / p.sum()

    @staticmethod
    def _cum_triangle(k, t):
        k = np.asarray(k, dtype=np.float64)
        return np.where(k < 0, 0.0, t + 2.0 * (k * t - k * (k + 1) / 2))

    @staticmethod
    def _cum_flat(k):
        k = np.asarray(k, dtype=np.float64)
        return np.where(k < 0, 0.0, 1.0 + 2.0 * k)

    def pulse(self, s) -> np.ndarray:
        """Cell probabilities of the pulse shape, (len(s), cells) for s of any shape."""
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))[:, None] * np.sqrt(2.0)
        cdf_hi = 2.0 * ndtr((self.hi + 0.5) / s) - 1.0
        cdf_lo = np.where(self.lo > 0, 2.0 * ndtr((self.lo - 0.5) / s) - 1.0, 0.0)
        total = 2.0 * ndtr((self.window + 0.5) / s) - 1.0
        return (cdf_hi - cdf_lo) / np.maximum(total, 1e-300)


def _em_weights(shapes: np.ndarray, counts: np.ndarray, steps: int = 400) -> np.ndarray:
    """ML mixture weights for fixed component shapes (..., k, cells): concave, so EM."""
    n = max(float(counts.sum()), 1e-300)
    w = np.full(shapes.shape[:-1], 1.0 / shapes.shape[-2])
    for _ in range(steps):
        mix = np.einsum("...k,...kc->...c", w, shapes)
        w = w * np.einsum("...kc,...c->...k", shapes, counts / np.maximum(mix, 1e-300)) / n
    return w


def _loglik(shapes: np.ndarray, counts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Log-likelihood of cell counts under the mixture w . shapes (over the last axis)."""
    mix = np.einsum("...k,...kc->...c", w, shapes)
    return (counts * np.log(np.maximum(mix, 1e-300))).sum(axis=-1)


def _profile(pulse: np.ndarray, floor: np.ndarray, counts: np.ndarray):
    """Profile log-likelihood of pulse fraction pi, for each s of a grid and count set.

    pulse: (grid, cells) pulse shapes; floor: (cells,); counts: (sets, cells). For fixed
    s, L(pi) = sum_c n_c log(pi p_c + (1 - pi) f_c) is concave in pi, so its maximum on
    [0, 1] is found by bisection on the (decreasing) derivative. Returns (sets, grid)
    log-likelihoods and fractions.
    """
    p = pulse[None]  # (1, grid, cells)
    f = floor[None, None]
    n = counts[:, None, :]  # (sets, 1, cells)
    lo = np.zeros(counts.shape[:1] + pulse.shape[:1])
    hi = np.ones_like(lo)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        mix = mid[..., None] * p + (1.0 - mid[..., None]) * f
        slope = (n * (p - f) / np.maximum(mix, 1e-300)).sum(axis=-1)
        up = slope > 0
        lo = np.where(up, mid, lo)
        hi = np.where(up, hi, mid)
    frac = 0.5 * (lo + hi)
    mix = frac[..., None] * p + (1.0 - frac[..., None]) * f
    return (n * np.log(np.maximum(mix, 1e-300))).sum(axis=-1), frac


def _peak(log_s: np.ndarray, ll: np.ndarray) -> np.ndarray:
    """Arg-max of each row of ll over the even grid log_s, refined by a parabola through
    the best point and its neighbours (the best point itself at the grid's ends)."""
    i = np.argmax(ll, axis=-1)
    j = np.clip(i, 1, log_s.size - 2)
    rows = np.arange(ll.shape[0])
    y0, y1, y2 = ll[rows, j - 1], ll[rows, j], ll[rows, j + 1]
    curv = y0 - 2.0 * y1 + y2
    step = log_s[1] - log_s[0]
    shift = np.where(curv < 0, 0.5 * (y0 - y2) / np.where(curv < 0, curv, -1.0), 0.0)
    inside = (i >= 1) & (i <= log_s.size - 2)
    return np.where(inside, log_s[j] + np.clip(shift, -1.0, 1.0) * step, log_s[i])


class _Pairs:
    """Photons of the pixels holding two or more, sorted by key = pixel * stride + bin.

    The stride exceeds twice the gate, so a lag search from any photon never reaches the
    next pixel: the photons j > i with key_j <= key_i + L are exactly the later photons
    of i's pixel within lag L, and each unordered pair is counted once.
    """

    def __init__(self, events: PhotonEvents, n_bins: int, rng: np.random.Generator):
        pixel = events.pixel.astype(np.int64)
        bins = events.bin.astype(np.int64)
        per_pixel = np.bincount(pixel) if pixel.size else np.zeros(0, np.int64)
        keep = per_pixel[pixel] >= 2
        pixel, bins = pixel[keep], bins[keep]
        n_pix = per_pixel.size
        if pixel.size > _MAX_PHOTONS:  # keep whole pixels: their pairs are the data
            chosen = rng.random(n_pix) < _MAX_PHOTONS / pixel.size
            pixel, bins = pixel[chosen[pixel]], bins[chosen[pixel]]
        self.stride = 2 * n_bins + 1
        self.key = np.sort(pixel * self.stride + bins)
        self.pixel = self.key // self.stride
        self.group = rng.integers(0, _GROUPS, size=max(n_pix, 1))[self.pixel]
        self.rank = np.arange(1, self.key.size + 1)

    @property
    def size(self) -> int:
        return int(self.key.size)

    def later_within(self, lag: int) -> np.ndarray:
        """Per photon, the later photons of its pixel at a lag <= ``lag``."""
        return np.searchsorted(self.key, self.key + lag, side="right") - self.rank

    def cell_counts(self, hi: np.ndarray) -> np.ndarray:
        """(groups, cells) pairs per pixel group with lag in cell j = (hi[j-1], hi[j]]."""
        cum = np.stack(
            [
                np.bincount(self.group, weights=self.later_within(int(h)), minlength=_GROUPS)
                for h in hi
            ],
            axis=1,
        )
        return np.diff(cum, axis=1, prepend=0.0)

    def taking_part(self, lag: int) -> tuple[int, int]:
        """(pixels, photons) with at least one partner within ``lag``."""
        later = self.later_within(lag) > 0
        earlier = self.rank - 1 - np.searchsorted(self.key, self.key - lag, side="left") > 0
        part = later | earlier
        return int(np.unique(self.pixel[part]).size), int(part.sum())


def _log_cells(window: int) -> tuple[np.ndarray, np.ndarray]:
    """Lag cells over 0..window: single lags up to 8, then widths growing by 1.25."""
    hi = np.unique(
        np.minimum(np.r_[np.arange(8), np.rint(8 * 1.25 ** np.arange(80))], window).astype(np.int64)
    )
    hi = hi[hi <= window]
    if hi[-1] != window:
        hi = np.r_[hi, window]
    return np.r_[0, hi[:-1] + 1], hi


def _even_cells(window: int) -> tuple[np.ndarray, np.ndarray]:
    """Lag cells over 0..window, single lags or at most ``_FINE_CELLS`` equal cells."""
    width = int(np.ceil((window + 1) / _FINE_CELLS))
    hi = np.r_[np.arange(width - 1, window, width), window]
    hi = np.unique(hi)
    return np.r_[0, hi[:-1] + 1], hi


def _lag_sd(s: float) -> float:
    """Standard deviation of the pulse's lag in bins, sqrt(2 s^2 + 1/12)."""
    return float(np.sqrt(2.0 * s * s + _QUANTISATION))


def estimate_pulse_sigma(
    events: PhotonEvents, n_bins: int, *, min_photons: int = 100, seed: int = 0
) -> PulseEstimate:
    """Estimate the IRF standard deviation, in bins, from the photons of one capture.

    Pooled over the frame, the lag |t_i - t_j| of two photons of one pixel is, for two
    returns of a Gaussian pulse, the difference of two rounded Gaussians: variance
    2 (sigma^2 + 1/12) bins^2; for a background photon it is spread over the gate. So the
    pairs' lag histogram is fitted by maximum likelihood with a mixture of the pulse's
    lag distribution and two floors (both photons uniform: P(k) ~ T - k; one of them
    uniform: flat), first over lags up to T / 4 in log-spaced cells for a coarse
    sigma, then twice over lags up to 5 lag standard deviations (``_LagModel``). The
    standard error is the spread of 64 bootstrap fits, resampling 64 groups of pixels.
    Only pairs within a pixel are used, so scenes at any depths, and any number of
    bins (sigma from below 1 bin to hundreds), cost the same: a searchsorted over the
    sorted photons per lag cell. Above 400,000 photons a random subset of pixels is used.

    Args:
        events: the photons of one frame (``is_signal`` is not read).
        n_bins: bins T of the gate; every event's bin must lie in 0..T-1.
        min_photons: the fewest photons, in pixels holding two or more, to try with.
        seed: seeds the pixel subset, the bootstrap groups and the resamples.

    Returns:
        PulseEstimate (sigma_bins, stderr_bins, n_pixels, n_photons).

    Raises:
        ValueError: bins outside the gate, fewer than ``min_photons`` photons in pixels
            with two or more, or no pulse standing out of the background.
    """
    n_bins = _check_events(events, n_bins, "estimate_pulse_sigma")
    rng = np.random.default_rng(seed)
    pairs = _Pairs(events, n_bins, rng)
    if pairs.size < min_photons:
        raise ValueError(
            f"estimate_pulse_sigma: found {pairs.size} photons in pixels holding two or more "
            f"(of {len(events)} photons), needs at least {min_photons} to estimate the pulse."
        )
    coarse_window = max(2, min(n_bins - 1, n_bins // 4))
    lo, hi = _log_cells(coarse_window)
    model = _LagModel(lo, hi, n_bins)
    counts = pairs.cell_counts(hi).sum(axis=0)
    log_s = np.linspace(np.log(0.21), np.log(max(coarse_window / 4.0, 0.6)), 64)
    shapes = np.concatenate(
        [
            model.pulse(np.exp(log_s))[:, None],
            np.broadcast_to(np.stack([model.triangle, model.flat]), (log_s.size, 2, lo.size)),
        ],
        axis=1,
    )  # (grid, 3, cells)
    w = _em_weights(shapes, counts)
    ll = _loglik(shapes, counts, w)
    best = int(np.argmax(ll))
    floor_shapes = shapes[0, 1:]
    ll_floor = float(_loglik(floor_shapes, counts, _em_weights(floor_shapes, counts)))
    # Pairs share photons, so the pair counts scatter more than independent draws would:
    # the likelihood ratio is divided by the pairs per photon (a design effect).
    evidence = 2.0 * (ll[best] - ll_floor) / max(counts.sum() / pairs.size, 1.0)
    if evidence < _MIN_LR or best >= log_s.size - 4 or w[best, 0] * counts.sum() < 10:
        raise ValueError(
            f"estimate_pulse_sigma: no pulse stands out of the background in the "
            f"{int(counts.sum())} photon pairs of {pairs.size} photons (evidence "
            f"{evidence:.1f}, needs {_MIN_LR:.0f}, for a pulse narrower than "
            f"{np.exp(log_s[-4]):.0f} bins); give the pulse width instead."
        )
    s = float(np.exp(_peak(log_s, ll[None])[0]))
    both_floors = w[best, 1] + w[best, 2]
    share = w[best, 1] / both_floors if both_floors > 0 else 0.5  # triangle's share
    for spread, points in ((2.0, 41), (1.5, 61)):
        window = int(min(coarse_window, max(4, np.ceil(_WINDOW_SIGMAS * _lag_sd(s)))))
        lo, hi = _even_cells(window)
        model = _LagModel(lo, hi, n_bins)
        floor = share * model.triangle + (1.0 - share) * model.flat
        cells = pairs.cell_counts(hi)
        log_s = np.log(s) + np.linspace(-np.log(spread), np.log(spread), points)
        pulse = model.pulse(np.exp(log_s))
        ll, _ = _profile(pulse, floor, cells.sum(axis=0)[None])
        s = float(np.exp(_peak(log_s, ll)[0]))
    resample = rng.multinomial(_GROUPS, np.full(_GROUPS, 1.0 / _GROUPS), size=_BOOTSTRAP)
    ll, _ = _profile(pulse, floor, resample @ cells)
    replicates = np.exp(_peak(log_s, ll))
    sigma = _sigma_from_s(s)
    stderr = float(np.std([_sigma_from_s(r) for r in replicates], ddof=1))
    n_pixels, n_photons = pairs.taking_part(window)
    return PulseEstimate(sigma, stderr, n_pixels, n_photons)


def _sigma_from_s(s: float) -> float:
    """sigma = sqrt(s^2 - 1/24), the model's s (``_LagModel``) back to the IRF's sigma."""
    return float(np.sqrt(max(s * s - _QUANTISATION / 2.0, 0.0)))


# ---------------------------------------------------------------------------------------
# MSPPP and SBR of a frame
# ---------------------------------------------------------------------------------------

_MIN_PER_CELL = 32.0  # background photons per cell of the summed histogram, at least
_TRUNCATE_Z = 1.5  # cells above level + z sqrt(level) are left out of the level's fit
_TILE_BACKGROUND = 2048.0  # background photons per tile, about
_MIN_TILE = 8  # pixels on a tile's side, at least


def _truncated_poisson_means(cells: np.ndarray, cut: np.ndarray) -> np.ndarray:
    """Per row of ``cells``, the ML Poisson mean of its cells <= cut (the rest left out).

    E[X | X <= c] = lam P(X <= c - 1) / P(X <= c) rises with lam, so the ML equation
    E[X | X <= c] = mean of the kept cells is solved by bisection on log lam.
    """
    c = np.floor(cut)[:, None]
    kept = cells <= c
    n_kept = kept.sum(axis=1)
    target = np.where(kept, cells, 0.0).sum(axis=1) / np.maximum(n_kept, 1)
    c = c[:, 0]
    lo = np.log(np.maximum(target, 1e-6))
    hi = np.log(np.maximum(4.0 * c, 1.0)) + 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lam = np.exp(mid)
        mean = lam * pdtr(c - 1, lam) / np.maximum(pdtr(c, lam), 1e-300)
        below = mean < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    out = np.where(target > 0, np.exp(0.5 * (lo + hi)), 0.0)
    return np.where(n_kept == 0, cells.mean(axis=1), out)


def _background_levels(
    tile: np.ndarray, bins: np.ndarray, n_tiles: int, n_bins: int, expected: float
) -> np.ndarray:
    """Background photons per bin of each tile, from the tiles' summed time histograms.

    Background is uniform over the gate; signal only adds photons, to the bins of the
    depths in the tile. The cells of a tile's histogram (runs of m bins, m such that a
    cell expects at least ``_MIN_PER_CELL`` background photons) that hold no signal are
    Poisson(lam m); those at most lam m + z sqrt(lam m) are fitted as a Poisson truncated
    there (``_truncated_poisson_means``), from the lower quartile, until the cut settles.
    Signal cells mostly sit above the cut. ``expected``: an upper bound on the background
    photons per tile, for the first cell width.
    """
    width = int(min(max(np.ceil(_MIN_PER_CELL * n_bins / max(expected, 1.0)), 1), n_bins // 8))
    width = max(width, 1)
    for _ in range(4):
        n_cells = n_bins // width
        flat = tile * (n_cells + 1) + np.minimum(bins // width, n_cells)
        cells = np.bincount(flat, minlength=n_tiles * (n_cells + 1)).reshape(n_tiles, -1)
        cells = cells[:, :n_cells].astype(np.float64)
        level = np.percentile(cells, 25, axis=1)
        cuts, previous = [None, None], level
        for _ in range(50):
            cut = np.floor(level + _TRUNCATE_Z * np.sqrt(level))
            if np.array_equal(cut, cuts[-1]):
                break  # the same cells kept: a fixed point
            if np.array_equal(cut, cuts[-2]):
                level = 0.5 * (level + previous)  # the cut flips between two integers
                break
            previous = level
            level = _truncated_poisson_means(cells, cut)
            cuts = [cuts[-1], cut]
        wanted = int(np.ceil(_MIN_PER_CELL * width / max(float(np.median(level)), 1e-12)))
        if wanted <= width or width >= n_bins // 8:
            break
        width = int(min(wanted, max(n_bins // 8, 1)))
    return level / width


def _tiles(shape: tuple[int, int], pixel: np.ndarray, per_side: int) -> np.ndarray:
    """Tile index of each photon's pixel, the frame cut into per_side x per_side tiles."""
    rows, cols = shape
    r, c = pixel // cols, pixel % cols
    return (r * per_side // rows) * per_side + (c * per_side // cols)


def estimate_conditions(
    events: PhotonEvents, n_bins: int, reconstruction: Reconstruction | None = None
) -> FrameConditions:
    """Estimate the signal photons per pixel (MSPPP) and the SBR of one frame.

    Background photons fall uniformly over the T bins of the gate, so the frame holds

        background_photons = b * T,   signal_photons = K - b * T,
        msppp = signal_photons / (rows * cols),   sbr = signal_photons / background_photons

    with K the frame's photons and b its background photons per bin. b is the sum over
    tiles of the frame (about 2048 background photons each, at least 8 x 8 pixels) of
    the background level of each tile's summed time histogram (``_background_levels``):
    within a tile the depths span fewer bins than over the frame, so a ground plane
    running through the range still leaves most of a tile's bins to the background.
    The estimate needs some bins of each tile free of returns; when the returns cover
    nearly the whole gate (a gate cut tightly around the scene), signal is taken for
    background and the SBR comes out low.

    Args:
        events: the photons of one frame (``is_signal`` is not read).
        n_bins: bins T of the gate; every event's bin must lie in 0..T-1.
        reconstruction: optional. When given, the split is the reconstruction's own
            instead: signal = sum of ``reflectivity``, background = sum of ``background``
            (the photons near and away from each pixel's depth). That follows the
            reconstruction's mistakes, so it is the worse estimate on steep scenes or
            few photons (a ground plane at 2 signal photons per pixel: SBR half the
            truth where the histogram is within 10%); leave it out unless the split has
            to agree with the reconstruction's intensity image.

    Returns:
        FrameConditions(msppp, sbr, signal_photons, background_photons, background_per_bin).

    Raises:
        ValueError: the frame holds no photon, bins lie outside the gate, or the
            reconstruction's shape is not the frame's.
    """
    n_bins = _check_events(events, n_bins, "estimate_conditions")
    rows, cols = (int(events.shape[0]), int(events.shape[1]))
    if len(events) == 0:
        raise ValueError(
            "estimate_conditions: the frame holds no photon, so neither its signal nor its "
            "background can be estimated."
        )
    total = float(len(events))
    if reconstruction is not None:
        if np.shape(reconstruction.reflectivity) != (rows, cols):
            raise ValueError(
                f"estimate_conditions: the reconstruction is "
                f"{np.shape(reconstruction.reflectivity)}, the frame {(rows, cols)}."
            )
        background = float(np.sum(reconstruction.background))
        signal = float(np.sum(reconstruction.reflectivity))
    else:
        bins = events.bin.astype(np.int64)
        frame = float(_background_levels(np.zeros_like(bins), bins, 1, n_bins, total)[0])
        side = int(np.sqrt(max(frame * n_bins / _TILE_BACKGROUND, 1.0)))
        side = max(1, min(side, rows // _MIN_TILE, cols // _MIN_TILE))
        if side > 1:
            tile = _tiles((rows, cols), events.pixel.astype(np.int64), side)
            frame = float(np.sum(_background_levels(tile, bins, side**2, n_bins, total / side**2)))
        background = min(frame * n_bins, total)
        signal = total - background
    sbr = signal / background if background > 0 else np.inf
    return FrameConditions(
        msppp=signal / (rows * cols),
        sbr=float(sbr),
        signal_photons=signal,
        background_photons=background,
        background_per_bin=background / n_bins,
    )
