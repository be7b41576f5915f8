"""Pictures of the photon engine: a scene under a grid of conditions, and real captures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write
from spl_al.photon.events import PhotonEvents
from spl_al.photon.reconstruct import reconstruct
from spl_al.photon.scene import Condition, PhotonScene
from spl_al.photon.sensor import SensorParams
from spl_al.photon.simulate import simulate_photons
from spl_al.plotting import fit_texts

DEMO_MSPPP = (10.0, 5.0, 2.0)
DEMO_SBR = (5.0, 1.0, 0.2)


def demo_scene(rows: int = 64, cols: int = 64):
    """A tabletop scene: a sphere and a box before a slanted wall, with shading.

    Returns (depth_m, reflectance), each (rows, cols); every pixel is valid.
    """
    yy, xx = np.mgrid[:rows, :cols].astype(np.float64)
    u, v = (xx - cols / 2) / cols, (yy - rows / 2) / rows
    depth = 8.0 + 2.0 * u  # wall, slanted left to right
    refl = np.full((rows, cols), 0.6)
    r2 = (u + 0.18) ** 2 + (v - 0.05) ** 2
    sphere = r2 < 0.22**2
    depth[sphere] = 4.0 - 1.2 * np.sqrt(np.clip(0.22**2 - r2[sphere], 0, None)) / 0.22
    refl[sphere] = 0.9 * np.sqrt(np.clip(1 - r2[sphere] / 0.22**2, 0, None)) + 0.1
    box = (np.abs(u - 0.25) < 0.12) & (np.abs(v + 0.1) < 0.25)
    depth[box] = 5.5
    refl[box] = 0.3
    return depth, refl


def _imshow_depth(ax, depth, vmin, vmax, title):
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("viridis").with_extremes(bad="black")  # voids black
    ax.imshow(np.ma.masked_invalid(depth), cmap=cmap, vmin=vmin, vmax=vmax)
    ax.set_title(title, fontsize=8)
    ax.set_xticks([])
    ax.set_yticks([])


def render_condition_grid(
    path, sensor: SensorParams | None = None, *, seed: int = 0, method: str = "pooled", weights=None
):
    """Write a PNG: clean depth and one pixel's histogram, then the reconstructed depth
    for every (msppp, sbr) in DEMO_MSPPP x DEMO_SBR. Voids are black."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sensor = sensor or SensorParams.tabletop()
    depth, refl = demo_scene()
    rng = np.random.default_rng(seed)
    vmin, vmax = float(depth.min()), float(depth.max())
    fig, axes = plt.subplots(
        len(DEMO_MSPPP),
        len(DEMO_SBR) + 2,
        figsize=(2.2 * (len(DEMO_SBR) + 2), 2.3 * len(DEMO_MSPPP)),
        layout="tight",
    )
    probe = (20, 24)  # a pixel on the sphere
    for i, msppp in enumerate(DEMO_MSPPP):
        for j, sbr in enumerate(DEMO_SBR):
            ev = simulate_photons(
                PhotonScene(depth, reflectance=refl), Condition(msppp, sbr, sensor), rng
            )
            rec = reconstruct(ev, depth.shape, sensor, method=method, weights=weights)
            voids = 100 * np.mean(~rec.valid)
            err_cm = 100 * np.nanmedian(np.abs(rec.depth_m - depth))
            _imshow_depth(
                axes[i, j + 2],
                rec.depth_m,
                vmin,
                vmax,
                f"MSPPP {msppp:g}, SBR {sbr:g}\nvoids {voids:.0f}%, med. err {err_cm:.1f} cm",
            )
            if j == len(DEMO_SBR) - 1:  # the hardest condition of this row
                flat = probe[0] * depth.shape[1] + probe[1]
                t_obs = sensor.depth_to_bin(depth[probe])
                bins = ev.bin[ev.pixel == flat]
                ax = axes[i, 1]
                ax.hist(bins, bins=np.arange(0, sensor.n_bins + 16, 16), color="grey")
                ax.axvline(t_obs, color="red", lw=0.8)
                ax.set_title(
                    f"pixel {probe}: {bins.size} photons\nMSPPP {msppp:g}, SBR {sbr:g}", fontsize=8
                )
                ax.set_xlabel("time bin", fontsize=7)
                ax.tick_params(labelsize=6)
        _imshow_depth(axes[i, 0], depth, vmin, vmax, "clean depth (m)")
    fig.suptitle(f"Photon simulation and '{method}' reconstruction (voids black)", fontsize=10)
    _save(fig, path)


