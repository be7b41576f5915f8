"""spl-al: condition-aware active learning for single-photon LiDAR (SPL) perception.

Areas (see docs/design.md for the map):

- ``spl_al.photon``: the SPL measurement model, photon simulation, reconstruction, SIV.
- ``spl_al.bench``: benchmarks that print tables (``python -m spl_al.bench NAME``).
"""

__version__ = "0.1.0"
