"""Label Studio in and out: batches as imports, exports as label files, brush RLE.

The fixtures under tests/fixtures/label_studio were made by the real thing
(``scripts/label-studio-roundtrip.py --record ... --browser`` against Label Studio
1.23.2, ``scripts/label-studio-sdk-rle.py`` with label-studio-sdk 2.1.2), not by hand:
exports of a classification workflow run (rounds 0 and 1), of a segmentation batch
annotated through the API, and of one whose brush stroke was painted in Chromium.
"""

from __future__ import annotations

import base64
import copy
import io
import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from helpers.label_studio_data import CLASSES as SEG_CLASSES
from helpers.label_studio_data import probabilities, segmentation_dataset
from PIL import Image

from spl_al.data import Dataset
from spl_al.data.label_files import labels_for
from spl_al.experiment.human import accept_labels
from spl_al.label_codes import IGNORE_INDEX
from spl_al.labeling import read_label_file, write_batch
from spl_al.labeling.label_studio import decode_rle, read_export, rle_to_mask

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = Path(__file__).parent / "fixtures" / "label_studio"
SEG_POOL = [0, 2, 3]


def fixture(name: str):
    return json.loads((FIXTURES / name).read_text())


def classification_dataset() -> Dataset:
    """A stand-in with the samples and classes of the recorded classification run."""
    facts = fixture("classification_dataset.json")
    uid = np.asarray(facts["train_uid"] + [10_000], dtype=np.int64)
    n = uid.size
    labels = [facts["classes"].index(facts["labels"][str(u)]) for u in facts["train_uid"]]
    return Dataset(
        "classification",
        facts["classes"],
        np.full((n, 4, 4), 5.0, np.float32),
        np.asarray([*labels, 0]),
        ["train"] * (n - 1) + ["test"],
        np.full(n, 1.0),
        np.full(n, 1.0),
        ["high"] * n,
        uid=uid,
    )


def pool_of(data: Dataset, export) -> list[int]:
    """Training-pool indices of an export's samples, in task order."""
    position = {int(data.uid[i]): p for p, i in enumerate(data.train_idx)}
    return [position[int(t["data"]["sample"])] for t in export]


