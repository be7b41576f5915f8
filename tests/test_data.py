"""Dataset container, on-disk format, observed images and synthetic generators."""

from __future__ import annotations

import numpy as np
import pytest

from spl_al.data import (
    SCENE_FIELDS,
    Dataset,
    make_classification_dataset,
    make_segmentation_dataset,
    observe,
)
from spl_al.data.observe import assign_conditions, condition_set
from spl_al.data.pictures import contact_sheet, variants_sheet
from spl_al.data.storage import choose_depth_step
from spl_al.label_codes import IGNORE_INDEX
from spl_al.photon import SensorParams
from spl_al.scenes import CATEGORIES, STREET_CLASSES

SMALL = {"n_per_class": 6, "image_shape": (24, 24), "seed": 3}


@pytest.fixture(scope="module")
def cls_data():
    return make_classification_dataset(**SMALL, workers=1)


@pytest.fixture(scope="module")
def seg_data():
    return make_segmentation_dataset(n_samples=6, image_shape=(16, 64), seed=1, workers=1)


def test_classification_dataset_fields(cls_data):
    d = cls_data
    n = 6 * len(CATEGORIES)
    assert d.task == "classification" and d.classes == list(CATEGORIES)
    assert d.depth_m.shape == (n, 24, 24) and d.depth_m.dtype == np.float32
    np.testing.assert_array_equal(d.valid, np.isfinite(d.depth_m))
    assert d.labels.dtype == np.int64 and np.bincount(d.labels).tolist() == [6] * len(CATEGORIES)
    assert d.clean_depth_m.shape == d.reflectance.shape == d.object_mask.shape == (n, 24, 24)
    assert d.sensor == SensorParams.paper_real() and d.variant_depth_m is None
    # Stratified 70/30 split: round(0.3 * 6) = 2 test samples per class.
    assert all((d.split[d.labels == c] == "test").sum() == 2 for c in range(len(CATEGORIES)))
    # The default sensor model puts background photons on pixels without a return too;
    # censoring keeps most of those voids, and the returns are mostly kept.
    returns = np.isfinite(d.clean_depth_m)
    assert (d.valid & ~returns).any() and (d.valid & ~returns).sum() < 0.5 * (~returns).sum()
    assert (d.valid & returns).sum() > 0.8 * returns.sum()
    assert d.meta["observation"]["background_everywhere"] is True
    # Every observed image carries its level and condition.
    for level, msppp in {"high": 10.0, "medium": 5.0, "low": 2.0}.items():
        assert (d.msppp[d.level == level] == msppp).all()
    assert set(np.unique(d.sbr)) <= {0.2, 1.0, 5.0}


def test_levels_are_balanced_per_class_and_split():
    labels = np.repeat(np.arange(4), 30)
    split = np.where(np.arange(120) % 10 < 3, "test", "train")
    msppp, _, level = assign_conditions(
        labels,
        split,
        levels={"high": 8, "low": (1, 3)},
        sbr_values=[0.5, 2],
        rng=np.random.default_rng(0),
    )
    for s in ("train", "test"):
        for group in [labels == c for c in range(4)] + [np.ones(120, bool)]:
            counts = [(group & (split == s) & (level == lv)).sum() for lv in ("high", "low")]
            assert abs(counts[0] - counts[1]) <= 1
    assert (msppp[level == "high"] == 8).all()
    assert ((msppp[level == "low"] >= 1) & (msppp[level == "low"] <= 3)).all()
    assert condition_set({"high": 8, "low": 2}, [0.5, 2]) == [(8, 0.5), (8, 2), (2, 0.5), (2, 2)]


def test_generation_is_deterministic_and_independent_of_workers(cls_data):
    again = make_classification_dataset(**SMALL, workers=2)
    for name in (
        "depth_m",
        "clean_depth_m",
        "reflectance",
        "labels",
        "split",
        "level",
        "msppp",
        "sbr",
    ):
        np.testing.assert_array_equal(getattr(again, name), getattr(cls_data, name), err_msg=name)
    other = make_classification_dataset(**{**SMALL, "seed": 4}, workers=1)
    assert not np.array_equal(np.isfinite(other.clean_depth_m), np.isfinite(cls_data.clean_depth_m))


