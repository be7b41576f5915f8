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