def depth_agreement(depth_a_m: np.ndarray, depth_b_m: np.ndarray) -> dict:
    """How two depth images agree on the pixels both reconstruct (finite in both).

    Returns n_both, median_abs_m = median |a - b|, and within_10cm / within_30cm,
    the fractions of those pixels with |a - b| <= 0.1 m / 0.3 m.
    """
    both = np.isfinite(depth_a_m) & np.isfinite(depth_b_m)
    diff = np.abs(depth_a_m - depth_b_m)[both]
    if diff.size == 0:
        return {"n_both": 0, "median_abs_m": np.nan, "within_10cm": np.nan, "within_30cm": np.nan}
    return {
        "n_both": int(diff.size),
        "median_abs_m": float(np.median(diff)),
        "within_10cm": float(np.mean(diff <= 0.1)),
        "within_30cm": float(np.mean(diff <= 0.3)),
    }


def render_real_capture(
    events: PhotonEvents,
    sensor: SensorParams,
    path,
    *,
    title: str = "",
    methods=("lmf", "pooled"),
    weights=None,
    depth_offset_m: float = 0.0,
):
    """Write a PNG of a real capture: summed histogram, photon counts, and depth by each
    of ``methods`` (``"sspi"`` needs ``weights``, see ``spl_al.photon.sspi``).

    ``depth_offset_m`` is the depth of the range gate's start (bin 0), added to every
    depth shown; the returned reconstructions keep depths from bin 0.

    Returns {method: Reconstruction}; with both ``"sspi"`` and ``"pooled"`` the SSPI
    panel's title carries their ``depth_agreement``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        1, 2 + len(methods), figsize=(3.5 * (2 + len(methods)), 3.4), layout="tight"
    )
    summed = np.bincount(events.bin, minlength=sensor.n_bins)
    axes[0].plot(sensor.bin_to_depth(np.arange(sensor.n_bins)) + depth_offset_m, summed, lw=0.6)
    axes[0].set_xlabel("depth (m)")
    axes[0].set_ylabel("photons (all pixels)")
    axes[0].set_title("summed histogram", fontsize=9)
    im = axes[1].imshow(events.counts(), cmap="magma")
    axes[1].set_title("photons per pixel", fontsize=9)
    fig.colorbar(im, ax=axes[1], fraction=0.046)
    recs = {
        m: reconstruct(events, events.shape, sensor, method=m, weights=weights) for m in methods
    }
    lo, hi = np.nanpercentile(recs[methods[-1]].depth_m, [2, 98]) + depth_offset_m
    for ax, method in zip(axes[2:], methods, strict=True):
        label = f"depth, {method} (m)"
        if method == "sspi" and "pooled" in recs:
            a = depth_agreement(recs["sspi"].depth_m, recs["pooled"].depth_m)
            label += (
                f"\nvs pooled: median |diff| {100 * a['median_abs_m']:.1f} cm, "
                f"{100 * a['within_10cm']:.0f}% <= 10 cm"
            )
        _imshow_depth(ax, recs[method].depth_m + depth_offset_m, lo, hi, label)
        fig.colorbar(ax.images[0], ax=ax, fraction=0.046)
    fig.suptitle(title, fontsize=10)
    _save(fig, path)
    return recs


def _save(fig, path):
    import matplotlib.pyplot as plt

    fit_texts(fig)  # laid out again (tight) at every draw, the wrapped titles too
    fmt = Path(path).suffix.lstrip(".") or "png"
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format=fmt))
    plt.close(fig)
