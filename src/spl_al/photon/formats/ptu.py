"""PicoQuant PTU image files (T3 records with line and frame markers), via ``ptufile``.

``ptufile`` decodes the time-tagged records into an image histogram (frames x
lines x pixels x channels x TCSPC bins); spl-al sums the frames (and the channels,
unless one is chosen) and keeps each pixel's delay-time histogram as photon
events. The bin width is the file's TCSPC resolution. Decoding goes a band of
lines at a time, so memory stays near one band's histogram.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.photon.capture import Capture
from spl_al.photon.events import PhotonEvents
from spl_al.photon.formats.base import CaptureFormat, FileOptions, register

_BAND_BYTES = 256 << 20  # decode at most ~256 MB of histogram at once


def read_ptu(path: Path, *, channel: int | None = None) -> Capture:
    """Capture of a PTU image file; ``channel`` picks one detector channel (default: all)."""
    import ptufile

    try:
        ptu = ptufile.PtuFile(path)
    except Exception as exc:  # ptufile raises its own and OS errors for bad files
        raise ValueError(f"{path}: not a readable PicoQuant PTU file ({exc}).") from None
    with ptu:
        if not ptu.is_image:
            raise ValueError(
                f"{path}: a PTU {ptu.measurement_mode} measurement without image (line and "
                "frame) markers; only T3 image scans are frames of pixels."
            )
        sizes = dict(zip(ptu.dims, ptu.shape, strict=True))
        n_channels = sizes.get("C", 1)
        if channel is not None and not 0 <= channel < n_channels:
            raise ValueError(
                f"{path}: channel {channel} does not exist; the file has {n_channels} "
                f"channel(s), 0..{n_channels - 1}."
            )
        rows, cols, n_bins = sizes["Y"], sizes["X"], sizes["H"]
        band = max(1, _BAND_BYTES // max(1, cols * n_bins * 4))
        pixels, bins, counts = [], [], []
        for y0 in range(0, rows, band):
            y1 = min(rows, y0 + band)
            selection = [slice(y0, y1) if d == "Y" else slice(None) for d in ptu.dims]
            try:
                hist = ptu.decode_image(
                    selection,
                    frame=-1,
                    channel=-1 if channel is None else channel,
                    dtime=0,
                    dtype=np.uint32,
                    keepdims=False,
                )
            except Exception as exc:  # truncated or corrupt records
                raise ValueError(f"{path}: its photon records cannot be decoded ({exc}).") from None
            hist = hist.reshape(y1 - y0, cols, -1)
            r, c, t = np.nonzero(hist)
            pixels.append((r + y0) * cols + c)
            bins.append(t)
            counts.append(hist[r, c, t])
        n_bins = hist.shape[-1]
        n_frames = sizes.get("T")
        resolution_s = float(ptu.tcspc_resolution)
    reps = np.concatenate(counts).astype(np.int64)
    pixel = np.repeat(np.concatenate(pixels).astype(np.int32), reps)
    events = PhotonEvents(
        pixel=pixel,
        bin=np.repeat(np.concatenate(bins).astype(np.int32), reps),
        is_signal=np.zeros(pixel.size, dtype=bool),
        shape=(int(rows), int(cols)),
    )
    return Capture(
        events=events,
        bin_width_s=resolution_s,
        n_bins=int(n_bins),
        n_frames=None if n_frames is None else int(n_frames),
        format="ptu",
        path=str(path),
    )


def _read(path: Path, options: FileOptions, variables: dict | None) -> Capture:
    return read_ptu(path, channel=options.channel)


register(
    CaptureFormat(
        name="ptu",
        suffixes=(".ptu",),
        read=_read,
        describe="a PicoQuant .ptu image",
        files=".ptu",
        any_suffix=True,
    )
)
