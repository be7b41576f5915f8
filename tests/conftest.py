"""Shared fixtures: small depth scenes and the real captures when present."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from photon_scenes import disc_scene

from spl_al.config import REAL_CAPTURES_ENV


@pytest.fixture
def scene():
    return disc_scene()


@pytest.fixture
def ugv45m_dir():
    """The folder of the real ugv45m captures, from $SPL_AL_REAL_CAPTURES (else skip)."""
    value = os.environ.get(REAL_CAPTURES_ENV)
    if not value:
        pytest.skip(f"real captures not given (set {REAL_CAPTURES_ENV} to the ugv45m folder)")
    folder = Path(value)
    if not (folder / "car_20.mat").exists():
        pytest.skip(f"{REAL_CAPTURES_ENV}={folder} holds no car_20.mat")
    return folder
