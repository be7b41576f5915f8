"""How the tests start Snakemake: on this checkout's Snakefile, from a folder of the
test's own, so that no test reads or writes the checkout's results/, .snakemake/ or
logs (a user's run there, finished or not, changes nothing here)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def snakemake_on(snakefile) -> list[str]:
    """The command that starts Snakemake on ``snakefile``."""
    return [sys.executable, "-m", "snakemake", "-s", str(snakefile)]


SNAKEMAKE = snakemake_on(ROOT / "Snakefile")
CI_CONFIG = str(ROOT / "config" / "ci.yaml")
# the repository's own folders a documented command names (config files, profiles)
REPO_FOLDERS = ("config/", "profiles/")


def from_checkout(args: list[str]) -> list[str]:
    """``args`` as written for a run in the checkout, with the repository's own files
    (config/..., profiles/...) named by their full path, for a run in another folder."""
    return [str(ROOT / a) if a.startswith(REPO_FOLDERS) else a for a in args]
