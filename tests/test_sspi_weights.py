"""SSPI weights: where they come from, loader errors, warnings, and a random-weight run."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch

import spl_al.photon.sspi as sspi
from spl_al.config import SSPI_WEIGHTS_ENV
from spl_al.photon import (
    Condition,
    PhotonScene,
    Reconstruction,
    SensorParams,
    reconstruct,
    simulate_photons,
)
from spl_al.photon.sspi.network import expected_shapes
from spl_al.photon.sspi.weights import load_state, weights_folder


def fake_state(seed=0) -> dict:
    """A state dict of the right keys and shapes with random values (BN variances > 0)."""
    gen = torch.Generator().manual_seed(seed)
    state = {}
    for key, shape in expected_shapes().items():
        if key.endswith("num_batches_tracked"):
            state[key] = torch.tensor(0)
        elif key.endswith("running_var"):
            state[key] = torch.ones(shape)
        else:
            state[key] = 0.3 * torch.randn(shape, generator=gen)
    return state


@pytest.fixture
def fake_weights(tmp_path):
    folder = tmp_path / "weights"
    folder.mkdir()
    for i, name in enumerate(("ssunet1.pth", "ssunet2.pth")):
        torch.save({"n_iter": 0, "epoch": 0, "state_dict": fake_state(i)}, folder / name)
    return folder


def test_expected_state_has_the_published_206_entries():
    shapes = expected_shapes()
    assert len(shapes) == 206
    assert shapes["start_head.0.weight"] == (4, 3, 3, 3, 1)
    assert shapes["path0_1.0.i_branch.0.weight"] == (8, 3, 3, 3, 16)
    assert shapes["end_tail.8.bias"] == (1,)


def test_no_weights_is_one_error_saying_where_to_get_them(monkeypatch, scene):
    monkeypatch.delenv(SSPI_WEIGHTS_ENV, raising=False)
    sensor = SensorParams.tabletop()
    ev = simulate_photons(PhotonScene(scene), Condition(2.0, 1.0, sensor), np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"y2w-oc/Dynamic-SSP-3D-Imaging.*Test/preTrain"):
        reconstruct(ev, scene.shape, sensor, method="sspi")


def test_folder_without_the_files_names_the_missing_file(tmp_path):
    (tmp_path / "ssunet1.pth").write_bytes(b"")
    with pytest.raises(ValueError, match=r"lacks ssunet2\.pth.*Test/preTrain"):
        weights_folder(tmp_path)


def test_environment_variable_is_the_fallback(monkeypatch, fake_weights):
    monkeypatch.setenv(SSPI_WEIGHTS_ENV, str(fake_weights))
    assert weights_folder(None) == fake_weights


def test_not_a_checkpoint_names_the_file(tmp_path):
    path = tmp_path / "ssunet1.pth"
    path.write_text("not a checkpoint")
    with pytest.raises(ValueError, match=r"ssunet1\.pth: not a torch checkpoint"):
        load_state(path)


def test_missing_key_names_file_and_key(tmp_path):
    state = fake_state()
    del state["path3.1.conv_branch.5.weight"]
    path = tmp_path / "ssunet2.pth"
    torch.save({"state_dict": state}, path)
    with pytest.raises(ValueError, match=r"ssunet2\.pth.*missing key 'path3\.1\.conv_branch\.5"):
        load_state(path)


def test_wrong_shape_names_file_key_and_shapes(tmp_path):
    state = fake_state()
    state["start_head.0.weight"] = torch.zeros((4, 3, 3, 3, 2))
    path = tmp_path / "ssunet1.pth"
    torch.save(state, path)  # a bare state dict is accepted too
    with pytest.raises(
        ValueError, match=r"ssunet1\.pth: key 'start_head\.0\.weight' has shape \(4, 3, 3, 3, 2\)"
    ):
        load_state(path)


SMALL_SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=160e-12, n_bins=256)


def small_scene(rows=12, cols=16):
    """A 12x16 step at 1 m / 2 m: small, so random weights run in a fraction of a second."""
    depth = np.full((rows, cols), 2.0)
    depth[:, : cols // 2] = 1.0
    return depth


@pytest.mark.filterwarnings("ignore:frames such as")
def test_random_weights_reconstruct_into_the_common_record(fake_weights):
    scene, sensor = small_scene(), SMALL_SENSOR
    ev = simulate_photons(PhotonScene(scene), Condition(2.0, 1.0, sensor), np.random.default_rng(1))
    rec = reconstruct(ev, scene.shape, sensor, method="sspi", weights=fake_weights)
    assert isinstance(rec, Reconstruction)
    assert all(f.shape == scene.shape for f in rec)
    assert np.array_equal(rec.valid, np.isfinite(rec.depth_m))
    assert np.array_equal(rec.counts, ev.counts())
    assert (rec.reflectivity[~rec.valid] == 0).all() and (rec.background >= 0).all()


@pytest.mark.filterwarnings("ignore:frames such as")  # recorded below, not re-emitted
def test_untrained_bin_width_and_frame_warn_once(fake_weights):
    scene = small_scene(8, 10)
    sensor = SensorParams(bin_width_s=1e-9, pulse_sigma_s=1e-9, n_bins=32)
    ev = simulate_photons(PhotonScene(scene), Condition(2.0, 1.0, sensor), np.random.default_rng(2))
    sspi._WARNED.clear()
    with pytest.warns(UserWarning, match="bin width 1000 ps is outside the 80-100 ps") as record:
        reconstruct(ev, scene.shape, sensor, method="sspi", weights=fake_weights)
    assert any("differ from the 64x64" in str(w.message) for w in record)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # later frames, of any size: silent
        reconstruct(ev, scene.shape, sensor, method="sspi", weights=fake_weights)
        smaller = simulate_photons(
            PhotonScene(scene[:6]), Condition(2.0, 1.0, sensor), np.random.default_rng(3)
        )
        reconstruct(smaller, (6, 10), sensor, method="sspi", weights=fake_weights)
    assert sspi.check_conditions(SensorParams.ugv45m(), (64, 64)) == []


@pytest.mark.filterwarnings("ignore:frames such as")
def test_an_sspi_variant_shard_times_one_frame_then_writes_its_variants(
    fake_weights, tmp_path, monkeypatch, capsys
):
    """The workflow's variants step with ``reconstruct_method: sspi``: the job log gets
    the expected time first, then the shard holds one SSPI variant per sample."""
    from spl_al.data import Dataset
    from spl_al.data.variants import VariantShard
    from spl_al.experiment.data_steps import make_variant_shard

    monkeypatch.setenv(SSPI_WEIGHTS_ENV, "")  # the step exports the folder; restored after the test
    Dataset(
        "classification",
        ["near", "far"],
        np.stack([small_scene(), small_scene()[:, ::-1]]).astype(np.float32),
        labels=np.array([0, 1]),
        split=np.array(["train", "train"]),
        msppp=np.array([5.0, 5.0]),
        sbr=np.array([1.0, 1.0]),
        level=np.array(["medium", "medium"]),
        sensor=SMALL_SENSOR,
    ).save(tmp_path / "observed.npz")
    variants = {"n": 1, "shards": 1, "seed": 0, "reconstruct_method": "sspi"}
    make_variant_shard(
        tmp_path / "observed.npz",
        variants,
        shard=0,
        out_path=tmp_path / "s0.npz",
        sspi_weights=fake_weights,
    )
    assert "this shard reconstructs 2 variants" in capsys.readouterr().out
    shard = VariantShard.load(tmp_path / "s0.npz")
    assert shard.depth_m.shape == (2, 1, 12, 16)
