"""Source ``unlabeled``: a folder of depth images without labels, the pool of a human
oracle (``spl_al.data.unlabeled_folder``).

Reads ``path``, ``classes``, ``task``, ``seed_labels`` (its ``test`` rows are the test
split, at least one), ``depth_key`` (default ``depth_ssp``) and ``synthesis.image_shape``.
"""

from __future__ import annotations

from pathlib import Path

from spl_al.data.dataset import Dataset
from spl_al.data.sources.base import register, synthesis_options
from spl_al.data.unlabeled_folder import load_unlabeled_folder


def _levels(entry: dict) -> bool | None:
    return True if entry.get("levels_file") else None


def _check(entry: dict) -> tuple[str, str] | None:
    if entry.get("oracle") == "human":
        return None
    return (
        "oracle",
        "an unlabeled folder has no labels to simulate the oracle with; set oracle: human.",
    )


@register("unlabeled", levels=_levels, check=_check)
def build(entry: dict, *, release_dir=None) -> Dataset:
    """Load the unlabeled folder at ``path`` (``release_dir`` is not used)."""
    if not entry.get("path") or not Path(entry["path"]).is_dir():
        raise ValueError(
            f"config key 'path': {entry.get('path')!r} is not a folder of depth files."
        )
    dataset = load_unlabeled_folder(
        entry["path"],
        entry.get("classes"),
        task=entry["task"],
        seed_labels=entry.get("seed_labels"),
        depth_key=entry.get("depth_key", "depth_ssp"),
        image_shape=synthesis_options(entry).get("image_shape"),
    )
    if not dataset.test_idx.size:
        raise ValueError(
            "config key 'seed_labels': no row has split 'test'; label a few samples as test "
            "there, they measure the model every round."
        )
    return dataset
