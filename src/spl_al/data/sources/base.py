"""The dataset-source contract and the registry every source module registers into.

A dataset source turns a dataset's config entry (``datasets.NAME`` of the config,
validated by ``config/schema.yaml``; its ``source`` key names the source) into the
``Dataset`` of its observed images. A source is a function registered under its name::

    @register("mine")
    def build(entry: dict, *, release_dir: Path | None = None) -> Dataset: ...

The contract (``tests/test_sources.py`` checks every registered source against it):

- ``entry`` holds ``task`` ("classification" or "segmentation"), ``source`` and the
  keys that source reads (``path``, ``synthesis``, ...); ``synthesis_options(entry)``
  gives its ``synthesis`` mapping with ``image_shape`` as a tuple. ``release_dir`` is
  a folder an earlier workflow rule made for the dataset (the reconstructions of a
  ``captures`` dataset), else None.
- It returns a ``Dataset`` of ``entry["task"]`` with a train and a test split. The
  same entry over the same files gives the same bits: every draw comes from a seed
  in the entry (``spl_al.data.seeds``), never from global state.
- It sets ``meta["synthetic_standin"] = True`` only when it synthesized the images in
  place of data the entry does not give (``build_dataset`` sets False otherwise).
- A bad entry is a ``ValueError`` of one sentence naming the config key.

``build_dataset(entry, release_dir=...)`` dispatches on ``entry["source"]``; an unknown
source is one sentence naming the known ones.

What the plan, the workflow and the estimate know of a source without building it are
its traits, given to ``register`` and kept on its ``SourceKind``: whether an entry's
images are synthesised from its ``synthesis`` (their number is then known from the
config), whether they carry MSPPP levels, the workflow rule that makes its
``release_dir``, what the plan calls its images, and the entry it refuses before any
job runs (``check_entry``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from spl_al.data.dataset import Dataset
from spl_al.data.external import folder_has_levels

Source = Callable[..., Dataset]  # build(entry, *, release_dir=None) -> Dataset


def _never(_entry: dict) -> bool:
    return False


def always(_entry: dict) -> bool:
    """The trait holds for every entry."""
    return True


def _from_files(_entry: dict) -> bool | None:
    return None


def _accepts(_entry: dict) -> tuple[str, str] | None:
    return None


@dataclass(frozen=True)
class SourceKind:
    """A registered source: its ``build`` and its traits.

    ``synthesised(entry)``: the images are made from the entry's ``synthesis`` (a
    procedural set or a stand-in), so their number is the config's. ``levels(entry)``:
    whether they carry MSPPP levels, None when only the files can tell
    (``has_levels``). ``release_rule``: the workflow rule that makes ``release_dir``
    first, if any. ``images``: what the plan calls them. ``check(entry)``: (key,
    problem) of an entry the config is refused for, else None."""

    name: str
    build: Source
    synthesised: Callable[[dict], bool] = _never
    levels: Callable[[dict], bool | None] = _from_files
    release_rule: str | None = None
    images: str = "files"
    check: Callable[[dict], tuple[str, str] | None] = _accepts


_REGISTRY: dict[str, SourceKind] = {}


def register(name: str, **traits) -> Callable[[Source], Source]:
    """Decorator: add a source's ``build(entry, *, release_dir=None)`` under ``name``,
    with its ``SourceKind`` traits."""

    def add(build: Source) -> Source:
        if not name or name in _REGISTRY:
            raise ValueError(f"dataset source name {name!r} is empty or already registered.")
        _REGISTRY[name] = SourceKind(name, build, **traits)
        return build

    return add


def names() -> list[str]:
    """Names of the registered dataset sources, sorted."""
    return sorted(_REGISTRY)


def source_kind(name: str) -> SourceKind:
    """The registered source ``name``; a ValueError naming the known ones."""
    if name not in _REGISTRY:
        raise ValueError(
            f"config key 'source': {name!r} is not a dataset source; expected one of "
            f"{', '.join(names())}."
        )
    return _REGISTRY[name]


def get(name: str) -> Source:
    """The ``build`` function of the source ``name``; a ValueError naming the known ones."""
    return source_kind(name).build


def is_synthesised(entry: dict) -> bool:
    """Whether an entry's images are synthesised from its ``synthesis`` options."""
    return source_kind(entry.get("source")).synthesised(entry)


def has_levels(entry: dict) -> bool:
    """Whether an entry's images carry MSPPP levels: its source's trait, else (a folder
    of files) whether its first ``.npz`` holds them."""
    known = source_kind(entry.get("source")).levels(entry)
    if known is not None:
        return known
    return folder_has_levels(entry["path"], entry.get("depth_key", "depth_ssp"))


def check_entry(dataset: str, entry: dict) -> None:
    """Refuse, in one sentence naming the key, an entry its source cannot build."""
    refused = source_kind(entry.get("source")).check(entry)
    if refused:
        key, problem = refused
        raise ValueError(f"config key 'datasets.{dataset}.{key}': {problem}")


def synthesis_options(entry: dict) -> dict:
    """A copy of the entry's ``synthesis`` mapping, ``image_shape`` as a tuple."""
    synthesis = dict(entry.get("synthesis", {}))
    if "image_shape" in synthesis:
        synthesis["image_shape"] = tuple(synthesis["image_shape"])
    return synthesis


def build_dataset(entry: dict, release_dir: Path | str | None = None) -> Dataset:
    """The dataset of ``entry`` from its source, ``meta["synthetic_standin"]`` set."""
    dataset = get(entry.get("source"))(entry, release_dir=release_dir)
    dataset.meta["synthetic_standin"] = bool(dataset.meta.get("synthetic_standin", False))
    return dataset
