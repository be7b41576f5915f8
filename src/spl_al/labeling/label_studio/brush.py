"""Label Studio's brush masks: its own run-length encoding (RLE), both ways.

A Label Studio brush region is stored as ``value.rle``: a list of byte values
encoding the region's RGBA picture (``original_height`` x ``original_width`` x 4,
flattened row by row) with thi.ng's rle-pack format, which Label Studio's front end
writes and its SDK reads (``label_studio_sdk.converter.brush``):

- header: 32 bits the number of values, 5 bits word size - 1, then 4 x 4 bits the
  four run-length field sizes - 1;
- then runs until that many values are read: 1 bit (1: a repeated value, 0: a
  literal run), 2 bits choosing a length field size, that many bits the run length
  - 1, then one word (repeated run) or one word per value (literal run);
- zero bits pad the last byte.

``decode_rle`` reads any header; ``encode_rle`` writes the SDK's choices (word size
8, length fields 3, 4, 8, 16 bits) so that its bytes equal the SDK's ``encode_rle``.
A mask pixel is painted where its alpha is above 0: Label Studio's front end stores
brush strokes semi-transparent (alpha 78 to 97 in a stroke painted in Chromium with
Label Studio 1.23, tests/fixtures/label_studio), so no higher threshold is safe.
"""

from __future__ import annotations

import numpy as np

WORD_BITS = 8
RUN_FIELD_BITS = (3, 4, 8, 16)
PAINTED_ALPHA = 1  # a pixel whose alpha is at least this is in the region


class RLEError(ValueError):
    """Bytes that are no rle-pack stream (truncated, or values wider than 8 bits)."""


def _runs(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths and values of the runs of equal consecutive values."""
    if values.size == 0:
        return np.zeros(0, np.int64), values
    ends = np.append(np.flatnonzero(values[1:] != values[:-1]), values.size - 1)
    lengths = np.diff(np.append(-1, ends))
    return lengths, values[ends]


def _run_bits(length: int, value: int) -> str:
    """One run in the SDK's layout: a single value, or a repeated one split at 2**16."""
    word = f"{value:0{WORD_BITS}b}"
    if length == 1:
        return "0" + "00" + "0" * RUN_FIELD_BITS[0] + word
    for index, bits in enumerate(RUN_FIELD_BITS[:3]):
        if length <= 2**bits:
            return "1" + f"{index:02b}" + f"{length - 1:0{bits}b}" + word
    parts = []
    full = 2 ** RUN_FIELD_BITS[3]
    while length > full:
        parts.append("111" + f"{full - 1:016b}" + word)
        length -= full
    parts.append("111" + f"{length - 1:016b}" + word)
    return "".join(parts)


def encode_rle(values) -> list[int]:
    """Label Studio RLE bytes of a flat array of 0..255 values (an RGBA picture)."""
    values = np.asarray(values).ravel()
    if values.size and (values.min() < 0 or values.max() > 255):
        raise RLEError("brush RLE holds 8-bit values; got values outside 0..255.")
    header = (
        f"{values.size:032b}"
        + f"{WORD_BITS - 1:05b}"
        + "".join(f"{b - 1:04b}" for b in RUN_FIELD_BITS)
    )
    lengths, run_values = _runs(values.astype(np.int64))
    bits = header + "".join(
        _run_bits(int(n), int(v)) for n, v in zip(lengths, run_values, strict=True)
    )
    bits += "0" * (8 - len(bits) % 8)  # as the SDK: always at least one pad bit
    return [int(bits[i : i + 8], 2) for i in range(0, len(bits), 8)]


class _Bits:
    """Read unsigned big-endian fields from a bit array."""

    def __init__(self, data: np.ndarray):
        self.bits = np.unpackbits(data)
        self.pos = 0

    def read(self, n: int) -> int:
        stop = self.pos + n
        if stop > self.bits.size:
            raise RLEError("brush RLE ends in the middle of a run (truncated).")
        field = self.bits[self.pos : stop]
        self.pos = stop
        return int(field @ (1 << np.arange(n - 1, -1, -1, dtype=np.int64))) if n else 0


def decode_rle(rle) -> np.ndarray:
    """The flat uint8 values of Label Studio RLE bytes (``value.rle`` of a brush region)."""
    try:
        data = np.asarray(rle, dtype=np.int64)
    except (TypeError, ValueError):
        raise RLEError("brush RLE is not a list of byte values.") from None
    if data.ndim != 1 or (data.size and (data.min() < 0 or data.max() > 255)):
        raise RLEError("brush RLE is not a list of byte values 0..255.")
    bits = _Bits(data.astype(np.uint8))
    n = bits.read(32)
    word = bits.read(5) + 1
    fields = [bits.read(4) + 1 for _ in range(4)]
    if word > 8:
        raise RLEError(f"brush RLE has {word}-bit values; Label Studio brushes use 8.")
    out = np.zeros(n, dtype=np.uint8)
    i = 0
    while i < n:
        repeated = bits.read(1)
        j = min(i + 1 + bits.read(fields[bits.read(2)]), n)
        if repeated:
            out[i:j] = bits.read(word)
        else:
            for k in range(i, j):
                out[k] = bits.read(word)
        i = j
    return out


def mask_to_rle(mask) -> list[int]:
    """Label Studio RLE of a (H, W) boolean mask: painted pixels opaque (255) in all
    four RGBA channels, the rest 0 (what the SDK's ``mask2rle`` writes for 0/255)."""
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim != 2:
        raise ValueError(f"a brush mask is 2-D (H, W); got shape {mask.shape}.")
    return encode_rle(np.repeat(mask.ravel().astype(np.uint8) * 255, 4))


def rle_to_mask(rle, height: int, width: int) -> np.ndarray:
    """The (height, width) boolean mask of a brush region: its pixels with alpha > 0."""
    values = decode_rle(rle)
    if values.size != height * width * 4:
        raise RLEError(
            f"brush RLE holds {values.size} values; a {width}x{height} RGBA picture "
            f"has {height * width * 4}."
        )
    return values.reshape(height, width, 4)[..., 3] >= PAINTED_ALPHA
