"""The Snakemake workflow: dry runs and config validation."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed")


def snakemake(*args, cwd=ROOT):
    return subprocess.run(
        [sys.executable, "-m", "snakemake", *args], cwd=cwd, capture_output=True, text=True
    )


def test_default_config_dry_runs():
    run = snakemake("-n", "--cores", "1", "--quiet")
    assert run.returncode == 0, run.stderr


def test_unknown_config_key_fails_before_any_job_with_the_key_named():
    run = snakemake("-n", "--cores", "1", "--config", "bogus_key=1")
    assert run.returncode != 0
    assert "bogus_key" in run.stderr
