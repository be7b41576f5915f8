"""Every capture format, wherever captures are read: the real-capture pictures,
``source: captures`` and ``python -m spl_al.photon reconstruct`` read .mat, .ptu, HDF5
and .npy/.npz cubes through one reader (``ReadOptions.load``); a cube that states no
timing stops in one sentence naming the key to set, and a file of any other format
is one line naming the supported formats."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.photon_captures import (
    simulate_capture,
    write_cube_h5,
    write_cube_npz,
    write_timestamps_mat,
)
from helpers.photon_scenes import disc_scene

from spl_al.data.raw_captures import (
    CaptureOptions,
    check_timing,
    not_read,
    picture_files,
    reconstruct_shard,
)
from spl_al.photon import SensorParams, histogram
from spl_al.photon.__main__ import main as photon_main
from spl_al.photon.io import SUPPORTED_FORMATS, ReadOptions, load_capture

SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=240e-12, n_bins=256)
PICTURES = "photon.real_capture_options.bin_width_ps"


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """One capture in each format, a .npy and a bare .npz stating no timing, and a note."""
    root = tmp_path_factory.mktemp("real")
    events = simulate_capture(disc_scene(16, 16, 1.0, 2.0), 5.0, 1.0, SENSOR, seed=1)
    cube = histogram(events, events.shape, SENSOR)
    np.save(root / "plain.npy", cube)
    np.savez(root / "bare.npz", counts=cube)
    write_cube_npz(root / "timed.npz", events, SENSOR)
    write_cube_h5(root / "timed_h5.h5", events, SENSOR)
    write_timestamps_mat(root / "stamps.mat", events, bin_width_ps=80)
    (root / "notes.txt").write_text("not a capture")
    (root / ".hidden").write_text("")
    return root


def test_pictures_take_every_format_with_the_options_of_a_dataset(folder):
    options = ReadOptions.from_dict({"bin_width_ps": 80}, "photon.real_capture_options")
    files = picture_files(folder, options, PICTURES)
    assert sorted(files) == ["bare", "plain", "stamps", "timed", "timed_h5"]
    for name, path in files.items():  # each reads through the one reader
        assert options.load(path).bin_width_s == pytest.approx(80e-12), name


def test_a_cube_without_timing_stops_in_one_sentence_naming_the_key(folder):
    options = ReadOptions.from_dict({}, "photon.real_capture_options")
    with pytest.raises(
        ValueError,
        match=rf"bare\.npz: a count cube that states no bin width.*"
        rf"set {PICTURES} ",
    ) as err:
        picture_files(folder, options, PICTURES)
    assert "\n" not in str(err.value)
    # a source: captures dataset stops the same way, naming its own key
    with pytest.raises(ValueError, match=r"plain\.npy: .* set datasets\.scans\.captures\."):
        check_timing(
            folder,
            ["timed.npz", "plain.npy"],
            CaptureOptions(),
            "datasets.scans.captures.bin_width_ps",
        )
    check_timing(folder, ["timed.npz", "timed_h5.h5", "stamps.mat"], CaptureOptions(), "x")


def test_another_format_is_one_line_naming_the_supported_formats(folder, tmp_path, capsys):
    lines = not_read(folder, recursive=False)
    assert lines == [
        f"{folder}: notes.txt is not read, not a capture format (supported: {SUPPORTED_FORMATS})."
    ]
    assert ".mat, .ptu, HDF5 (.h5, .hdf5) and .npy/.npz" in SUPPORTED_FORMATS
    with pytest.raises(ValueError, match=r"notes\.txt: not a capture file this reader knows"):
        load_capture(folder / "notes.txt")
    assert photon_main(["reconstruct", str(folder / "notes.txt"), str(tmp_path / "o.npz")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"supported: {SUPPORTED_FORMATS}" in err


def test_only_reader_options_for_the_pictures():
    with pytest.raises(
        ValueError, match=r"'photon.real_capture_options' has unknown options \['shards'\]"
    ):
        ReadOptions.from_dict({"shards": 2}, "photon.real_capture_options")


def test_the_picture_command_reads_a_npy_cube_with_the_configured_options(folder, tmp_path, capsys):
    options = ReadOptions.from_dict(
        {"bin_width_ps": 80, "time_axis": 2, "pulse_sigma_ps": 240}, "photon.real_capture_options"
    )
    assert options.cli_args() == [
        "--bin-width-ps",
        "80",
        "--pulse-sigma-ps",
        "240",
        "--time-axis",
        "2",
    ]
    out = tmp_path / "plain.png"
    assert photon_main(["--real", str(folder / "plain.npy"), str(out), *options.cli_args()]) == 0
    assert out.stat().st_size > 0
    assert "bins of 80 ps" in capsys.readouterr().out
    # without the bin width the command says what to give
    assert photon_main(["--real", str(folder / "plain.npy"), str(tmp_path / "x.png")]) == 2
    assert "states no bin width" in capsys.readouterr().err


def test_a_captures_dataset_reads_npy_and_npz_cubes(folder, tmp_path):
    options = CaptureOptions.from_dict({"bin_width_ps": 80, "shards": 1})
    files = ["bare.npz", "plain.npy", "timed_h5.h5"]
    assert reconstruct_shard(folder, files, out_path=tmp_path / "s.npz", options=options) == 3


def test_the_ugv45m_folder_is_pictured_and_its_readme_named(ugv45m_dir):
    options = ReadOptions.from_dict({}, "photon.real_capture_options")
    assert "car_20" in picture_files(ugv45m_dir, options, PICTURES)
    named = not_read(ugv45m_dir, recursive=False)
    assert all("not a capture format (supported: " in line for line in named)
