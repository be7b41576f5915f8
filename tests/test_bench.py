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


@pytest.mark.parametrize("batch", ["5", "[5]"])  # one batch, or a per-round list
def test_projection_counts_every_training_job_and_image(tmp_path, batch):
    """Two methods x one seed x two rounds, 3 epochs: round 0 of each number of variants
    once (train_initial), each job epochs x (one batch of all its images)."""
    from spl_al.bench import projection

    override = tmp_path / "small.yaml"
    override.write_text(
        "datasets:\n"
        "  real_cls:\n"
        f"    al: {{initial: 10, batch: {batch}}}\n"
        "    variants: {n: 4}\n"
        "    train: {fit: {epochs: 3, min_steps: 0, batch_size: 512}}\n"
        "    experiments:\n"
        "      budget: {methods: [random, duis], seeds: [1], rounds: 2}\n"
        "      ablation: null\n"
        "      sensitivity: null\n"
    )
    config = projection.merged_config([override])
    counts = projection.protocol_images(config, "real_cls")
    # random: 10 then 15 images; duis (observed + 4 variants): 50 then 75
    assert counts["jobs"] == 4 and counts["steps"] == 4 * 3
    assert counts["train_images"] == 3 * (10 + 15 + 50 + 75)
    assert counts["largest_job_images"] == 3 * 75
    n_pool, n_test = 770, 330  # 1,100 images, 30% test
    # every round is evaluated; only round 0 is scored (round 1 is the last)
    assert counts["forward_images"] == 4 * n_test + (n_pool - 10) + 5 * (n_pool - 10)


def test_projection_counts_resnet18_flops_like_its_known_cost():
    """ResNet-18 is 1.82 GMAC per 224x224 image: ~0.30 GFLOP at 64x64 forward (2 input
    channels instead of 3 take a little off), and a training step ~3x a forward pass."""
    from spl_al.bench import projection

    config = projection.merged_config([projection.ROOT / "config" / "paper.yaml"])
    task, model, _, _, shape, n_classes = projection.model_case(config, "real_cls")
    train, forward = projection.flops_per_image(task, model, shape, n_classes, batch=2)
    assert 0.25e9 < forward < 0.31e9
    assert 2.8 < train / forward < 3.2


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
