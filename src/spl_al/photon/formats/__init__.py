"""Readers of SPL capture files, one module per format (``spl_al.photon.io`` picks one).

- ``sparse_mat``: a sparse pixels x bins count matrix in a ``.mat``;
- ``timestamps``: an H x W cell array of photon arrival times in a ``.mat``;
- ``cube``: a dense H x W x T (or T x H x W) count cube in ``.mat``, ``.npy``, ``.npz``
  or HDF5;
- ``ptu``: a PicoQuant PTU image (T3 records with line and frame markers), read with
  the ``ptufile`` library.

Each returns a ``spl_al.photon.capture.Capture``.
"""
