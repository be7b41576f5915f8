"""spl_al.deploy: model cards, ONNX export checked with onnxruntime, predict on new frames."""

from __future__ import annotations

import csv
import json
import shutil

import numpy as np
import pytest
import torch
from helpers.deploy_models import make_round
from helpers.photon_captures import simulate_capture, write_ptu, write_sparse_mat
from helpers.photon_scenes import disc_scene

from spl_al.__main__ import main as cli
from spl_al.deploy.bundle import open_model
from spl_al.deploy.card import read_card
from spl_al.deploy.export import MAX_LOGIT_DIFF, MIN_AGREEMENT, export_onnx
from spl_al.models.normalise import _nanmedian
from spl_al.photon import SensorParams

pytest.importorskip("onnxruntime")

SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=1024)


@pytest.fixture(scope="module")
def rounds(tmp_path_factory):
    root = tmp_path_factory.mktemp("deploy")
    return {task: make_round(root / task, task) for task in ("classification", "segmentation")}


@pytest.fixture(scope="module")
def exported(rounds, tmp_path_factory):
    out = tmp_path_factory.mktemp("onnx")
    return {
        task: export_onnx(pt, out / f"{task}.onnx", log=lambda _: None) and out / f"{task}.onnx"
        for task, pt in rounds.items()
    }


def test_export_median_is_the_training_median():
    flat = torch.tensor(
        [[3.0, float("nan"), 1.0, 2.0, 8.0], [float("nan")] * 5, [4.0, 1.0, float("nan"), 2.0, 9.0]]
    )
    expected = flat.nanmedian(dim=1).values

    class Median(torch.nn.Module):
        def forward(self, x):
            return _nanmedian(x)

    import io

    import onnxruntime as ort

    buffer = io.BytesIO()
    torch.onnx.export(Median(), (flat,), buffer, dynamo=False, opset_version=17)
    got = ort.InferenceSession(buffer.getvalue()).run(None, {"x": flat.numpy()})[0]
    assert got[0] == 2.0 and np.isnan(got[1]) and got[2] == 2.0  # lower median of 4
    np.testing.assert_array_equal(got, expected.numpy())


@pytest.mark.parametrize("task", ["classification", "segmentation"])
def test_onnxruntime_reproduces_torch_on_the_test_split(exported, rounds, task):
    card = read_card(exported[task].with_name(f"{task}.card.json"))
    check = card["onnx"]["check"]
    assert check["max_abs_logit_diff"] <= MAX_LOGIT_DIFF
    assert check["argmax_agreement"] >= MIN_AGREEMENT
    assert check["unit"] == ("sample" if task == "classification" else "pixel")
    # dynamic batch: 1 and 5 frames give what torch's own preprocessing and model give
    onnx_model, torch_model = open_model(exported[task]), open_model(rounds[task])
    from spl_al.data import Dataset

    data = Dataset.load(rounds[task].with_name("dataset.npz"))
    frames = np.where(data.valid[:5], data.depth_m[:5], np.nan).astype(np.float32)
    for batch in (frames[:1], frames):
        a, b = onnx_model.run(batch)[0], torch_model.run(batch)[0]
        np.testing.assert_allclose(a, b, atol=MAX_LOGIT_DIFF)
    # the card names the per-level metric and renders it
    assert card["test"]["per_level"] and "per MSPPP level" in card["test"]["per_level_metric"]
    md = exported[task].with_name(f"{task}.card.md").read_text()
    assert "MSPPP high" in md and "argmax agreement" in md and card["provenance"]["config_hash"]