def save(tmp_path: Path, export, name="round1.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(export))
    return path


# ---------------------------------------------------------------- out


def picture(url: str) -> np.ndarray:
    prefix = "data:image/png;base64,"
    assert url.startswith(prefix)
    return np.array(Image.open(io.BytesIO(base64.b64decode(url[len(prefix) :]))))


def test_classification_batch_is_a_label_studio_import_with_predictions(tmp_path):
    data = classification_dataset()
    data.depth_m[3, 0, 0] = np.nan
    probs = np.full((2, len(data.classes)), 0.01)
    probs[0, 4], probs[1, 1] = 0.8, 0.6
    out = write_batch(
        data, [3, 1], out_dir=tmp_path / "to_label", labels_file="labels/round1.csv", probs=probs
    )
    config = ET.parse(out / "label_studio.xml").getroot()
    choices = config.find("Choices")
    assert (choices.get("name"), choices.get("toName")) == ("label", "image")
    assert [c.get("value") for c in choices] == data.classes
    assert config.find("Image").get("value") == "$image"
    tasks = json.loads((out / "label_studio.json").read_text())
    assert [t["data"]["sample"] for t in tasks] == [int(data.uid[3]), int(data.uid[1])]
    image = picture(tasks[0]["data"]["image"])
    assert image.shape == (4, 4, 3) and not image[0, 0].any() and image[1, 1].any()
    first = tasks[0]["predictions"][0]
    assert first["score"] == pytest.approx(0.8)
    assert first["result"][0]["value"] == {"choices": [data.classes[4]]}
    assert tasks[1]["predictions"][0]["result"][0]["value"] == {"choices": [data.classes[1]]}
    assert "labels/round1.json" in (out / "README.txt").read_text()

    plain = write_batch(data, [3], out_dir=tmp_path / "initial", labels_file="labels/initial.csv")
    assert "predictions" not in json.loads((plain / "label_studio.json").read_text())[0]


def test_segmentation_import_has_class_colours_and_predicted_brush_masks(tmp_path):
    data = segmentation_dataset()
    probs = probabilities(data, SEG_POOL)
    out = write_batch(
        data, SEG_POOL, out_dir=tmp_path / "to_label", labels_file="round1.csv", probs=probs
    )
    brush = ET.parse(out / "label_studio.xml").getroot().find("BrushLabels")
    colours = [line.split(",") for line in (out / "classes.csv").read_text().splitlines()[1:4]]
    assert [(lab.get("value"), lab.get("background")) for lab in brush] == [
        (name, colour) for _, name, colour in colours
    ]
    tasks = json.loads((out / "label_studio.json").read_text())
    h, w = data.image_shape
    valid = np.isfinite(data.depth_m[data.train_idx[SEG_POOL[0]]])
    painted = np.full((h, w), IGNORE_INDEX)
    for region in tasks[0]["predictions"][0]["result"]:
        assert (region["original_height"], region["original_width"]) == (h, w)
        k = SEG_CLASSES.index(region["value"]["brushlabels"][0])
        mask = rle_to_mask(region["value"]["rle"], h, w)
        assert (painted[mask] == IGNORE_INDEX).all()  # regions do not overlap
        painted[mask] = k
    expected = np.where(valid, probs[0].argmax(axis=0), IGNORE_INDEX)
    assert np.array_equal(painted, expected)
    assert picture(tasks[0]["data"]["image"]).shape == (h, w, 3)
    assert picture(tasks[0]["data"]["variants"]).shape[1] > 2 * w


# ---------------------------------------------------------------- in: recorded exports


def test_recorded_classification_exports_give_the_annotated_classes(tmp_path):
    data = classification_dataset()
    for name in ("classification_initial_export.json", "classification_round1_export.json"):
        export = fixture(name)
        pool = pool_of(data, export)
        got = read_label_file(FIXTURES / name, data, pool)
        assert got.tolist() == data.labels[data.train_idx[pool]].tolist()
    # round 1's tasks carry the round-0 model's predictions; they are not labels
    assert all(t["predictions"] for t in fixture("classification_round1_export.json"))


def test_recorded_segmentation_export_gives_the_annotated_masks():
    data = segmentation_dataset()
    got = read_export(FIXTURES / "segmentation_export.json", data, SEG_POOL)
    assert got.dtype == np.uint8
    assert np.array_equal(got, data.labels[data.train_idx[SEG_POOL]])


def test_a_stroke_painted_in_the_browser_wins_over_the_pre_annotation(tmp_path):
    data = segmentation_dataset()
    export = fixture("segmentation_browser_export.json")
    path = FIXTURES / "segmentation_browser_export.json"
    with pytest.raises(ValueError, match=r"no submitted annotation for 2 sample\(s\)"):
        read_export(path, data, SEG_POOL)
    painted = [t for t in export if t["annotations"]]
    sample = int(painted[0]["data"]["sample"])
    pool = pool_of(data, painted)
    got = read_export(save(tmp_path, painted), data, pool)[0]
    regions = painted[0]["annotations"][0]["result"]
    stroke = [r for r in regions if r.get("origin") == "manual"]
    assert len(stroke) == 1 and stroke[0]["value"]["brushlabels"] == ["car"]
    h, w = data.image_shape
    alpha = decode_rle(stroke[0]["value"]["rle"]).reshape(h, w, 4)[..., 3]
    assert 0 < alpha.max() < 128  # the front end paints semi-transparent
    in_stroke = alpha > 0
    assert 10 < in_stroke.sum() < h * w // 4
    assert (got[in_stroke] == SEG_CLASSES.index("car")).all()
    probs = probabilities(data, SEG_POOL)[SEG_POOL.index(pool[0])]
    valid = np.isfinite(data.depth_m[data.train_idx[pool[0]]])
    predicted = np.where(valid, probs.argmax(axis=0), IGNORE_INDEX)
    assert np.array_equal(got[~in_stroke], predicted[~in_stroke]), sample


# ---------------------------------------------------------------- in: what is refused


def classification_case(tmp_path, change):
    data = classification_dataset()
    export = copy.deepcopy(fixture("classification_round1_export.json"))
    pool = pool_of(data, export)
    pool = change(export, pool, data) or pool
    return save(tmp_path, export), data, pool


def choose(task, name, annotation_id=None, ground_truth=False):
    annotation = copy.deepcopy(task["annotations"][0])
    annotation["result"][0]["value"]["choices"] = [name]
    if annotation_id is not None:
        annotation["id"] = annotation_id
        annotation["ground_truth"] = ground_truth
        task["annotations"].append(annotation)
    else:
        task["annotations"][0] = annotation


def other_class(data, task):
    given = task["annotations"][0]["result"][0]["value"]["choices"][0]
    return next(c for c in data.classes if c != given)


CASES = {
    "unknown class": (
        lambda e, p, d: choose(e[0], "bycicle"),
        r"task \d+ \(sample \d+\) annotation \d+: 'bycicle' is not a class; expected one of",
    ),
    "two classes": (
        lambda e, p, d: e[0]["annotations"][0]["result"][0]["value"].update(
            choices=[d.classes[0], d.classes[1]]
        ),
        r"annotation \d+: 2 classes chosen",
    ),
    "not in the batch": (lambda e, p, d: p[1:], r"sample \d+ was not asked for in this batch"),
    "no sample of the dataset": (
        lambda e, p, d: e[0]["data"].update(sample=987654),
        r"sample 987654 is not a sample id of the dataset",
    ),
    "a task twice": (
        lambda e, p, d: e.append(copy.deepcopy(e[0])) and None,
        r"sample \d+ is also task \d+; import each batch",
    ),
    "no annotation": (
        lambda e, p, d: e[1].update(annotations=[]),
        r"no submitted annotation for 1 sample\(s\) of the batch \(sample \d+ \(task \d+\)\)",
    ),
    "only skipped": (
        lambda e, p, d: e[1]["annotations"][0].update(was_cancelled=True),
        r"no submitted annotation for 1 sample\(s\)",
    ),
    "no task": (lambda e, p, d: e.pop() and None, r"sample \d+ \(no task\)"),
    "disagreeing annotations": (
        lambda e, p, d: choose(e[0], other_class(d, e[0]), annotation_id=999),
        r"annotations \d+ and 999 disagree \('.+' and '.+'\); delete one or mark the right "
        "one as ground truth",
    ),
    "JSON-MIN": (
        lambda e, p, d: e.__setitem__(0, {"image": "x", "label": "car"}),
        r"is not a Label Studio JSON export .* not JSON-MIN or CSV",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_wrong_export_is_one_error_naming_file_task_and_value(tmp_path, case):
    change, message = CASES[case]
    path, data, pool = classification_case(tmp_path, change)
    with pytest.raises(ValueError, match=message) as err:
        read_label_file(path, data, pool)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_a_ground_truth_annotation_settles_a_disagreement(tmp_path):
    def change(export, pool, data):
        choose(export[0], other_class(data, export[0]), annotation_id=999, ground_truth=True)

    path, data, pool = classification_case(tmp_path, change)
    export = json.loads(path.read_text())
    got = read_label_file(path, data, pool)
    assert data.classes[got[0]] == export[0]["annotations"][1]["result"][0]["value"]["choices"][0]
    assert got[1:].tolist() == data.labels[data.train_idx[pool[1:]]].tolist()


def test_a_brush_mask_of_the_wrong_size_is_refused(tmp_path):
    data = segmentation_dataset()
    export = fixture("segmentation_export.json")
    export[1]["annotations"][0]["result"][0]["original_width"] = 33
    with pytest.raises(ValueError, match=r"a brush mask of 33x24 pixels \(width x height\); "):
        read_export(save(tmp_path, export), data, pool_of(data, export))
    export[1]["annotations"][0]["result"][0].update(original_width=32)
    export[1]["annotations"][0]["result"][0]["value"]["brushlabels"] = ["tree"]
    with pytest.raises(ValueError, match=r"'tree' is not a class; expected one of: road, car"):
        read_export(save(tmp_path, export), data, pool_of(data, export))


def test_accept_reads_an_export_in_place_of_the_csv_and_writes_nothing_when_refused(tmp_path):
    data = classification_dataset()
    data.save(tmp_path / "dataset.npz")
    export = fixture("classification_round1_export.json")
    queried = pool_of(data, export)
    before = [p for p in range(len(data.train_idx)) if p not in queried][:3]
    request = tmp_path / "query.json"
    request.write_text(json.dumps({"pool_indices": sorted(before + queried), "queried": queried}))
    from spl_al.data.label_files import save_labels

    save_labels(tmp_path / "before.npz", before, data.labels[data.train_idx[before]])
    csv_file, json_file = tmp_path / "labels/round1.csv", tmp_path / "labels/round1.json"
    out_json, out_npz = tmp_path / "labeled.json", tmp_path / "labels.npz"

    def accept():
        return accept_labels(
            tmp_path / "dataset.npz",
            request,
            labels_file=csv_file,
            batch_dir=tmp_path / "to_label",
            previous_labels=tmp_path / "before.npz",
            out_labeled=out_json,
            out_labels=out_npz,
            export_file=json_file,
        )

    with pytest.raises(ValueError, match=f"save it as {csv_file}, or label .* as {json_file}"):
        accept()
    json_file.parent.mkdir()
    wrong = copy.deepcopy(export)
    choose(wrong[2], "bycicle")
    json_file.write_text(json.dumps(wrong))
    with pytest.raises(ValueError, match="'bycicle' is not a class"):
        accept()
    assert not out_json.exists() and not out_npz.exists()
    json_file.write_text(json.dumps(export))
    csv_file.write_text("sample,label\n")
    with pytest.raises(ValueError, match=f"both {csv_file} and {json_file} exist"):
        accept()
    csv_file.unlink()
    assert accept() == {"accepted": len(queried), "n_labeled": len(before) + len(queried)}
    all_given = before + queried
    assert (
        labels_for(out_npz, all_given).tolist() == data.labels[data.train_idx[all_given]].tolist()
    )


# ---------------------------------------------------------------- opt-in: the real server

LABEL_STUDIO = os.environ.get("SPL_AL_LABEL_STUDIO")
needs_label_studio = pytest.mark.skipif(
    not LABEL_STUDIO,
    reason="set SPL_AL_LABEL_STUDIO to a label-studio executable (in its own venv) to run",
)


@pytest.mark.slow
@needs_label_studio
def test_two_rounds_through_a_real_label_studio(tmp_path):
    script = ROOT / "scripts/label-studio-roundtrip.py"
    cmd = [sys.executable, str(script), "--label-studio", LABEL_STUDIO, "--workdir", str(tmp_path)]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-3000:]
    assert "OK: two rounds labeled in Label Studio" in run.stdout
