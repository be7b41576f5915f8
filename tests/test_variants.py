"""SIV over a dataset: sharding, seeding, observed inputs, merging."""

from __future__ import annotations

import numpy as np
import pytest

from spl_al.data import Dataset, make_classification_dataset
from spl_al.variants import VariantShard, attach_variants, default_conditions, generate_variants


@pytest.fixture(scope="module")
def data():
    return make_classification_dataset(
        n_per_class=2, image_shape=(20, 20), classes=["bin", "apple", "human"], seed=2, workers=1
    )


@pytest.fixture(scope="module")
def whole(data):
    return generate_variants(data, n_variants=3, seed=5, workers=1)


def test_sharded_equals_unsharded_bit_identical(data, whole):
    shards = [
        generate_variants(data, n_variants=3, seed=5, shard=(k, 3), workers=2) for k in range(3)
    ]
    assert [s.indices.tolist() for s in shards] == [[0, 1], [2, 3], [4, 5]]
    merged = attach_variants(data, shards[::-1])  # any order
    np.testing.assert_array_equal(merged.variant_depth_m, whole.depth_m)
    np.testing.assert_array_equal(merged.variant_msppp, whole.msppp)
    np.testing.assert_array_equal(merged.variant_sbr, whole.sbr)


def test_variants_are_keyed_by_sample_not_position(data, whole):
    sub = data.subset([4, 1])
    part = generate_variants(sub, n_variants=3, seed=5, workers=1)
    np.testing.assert_array_equal(part.depth_m, whole.depth_m[[4, 1]])
    other_seed = generate_variants(data, n_variants=3, seed=6, workers=1)
    assert not np.array_equal(np.isfinite(other_seed.depth_m), np.isfinite(whole.depth_m))


def test_variants_come_from_the_observed_image(data, whole):
    """Photons are simulated from the observed depth and reflectivity: a pixel that is a
    void in the observed image has no return, so it is a void in every variant, and the
    variant depths scatter around the observed depth."""
    obs_valid = data.valid[:, None]
    assert not (np.isfinite(whole.depth_m) & ~obs_valid).any()
    assert (np.isfinite(data.clean_depth_m) & ~data.valid).any(), "observed voids exist"
    both = np.isfinite(whole.depth_m) & obs_valid
    err_obs = np.median(np.abs(whole.depth_m - data.depth_m[:, None])[both])
    assert err_obs < 0.1


def test_conditions_are_drawn_from_the_set(data, whole):
    conditions = default_conditions(data)
    assert len(conditions) == 9
    pairs = {tuple(c) for c in conditions}
    for i in range(len(data)):
        drawn = list(zip(whole.msppp[i], whole.sbr[i], strict=True))
        assert set(drawn) <= pairs and len(set(drawn)) == 3, "without replacement"
    custom = generate_variants(data.subset([0]), n_variants=4, conditions=[(3, 1)], workers=1)
    assert (custom.msppp == 3).all() and (custom.sbr == 1).all()


def test_attach_refuses_overlap_missing_and_foreign(data, whole):
    a = generate_variants(data, n_variants=3, seed=5, shard=(0, 2), workers=1)
    b = generate_variants(data, n_variants=3, seed=5, shard=(1, 2), workers=1)
    with pytest.raises(ValueError, match="shards miss 3 samples"):
        attach_variants(data, [a])
    with pytest.raises(ValueError, match=r"shards overlap: samples \[0, 1, 2\]"):
        attach_variants(data, [a, b, a])
    c = generate_variants(data, n_variants=3, seed=7, shard=(1, 2), workers=1)
    with pytest.raises(ValueError, match="regenerate them alike"):
        attach_variants(data, [a, c])
    other = make_classification_dataset(
        n_per_class=1, image_shape=(20, 20), classes=["bin"], workers=1
    )
    with pytest.raises(ValueError, match="another dataset"):
        attach_variants(other, [a, b])
    with pytest.raises(ValueError, match="shard must be"):
        generate_variants(data, shard=(2, 2))


