"""Label Studio in and out: batches as imports with pre-annotations, exports as labels.

- ``write_import`` (``tasks``): a labeling batch's ``label_studio.xml`` (labeling
  config) and ``label_studio.json`` (tasks, with the model's predictions);
- ``read_export`` (``export``): the labels of a batch from the project's JSON export,
  checked like a filled ``to_label.csv``;
- ``mask_to_rle`` / ``rle_to_mask`` (``brush``): Label Studio's brush RLE.
"""

from spl_al.labeling.label_studio.brush import decode_rle, encode_rle, mask_to_rle, rle_to_mask
from spl_al.labeling.label_studio.export import read_export
from spl_al.labeling.label_studio.tasks import (
    CONFIG_FILE,
    TASKS_FILE,
    labeling_config,
    write_import,
)

__all__ = [
    "CONFIG_FILE",
    "TASKS_FILE",
    "decode_rle",
    "encode_rle",
    "labeling_config",
    "mask_to_rle",
    "read_export",
    "rle_to_mask",
    "write_import",
]