def test_a_valid_pixel_at_zero_metres_is_a_void_on_both_sides(rounds, tmp_path):
    """A reconstruction can mark a pixel valid at exactly 0 m; the deployed graph's rule
    (finite, positive depth) makes it a void, and the check must give torch the same
    void, or that one image's input differs and the export is refused (seen on
    real_cls: 0.012 logit difference from one such pixel)."""
    from spl_al.data import Dataset

    data = Dataset.load(rounds["classification"].with_name("dataset.npz"))
    for i in data.test_idx[:3]:
        rows, cols = np.nonzero(data.valid[i])
        data.depth_m[i, rows[: len(rows) // 3], cols[: len(rows) // 3]] = 0.0
    path = data.save(tmp_path / "dataset.npz", precision="float32")
    card = export_onnx(
        rounds["classification"], tmp_path / "zero.onnx", dataset_path=path, log=lambda _: None
    )
    assert card["onnx"]["check"]["max_abs_logit_diff"] <= MAX_LOGIT_DIFF


def test_card_records_what_predict_needs(rounds):
    card = read_card(rounds["segmentation"].with_name("model.card.json"))
    assert card["data"]["image_shape"] == [16, 64] and len(card["data"]["colours"]) == 7
    assert card["model"]["input_kind"] == "range_m" and card["run"]["n_labeled"] == 4
    assert card["run"]["variants_per_group"] == 2 and len(card["run"]["labeled_uids"]) == 4
    lo, hi = card["data"]["trained_conditions"]["msppp"]
    assert 0 < lo <= hi


def test_bad_exports_say_one_sentence_and_write_nothing(rounds, tmp_path):
    pt = rounds["classification"]
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ValueError, match="cannot create its folder"):
        export_onnx(pt, blocker / "out.onnx")
    with pytest.raises(ValueError, match=r"must be a \.onnx file"):
        export_onnx(pt, tmp_path / "out.txt")
    # a model file of another dataset beside this card
    other = tmp_path / "other" / "model.pt"
    other.parent.mkdir()
    shutil.copy(rounds["segmentation"], other)
    shutil.copy(pt.with_name("model.card.json"), other.with_name("model.card.json"))
    with pytest.raises(ValueError, match="not the model its card"):
        export_onnx(other, tmp_path / "other.onnx")
    # ... even when the card's checksum is made to match: the weights do not fit
    card = json.loads(other.with_name("model.card.json").read_text())
    from spl_al.deploy.card import file_sha256

    card["model"]["sha256"] = file_sha256(other)
    other.with_name("model.card.json").write_text(json.dumps(card))
    with pytest.raises(ValueError, match="not weights of the smallcnn"):
        export_onnx(other, tmp_path / "other.onnx")
    card["version"] = 99
    other.with_name("model.card.json").write_text(json.dumps(card))
    with pytest.raises(ValueError, match="model card version 99"):
        export_onnx(other, tmp_path / "other.onnx")
    shutil.copy(pt, tmp_path / "lonely.pt")
    with pytest.raises(ValueError, match="no model card"):
        export_onnx(tmp_path / "lonely.pt", tmp_path / "lonely.onnx")
    assert not list(tmp_path.glob("*.onnx")) and not list(tmp_path.glob(".*tmp"))


def test_pointnet_export_is_refused_with_the_workaround(tmp_path):
    pc = {
        "arch": "pointnet2",
        "n_points": 32,
        "centres": [8, 4],
        "radii_m": [2, 6],
        "neighbours": 4,
        "width": 4,
    }
    pt = make_round(tmp_path / "pc", "segmentation", pc)
    with pytest.raises(ValueError, match="python -m spl_al predict"):
        export_onnx(pt, tmp_path / "pc.onnx")
    assert not (tmp_path / "pc.onnx").exists()


@pytest.fixture(scope="module")
def capture_folder(tmp_path_factory):
    """Raw captures in two formats (sparse .mat, PicoQuant .ptu) and a release frame."""
    from spl_al.photon.io import load_capture
    from spl_al.photon.release import reconstruct_capture, save_release

    root = tmp_path_factory.mktemp("captures") / "new"
    root.mkdir()
    for j, (msppp, sbr) in enumerate([(5.0, 1.0), (0.5, 1.0)]):
        events = simulate_capture(disc_scene(32, 32, 3.0, 6.0), msppp, sbr, SENSOR, seed=j)
        write_sparse_mat(root / f"scan{j}.mat", events, SENSOR)
        write_ptu(root / f"scan{j}.ptu", events, SENSOR)
    rec = reconstruct_capture(load_capture(root / "scan0.mat"), pulse_sigma_s=520e-12)
    save_release(root / "release" / "frame.npz", rec)
    return root


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("backend", ["pt", "onnx"])
def test_predict_classifies_captures_of_two_formats_with_conditions(
    rounds, exported, capture_folder, tmp_path, backend
):
    model = rounds["classification"] if backend == "pt" else exported["classification"]
    out = tmp_path / "pred"
    assert cli(["predict", str(model), str(capture_folder), "--out", str(out)]) == 0
    rows = _rows(out / "predictions.csv")
    assert [r["file"] for r in rows] == [
        "release/frame.npz",
        "scan0.mat",
        "scan0.ptu",
        "scan1.mat",
        "scan1.ptu",
    ]
    classes = read_card(rounds["classification"].with_name("model.card.json"))["data"]["classes"]
    for row in rows:
        assert row["class"] in classes and 0 < float(row["probability"]) <= 1
        assert len(row["top3"].split(";")) == 3
        assert float(row["msppp"]) > 0 and float(row["sbr"]) > 0
    by_file = {r["file"]: r for r in rows}
    # both formats of one capture give the same frame and the same answer
    assert by_file["scan0.mat"]["top3"] == by_file["scan0.ptu"]["top3"]
    assert abs(float(by_file["scan0.mat"]["msppp"]) - 5) < 1
    assert by_file["scan0.mat"]["warning"] == ""  # MSPPP 5, SBR 1, 32x32: as trained
    assert "MSPPP" in by_file["scan1.mat"]["warning"]  # 0.5 photons: below the trained range


def test_predict_segments_with_palette_masks_and_fractions(rounds, capture_folder, tmp_path):
    from PIL import Image

    out = tmp_path / "seg"
    assert (
        cli(
            [
                "predict",
                str(rounds["segmentation"]),
                str(capture_folder / "scan0.mat"),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    (row,) = _rows(out / "predictions.csv")
    fractions = [float(v) for k, v in row.items() if k.startswith("fraction_")]
    assert len(fractions) == 7 and abs(sum(fractions) - 1) < 1e-3
    assert "shape 32x32 not the trained 16x64" in row["warning"]
    image = Image.open(out / row["mask"])
    assert image.mode == "P" and image.size == (32, 32)
    labels = np.load(out / "masks" / "scan0.npz")["labels"]
    assert labels.shape == (32, 32) and set(np.unique(labels)) <= set(range(7)) | {255}


def test_predict_bad_input_is_one_sentence_and_writes_nothing(
    rounds, exported, capture_folder, tmp_path, capsys
):
    broken = tmp_path / "in"
    broken.mkdir()
    shutil.copy(capture_folder / "scan0.mat", broken / "a.mat")
    (broken / "b.mat").write_bytes(b"not a mat file")
    out = tmp_path / "pred"
    assert cli(["predict", str(rounds["classification"]), str(broken), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "b.mat" in err and len(err.splitlines()) == 1
    assert not out.exists()
    # the ONNX graph takes its training shape only
    assert (
        cli(
            [
                "predict",
                str(exported["segmentation"]),
                str(capture_folder / "scan0.mat"),
                "--out",
                str(out),
            ]
        )
        == 2
    )
    assert "cannot take" in capsys.readouterr().err and not out.exists()
    assert cli(["predict", str(tmp_path / "none.pt"), str(broken), "--out", str(out)]) == 2
    assert cli(["export", str(rounds["classification"]), "/proc/x/y.onnx"]) == 2
    assert not out.exists()


def test_inference_bench_times_torch_and_onnxruntime():
    from spl_al.bench.inference import bench_one

    result = bench_one(
        "classification",
        {"arch": "smallcnn"},
        shape=(16, 16),
        n_classes=3,
        threads=1,
        batch_size=4,
        repeats=3,
    )
    assert set(result) == {"torch", "onnxruntime"}
    for latency_s, fps in result.values():
        assert latency_s > 0 and fps > 0
    pc = {"arch": "pointnet2", "n_points": 16, "centres": [4], "radii_m": [4], "neighbours": 4}
    assert set(
        bench_one(
            "segmentation",
            {**pc, "width": 4},
            shape=(8, 16),
            n_classes=7,
            threads=1,
            batch_size=2,
            repeats=3,
        )
    ) == {"torch"}


def test_predict_on_a_real_capture(rounds, ugv45m_dir, tmp_path):
    """Opt-in ($SPL_AL_REAL_CAPTURES): a real ugv45m frame through predict, its
    conditions estimated from its photons and its other shape flagged."""
    out = tmp_path / "real"
    assert (
        cli(
            [
                "predict",
                str(rounds["classification"]),
                str(ugv45m_dir / "car_20.mat"),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    (row,) = _rows(out / "predictions.csv")
    assert float(row["msppp"]) > 0 and float(row["sbr"]) > 0
    assert "not the trained 32x32" in row["warning"]
