"""Shared fixtures: small depth scenes and the real captures when present."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from photon_scenes import disc_scene

from spl_al.bench.estimate import ESTIMATE_ENV
from spl_al.config import REAL_CAPTURES_ENV

# The test runs' plans leave out the time estimate: it times every model first.
os.environ.setdefault(ESTIMATE_ENV, "0")


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
