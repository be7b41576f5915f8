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


@pytest.fixture
def sspi_weights():
    """Folder of the published SSPI weights from $SPL_AL_SSPI_WEIGHTS (skip when unset)."""
    import os

    folder = os.environ.get("SPL_AL_SSPI_WEIGHTS")
    if not folder or not (Path(folder) / "ssunet1.pth").is_file():
        pytest.skip("SSPI weights not given: set SPL_AL_SSPI_WEIGHTS to a folder with ssunet*.pth")
    return Path(folder)


@pytest.fixture
def real_captures():
    """Folder of real .mat captures from $SPL_AL_REAL_CAPTURES (skip when unset)."""
    import os

    folder = os.environ.get("SPL_AL_REAL_CAPTURES")
    if not folder or not any(Path(folder).glob("*.mat")):
        pytest.skip("real captures not given: set SPL_AL_REAL_CAPTURES to a folder of .mat files")
    return Path(folder)
