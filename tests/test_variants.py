"""SIV over a dataset: sharding, seeding, observed inputs, merging."""

from __future__ import annotations

import numpy as np
import pytest

from spl_al.data import Dataset, make_classification_dataset
from spl_al.data.variants import (
    VariantShard,
    attach_variants,
    default_conditions,
    generate_variants,
)


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


def test_variant_j_of_every_group_uses_condition_j(data, whole):
    """Systematic conditions: the same ordered list for every group, so d_i compares
    like with like; the first m variants are what M = m would make (nested M sweep)."""
    conditions = default_conditions(data)
    assert len(conditions) == 9 and len(set(conditions)) == 9
    assert conditions[:3] == [(5.0, 1.0), (2.0, 0.2), (2.0, 5.0)]  # centre, then spread
    np.testing.assert_array_equal(whole.msppp, np.tile([c[0] for c in conditions[:3]], (6, 1)))
    np.testing.assert_array_equal(whole.sbr, np.tile([c[1] for c in conditions[:3]], (6, 1)))
    two = generate_variants(data, n_variants=2, seed=5, workers=1)
    np.testing.assert_array_equal(two.depth_m, whole.depth_m[:, :2])
    custom = generate_variants(
        data.subset([0]), n_variants=2, conditions=[(3, 1), (1, 0.5)], workers=1
    )
    assert custom.msppp.tolist() == [[3, 1]] and custom.sbr.tolist() == [[1, 0.5]]
    with pytest.raises(ValueError, match="give at least M"):
        generate_variants(data.subset([0]), n_variants=3, conditions=[(3, 1)], workers=1)


def test_spread_conditions_is_a_permutation_whose_prefixes_spread():
    from spl_al.data import condition_set
    from spl_al.data.variants import spread_conditions

    grid = condition_set({"high": 8, "low": 1}, [0.1, 1, 10])
    order = spread_conditions(grid)
    assert sorted(order) == sorted(grid)
    assert order[0][1] == 1.0, "the middle SBR first"
    lo = {m for m, _ in order[:3]}
    assert lo == {1.0, 8.0}, "the first three cover both photon levels"
    # the default grid in the order the variants module's docstring states
    default = spread_conditions(condition_set())
    assert default == [
        (5, 1),
        (2, 0.2),
        (2, 5),
        (10, 0.2),
        (10, 5),
        (2, 1),
        (5, 0.2),
        (10, 1),
        (5, 5),
    ]


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
    from spl_al.photon import Condition, PhotonScene, synthesize_variant

    conditions = default_conditions(data)[:3]
    for i in range(len(data)):
        rng = sample_rng(5, STREAM_VARIANT, data.uid[i])
        valid = data.valid[i]
        refl = np.where(valid, data.reflectance[i], 0.0)
        for j, (m, s) in enumerate(conditions):
            full = synthesize_variant(
                PhotonScene(data.depth_m[i], reflectance=refl, valid=valid),
                Condition(m, s, data.sensor),
                rng,
            )
            np.testing.assert_array_equal(whole.depth_m[i, j], full.astype(np.float32))


def test_observed_images_equal_the_photon_engine_on_the_full_frame(data):
    """Observed images are the sensor model's photons, reconstructed with censoring."""
    from spl_al.data.seeds import STREAM_OBSERVE, sample_rng
    from spl_al.photon import Condition, ObservationModel, PhotonScene, observe_photons, reconstruct

    model = ObservationModel.from_dict(data.meta["observation"])
    for i in range(len(data)):
        clean = data.clean_depth_m[i]
        valid = np.isfinite(clean)
        rng = sample_rng(2, STREAM_OBSERVE, data.uid[i])
        refl = np.where(valid, data.clean_reflectance[i], 0.0)
        events = observe_photons(
            PhotonScene(clean, reflectance=refl, valid=valid),
            Condition(data.msppp[i], data.sbr[i], data.sensor),
            rng,
            model=model,
        )
        rec = reconstruct(events, clean.shape, data.sensor, censor=True)
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