def test_observed_images_follow_the_photon_budget():
    """More signal photons: fewer voids and smaller depth error against the clean depth."""
    d = make_classification_dataset(
        n_per_class=3, image_shape=(24, 24), classes=["bin", "human"], workers=1
    )
    clean, refl = d.clean_depth_m, d.clean_reflectance
    high, _ = observe(clean, refl, msppp=10.0, sbr=5.0, sensor=d.sensor, seed=0)
    sparse, _ = observe(clean, refl, msppp=1.0, sbr=5.0, sensor=d.sensor, seed=0)
    noisy, _ = observe(clean, refl, msppp=1.0, sbr=0.2, sensor=d.sensor, seed=0)
    has = np.isfinite(clean)
    # Pixels without any photon are voids: common at 1.2 photons per pixel.
    assert np.isfinite(high)[has].mean() > np.isfinite(sparse)[has].mean() + 0.1
    err_high = np.nanmedian(np.abs(high - clean))
    assert err_high < 0.05, "at 10 photons per pixel the median depth error is a few cm"
    assert err_high < np.nanmedian(np.abs(noisy - clean))
    # Reflectivity is reconstructed with the image: zero exactly at its voids.
    _, rec_refl = observe(clean, refl, msppp=10.0, sbr=5.0, sensor=d.sensor, seed=0)
    np.testing.assert_array_equal(rec_refl[~np.isfinite(high)], 0.0)


@pytest.mark.parametrize("precision", ["uint16", "float32"])
def test_save_load_roundtrip(cls_data, tmp_path, precision):
    path = cls_data.save(tmp_path / "sub" / "ds.npz", precision=precision)
    assert sorted(p.name for p in path.parent.iterdir()) == ["ds.npz"], "no temporary file left"
    back = Dataset.load(path)
    for name in ("labels", "split", "level", "msppp", "sbr", "uid", "object_mask", "valid"):
        np.testing.assert_array_equal(getattr(back, name), getattr(cls_data, name), err_msg=name)
    assert (
        back.classes == cls_data.classes
        and back.sensor == cls_data.sensor
        and back.meta == cls_data.meta
    )
    # Half a step of rounding, plus float32 spacing at up to 140 m.
    tol = 0 if precision == "float32" else choose_depth_step(140.0) / 2 + 140.0 * 2.0**-22
    for name in ("depth_m", "clean_depth_m"):
        a, b = getattr(back, name), getattr(cls_data, name)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        assert np.nanmax(np.abs(a - b)) <= tol
    np.testing.assert_allclose(back.reflectance, cls_data.reflectance, rtol=1e-3, atol=1e-3)


def test_load_can_skip_the_scene(cls_data, tmp_path):
    """Training and scoring jobs load without the clean scene: the same images, no
    scene arrays; asking to skip a field they need is refused."""
    path = cls_data.save(tmp_path / "ds.npz")
    full, lean = Dataset.load(path), Dataset.load(path, skip=SCENE_FIELDS)
    np.testing.assert_array_equal(lean.depth_m, full.depth_m)
    np.testing.assert_array_equal(lean.labels, full.labels)
    assert all(getattr(lean, name) is None for name in SCENE_FIELDS)
    with pytest.raises(ValueError, match=r"can skip the scene fields .* not \['labels'\]"):
        Dataset.load(path, skip=["labels"])


