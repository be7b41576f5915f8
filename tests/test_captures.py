"""spl_al.data.raw_captures: a folder of captures becomes a release-layout folder with levels."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.photon_captures import simulate_capture, write_cube_npz, write_timestamps_mat
from helpers.photon_scenes import disc_scene

from spl_al.data import load_folder
from spl_al.data.raw_captures import (
    CaptureOptions,
    assign_levels,
    capture_files,
    reconstruct_shard,
    shard_count,
    shard_of,
    write_release,
)
from spl_al.photon import SensorParams

SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=1024)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Two classes in class folders, 3 captures each at MSPPP 2 / 5 / 10, two formats."""
    root = tmp_path_factory.mktemp("caps") / "scans"
    for c, (near, far) in enumerate([(3.0, 6.0), (5.0, 4.0)]):
        (root / f"class{c}").mkdir(parents=True)
        for j, msppp in enumerate((2.0, 5.0, 10.0)):
            events = simulate_capture(disc_scene(24, 24, near, far), msppp, 1.0, SENSOR, seed=j)
            if j % 2:
                write_cube_npz(root / f"class{c}" / f"f{j}.npz", events, SENSOR)
            else:
                write_timestamps_mat(root / f"class{c}" / f"f{j}.mat", events, bin_width_ps=80)
    (root / "notes.txt").write_text("not a capture")
    return root


def test_levels_by_tertiles_and_edges():
    msppp = np.array([9.0, 1.0, 4.0, 12.0, 2.0, 5.0])
    assert assign_levels(msppp).tolist() == ["high", "low", "medium", "high", "low", "medium"]
    by_edges = assign_levels(msppp, "edges", [3.0, 7.0]).tolist()
    assert by_edges == ["high", "low", "medium", "high", "low", "medium"]
    assert assign_levels(np.array([2.0]), "edges", [3.0, 7.0]).tolist() == ["low"]


def test_folder_to_release_layout_with_levels(folder, tmp_path):
    files = capture_files(folder)
    assert files == [f"class{c}/f{j}.{'npz' if j % 2 else 'mat'}" for c in (0, 1) for j in range(3)]
    options = CaptureOptions.from_dict({"shards": 4})
    n = shard_count(options, len(files))
    shards = [tmp_path / f"shard{k}.npz" for k in range(n)]
    for k, path in enumerate(shards):
        reconstruct_shard(folder, shard_of(files, n, k), out_path=path, options=options)
    release = write_release(shards, tmp_path / "release", options)
    dataset = load_folder(release, depth_key="depth_ssp", reflectance_key="intensity")
    assert dataset.classes == ["class0", "class1"] and len(dataset) == 6
    by_file = dict(zip(dataset.meta["files"], dataset.level, strict=True))
    for c in (0, 1):
        assert [by_file[f"class{c}/f{j}.npz"] for j in range(3)] == ["low", "medium", "high"]
    assert np.all(np.abs(dataset.msppp[dataset.level == "high"] / 10 - 1) < 0.15)
    csv = (release / "conditions.csv").read_text().splitlines()
    assert csv[0] == "file,capture,level,msppp,sbr,pulse_sigma_ps,voids" and len(csv) == 7


def test_labels_file_places_captures_in_class_folders(folder, tmp_path):
    files = capture_files(folder)
    labels = tmp_path / "labels.csv"
    labels.write_text("file,label\n" + "".join(f"{f},{'ab'[i % 2]}\n" for i, f in enumerate(files)))
    options = CaptureOptions.from_dict({"labels_file": str(labels), "shards": 1})
    reconstruct_shard(folder, files, out_path=tmp_path / "s.npz", options=options)
    release = write_release([tmp_path / "s.npz"], tmp_path / "release", options)
    assert sorted(p.parent.name for p in release.rglob("*.npz")) == ["a"] * 3 + ["b"] * 3
    labels.write_text("file,label\nclass0/f0.mat,a\n")
    with pytest.raises(ValueError, match=r"labels.csv: no label for 5 captures"):
        write_release([tmp_path / "s.npz"], tmp_path / "release2", options)
    assert not (tmp_path / "release2").exists()


