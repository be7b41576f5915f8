"""Label Studio's brush RLE, checked against its own SDK.

``tests/fixtures/label_studio/sdk_rle.json`` was recorded by
``scripts/label-studio-sdk-rle.py`` with label-studio-sdk 2.1.2 (installed beside Label
Studio 1.23.2 in its own virtual environment: in the project's it would pin numpy back
from 2.4 to 2.2). With ``SPL_AL_LABEL_STUDIO`` set, the same comparison runs against the
SDK installed next to that executable.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from spl_al.labeling.label_studio import decode_rle, encode_rle, mask_to_rle, rle_to_mask
from spl_al.labeling.label_studio.brush import RLEError

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = Path(__file__).parent / "fixtures" / "label_studio"
LABEL_STUDIO = os.environ.get("SPL_AL_LABEL_STUDIO")


def fixture(name: str):
    return json.loads((FIXTURES / name).read_text())


def test_brush_rle_is_byte_for_byte_the_sdks():
    recorded = fixture("sdk_rle.json")
    for case in recorded["masks"]:
        shape = tuple(case["shape"])
        bits = np.unpackbits(np.frombuffer(bytes.fromhex(case["bits"]), np.uint8))
        mask = bits[: shape[0] * shape[1]].reshape(shape).astype(bool)
        assert mask_to_rle(mask) == case["rle"], case["name"]
        assert np.array_equal(rle_to_mask(case["rle"], *shape), mask), case["name"]
    values = np.asarray(recorded["rgba"]["values"], np.uint8)
    assert encode_rle(values) == recorded["rgba"]["rle"]
    assert np.array_equal(decode_rle(recorded["rgba"]["rle"]), values)


def test_rle_reads_literal_runs_as_the_front_end_may_write_them():
    # header: 3 values, word 8 bits, run fields 3/4/8/16 bits; one literal run of 3
    bits = f"{3:032b}{7:05b}" + "".join(f"{b - 1:04b}" for b in (3, 4, 8, 16))
    bits += "0" + "00" + f"{2:03b}" + "".join(f"{v:08b}" for v in (5, 6, 250))
    bits += "0" * (-len(bits) % 8)
    rle = [int(bits[i : i + 8], 2) for i in range(0, len(bits), 8)]
    assert decode_rle(rle).tolist() == [5, 6, 250]


def test_a_broken_rle_is_refused():
    rle = mask_to_rle(np.ones((4, 4), bool) ^ np.eye(4, dtype=bool))
    with pytest.raises(RLEError, match="truncated"):
        decode_rle(rle[:10])
    with pytest.raises(RLEError, match=r"holds 64 values; a 5x4 RGBA picture has 80"):
        rle_to_mask(rle, 4, 5)


@pytest.mark.skipif(
    not LABEL_STUDIO,
    reason="set SPL_AL_LABEL_STUDIO to a label-studio executable (in its own venv) to run",
)
def test_rle_matches_the_installed_sdk(tmp_path):
    python = Path(LABEL_STUDIO).with_name("python")
    out = tmp_path / "sdk_rle.json"
    script = ROOT / "scripts/label-studio-sdk-rle.py"
    subprocess.run([str(python), str(script), str(out)], check=True)
    for case in json.loads(out.read_text())["masks"]:
        shape = tuple(case["shape"])
        bits = np.unpackbits(np.frombuffer(bytes.fromhex(case["bits"]), np.uint8))
        assert mask_to_rle(bits[: shape[0] * shape[1]].reshape(shape)) == case["rle"]
