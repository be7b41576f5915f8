"""Capture formats: readers of SPL capture files, one module per format behind one
registry (the config's ``captures.format``; ``spl_al.photon.io.load_capture`` reads
through it).

``names()`` lists the formats, ``get(name)`` gives one's ``CaptureFormat``,
``register(CaptureFormat(...))`` adds one. The contract a format keeps is in
``spl_al.photon.formats.base``; ``tests/test_capture_formats_contract.py`` checks every
registered one. Registration order is ``format="auto"``'s order of detection among
the formats of one suffix.

- ``sparse_mat``: a sparse pixels x bins count matrix in a ``.mat``;
- ``timestamps_mat`` (``timestamps.py``): an H x W cell array of photon arrival times
  in a ``.mat``;
- ``cube``: a dense H x W x T (or T x H x W) count cube in ``.mat``, ``.npy``, ``.npz``
  or HDF5;
- ``ptu``: a PicoQuant PTU image (T3 records with line and frame markers), read with
  the ``ptufile`` library.

Each returns a ``spl_al.photon.capture.Capture``. Helpers shared by readers:
``matfile`` (MATLAB v5 / v7.3 variables), ``timing`` (timing a file states),
``choose`` (which variable holds the photons), ``writers`` (files for tests).
"""

from spl_al.photon.formats import sparse_mat, timestamps, cube, ptu  # noqa: I001  (order: detection)
from spl_al.photon.formats.base import (
    MAT_SUFFIX,
    CaptureFormat,
    FileOptions,
    get,
    names,
    of_suffix,
    register,
    suffixes,
)

__all__ = [
    "MAT_SUFFIX",
    "CaptureFormat",
    "FileOptions",
    "cube",
    "get",
    "names",
    "of_suffix",
    "ptu",
    "register",
    "sparse_mat",
    "suffixes",
    "timestamps",
]
