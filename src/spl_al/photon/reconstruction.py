"""The result type of every reconstruction method (``spl_al.photon.reconstruct``).

Its own module so that the methods (``reconstruct`` and ``spl_al.photon.sspi``) both
import it from below instead of from each other.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Reconstruction(NamedTuple):
    """What ``reconstruct`` recovers; every field is a (rows, cols) image.

    depth_m: depth in metres, NaN at voids (pixels without a usable photon).
    reflectivity: estimated signal photons per pixel (the intensity image); 0 at voids.
    background: estimated background photons per pixel over all T bins.
    counts: photons detected per pixel (int64).
    valid: bool, True where depth_m is finite.
    """

    depth_m: np.ndarray
    reflectivity: np.ndarray
    background: np.ndarray
    counts: np.ndarray
    valid: np.ndarray
