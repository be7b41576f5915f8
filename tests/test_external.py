"""External data: the authors' released layout, generic folders, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from spl_al.data.external import load_folder
from spl_al.data.variants import make_variants

CLASSES = ("bike", "fire_hydrant", "water bottle")


def _depth(rng, shape=(55, 55)):
    depth = 5.0 + rng.normal(0, 0.05, shape)
    depth[:5] = 0.0  # no return: zero depth is a void in the release
    return depth


def _release(root, n=4, rng=None):
    """A fake copy of the authors' release: {class}_{NNNN}.npz with depth_ssp and Z_true."""
    rng = rng or np.random.default_rng(0)
    root.mkdir(parents=True, exist_ok=True)
    for cls in CLASSES:
        for k in range(n):
            z = _depth(rng)
            ssp = np.where(z > 0, z + rng.normal(0, 0.1, z.shape), 0.0)
            np.savez(root / f"{cls}_{k + 1:04d}.npz", depth_ssp=ssp, Z_true=z)
    return root


def test_authors_release_layout(tmp_path):
    root = _release(tmp_path / "release")
    data = load_folder(root, depth_key="depth_ssp")
    assert data.task == "classification" and data.classes == sorted(CLASSES)
    assert data.depth_m.shape == (12, 55, 55) and data.labels.dtype == np.int64
    assert np.bincount(data.labels).tolist() == [4, 4, 4]
    assert data.meta["files"][0] == "bike_0001.npz" and data.meta["layout"] == "flat"
    assert not data.valid[:, :5].any() and data.valid[:, 5:].all()
    assert data.clean_depth_m is not None and data.reflectance is None
    assert (data.level == "unknown").all() and np.isnan(data.msppp).all()
    assert (data.split == "test").sum() == 3  # round(0.3 * 4) per class
    assert data.meta["load_report"]["zero"] == 12 * 5 * 55
    assert data.subset([5, 0]).meta["files"] == [data.meta["files"][5], "bike_0001.npz"]
    assert (
        repr(data)
        == "Dataset(classification, 12 images (55, 55), 3 classes, 0 variants, source='external')"
    )
    with pytest.raises(ValueError, match=r"no files for classes \['cap'\]"):
        load_folder(root, classes=[*sorted(CLASSES), "cap"])
    # Variants are built the same way as for synthetic data (uniform reflectance).
    with_variants = make_variants(data.subset([0, 5]), n_variants=2, workers=1)
    assert with_variants.variant_depth_m.shape == (2, 2, 55, 55)
    assert not np.isfinite(with_variants.variant_depth_m[:, :, :5]).any()


def test_depth_key_and_bad_pixels_are_reported(tmp_path):
    root = _release(tmp_path / "release", n=2)
    z = _depth(np.random.default_rng(1))
    z[10, 10], z[11, 11], z[12, 12] = np.nan, np.inf, -1.0
    np.savez(root / "bike_0099.npz", depth_ssp=z, Z_true=z)
    with pytest.warns(UserWarning, match="2 NaN/inf, 1 negative"):
        data = load_folder(root, depth_key="Z_true")
    bad = data.meta["files"].index("bike_0099.npz")
    assert not data.valid[bad, 10:13, 10:13].diagonal().any()
    assert data.meta["load_report"]["files_with_bad_pixels"] == ["bike_0099.npz"]


def test_generic_per_class_folders_with_png_and_npy(tmp_path):
    rng = np.random.default_rng(2)
    for cls in ("cone", "person"):
        (tmp_path / cls).mkdir()
        for k in range(3):
            depth_mm = np.round(_depth(rng, (32, 40)) * 1000).astype(np.uint16)
            Image.fromarray(depth_mm).save(tmp_path / cls / f"{k}.png")
        np.save(tmp_path / cls / "extra.npy", _depth(rng, (32, 40)))
    data = load_folder(tmp_path, clean_key=None)
    assert data.classes == ["cone", "person"] and data.depth_m.shape == (8, 32, 40)
    png = data.meta["files"].index("cone/0.png")
    assert abs(np.nanmean(data.depth_m[png]) - 5.0) < 0.05, "PNG depth is read in millimetres"
    resized = load_folder(tmp_path, image_shape=(16, 20))
    assert resized.depth_m.shape == (8, 16, 20)


