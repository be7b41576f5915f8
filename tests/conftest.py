"""Shared fixtures: small depth scenes and the real captures when present."""

from __future__ import annotations

from pathlib import Path

import pytest
from photon_scenes import disc_scene

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture
def scene():
    return disc_scene()


@pytest.fixture
def ugv45m_dir():
    folder = SHARED_DATA / "ugv45m"
    if not (folder / "car_20.mat").exists():
        pytest.skip("real captures not found at ../shared/data/ugv45m")
    return folder
