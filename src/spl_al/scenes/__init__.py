"""Procedural depth scenes: pure geometry, no photons.

- ``objects``: the 11 object categories of the DUIS paper's real dataset
  (``CATEGORIES``, ``render_object``), for classification.
- ``street``: street scenes as LiDAR-like range images with per-pixel labels
  (``STREET_CLASSES``, ``render_street``, ``range_image_to_points``), for segmentation.
- ``mesh``: triangle meshes of analytic shapes (lofts, lathes, tubes, boxes).
- ``raycast``: scanning-sensor rays (``ScanGrid``, ``Pose``), exact ray-triangle
  and ray-plane intersection.
"""

from spl_al.scenes.objects import CATEGORIES, ObjectImage, render_object
from spl_al.scenes.raycast import Pose, ScanGrid
from spl_al.scenes.street import STREET_CLASSES, StreetImage, range_image_to_points, render_street

__all__ = [
    "CATEGORIES",
    "STREET_CLASSES",
    "ObjectImage",
    "Pose",
    "ScanGrid",
    "StreetImage",
    "range_image_to_points",
    "render_object",
    "render_street",
]
