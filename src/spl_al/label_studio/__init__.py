"""Label Studio in and out.

- ``mask_to_rle`` / ``rle_to_mask`` (``brush``): Label Studio's brush RLE.
"""

from spl_al.label_studio.brush import decode_rle, encode_rle, mask_to_rle, rle_to_mask

__all__ = ["decode_rle", "encode_rle", "mask_to_rle", "rle_to_mask"]