def test_bad_folder_options_and_captures(folder, tmp_path):
    with pytest.raises(ValueError, match=r"captures folder .* does not exist"):
        capture_files(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="holds no capture file"):
        capture_files(tmp_path / "empty")
    with pytest.raises(ValueError, match=r"unknown options \['bin_width'\]"):
        CaptureOptions.from_dict({"bin_width": 80})
    with pytest.raises(ValueError, match="level_edges must be two MSPPP values"):
        CaptureOptions.from_dict({"level_split": "edges", "level_edges": [7, 3]})
    bad = tmp_path / "bad"
    bad.mkdir()
    np.savez(bad / "x.npz", counts=np.zeros((8, 8, 8)), bin_width_ps=80.0)
    with pytest.raises(ValueError, match=r"x\.npz: cannot tell which axis"):
        reconstruct_shard(bad, ["x.npz"], out_path=tmp_path / "s.npz", options=CaptureOptions())
    assert not (tmp_path / "s.npz").exists()


def test_unlabeled_captures_for_a_human_oracle(tmp_path):
    from spl_al.data import Dataset
    from spl_al.experiment.data_steps import make_dataset

    scans = tmp_path / "scans"
    scans.mkdir()
    for j, msppp in enumerate((2.0, 5.0, 10.0, 2.0, 5.0, 10.0)):
        events = simulate_capture(disc_scene(16, 16, 3.0, 6.0), msppp, 1.0, SENSOR, seed=j)
        write_timestamps_mat(scans / f"scan{j}.mat", events, bin_width_ps=80)
    entry = {"task": "classification", "source": "captures", "oracle": "human"}
    entry |= {"path": str(scans), "classes": ["car", "wall"], "captures": {"shards": 1}}
    seed = tmp_path / "seed.csv"
    seed.write_text("file,label,split\nscan0.npz,car,test\nscan1.npz,wall,test\n")
    entry["seed_labels"] = str(seed)
    options = CaptureOptions.from_dict(entry["captures"])
    reconstruct_shard(scans, capture_files(scans), out_path=tmp_path / "s.npz", options=options)
    release = write_release([tmp_path / "s.npz"], tmp_path / "release", options)
    make_dataset(entry, tmp_path / "observed.npz", release_dir=release)
    dataset = Dataset.load(tmp_path / "observed.npz")
    assert dataset.split.tolist() == ["test", "test"] + ["train"] * 4
    assert dataset.level.tolist() == ["low", "medium", "high"] * 2

    (release / "sub").mkdir()
    (release / "scan5.npz").rename(release / "sub" / "scan5.npz")
    with pytest.raises(ValueError, match="with oracle: human the captures must lie directly"):
        make_dataset(entry, tmp_path / "observed2.npz", release_dir=release)
    assert not (tmp_path / "observed2.npz").exists()

    # the workflow refuses such a folder before any reconstruction job runs
    (scans / "sub").mkdir()
    (scans / "scan5.mat").rename(scans / "sub" / "scan5.mat")
    assert "sub/scan5.mat" in capture_files(scans)
    with pytest.raises(ValueError, match=r"must lie directly in .*scans .*found sub/\."):
        capture_files(scans, flat=True)


def test_labels_file_refuses_two_captures_landing_on_one_name(tmp_path):
    scans = tmp_path / "scans"
    for sub in ("a", "b"):
        (scans / sub).mkdir(parents=True)
        events = simulate_capture(disc_scene(16, 16, 3.0, 6.0), 5.0, 1.0, SENSOR, seed=1)
        write_timestamps_mat(scans / sub / "x.mat", events, bin_width_ps=80)
    labels = tmp_path / "labels.csv"
    labels.write_text("file,label\na/x.mat,car\nb/x.mat,car\n")
    options = CaptureOptions.from_dict({"labels_file": str(labels), "shards": 1})
    reconstruct_shard(scans, capture_files(scans), out_path=tmp_path / "s.npz", options=options)
    with pytest.raises(ValueError, match=r"captures a/x.mat and b/x.mat would both be car/x.npz"):
        write_release([tmp_path / "s.npz"], tmp_path / "release", options)
    assert not (tmp_path / "release").exists()


def test_a_captures_dataset_needs_its_path():
    with pytest.raises(ValueError, match="a captures dataset needs 'path'"):
        capture_files(None)
