"""Dataset sources: where a dataset's observed images come from, one module per
source behind one registry (the config's ``datasets.NAME.source``).

``build_dataset(entry, release_dir=None)`` builds the ``Dataset`` of a config entry
through the source it names; ``names()`` lists the sources, ``get(name)`` gives one's
``build`` function, ``source_kind(name)`` its traits (``is_synthesised``,
``has_levels`` and ``check_entry`` read them for an entry), ``register(name, **traits)``
adds one. The contract a source keeps is in
``spl_al.data.sources.base``; ``tests/test_sources.py`` checks every registered one.

- synthetic: procedural images (``spl_al.data.procedural``).
- folder: a folder of labeled depth images (``spl_al.data.external``), or a
  synthetic stand-in when no path is given and ``standin: true``.
- unlabeled: a folder of depth images for a human oracle (``spl_al.data.unlabeled_folder``).
- captures: raw photon captures, read from the folder of their reconstructions.
"""

from spl_al.data.sources import captures, folder, synthetic, unlabeled
from spl_al.data.sources.base import (
    Source,
    SourceKind,
    build_dataset,
    check_entry,
    get,
    has_levels,
    is_synthesised,
    names,
    register,
    source_kind,
    synthesis_options,
)

__all__ = [
    "Source",
    "SourceKind",
    "build_dataset",
    "captures",
    "check_entry",
    "folder",
    "get",
    "has_levels",
    "is_synthesised",
    "names",
    "register",
    "source_kind",
    "synthesis_options",
    "synthetic",
    "unlabeled",
]