def test_load_refuses_other_files(tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, depth=np.zeros(3))
    with pytest.raises(ValueError, match=r"bad\.npz: not an spl-al-dataset file"):
        Dataset.load(bad)
    (tmp_path / "cut.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(ValueError, match=r"cut\.npz: cannot be read"):
        Dataset.load(tmp_path / "cut.npz")


def test_subset_groups_and_indices(cls_data):
    sub = cls_data.subset([5, 0, 7])
    np.testing.assert_array_equal(sub.uid, [5, 0, 7])
    np.testing.assert_array_equal(sub.depth_m[1], cls_data.depth_m[0])
    depth, valid = cls_data.groups([2, 3])
    assert depth.shape == (2, 1, 24, 24) and valid.dtype == bool
    with pytest.raises(ValueError, match="no variants"):
        cls_data.groups([0], n_variants=2)
    assert np.array_equal(
        np.sort(np.r_[cls_data.train_idx, cls_data.test_idx]), np.arange(len(cls_data))
    )
    assert set(cls_data.level[cls_data.level_idx("low")]) == {"low"}
    assert set(cls_data.split[cls_data.level_idx("low")]) == {"test"}


def test_dataset_validates_its_fields():
    depth = np.full((2, 4, 4), 1.0, np.float32)
    common = {"split": ["train", "test"], "msppp": [1, 1], "sbr": [1, 1], "level": ["low", "low"]}
    with pytest.raises(ValueError, match="labels must index classes"):
        Dataset("classification", ["a"], depth, np.array([0, 1]), **common)
    with pytest.raises(ValueError, match="segmentation labels must be < 1 or 255"):
        Dataset("segmentation", ["a"], depth, np.full((2, 4, 4), 3, np.uint8), **common)
    with pytest.raises(ValueError, match="split values"):
        Dataset(
            "classification",
            ["a"],
            depth,
            np.array([0, 0]),
            **{**common, "split": ["train", "val"]},
        )
    with pytest.raises(ValueError, match="variant_depth_m must have shape"):
        Dataset(
            "classification",
            ["a"],
            depth,
            np.array([0, 0]),
            variant_depth_m=np.zeros((2, 4, 4)),
            **common,
        )


def test_generators_reject_bad_arguments():
    with pytest.raises(ValueError, match="levels has key 'extreme'"):
        make_classification_dataset(n_per_class=1, levels={"extreme": 100})
    with pytest.raises(ValueError, match="classes must be a non-empty subset"):
        make_classification_dataset(n_per_class=1, classes=["dog"])
    with pytest.raises(ValueError, match="beyond the sensor's reach"):
        make_classification_dataset(n_per_class=1, sensor=SensorParams.tabletop())
    with pytest.raises(ValueError, match="image_shape must be"):
        make_segmentation_dataset(n_samples=1, image_shape=(2,))


def test_segmentation_dataset_and_points(seg_data):
    d = seg_data
    assert d.task == "segmentation" and d.classes == list(STREET_CLASSES)
    assert d.labels.shape == (6, 16, 64) and d.labels.dtype == np.uint8
    np.testing.assert_array_equal(d.labels == IGNORE_INDEX, ~np.isfinite(d.clean_depth_m))
    assert d.sensor == SensorParams.street()
    xyz, lab = d.points(0)
    assert xyz.shape == (d.valid[0].sum(), 3) and lab.shape == (xyz.shape[0],)
    np.testing.assert_allclose(np.linalg.norm(xyz, axis=1), d.depth_m[0][d.valid[0]], rtol=1e-5)
    # returns where the scene has none (background photons) carry no label
    np.testing.assert_array_equal(lab == IGNORE_INDEX, d.labels[0][d.valid[0]] == IGNORE_INDEX)
    assert (lab != IGNORE_INDEX).mean() > 0.9


def test_pictures_are_png(cls_data, seg_data, tmp_path):
    from spl_al.data.variants import make_variants

    for data, name in ((cls_data, "cls"), (seg_data, "seg")):
        sheet = contact_sheet(data, tmp_path / f"{name}_contact.png", per_class=2)
        assert sheet.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        with_variants = make_variants(data.subset([0, 1]), n_variants=2, workers=1)
        out = variants_sheet(with_variants, 1, tmp_path / f"{name}_variants.png")
        assert out.stat().st_size > 5000
    with pytest.raises(ValueError, match="no variants"):
        variants_sheet(cls_data, 0, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_command_line(tmp_path, capsys):
    from spl_al.data.__main__ import main

    out = tmp_path / "tiny.npz"
    args = [
        "classification",
        str(out),
        "--n-per-class",
        "1",
        "--image-shape",
        "16x16",
        "--workers",
        "1",
    ]
    assert main(args) == 0
    assert Dataset.load(out).depth_m.shape == (11, 16, 16)
    assert (
        main(["variants", str(out), str(tmp_path / "s.npz"), "--shard", "0/2", "--n-variants", "1"])
        == 0
    )
    capsys.readouterr()
    assert (
        main(["attach", str(out), str(tmp_path / "s.npz"), "--out", str(tmp_path / "v.npz")]) == 2
    )
    err = capsys.readouterr().err
    assert err.startswith("error: shards miss 5 samples") and err.count("\n") == 1
    assert not (tmp_path / "v.npz").exists()
