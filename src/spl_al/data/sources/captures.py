"""Source ``captures``: raw photon captures, read from their reconstructions.

The workflow reconstructs the captures in ``path`` first (``spl_al.data.raw_captures``,
rules ``captures_shard`` and ``captures_release``) into a release-layout folder, the
``release_dir`` this source reads: as a ``folder`` (labels from names or class
folders, levels from the estimated MSPPP), or with ``oracle: human`` as an
``unlabeled`` folder read flat, whose ``seed_labels`` name the frames
``{capture stem}.npz``. Also reads ``synthesis`` as those sources do.
"""

from __future__ import annotations

from pathlib import Path

from spl_al.data.dataset import Dataset
from spl_al.data.sources import folder, unlabeled
from spl_al.data.sources.base import always, register


def as_folder_entry(entry: dict, release_dir) -> dict:
    """A captures entry as the ``folder`` (or ``unlabeled``) entry of its reconstructions."""
    if release_dir is None:
        raise ValueError("a captures dataset needs the folder of its reconstructions.")
    nested = sorted(p for p in Path(release_dir).rglob("*.npz") if p.parent != Path(release_dir))
    if entry.get("oracle") == "human" and nested:
        raise ValueError(
            f"config key 'path': with oracle: human the captures must lie directly in "
            f"{entry['path']} (an unlabeled pool is read flat); found "
            f"{nested[0].relative_to(release_dir).parent}/."
        )
    return {
        **entry,
        "source": "unlabeled" if entry.get("oracle") == "human" else "folder",
        "path": str(release_dir),
        "depth_key": "depth_ssp",
        "reflectance_key": "intensity",
        "levels_file": None,
    }


@register("captures", levels=always, release_rule="captures_release", images="captures")
def build(entry: dict, *, release_dir=None) -> Dataset:
    """Load the reconstructions in ``release_dir`` as a folder or unlabeled dataset."""
    as_folder = as_folder_entry(entry, release_dir)
    source = unlabeled if as_folder["source"] == "unlabeled" else folder
    return source.build(as_folder)
