"""Source ``folder``: a folder of labeled SPL depth images (``spl_al.data.external``).

Reads ``path``, ``depth_key`` (default ``depth_ssp``), ``reflectance_key``,
``levels_file``, ``n_per_class`` and, from ``synthesis``, ``image_shape``,
``test_fraction`` (0.3) and ``seed`` (0). Without ``path``, ``standin: true``
synthesizes a stand-in from ``synthesis`` instead (``meta["synthetic_standin"]``).
"""

from __future__ import annotations

from pathlib import Path

from spl_al.config import NO_PATH, is_standin
from spl_al.data.dataset import Dataset
from spl_al.data.external import load_folder
from spl_al.data.sources.base import register, synthesis_options
from spl_al.data.sources.synthetic import synthesize


def _levels(entry: dict) -> bool | None:
    """A stand-in's images and a ``levels_file``'s assignment carry levels; else the files."""
    return True if is_standin(entry) or entry.get("levels_file") else None


def _check(entry: dict) -> tuple[str, str] | None:
    return ("path", NO_PATH) if not entry.get("path") and not is_standin(entry) else None


@register("folder", synthesised=is_standin, levels=_levels, check=_check)
def build(entry: dict, *, release_dir=None) -> Dataset:
    """Load the folder at ``path``, or the synthetic stand-in (``release_dir`` is not used)."""
    if not entry.get("path"):
        if not is_standin(entry):
            raise ValueError(NO_PATH)
        dataset = synthesize(entry)
        dataset.meta["synthetic_standin"] = True
        return dataset
    root = Path(entry["path"])
    if not root.is_dir():
        raise ValueError(f"dataset folder {root} does not exist (config key 'path').")
    synthesis = synthesis_options(entry)
    return load_folder(
        root,
        depth_key=entry.get("depth_key", "depth_ssp"),
        reflectance_key=entry.get("reflectance_key"),
        image_shape=synthesis.get("image_shape"),
        test_fraction=synthesis.get("test_fraction", 0.3),
        seed=synthesis.get("seed", 0),
        levels_file=entry.get("levels_file"),
        n_per_class=entry.get("n_per_class"),
    )
