"""The benches: recipe overrides reach the learner, tuning never reads the test split,
the projection's counts, the capture bench."""

import ast
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

import spl_al.bench
import spl_al.bench.__main__ as bench_main
from spl_al.bench import learnability, spread
from spl_al.data import Dataset, make_classification_dataset
from spl_al.data.variants import make_variants

ROOT = Path(__file__).resolve().parent.parent
BENCH_MODULES = sorted(Path(spl_al.bench.__file__).parent.glob("*.py"))


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
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| tiny"))
    assert row.count("±") == 3  # linear reference, learner, learner with variants
    assert "8 training groups = 6 fit + 2 validation" in out
    assert "validation split: 0.2 of the training pool, seed 0" in out
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
        "      budget: {methods: [random, duis], seeds: [1], rounds: 2, matched: false}\n"
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
    train, forward = projection.flops_per_image(
        task, model, shape=shape, n_classes=n_classes, batch=2
    )
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


# ---------------------------------------------------------------- no tuning on the test split


def _test_split_reads(source: str) -> list[str]:
    """Where ``source`` reaches for the test split: ``test_idx``, ``level_idx`` (its
    split is "test" unless told) or the string "test" (``split == "test"``)."""
    hits = []
    for node in ast.walk(ast.parse(source)):
        name = getattr(node, "attr", None) or getattr(node, "id", None)
        if name in ("test_idx", "level_idx"):
            hits.append(f"line {node.lineno}: {name}")
        elif isinstance(node, ast.Constant) and node.value == "test":
            hits.append(f"line {node.lineno}: 'test'")
    return hits


def test_the_scan_finds_what_the_old_benches_did():
    assert _test_split_reads("test = dataset.test_idx") == ["line 1: test_idx"]
    assert _test_split_reads("x = d.split == 'test'\ny = d.level_idx('low')") == [
        "line 1: 'test'",
        "line 2: level_idx",
    ]


@pytest.mark.parametrize("module", BENCH_MODULES, ids=lambda p: p.name)
def test_no_bench_reads_the_test_split(module):
    hits = _test_split_reads(module.read_text())
    assert not hits, f"spl_al/bench/{module.name} reads the test split: {hits}"


class _TestSplitRaises(Dataset):
    @property
    def test_idx(self):
        raise AssertionError("a tuning bench read the test split")


def _poisoned(data: Dataset) -> Dataset:
    """``data`` with garbage images, variants and labels in its test split, whose
    ``test_idx`` raises."""
    test = data.test_idx
    rng = np.random.default_rng(0)
    labels = data.labels.copy()
    labels[test] = 0  # one class: an accuracy on these differs from one on the real labels
    depth = data.depth_m.copy()
    depth[test] = rng.uniform(1.0, 20.0, depth[test].shape)
    variants = data.variant_depth_m.copy()
    variants[test] = rng.uniform(1.0, 20.0, variants[test].shape)
    fields = {f.name: getattr(data, f.name) for f in dataclasses.fields(data)}
    fields.update(labels=labels, depth_m=depth, valid=None, variant_depth_m=variants)
    return _TestSplitRaises(**fields)


def test_tuning_benches_score_without_the_test_split():
    data = make_classification_dataset(
        n_per_class=8, image_shape=(16, 16), classes=("apple", "bike"), workers=1
    )
    data = make_variants(data, n_variants=1, seed=0)
    poisoned = _poisoned(data)
    with pytest.raises(AssertionError, match="read the test split"):
        _ = poisoned.test_idx
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    train = config["datasets"]["real_cls"]["train"]
    fit = {**train["fit"], "steps": 2, "min_steps": 0}
    kwargs = {"fractions": (0.5, 1.0), "seeds": (1,), "log": lambda _: None}
    clean = learnability.learning_curves(data, train["model"], fit, **kwargs)
    assert learnability.learning_curves(poisoned, train["model"], fit, **kwargs) == clean
    assert [r["n"] for r in clean] == [5, 10]  # halves of the 10 groups the fit part keeps
    kwargs = {"model_cfg": train["model"], "fit_cfg": fit, "seeds": [1, 2], "variants": True}
    row = spread.spread_row(data, 4, **kwargs)
    assert spread.spread_row(poisoned, 4, **kwargs) == row


