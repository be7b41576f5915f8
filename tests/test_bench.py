"""The learnability benchmark's command line: recipe overrides reach the learner."""

import pytest

from spl_al.bench import learnability
from spl_al.data import make_classification_dataset
from spl_al.variants import make_variants


def test_recipe_overrides_read_yaml_values():
    out = learnability.recipe_overrides(["fit.mixup=0.4", "model.width=32", "fit.hflip=false"])
    assert out == {"model": {"width": 32}, "fit": {"mixup": 0.4, "hflip": False}}
    for bad in ("mixup=0.4", "fit.mixup", "train.lr=1", "fit.=1"):
        with pytest.raises(ValueError, match="--set takes"):
            learnability.recipe_overrides([bad])


def test_learnability_runs_a_dataset_file_with_an_overridden_recipe(tmp_path, capsys):
    data = make_classification_dataset(
        n_per_class=6, image_shape=(16, 16), classes=("apple", "bike"), workers=1
    )
    path = make_variants(data, n_variants=2, seed=0).save(tmp_path / "tiny.npz")
    args = [
        str(path),
        "--fractions",
        "1.0",
        "--seeds",
        "1",
        "--set",
        "fit.steps=2",
        "fit.min_steps=0",
    ]
    assert learnability.main(args) == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("| tiny"))
    assert row.count("±") == 3  # linear reference, learner, learner with variants
    with pytest.raises(ValueError, match=r"TrainConfig\.lr"):
        learnability.main([*args, "fit.lr=-1"])


def test_capture_bench_reads_every_format_back_to_its_simulation(capsys, monkeypatch):
    from spl_al.bench import captures

    monkeypatch.delenv("SPL_AL_REAL_CAPTURES", raising=False)
    assert captures.main(["--repeats", "1"]) == 0
    rows = [line.split("|")[1:-1] for line in capsys.readouterr().out.splitlines()]
    rows = [[cell.strip() for cell in row] for row in rows if len(row) == 11][2:]
    assert [row[0] for row in rows] == [
        "sparse_mat",
        "timestamps_mat (4 ps)",
        "cube .npz",
        "cube HDF5",
        "ptu",
    ]
    for row in rows:  # sigma 520 ps, MSPPP 5, SBR 1 simulated
        assert abs(float(row[8]) / 520 - 1) < 0.1 and abs(float(row[9]) / 5 - 1) < 0.1
        assert abs(float(row[10]) - 1) < 0.1 and row[2] == rows[0][2]
