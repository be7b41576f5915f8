"""The capture-format contract (``spl_al.photon.formats.base``), checked for every
registered format on small simulated captures; a new format adds its writer to ``CASES``.

Each case writes a capture with the project's writers (``spl_al.photon.formats.writers``).
The contract: ``load_capture`` reads it back, by name and by ``format="auto"``, to the
photons, shape and timing written; the same file gives the same bits twice; an empty or
corrupt file is a ValueError of one sentence naming the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers.photon_captures import (
    pixel_bin_counts,
    simulate_capture,
    write_cube_h5,
    write_cube_npz,
    write_ptu,
    write_sparse_mat,
    write_timestamps_mat,
)
from helpers.photon_scenes import disc_scene

from spl_al.photon import SensorParams, formats
from spl_al.photon.io import CAPTURE_SUFFIXES, FORMATS, SUPPORTED_FORMATS, is_capture, load_capture

ROOT = Path(__file__).resolve().parents[1]
SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=160e-12, n_bins=256)
GATE_PS = (0, 256 * 80)  # timestamps state their gate, so bins start at 0 as in the others

# format name -> (file name, writer(path, events)); a format may have several files.
CASES = {
    "sparse_mat": [("frame.mat", lambda p, e: write_sparse_mat(p, e, SENSOR))],
    "timestamps_mat": [
        ("frame.mat", lambda p, e: write_timestamps_mat(p, e, bin_width_ps=80, gate_ps=GATE_PS))
    ],
    "cube": [
        ("frame.npz", lambda p, e: write_cube_npz(p, e, SENSOR)),
        ("frame.h5", lambda p, e: write_cube_h5(p, e, SENSOR)),
    ],
    "ptu": [("frame.ptu", lambda p, e: write_ptu(p, e, SENSOR))],
}


def case_params():
    """(format, file name, writer) of every registered format (a missing case: None)."""
    out = []
    for name in formats.names():
        for file, write in CASES.get(name, [(None, None)]):
            out.append(pytest.param(name, file, write, id=f"{name}-{file}"))
    return out


@pytest.fixture(scope="module")
def events():
    depth = disc_scene(16, 16, near_m=1.0, far_m=2.0)  # square: sparse_mat needs no shape
    return simulate_capture(depth, 5.0, 1.0, SENSOR, seed=3)


def test_every_format_has_a_case_and_the_config_names_the_registry():
    assert set(CASES) == set(formats.names()), (
        "a capture format needs its writer in CASES of tests/test_capture_formats_contract.py"
    )
    schema = yaml.safe_load((ROOT / "config" / "schema.yaml").read_text())
    enum = schema["$defs"]["capture_read"]["properties"]["format"]["enum"]
    assert enum == list(FORMATS) == ["auto", *formats.names()], (
        "config/schema.yaml's capture_read format enum lists 'auto' and the registry"
    )


def test_suffixes_and_words_derive_from_the_registry():
    for name in formats.names():
        fmt = formats.get(name)
        assert fmt.suffixes and all(s in CAPTURE_SUFFIXES for s in fmt.suffixes)
        assert fmt.files in SUPPORTED_FORMATS and is_capture(f"x{fmt.suffixes[0].upper()}")
        if formats.MAT_SUFFIX in fmt.suffixes:
            assert fmt.detect is not None, f"{name} shares .mat and needs detect"
    assert not is_capture("notes.txt")


def test_an_unknown_format_name_is_one_sentence_naming_the_known_ones(tmp_path):
    path = tmp_path / "frame.npz"
    path.write_bytes(b"")
    with pytest.raises(ValueError, match=r"format 'nope' is not known; expected one of auto, "):
        load_capture(path, "nope")
    with pytest.raises(ValueError) as err:
        formats.register(formats.get("cube"))
    assert "already registered" in str(err.value)


@pytest.mark.parametrize(("name", "file", "write"), case_params())
def test_format_contract(name, file, write, events, tmp_path):
    if write is None:
        pytest.skip(f"capture format {name!r} has no case in {Path(__file__).name}")
    path = write(tmp_path / file, events)
    expected = pixel_bin_counts(events)
    for fmt in ("auto", name):
        cap = load_capture(path, fmt)
        assert cap.format == name and cap.shape == events.shape
        assert cap.bin_width_s == pytest.approx(SENSOR.bin_width_s)
        assert cap.gate_start_s == pytest.approx(0.0) and cap.n_bins >= SENSOR.n_bins
        assert int(cap.events.bin.max()) < cap.n_bins
        np.testing.assert_array_equal(pixel_bin_counts(cap.events), expected)
    again = load_capture(path, name)
    np.testing.assert_array_equal(again.events.pixel, cap.events.pixel)
    np.testing.assert_array_equal(again.events.bin, cap.events.bin)
    assert (again.bin_width_s, again.n_bins) == (cap.bin_width_s, cap.n_bins)


@pytest.mark.parametrize("content", [b"", b"not a capture, just some bytes\n"])
@pytest.mark.parametrize(("name", "file", "write"), case_params())
def test_a_bad_file_is_one_sentence_naming_it(name, file, write, content, tmp_path):
    if write is None:
        pytest.skip(f"capture format {name!r} has no case in {Path(__file__).name}")
    path = tmp_path / file
    path.write_bytes(content)
    for fmt in ("auto", name):
        with pytest.raises(ValueError) as err:
            load_capture(path, fmt)
        message = str(err.value)
        assert message.startswith(f"{path}: ") and "\n" not in message