def test_estimate_counts_what_the_plan_runs(tmp_path):
    """random, its matched twin Syn+Random and DUIS, two seeds, three rounds: the
    trainings, round-0 copies and queries a run makes, and the images they touch."""
    from spl_al.bench import estimate, projection

    override = tmp_path / "small.yaml"
    override.write_text(
        "datasets:\n"
        "  real_cls:\n"
        "    al: {initial: 10, batch: [5, 10]}\n"
        "    variants: {n: 4}\n"
        "    train: {fit: {epochs: 1, min_steps: 7, batch_size: 8}}\n"
        "    experiments:\n"
        "      budget: {methods: [random, duis], seeds: [1, 2], rounds: 3, matched: true}\n"
        "      ablation: null\n"
        "      sensitivity: null\n"
    )
    config = projection.merged_config([override])
    counts = estimate.plan_counts(config, "real_cls")
    # round 0 is fitted once per seed and variants per group (random; syn_random and
    # duis share theirs), rounds 1, 2 by each of the 3 methods
    assert counts["trainings"] == 2 * (2 + 3 * 2)
    assert counts["copies"] == 2 * 3 and counts["queries"] == 2 * 3 * 2
    # 7 steps of 8 images at 10, 15, 25 labeled groups (steps_by: groups)
    assert counts["train_images"] == counts["trainings"] * 7 * 8
    n_pool, n_test = 770, 330
    scored = (n_pool - 10) + (n_pool - 15)  # the pool before the queries of rounds 1, 2
    # random and syn_random score the observed image, DUIS all 5 images of a group
    assert counts["forward_images"] == counts["trainings"] * n_test + 2 * (2 + 5) * scored


@pytest.mark.parametrize("strategy", ["random", "duis", "dropquery"])
def test_the_estimate_times_every_embedding_round_it_plans(strategy):
    """A round of each framework's probe is timed for every strategy a config may plan,
    DropQuery (its own dropout head) among them, classification and segmentation."""
    from spl_al.bench import estimate
    from spl_al.experiment.plan import MethodSpec

    params = {"n_cand": 40} if strategy == "duis" else {}
    spec = MethodSpec(name=strategy, strategy=strategy, params=params, use_variants=True)
    sizes = dict(n_pool=40, m=2, n_labeled=6, repeats=1)
    assert estimate.probe_round_seconds(spec, n_test=20, dim=16, **sizes) > 0
    assert estimate.dense_round_seconds(spec, n_test=500, dim=12, **sizes) > 0


def test_the_estimate_times_an_encoder_at_the_jobs_threads(monkeypatch):
    """An encoder job trains at its rule's one thread: the estimate times its steps
    there, whatever torch's count was, and leaves that count as it found it."""
    import torch

    from spl_al.bench import estimate, projection
    from spl_al.training import dense_contrastive

    seen = []
    train = dense_contrastive.train_dense_encoder

    def spy(*args, **kwargs):
        seen.append(torch.get_num_threads())
        return train(*args, **kwargs)

    monkeypatch.setattr(dense_contrastive, "train_dense_encoder", spy)
    entry = dict(
        projection.merged_config([ROOT / "config" / "street.yaml"])["datasets"]["street_seg"]
    )
    entry["synthesis"] = {**entry["synthesis"], "n_samples": 20}
    entry["embedding"] = {**entry["embedding"], "encoder": {"width": 4, "depth": 1, "steps": 2}}
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        assert estimate.encoder_seconds(entry, steps=1, threads=1) > 0
        assert seen == [1, 1] and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


@pytest.mark.parametrize("name", bench_main.available())
def test_every_bench_answers_help(name, capsys):
    """`python -m spl_al.bench NAME --help` prints a usage line and exits 0 for every
    benchmark the dispatcher lists (docs/benchmarks.md shows their commands)."""
    with pytest.raises(SystemExit) as stop:
        bench_main.main([name, "--help"])
    assert stop.value.code == 0
    assert "usage:" in capsys.readouterr().out


def test_a_helper_module_is_no_bench(capsys):
    assert "timing" not in bench_main.available()
    assert bench_main.main(["timing", "--help"]) == 2
    assert "unknown benchmark 'timing'" in capsys.readouterr().err


