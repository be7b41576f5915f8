"""Human oracle: labeling batches, label files and their errors, unlabeled folders."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from PIL import Image

from spl_al.data import Dataset
from spl_al.data.label_files import labels_for, save_labels
from spl_al.data.unlabeled_folder import load_unlabeled_folder
from spl_al.experiment.human import accept_labels
from spl_al.label_codes import IGNORE_INDEX, UNKNOWN_CLASS
from spl_al.labeling import read_label_file, write_batch

CLASSES = ["car", "person", "bike"]


def dataset(task="classification", n=8, shape=(6, 10), variants=1):
    rng = np.random.default_rng(0)
    depth = rng.uniform(2, 9, (n, *shape)).astype(np.float32)
    depth[:, 0, 0] = np.nan
    if task == "classification":
        labels = np.arange(n) % len(CLASSES)
    else:
        labels = rng.integers(0, len(CLASSES), (n, *shape)).astype(np.uint8)
    split = ["train"] * (n - 2) + ["test"] * 2
    vdepth = np.repeat(depth[:, None], variants, axis=1) + 0.1
    return Dataset(
        task,
        CLASSES,
        depth,
        labels,
        split,
        np.full(n, 5.0),
        np.full(n, 1.0),
        ["high"] * n,
        uid=np.arange(n) + 100,
        variant_depth_m=vdepth,
        variant_msppp=np.full((n, variants), 2.0),
        variant_sbr=np.full((n, variants), 0.2),
    )


def write_csv(path, rows, header=("sample", "file", "label")):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(rows)
    return path


def test_batch_lists_the_queried_samples_with_an_empty_label_column(tmp_path):
    data = dataset()
    out = write_batch(data, [1, 3], out_dir=tmp_path / "to_label", labels_file="labels/round1.csv")
    with open(out / "to_label.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["sample"], r["label"]) for r in rows] == [("101", ""), ("103", "")]
    for name in ("sample101.png", "sample103.png", "contact_sheet.png"):
        assert (out / name).read_bytes()[:4] == b"\x89PNG"
    assert "labels/round1.csv" in (out / "README.txt").read_text()
    assert (out / "classes.csv").read_text().splitlines()[1] == "0,car"


def test_a_filled_file_gives_the_labels_in_query_order(tmp_path):
    data = dataset()
    path = write_csv(tmp_path / "r.csv", [[103, "", "car"], [101, "x.npz", "bike"]])
    assert read_label_file(path, data, [1, 3]).tolist() == [2, 0]


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ([[101, "", "bycicle"]], r"line 2: 'bycicle' is not a class; expected one of: car"),
        ([[101, "", ""]], r"line 2: 101 has no label"),
        (
            [[101, "", "car"], [101, "", "car"]],
            r"line 3: sample '101' is listed twice \(first on line 2\)",
        ),
        ([[101, "", "car"], [105, "", "car"]], r"line 3: sample '105' was not asked for"),
        ([[101, "", "car"], [999, "", "car"]], r"line 3: sample '999' is not a sample id"),
        ([[101, "", "car"]], r"no row for 1 sample\(s\) of the batch \(sample 103\)"),
    ],
)
def test_a_wrong_file_is_one_error_naming_file_line_and_value(tmp_path, rows, message):
    data = dataset()
    if len(rows) == 1 and "no row" not in message:
        rows = [*rows, [103, "", "car"]]
    path = write_csv(tmp_path / "r.csv", rows)
    with pytest.raises(ValueError, match=message) as err:
        read_label_file(path, data, [1, 3])
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_a_file_without_the_label_column_is_refused(tmp_path):
    path = write_csv(tmp_path / "r.csv", [[101, "x"]], header=("sample", "class"))
    with pytest.raises(ValueError, match=r"needs the columns 'sample' \(or 'file'\) and 'label'"):
        read_label_file(path, dataset(), [1])


def mask_png(path, mask):
    Image.fromarray(np.asarray(mask, dtype=np.uint8), mode="L").save(path)


def test_segmentation_masks_are_read_and_checked(tmp_path):
    data = dataset("segmentation")
    good = np.full(data.image_shape, IGNORE_INDEX, np.uint8)
    good[2:, :] = 1
    mask_png(tmp_path / "a.png", good)
    np.save(tmp_path / "b.npy", np.zeros(data.image_shape, np.uint8))
    path = write_csv(
        tmp_path / "r.csv", [[101, "", "a.png"], [102, "", "b.npy"]], ("sample", "file", "mask")
    )
    got = read_label_file(path, data, [1, 2])
    assert got.dtype == np.uint8 and np.array_equal(got[0], good) and not got[1].any()

    mask_png(tmp_path / "small.png", np.zeros((3, 3)))
    bad = good.copy()
    bad[0, 0] = 7
    mask_png(tmp_path / "bad.png", bad)
    for name, message in [
        ("small.png", r"line 2: mask .*small.png has shape \(3, 3\); the image is \(6, 10\)"),
        ("bad.png", r"line 2: mask .*bad.png holds values \[7\]; expected class indices 0..2"),
        ("none.png", r"line 2: mask file .*none.png does not exist"),
    ]:
        path = write_csv(tmp_path / "r.csv", [[101, "", name]], ("sample", "file", "mask"))
        with pytest.raises(ValueError, match=message):
            read_label_file(path, data, [1])


def test_accept_writes_nothing_until_the_file_is_right(tmp_path):
    data = dataset()
    data.save(tmp_path / "dataset.npz")
    request = tmp_path / "query.json"
    request.write_text(json.dumps({"pool_indices": [0, 1, 3], "queried": [1, 3]}))
    save_labels(tmp_path / "before.npz", [0], [0])
    labels_file = tmp_path / "labels" / "round1.csv"
    out_json, out_npz = tmp_path / "labeled.json", tmp_path / "labels.npz"

    def accept():
        return accept_labels(
            tmp_path / "dataset.npz",
            request,
            labels_file=labels_file,
            batch_dir=tmp_path / "to_label",
            previous_labels=tmp_path / "before.npz",
            out_labeled=out_json,
            out_labels=out_npz,
        )

    with pytest.raises(ValueError, match=f"waiting for labels: .* save it as {labels_file}"):
        accept()
    labels_file.parent.mkdir()
    write_csv(labels_file, [[101, "", "car"], [103, "", "pony"]])
    with pytest.raises(ValueError, match="line 3: 'pony' is not a class"):
        accept()
    assert not out_json.exists() and not out_npz.exists()

    write_csv(labels_file, [[101, "", "person"], [103, "", "car"]])
    assert accept() == {"accepted": 2, "n_labeled": 3}
    assert json.loads(out_json.read_text())["pool_indices"] == [0, 1, 3]
    assert labels_for(out_npz, [3, 0, 1]).tolist() == [0, 0, 1]


def test_unlabeled_folder_is_a_pool_with_a_labeled_test_split(tmp_path):
    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(6):
        np.savez(frames / f"frame_{k:04d}.npz", depth_ssp=np.full((5, 7), 3.0 + k))
    seed = write_csv(
        tmp_path / "seed.csv",
        [
            ["frame_0000.npz", "car", "train"],
            ["frame_0004.npz", "bike", "test"],
            ["frame_0005.npz", "car", "test"],
        ],
        header=("file", "label", "split"),
    )
    data = load_unlabeled_folder(frames, CLASSES, seed_labels=seed)
    assert data.split.tolist() == ["train"] * 4 + ["test"] * 2
    assert data.labels.tolist() == [UNKNOWN_CLASS] * 4 + [2, 0]
    assert data.meta["files"][0] == "frame_0000.npz"
    # the train row is round 0's label, read by the round, not stored in the dataset
    assert read_label_file(seed, data, [0]).tolist() == [0]

    bad = write_csv(
        tmp_path / "bad.csv", [["frame_0009.npz", "car", "test"]], ("file", "label", "split")
    )
    with pytest.raises(ValueError, match=r"bad.csv line 2: file 'frame_0009.npz' is not in"):
        load_unlabeled_folder(frames, CLASSES, seed_labels=bad)


def test_segmentation_batch_proposes_mask_paths_and_lists_class_colours(tmp_path):
    out = write_batch(
        dataset("segmentation"), [1], out_dir=tmp_path / "to_label", labels_file="lab/round1.csv"
    )
    with open(out / "to_label.csv") as f:
        assert list(csv.DictReader(f)) == [
            {"sample": "101", "file": "", "mask": "round1_masks/sample101.png"}
        ]
    lines = (out / "classes.csv").read_text().splitlines()
    assert lines[0] == "index,name,colour" and lines[1].startswith("0,car,#")
    assert lines[-1] == "255,(no label),#000000"


def test_seed_labels_with_only_test_rows_leave_round_0_to_a_batch(tmp_path):
    from spl_al.data.label_files import lists_training_rows

    csv = tmp_path / "seed.csv"
    csv.write_text("file,label,split\na.npz,car,test\nb.npz,wall,test\n")
    assert not lists_training_rows(csv)
    csv.write_text("file,label,split\na.npz,car,test\nb.npz,wall,\n")
    assert lists_training_rows(csv)
    csv.write_text("file,label\na.npz,car\n")  # no split column: every row trains
    assert lists_training_rows(csv)
