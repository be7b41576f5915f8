"""Shared fixtures: small depth scenes and the real captures when present."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from helpers.photon_scenes import disc_scene

from spl_al.bench.estimate import ESTIMATE_ENV
from spl_al.config import REAL_CAPTURES_ENV
from spl_al.warm.server import SOCKET_ENV, Server

# The test runs' plans leave out the time estimate: it times every model first.
os.environ.setdefault(ESTIMATE_ENV, "0")


def pytest_configure(config):
    # Under pytest-xdist, torch's threads share the cores among the workers: two workers
    # with two OpenMP threads each on two cores spin against each other (~10% slower).
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if workers > 1:
        import torch

        torch.set_num_threads(max(1, (os.cpu_count() or 1) // workers))


@pytest.fixture(scope="session")
def warm_server(tmp_path_factory):
    """One warm job server for this test process's Snakemake runs, named in the
    environment they inherit: each run uses it (same library, see
    ``spl_al.warm.server.shared_server``) instead of starting its own, whose
    imports cost ~7 CPU-s on a 2-core AVX2 CPU. Runs with another PYTHONPATH, on a
    cluster profile or with ``warm_worker: false`` still do without it."""
    previous = os.environ.pop(SOCKET_ENV, None)
    server = Server.start(tmp_path_factory.mktemp("warm") / "server.log")
    yield server.address
    server.stop()
    if previous is not None:
        os.environ[SOCKET_ENV] = previous


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