def test_the_estimate_names_a_config_file_that_does_not_exist(tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        bench_main.main(["estimate", "--configfile", str(tmp_path / "mine.yaml")])
    assert stop.value.code == 2
    assert "mine.yaml: no such file" in capsys.readouterr().err


def _draw(root: Path, verdict: str, diffs: dict) -> Path:
    """A results folder whose real_cls embedding tables hold one claim and the AUBC
    comparisons ``diffs`` ((a, b) -> (diff, direction))."""
    import pandas as pd

    tables = root / "real_cls" / "embedding" / "tables"
    tables.mkdir(parents=True)
    pd.DataFrame([{"claim_id": "duis_best", "verdict": verdict}]).to_csv(tables / "claims.csv")
    rows = [
        {"experiment": "budget", "point": "AUBC", "parameter": "", "method_a": a,
         "method_b": b, "diff": d, "resolved": bool(direction), "direction": direction}
        for (a, b), (d, direction) in diffs.items()
    ]  # fmt: skip
    pd.DataFrame(rows).to_csv(tables / "comparisons.csv", index=False)
    return root


def test_the_draws_bench_names_a_reversed_claim_and_comparison(tmp_path, capsys):
    from spl_al.bench import draws

    a = _draw(
        tmp_path / "a",
        "supported",
        {("duis", "random"): (2.0, 1), ("syn_maxherding", "duis"): (9.0, 1)},
    )
    b = _draw(
        tmp_path / "b",
        "inconclusive",
        {("duis", "random"): (0.5, 0), ("syn_maxherding", "duis"): (8.0, 1)},
    )
    assert draws.main([str(a), str(b), "--datasets", "real_cls"]) == 0
    out = capsys.readouterr().out
    assert "| comparisons resolved | 2 | 1 |" in out and "1 / 1 / 0" in out
    assert "+9.0 (resolved)" in out and "1.50" in out  # the median shift of 1.5 and 1.0
    c = _draw(
        tmp_path / "c",
        "contradicted",
        {("duis", "random"): (-2.0, -1), ("syn_maxherding", "duis"): (9.0, 1)},
    )
    assert draws.main([str(a), str(c), "--datasets", "real_cls"]) == 1
    out = capsys.readouterr().out
    assert "duis_best" in out and "Opposite: budget AUBC duis - random" in out
    with pytest.raises(SystemExit, match="embedding framework has run"):
        draws.main([str(a), str(tmp_path / "none"), "--datasets", "real_cls"])


def _framework_comparisons(folder: Path, rows: list[tuple]) -> None:
    """A comparisons.csv in ``folder``/tables: rows (point, n_labeled, a, b, diff,
    resolved, mean_a, mean_b, unit, n), half-width 1 point."""
    import pandas as pd

    tables = folder / "tables"
    tables.mkdir(parents=True)
    frame = pd.DataFrame(
        [
            {"experiment": "budget", "point": point, "parameter": "", "n_labeled": n_lab,
             "round": 0 if n_lab == 20 else 1 if n_lab else None, "method_a": a,
             "method_b": b, "diff": d, "ci_low": d - 1, "ci_high": d + 1, "resolved": res,
             "direction": int(res) * (1 if d > 0 else -1), "mean_a": ma, "mean_b": mb,
             "span": "rounds 1-3" if point == "AUBC" else "", "unit": unit, "n": n}
            for point, n_lab, a, b, d, res, ma, mb, unit, n in rows
        ]
    )  # fmt: skip
    frame.to_csv(tables / "comparisons.csv", index=False)


def test_the_agreement_bench_sets_the_two_frameworks_side_by_side(tmp_path, capsys):
    from spl_al.bench import agreement

    emb = tmp_path / "emb"
    _framework_comparisons(
        emb / "real_cls" / "embedding",
        [
            ("AUBC", None, "duis", "random", 2.0, True, 60.0, 58.0, "encoder", 12),
            ("AUBC", None, "duis", "syn_margin", -3.0, True, 60.0, 63.0, "encoder", 12),
            ("AUBC", None, "syn_margin", "random", 5.0, True, 63.0, 58.0, "encoder", 12),
            ("round 1 (3.6%)", 40, "duis", "random", 0.5, False, 0, 0, "encoder", 12),
            ("round 0 (1.8%)", 20, "duis", "random", 0.0, False, 0, 0, "encoder", 12),
            ("AUBC", None, "duis", "syn_typiclust", -6.0, True, 60.0, 66.0, "encoder", 12),
        ],
    )
    sup = tmp_path / "sup"
    _framework_comparisons(
        sup / "real_cls",
        [
            # the other order of the same pair: the difference turns with it
            ("AUBC", None, "random", "duis", -3.0, True, 57.0, 60.0, "seed", 24),
            ("AUBC", None, "duis", "syn_margin", 1.5, True, 60.0, 58.5, "seed", 24),
            ("AUBC", None, "syn_margin", "random", 1.5, False, 58.5, 57.0, "seed", 24),
            ("round 1 (3.6%)", 40, "duis", "random", 0.7, False, 0, 0, "seed", 24),
        ],
    )
    both, facts = agreement.compare(emb, sup, "real_cls")
    assert facts["comparisons"] == 4 and facts["aubc_comparisons"] == 3  # no round 0
    row = both[
        (both["at"] == "AUBC") & (both["method_b"] == "random") & (both["method_a"] == "duis")
    ]
    assert row["diff_supervised"].iloc[0] == 3.0 and bool(row["signs_agree"].iloc[0])
    # both resolved alike, one only, opposite; and the round, neither
    assert sorted(both["resolution"]) == ["both", "neither", "one only", "opposite"]
    assert facts["signs_agree"] == 3 and facts["opposite"] == 1
    assert facts["both"] == facts["neither"] == facts["one_only"] == 1
    assert facts["methods"] == ["duis", "random", "syn_margin"]  # typiclust: embedding only
    assert facts["spearman"] == pytest.approx(0.5)  # ranks (2, 1, 3) against (3, 1, 2)
    figures = tmp_path / "figures"
    args = [str(emb), str(sup), "--datasets", "real_cls", "synth_cls"]
    assert agreement.main([*args, "--out", str(tmp_path), "--figures", str(figures)]) == 0
    out = capsys.readouterr().out
    assert "Signs agree in 3 of 4" in out and "synth_cls: skipped" in out
    assert "embedding over 12 encoders, supervised over 24 seeds" in out
    assert (tmp_path / "agreement_real_cls.csv").is_file()
    assert (figures / "agreement_real_cls.png").is_file()
    assert agreement.main([str(emb), str(tmp_path / "none")]) == 2


def test_query_bench_splits_the_time_of_a_duis_query(capsys):
    from spl_al.bench import query

    args = ["--frames", "16", "--labeled", "4", "--budget", "3", "--profile-frames", "2"]
    assert query.main(args) == 0
    out = capsys.readouterr().out
    assert "60 images through predict" in out  # 12 unlabeled frames and 4 variants each
    for part in ("predict (SmallCNN", "variants (photon", "selection (k-means", "**whole query**"):
        assert part in out
    assert "Overhead (outside predict)" in out and out.count("| 0.2 |") >= 2


def test_the_pipeline_bench_names_the_embedding_framework_s_rules():
    from spl_al.bench.pipeline import embedding_rule_of

    assert embedding_rule_of("encoder_seed11") == "encoder"
    assert embedding_rule_of("table_budget") == "embedding_table"
    assert embedding_rule_of("stats") == "embedding_stats"
    assert embedding_rule_of("syn_dropquery") == "probe_runs"


def test_the_pipeline_bench_reads_what_embedding_rounds_cost(tmp_path):
    from spl_al.bench.pipeline import round_rows

    runs = tmp_path / "street_seg" / "embedding" / "runs"
    runs.mkdir(parents=True)
    records = [
        {"round": 0, "train_seconds": 0.1, "seconds": 0.3},
        {"round": 1, "train_seconds": 0.3, "seconds": 0.5},
        {"round": 2, "train_seconds": 0.9},
    ]
    (runs / "duis.json").write_text(json.dumps(records))
    assert round_rows(tmp_path) == [["street_seg", "duis", 3, "0.200", "0.400"]]
