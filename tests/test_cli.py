"""One ``spl-al`` command (estimate, reconstruct, export, predict, query), and ``spl-al
query``: a trained model picks a folder's frames and writes their labeling batch."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers.deploy_models import make_round
from helpers.photon_captures import simulate_capture, write_sparse_mat
from helpers.photon_scenes import disc_scene

from spl_al.__main__ import COMMANDS
from spl_al.__main__ import main as cli
from spl_al.photon import SensorParams

ROOT = Path(__file__).resolve().parents[1]
COMMAND_NAMES = ("estimate", "reconstruct", "export", "predict", "query")


def test_spl_al_help_lists_every_command():
    out = subprocess.run(
        [sys.executable, "-m", "spl_al", "--help"],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout
    listed = [line.split()[0] for line in out.splitlines() if line.startswith("  ")]
    assert set(COMMAND_NAMES) <= set(listed) and set(listed) == set(COMMANDS)


@pytest.mark.parametrize("command", COMMAND_NAMES)
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as done:
        cli([command, "--help"])
    assert done.value.code == 0
    assert "usage" in capsys.readouterr().out.lower()


def test_the_module_entry_points_keep_working(capsys):
    from spl_al.bench.__main__ import main as bench
    from spl_al.photon.__main__ import main as photon

    for run, argv in ((photon, ["reconstruct", "--help"]), (bench, ["estimate", "--help"])):
        with pytest.raises(SystemExit) as done:
            run(argv)
        assert done.value.code == 0
    assert capsys.readouterr().out.count("usage") == 2


def test_an_unknown_command_is_one_line(capsys):
    assert cli(["nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "query" in err


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    root = tmp_path_factory.mktemp("models")
    return {task: make_round(root / task, task) for task in ("classification", "segmentation")}


def release_folder(root: Path, shape, n: int, seed: int = 0) -> Path:
    """``n`` release-layout frames (depth_ssp, 0 = no return; msppp, sbr) of ``shape``."""
    rng = np.random.default_rng(seed)
    root.mkdir(parents=True)
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    for k in range(n):
        depth = rng.uniform(3, 6) + 0.02 * rng.normal() * xx + 0.02 * yy
        r, c = rng.integers(0, shape[0] // 2), rng.integers(0, shape[1] // 2)
        depth[r : r + shape[0] // 3, c : c + shape[1] // 3] -= rng.uniform(0.5, 1.5)
        depth[rng.random(shape) < 0.1] = 0
        np.savez(root / f"frame{k:02d}.npz", depth_ssp=depth, msppp=5.0, sbr=1.0)
    return root


def rows(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_query_writes_the_labeling_batch_of_a_trained_classifier(models, tmp_path, capsys):
    frames = release_folder(tmp_path / "frames", (32, 32), 24)
    # a raw capture beside the release frames, reconstructed as `predict` reconstructs it
    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=1024)
    events = simulate_capture(disc_scene(32, 32, 3.0, 6.0), 5.0, 1.0, sensor, seed=0)
    write_sparse_mat(frames / "scan.mat", events, sensor)
    (tmp_path / "labeled.csv").write_text("file,label\nframe00.npz,apple\nframe05.npz,bin\n")
    out = tmp_path / "batch"
    args = ["query", "--model", str(models["classification"]), "--frames", str(frames)]
    args += ["--labeled", str(tmp_path / "labeled.csv"), "--budget", "4", "--method", "duis"]
    assert cli([*args, "--out", str(out)]) == 0
    assert "4 of 23 unlabeled frames" in capsys.readouterr().out  # 24 + 1 frames, 2 labeled
    asked = rows(out / "to_label.csv")
    files = [r["file"] for r in asked]
    assert len(set(files)) == 4 and not {"frame00.npz", "frame05.npz"} & set(files)
    order = sorted(p.name for p in frames.iterdir())  # a sample id: its place in the folder
    assert [r["sample"] for r in asked] == [str(order.index(f)) for f in files]
    for name in ("classes.csv", "contact_sheet.png", "label_studio.xml", "README.txt"):
        assert (out / name).is_file()
    assert all((out / f"sample{r['sample']}.png").is_file() for r in asked)
    tasks = json.loads((out / "label_studio.json").read_text())
    assert len(tasks) == 4 and all(t["predictions"] for t in tasks)
    assert "variants" in tasks[0]["data"]  # DUIS's variants beside each frame
    readme = (out / "README.txt").read_text()
    assert "chosen by duis" in readme and "Snakemake" not in readme
    # the filled batch is the next query's --labeled: none of its frames comes again
    with open(tmp_path / "round1.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["sample", "file", "label"])
        writer.writerows([r["sample"], r["file"], "apple"] for r in asked)
    again = [*args, "--labeled", str(tmp_path / "round1.csv"), "--out", str(tmp_path / "b2")]
    assert cli([*again, "--seed", "1", "--method", "margin"]) == 0
    second = {r["file"] for r in rows(tmp_path / "b2" / "to_label.csv")}
    assert len(second) == 4 and not second & (set(files) | {"frame00.npz", "frame05.npz"})


def test_query_segments_with_a_trained_segmenter(models, tmp_path):
    frames = release_folder(tmp_path / "frames", (16, 64), 12)
    out = tmp_path / "batch"
    args = ["query", "--model", str(models["segmentation"]), "--frames", str(frames)]
    assert cli([*args, "--budget", "3", "--out", str(out), "--params", '{"n_cand": 5}']) == 0
    asked = rows(out / "to_label.csv")
    assert len(asked) == 3 and all(r["mask"] for r in asked)
    tasks = json.loads((out / "label_studio.json").read_text())
    assert tasks[0]["predictions"][0]["result"][0]["type"] == "brushlabels"


def test_query_keeps_the_variants_for_the_next_round(models, tmp_path, capsys):
    """--variants: made and written by the first query, read by the next with the same
    picks, refused for another folder of frames."""
    frames = release_folder(tmp_path / "frames", (32, 32), 14)
    kept = tmp_path / "variants.npz"
    base = ["query", "--model", str(models["classification"]), "--budget", "3"]
    plain = [*base, "--frames", str(frames), "--out", str(tmp_path / "plain")]
    assert cli(plain) == 0
    first = [*base, "--frames", str(frames), "--variants", str(kept), "--jobs", "2"]
    assert cli([*first, "--out", str(tmp_path / "a")]) == 0
    assert "wrote the variants of 14 frames" in capsys.readouterr().out
    assert cli([*first, "--out", str(tmp_path / "b")]) == 0
    assert "read the variants of 14 frames" in capsys.readouterr().out
    picks = [[r["file"] for r in rows(tmp_path / b / "to_label.csv")] for b in ("plain", "a", "b")]
    assert picks[0] == picks[1] == picks[2]
    other = release_folder(tmp_path / "other", (32, 32), 14, seed=1)
    args = [*base, "--frames", str(other), "--variants", str(kept), "--out", str(tmp_path / "c")]
    assert cli(args) == 2
    err = capsys.readouterr().err.strip()
    assert "holds the variants of other frames or settings" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "c").exists()


def test_query_runs_an_onnx_file_with_or_without_its_card(models, tmp_path):
    pytest.importorskip("onnxruntime")
    from spl_al.deploy.export import export_onnx

    frames = release_folder(tmp_path / "frames", (32, 32), 16)
    onnx = tmp_path / "model.onnx"
    export_onnx(models["classification"], onnx, log=lambda _: None)
    base = ["query", "--frames", str(frames), "--budget", "3"]
    assert cli([*base, "--model", str(onnx), "--out", str(tmp_path / "a")]) == 0
    own = tmp_path / "own" / "mine.onnx"  # a file of the user's own: no card beside it
    own.parent.mkdir()
    shutil.copy(onnx, own)
    assert cli([*base, "--model", str(own), "--out", str(tmp_path / "b")]) == 2
    names = "apple,banana,bin"
    assert cli([*base, "--model", str(own), "--classes", names, "--out", str(tmp_path / "b")]) == 0
    assert len(rows(tmp_path / "b" / "to_label.csv")) == 3
    assert (tmp_path / "b" / "classes.csv").read_text().count("\n") == 4


def test_query_bad_input_is_one_sentence_and_writes_nothing(models, tmp_path, capsys):
    frames = release_folder(tmp_path / "frames", (32, 32), 10)
    (tmp_path / "wrong.csv").write_text("file,label\nnot_a_frame.npz,apple\n")
    (tmp_path / "nofile.csv").write_text("sample,label\n3,apple\n")
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "notes.txt").write_text("mine")
    out = tmp_path / "batch"
    base = ["query", "--model", str(models["classification"]), "--frames", str(frames)]
    cases = [
        (["--budget", "11", "--out", str(out)], "budget 11 is more than the 10 unlabeled"),
        (["--budget", "2", "--labeled", str(tmp_path / "wrong.csv"), "--out", str(out)], "line 2"),
        (["--budget", "2", "--labeled", str(tmp_path / "nofile.csv"), "--out", str(out)], "file"),
        (["--budget", "2", "--method", "badge", "--out", str(out)], None),  # .pt: features
        (["--budget", "2", "--method", "dropquery", "--out", str(out)], "last linear layer"),
        (["--budget", "2", "--params", "[1]", "--out", str(out)], "JSON object"),
        (["--budget", "2", "--out", str(taken)], "holds no to_label.csv"),
    ]
    for extra, expected in cases:
        code = cli([*base, *extra])
        err = capsys.readouterr().err.strip()
        if expected is None:
            assert code == 0
            shutil.rmtree(out)
            continue
        assert code == 2, extra
        assert err.startswith("error: ") and expected in err and len(err.splitlines()) == 1
        assert not out.exists() and sorted(p.name for p in taken.iterdir()) == ["notes.txt"]
    assert not list(tmp_path.glob(".batch*"))