def test_segmentation_pairs(tmp_path):
    rng = np.random.default_rng(3)
    (tmp_path / "depth").mkdir()
    (tmp_path / "labels").mkdir()
    for k in range(4):
        np.save(tmp_path / "depth" / f"scan{k}.npy", _depth(rng, (16, 64)))
        lab = rng.integers(0, 3, (16, 64)).astype(np.uint8)
        lab[:5] = 255
        Image.fromarray(lab).save(tmp_path / "labels" / f"scan{k}.png")
    (tmp_path / "classes.txt").write_text("road\ncar\npole\n")
    data = load_folder(tmp_path)
    assert data.task == "segmentation" and data.classes == ["road", "car", "pole"]
    assert data.labels.shape == (4, 16, 64) and (data.labels[:, :5] == 255).all()


def test_segmentation_from_label_key(tmp_path):
    rng = np.random.default_rng(4)
    for k in range(3):
        np.savez(
            tmp_path / f"scene_{k:04d}.npz",
            depth=_depth(rng, (8, 8)),
            sem=np.ones((8, 8), np.uint8),
        )
    data = load_folder(tmp_path, depth_key="depth", label_key="sem", classes=["a", "b"])
    assert data.task == "segmentation" and (data.labels == 1).all()
    with pytest.raises(ValueError, match="labels hold values"):
        load_folder(tmp_path, depth_key="depth", label_key="sem", classes=["a"])


def _error(root, match, **kw):
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    with pytest.raises(ValueError, match=match):
        load_folder(root, **kw)
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before, "nothing written"


def test_bad_files_name_the_file_and_the_problem(tmp_path):
    root = _release(tmp_path / "r", n=1)
    (root / "bike_0002.npz").write_bytes((root / "bike_0001.npz").read_bytes()[:100])
    _error(root, r"bike_0002\.npz: cannot be read")
    (root / "bike_0002.npz").unlink()

    np.savez(root / "bike_0003.npz", depth=np.ones((55, 55)))
    _error(root, r"bike_0003\.npz: has no array 'depth_ssp' \(keys: depth\)")
    np.savez(root / "bike_0003.npz", depth_ssp=np.ones((2, 55, 55)), Z_true=np.ones((55, 55)))
    _error(root, r"bike_0003\.npz: depth_ssp has shape \(2, 55, 55\); expected a 2-D image")
    np.savez(root / "bike_0003.npz", depth_ssp=np.ones((64, 64)), Z_true=np.ones((64, 64)))
    _error(
        root,
        r"different shapes: \(55, 55\) in 3 files .*"
        r"\(64, 64\) in 1 files \(e\.g\. bike_0003\.npz\)",
    )
    assert load_folder(root, image_shape=(55, 55)).depth_m.shape == (4, 55, 55)

    (root / "bike_0003.npz").write_bytes(b"")
    _error(root, r"bike_0003\.npz: cannot be read")
    (root / "bike_0003.npz").unlink()
    np.save(root / "README.npy", np.ones(3))
    _error(root, r"README\.npy: name does not follow \{class\}_\{NNNN\}")


def test_bad_folders(tmp_path):
    (tmp_path / "empty").mkdir()
    _error(tmp_path / "empty", "no .npz/.npy/.png files found")
    with pytest.raises(ValueError, match="no such folder"):
        load_folder(tmp_path / "missing")
    classes = tmp_path / "classes"
    (classes / "bike").mkdir(parents=True)
    (classes / "bin").mkdir()
    np.save(classes / "bike" / "a.npy", np.ones((8, 8)))
    _error(classes, r"bin: class folder holds no \.npz/\.npy/\.png files")
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(classes / "bin" / "a.png")
    _error(classes, r"a\.png: PNG mode 'L'; expected a 16-bit greyscale PNG")
