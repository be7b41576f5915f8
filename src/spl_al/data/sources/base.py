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
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from spl_al.data.dataset import Dataset

Source = Callable[..., Dataset]  # build(entry, *, release_dir=None) -> Dataset

_REGISTRY: dict[str, Source] = {}


def register(name: str) -> Callable[[Source], Source]:
    """Decorator: add a source's ``build(entry, *, release_dir=None)`` under ``name``."""

    def add(build: Source) -> Source:
        if not name or name in _REGISTRY:
            raise ValueError(f"dataset source name {name!r} is empty or already registered.")
        _REGISTRY[name] = build
        return build

    return add


def names() -> list[str]:
    """Names of the registered dataset sources, sorted."""
    return sorted(_REGISTRY)


def get(name: str) -> Source:
    """The ``build`` function of the source ``name``; a ValueError naming the known ones."""
    if name not in _REGISTRY:
        raise ValueError(
            f"config key 'source': {name!r} is not a dataset source; expected one of "
            f"{', '.join(names())}."
        )
    return _REGISTRY[name]


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
