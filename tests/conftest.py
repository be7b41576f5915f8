"""Shared fixtures: small depth scenes and the real captures when present."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def disc_scene(rows=64, cols=64, near_m=3.0, far_m=6.0):
    """A disc at ``near_m`` in front of a slanted wall around ``far_m``."""
    yy, xx = np.mgrid[:rows, :cols]
    depth = far_m + 0.01 * xx
    disc = (yy - rows / 2) ** 2 + (xx - cols / 2) ** 2 < (min(rows, cols) / 4) ** 2
    depth[disc] = near_m
    return depth


@pytest.fixture
def scene():
    return disc_scene()


@pytest.fixture
def ugv45m_dir():
    folder = SHARED_DATA / "ugv45m"
    if not (folder / "car_20.mat").exists():
        pytest.skip("real captures not found at ../shared/data/ugv45m")
    return folder