def test_shard_files_and_dataset_with_variants_roundtrip(data, whole, tmp_path):
    shards = [
        generate_variants(data, n_variants=3, seed=5, shard=(k, 2), workers=1) for k in range(2)
    ]
    paths = [s.save(tmp_path / f"shard{k}.npz") for k, s in enumerate(shards)]
    assert VariantShard.load(paths[0]).settings["shard"] == [0, 2]
    merged = attach_variants(data, paths)
    step = 0.0025  # uint16 codes of a dataset reaching 140 m
    assert np.nanmax(np.abs(merged.variant_depth_m - whole.depth_m)) <= step / 2 + 1e-4
    saved = Dataset.load(merged.save(tmp_path / "with_variants.npz"))
    assert saved.n_variants == 3 and saved.meta["variants"]["seed"] == 5
    depth, valid = saved.groups([1, 2], n_variants=2)
    assert depth.shape == (2, 3, 20, 20)
    np.testing.assert_array_equal(valid[:, 0], saved.valid[[1, 2]])
    np.testing.assert_array_equal(valid[:, 1:], np.isfinite(saved.variant_depth_m[[1, 2], :2]))


def test_void_observed_image_gives_void_variants(data):
    blank = data.subset([0])
    blank.depth_m[:] = np.nan
    blank.valid[:] = False
    shard = generate_variants(blank, n_variants=2, workers=1)
    assert np.isnan(shard.depth_m).all()


def test_variants_equal_synthesize_variant_on_the_full_frame(data, whole):
    """The bounding-box shortcut changes nothing: Algorithm 1 on the whole frame, with
    the same random stream, gives the same variants bit for bit."""
    from spl_al.data.seeds import STREAM_VARIANT, sample_rng
    from spl_al.photon import synthesize_variant
    from spl_al.variants import draw_variant_conditions

    conditions = default_conditions(data)
    for i in range(len(data)):
        rng = sample_rng(5, STREAM_VARIANT, data.uid[i])
        picks = draw_variant_conditions(rng, conditions, 3)
        valid = data.valid[i]
        refl = np.where(valid, data.reflectance[i], 0.0)
        for j, p in enumerate(picks):
            m, s = conditions[p]
            full = synthesize_variant(data.depth_m[i], refl, valid, m, s, data.sensor, rng)
            np.testing.assert_array_equal(whole.depth_m[i, j], full.astype(np.float32))


def test_observed_images_equal_the_photon_engine_on_the_full_frame(data):
    from spl_al.data.seeds import STREAM_OBSERVE, sample_rng
    from spl_al.photon import reconstruct, simulate_photons

    for i in range(len(data)):
        clean = data.clean_depth_m[i]
        valid = np.isfinite(clean)
        rng = sample_rng(2, STREAM_OBSERVE, data.uid[i])
        refl = np.where(valid, data.clean_reflectance[i], 0.0)
        events = simulate_photons(clean, refl, valid, data.msppp[i], data.sbr[i], data.sensor, rng)
        rec = reconstruct(events, clean.shape, data.sensor)
        np.testing.assert_array_equal(data.depth_m[i], rec.depth_m.astype(np.float32))
        np.testing.assert_array_equal(data.reflectance[i], rec.reflectivity.astype(np.float32))


def test_observed_depth_in_the_last_bin_after_storage_rounding_is_accepted(data, tmp_path):
    """A background photon in the last bin reconstructs to max_depth_m; uint16 storage may
    round it up by under 1.25 mm, which is still inside the last bin."""
    one = data.subset([0])
    reach = one.sensor.max_depth_m
    one.depth_m[0, 0, 0] = reach + 0.001
    one.valid[0, 0, 0] = True
    shard = generate_variants(one, n_variants=1, workers=1)
    assert shard.depth_m.shape[:2] == (1, 1)
    one.depth_m[0, 0, 0] = reach + one.sensor.bin_depth_m  # a whole bin past: refused
    with pytest.raises(ValueError, match="beyond the sensor's reach"):
        generate_variants(one, n_variants=1, workers=1)
