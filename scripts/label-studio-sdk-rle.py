"""Record brush RLEs made by Label Studio's own SDK, for tests/test_label_studio.py.

    /opt/lsvenv/bin/python scripts/label-studio-sdk-rle.py tests/fixtures/label_studio/sdk_rle.json

Runs in Label Studio's virtual environment (``label_studio_sdk`` comes with
``label-studio``; the project's environment does not install it: it would pin numpy
back). For each mask it records the mask (``np.packbits`` as hex) and what the SDK's
``mask2rle`` makes of it (0 / 255 masks, as spl-al writes them); for a random RGBA
array, the SDK's ``encode_rle`` bytes.
"""

import json
import sys

import numpy as np
from label_studio_sdk import __version__ as sdk_version
from label_studio_sdk.converter.brush import encode_rle, mask2rle


def masks():
    rng = np.random.default_rng(0)
    yield "single pixel", np.ones((1, 1), bool)
    yield "empty 5x7", np.zeros((5, 7), bool)
    yield "sparse 24x32", rng.random((24, 32)) < 0.05
    yield "half 24x32", rng.random((24, 32)) < 0.5
    block = np.zeros((64, 64), bool)
    block[10:40, 5:60] = True
    yield "block 64x64", block
    yield "full 200x400 (runs over 2**16)", np.ones((200, 400), bool)


def main() -> None:
    out = {"sdk": f"label-studio-sdk {sdk_version}", "masks": []}
    for name, mask in masks():
        out["masks"].append(
            {
                "name": name,
                "shape": list(mask.shape),
                "bits": np.packbits(mask.ravel()).tobytes().hex(),
                "rle": mask2rle(mask.astype(np.uint8) * 255),
            }
        )
    values = np.random.default_rng(1).integers(0, 256, 4 * 300).astype(np.uint8)
    values[100:400] = 7  # a long run among single values
    out["rgba"] = {"values": values.tolist(), "rle": encode_rle(values)}
    with open(sys.argv[1], "w") as f:
        json.dump(out, f)
        f.write("\n")


if __name__ == "__main__":
    main()
