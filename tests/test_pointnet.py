"""PointNet++ on range-image points: point operations against brute force, permutation
equivariance, learning, determinism, and the build/train/predict/score round trip."""

import numpy as np
import pytest
import torch

from spl_al.data.procedural import make_segmentation_dataset
from spl_al.models import build_model, model_input, to_range_input, training_outputs
from spl_al.models.configured import model_for
from spl_al.models.pointnet import (
    ball_query,
    farthest_point_sample,
    sample_pixels,
    three_nn_interpolate,
)
from spl_al.scenes.raycast import ScanGrid
from spl_al.scoring import compute_inputs
from spl_al.strategies import get
from spl_al.strategies.duis import margin_and_inconsistency
from spl_al.training import evaluate, predict, train
from spl_al.training.compute import Compute

CPU = Compute("cpu")

SMALL = {"n_points": 128, "centres": (32, 8), "radii_m": (2.0, 6.0), "neighbours": 8, "width": 8}
BACKENDS = ("kdtree", "torch")


def _cloud(b=2, n=60, seed=0) -> torch.Tensor:
    return torch.from_numpy(np.random.default_rng(seed).uniform(-5, 5, (b, n, 3)))


def _fps_reference(x: np.ndarray, s: int) -> list[int]:
    first = int(np.argmax(((x - x.mean(0)) ** 2).sum(1)))
    chosen = [first]
    for _ in range(s - 1):
        d = np.min([((x - x[c]) ** 2).sum(1) for c in chosen], axis=0)
        chosen.append(int(np.argmax(d)))
    return chosen


@pytest.mark.parametrize("backend", ["numpy", "torch"])
def test_farthest_point_sampling_matches_brute_force(backend):
    x = _cloud()
    got = farthest_point_sample(x, 12, backend)
    for b in range(len(x)):
        assert got[b].tolist() == _fps_reference(x[b].numpy(), 12)
    cloud32 = _cloud(b=4, n=500, seed=4).float()
    assert torch.equal(
        farthest_point_sample(cloud32, 64, "numpy"), farthest_point_sample(cloud32, 64, "torch")
    )
    with pytest.raises(ValueError, match="n_centres"):
        farthest_point_sample(x, 61, backend)


@pytest.mark.parametrize("backend", BACKENDS)
def test_ball_query_matches_brute_force(backend):
    x = _cloud()
    centres = x[:, :7] + 0.1  # near a point, but not one
    radius, k = 2.5, 6
    got = ball_query(x, centres, radius_m=radius, k=k, backend=backend).numpy()
    for b in range(len(x)):
        for s in range(centres.shape[1]):
            d = np.sqrt(((x[b].numpy() - centres[b, s].numpy()) ** 2).sum(1))
            order = np.argsort(d, kind="stable")
            inside = [int(i) for i in order[:k] if d[i] <= radius]
            expected = inside + [int(order[0])] * (k - len(inside))
            assert got[b, s].tolist() == expected
    # more slots than points: padded with the nearest
    assert ball_query(x[:, :3], centres, radius_m=100.0, k=5, backend=backend).shape == (2, 7, 5)
    # an empty ball: every slot is the nearest point, however far
    far = x[:, :1] + 50.0
    nearest = ((x - far) ** 2).sum(-1).argmin(-1)
    got = ball_query(x, far, radius_m=1.0, k=4, backend=backend)
    assert torch.equal(got, nearest[:, None, None].expand(-1, 1, 4))


@pytest.mark.parametrize("backend", BACKENDS)
def test_three_nn_interpolation_matches_brute_force(backend):
    x, q = _cloud(n=30), _cloud(n=9, seed=1)
    v = torch.from_numpy(np.random.default_rng(2).normal(size=(2, 30, 4)))
    got = three_nn_interpolate(q, x, v, backend).numpy()
    for b in range(2):
        d = np.sqrt(((q[b].numpy()[:, None] - x[b].numpy()[None]) ** 2).sum(-1))
        nn3 = np.argsort(d, axis=1)[:, :3]
        w = 1 / (np.take_along_axis(d, nn3, 1) + 1e-8)
        w /= w.sum(1, keepdims=True)
        np.testing.assert_allclose(got[b], (v[b].numpy()[nn3] * w[..., None]).sum(1), atol=1e-9)
    # a query at a known point takes that point's value, also in float32 100 m away
    np.testing.assert_allclose(three_nn_interpolate(x, x, v, backend).numpy(), v.numpy(), atol=1e-6)
    far = (x + 100.0).float()
    own = three_nn_interpolate(far, far, v.float(), backend).numpy()
    np.testing.assert_allclose(own, v.numpy(), atol=1e-4)


def test_sample_pixels_rules():
    valid = torch.tensor([[True] * 6 + [False] * 4, [False] * 7 + [True] * 3])
    # evaluation: evenly spaced valid pixels in raster order, no randomness
    assert sample_pixels(valid, 3, None).tolist() == [[0, 2, 4], [7, 8, 9]]
    assert sample_pixels(valid, 6, None)[1].tolist() == [7, 7, 8, 8, 9, 9]
    # training: a seeded random order; without replacement when enough, cycled otherwise
    a = sample_pixels(valid, 5, torch.Generator().manual_seed(3))
    b = sample_pixels(valid, 5, torch.Generator().manual_seed(3))
    assert torch.equal(a, b)
    assert len(set(a[0].tolist())) == 5 and set(a[0].tolist()) <= set(range(6))
    assert sorted(a[1, :3].tolist()) == [7, 8, 9] and a[1, 3:].tolist() == a[1, :2].tolist()


def _grid(shape=(8, 24)) -> ScanGrid:
    return ScanGrid(shape, (5.0, -25.0), (-40.0, 40.0))


def test_network_is_permutation_equivariant():
    torch.manual_seed(0)
    model = build_model("segmentation", 3, "pointnet2", seed=0, grid=_grid(), **SMALL).eval()
    xyz = torch.from_numpy(np.random.default_rng(0).uniform(-8, 8, (2, 128, 3))).float()
    feats = model.point_features(xyz, xyz.norm(dim=-1))
    perm = torch.from_numpy(np.random.default_rng(1).permutation(128))
    with torch.no_grad():
        out = model.point_forward(xyz, feats)
        out_perm = model.point_forward(xyz[:, perm], feats[:, perm])
    torch.testing.assert_close(out_perm, out[:, perm], atol=1e-5, rtol=1e-4)


def test_input_features_are_standardised_per_channel():
    """Training: each of (x, y, z, r) has zero mean and unit variance over the batch's
    points, however unequal their spreads in metres; evaluation: the running statistics."""
    model = build_model("segmentation", 2, "pointnet2", seed=0, grid=_grid(), **SMALL).train()
    rng = np.random.default_rng(0)
    xyz = torch.from_numpy(rng.normal(0, 1, (4, 128, 3)) * [20.0, 40.0, 0.5] + [0, 30, -1.8])
    xyz = xyz.float()
    feats = model.point_features(xyz, xyz.norm(dim=-1)).reshape(-1, 4)
    torch.testing.assert_close(feats.mean(0), torch.zeros(4), atol=1e-4, rtol=0)
    torch.testing.assert_close(feats.std(0, unbiased=False), torch.ones(4), atol=1e-3, rtol=0)
    norm = model.input_norm
    raw_m = torch.cat([xyz, xyz.norm(dim=-1, keepdim=True)], dim=-1).reshape(-1, 4)
    torch.testing.assert_close(norm.running_mean, 0.1 * raw_m.mean(0))  # one update from 0
    model.eval()
    expected = (raw_m - norm.running_mean) / (norm.running_var + norm.eps).sqrt()
    got = model.point_features(xyz, xyz.norm(dim=-1)).reshape(-1, 4)
    torch.testing.assert_close(got, expected)

    plain = build_model("segmentation", 2, "pointnet2", grid=_grid(), input_norm=False, **SMALL)
    assert plain.input_norm is None  # metres over coord_scale_m (20), as they are
    torch.testing.assert_close(
        plain.point_features(xyz, xyz.norm(dim=-1)).reshape(-1, 4), raw_m / 20
    )
    # weights of one setting do not silently load into the other
    with pytest.raises(ValueError, match=r"without input normalisation; .* input_norm: false"):
        model.load_state_dict(plain.state_dict())
    with pytest.raises(ValueError, match=r"with input normalisation; .* input_norm: true"):
        plain.load_state_dict(model.state_dict())


def _toy_scenes(n: int, grid: ScanGrid, seed: int):
    """Ground (class 0) below a wall (class 1) at a random distance; 10% voids."""
    rng = np.random.default_rng(seed)
    u = grid.directions()  # (H, W, 3)
    depth = np.empty((n, *grid.shape), dtype=np.float32)
    labels = np.empty((n, *grid.shape), dtype=np.uint8)
    for i in range(n):
        height, wall = rng.uniform(1.2, 2.0), rng.uniform(6.0, 14.0)
        t_ground = np.where(u[..., 2] < 0, height / np.maximum(-u[..., 2], 1e-9), np.inf)
        t_wall = wall / u[..., 1]
        depth[i] = np.minimum(t_ground, t_wall) + rng.normal(0, 0.02, grid.shape)
        labels[i] = np.where(t_ground < t_wall, 0, 1)
    valid = rng.random(depth.shape) > 0.1
    depth[~valid] = np.nan
    labels[~valid] = 255
    return depth, valid, labels


FIT = {"epochs": 15, "min_steps": 0, "batch_size": 8, "lr": 0.05, "channels_last": False}


@pytest.mark.parametrize("loss_at", ["points", "pixels"])
def test_learns_a_toy_two_class_cloud(loss_at):
    grid = _grid()
    depth, valid, labels = _toy_scenes(48, grid, seed=0)
    test_d, test_v, test_y = _toy_scenes(16, grid, seed=1)
    model = build_model("segmentation", 2, "pointnet2", grid=grid, loss_at=loss_at, **SMALL)
    train(model, depth, valid, labels, cfg={**FIT, "log_every": 0}, seed=1, compute=CPU)
    metrics = evaluate(model, test_d, test_v, test_y, compute=CPU)
    assert metrics["pixel_accuracy"] >= 0.95, metrics


def test_training_scores_the_sampled_points_unless_told_pixels():
    grid = _grid()
    depth, valid, labels = _toy_scenes(3, grid, seed=3)
    model = build_model("segmentation", 2, "pointnet2", seed=0, grid=grid, **SMALL).eval()
    x, y = model_input(model, depth, valid), torch.from_numpy(labels.astype(np.int64))
    with torch.no_grad():
        logits, target = training_outputs(model, x, y)
        pixel_logits = model(x)[0].reshape(3, 2, -1)
    # evaluation mode samples deterministically, so the sampled pixels are known
    idx = sample_pixels(torch.from_numpy(valid).reshape(3, -1), SMALL["n_points"], None)
    assert logits.shape == (3, 2, SMALL["n_points"])
    assert torch.equal(target, torch.gather(y.reshape(3, -1), 1, idx))
    assert int(target.max()) < 2  # sampled pixels are valid, none carries the ignore label
    # a sampled pixel's interpolated prediction is its own point's
    at_points = torch.gather(pixel_logits, 2, idx[:, None].expand(-1, 2, -1))
    torch.testing.assert_close(logits, at_points, atol=1e-4, rtol=1e-3)

    per_pixel = build_model("segmentation", 2, "pointnet2", grid=grid, loss_at="pixels", **SMALL)
    logits, target = training_outputs(per_pixel.eval(), x, y)
    assert logits.shape == (3, 2, *grid.shape) and target is y
    with pytest.raises(ValueError, match="loss_at must be"):
        build_model("segmentation", 2, "pointnet2", grid=grid, loss_at="rays", **SMALL)


def test_weights_saved_with_convolution_mlps_still_load():
    grid = _grid()
    model = build_model("segmentation", 3, "pointnet2", seed=0, grid=grid, **SMALL).eval()
    # the layout before the shared MLPs were matrix products: nn.Sequential(conv, batch
    # norm, ReLU, ...) with (out, in, 1, 1) / (out, in, 1) convolution weights
    old = {}
    for key, value in model.state_dict().items():
        parts = key.split(".")
        if "linears" in parts or "norms" in parts:
            at = parts.index("linears") if "linears" in parts else parts.index("norms")
            i = int(parts[at + 1])
            index = 3 * i if parts[at] == "linears" else 3 * i + 1
            if parts[at] == "linears":
                value = value[..., None, None] if parts[0] == "sa" else value[..., None]
            key = ".".join([*parts[:at], str(index), *parts[at + 2 :]])
        old[key] = value.clone()
    assert "sa.0.mlp.0.weight" in old and old["sa.0.mlp.0.weight"].ndim == 4
    fresh = build_model("segmentation", 3, "pointnet2", seed=1, grid=grid, **SMALL).eval()
    fresh.load_state_dict(old)
    depth, valid, _ = _toy_scenes(2, grid, seed=4)
    x = model_input(model, depth, valid)
    with torch.no_grad():
        torch.testing.assert_close(fresh(x)[0], model(x)[0])


def test_training_is_deterministic_for_a_seed():
    grid = _grid()
    depth, valid, labels = _toy_scenes(16, grid, seed=2)
    fit = {**FIT, "epochs": 2, "log_every": 0}
    states = []
    for seed in (5, 5, 6):
        model = build_model("segmentation", 2, "pointnet2", grid=grid, **SMALL)
        states.append(
            train(model, depth, valid, labels, cfg=fit, seed=seed, compute=CPU).state_dict()
        )
    assert all(torch.equal(states[0][k], states[1][k]) for k in states[0])
    assert not all(torch.equal(states[0][k], states[2][k]) for k in states[0])
    with pytest.raises(ValueError, match="tied to its scan grid"):
        train(model, depth, valid, labels, cfg={**fit, "crop_width": 0.5}, seed=0, compute=CPU)


def test_fine_tuning_samples_points_from_the_training_seed_not_the_global_rng():
    """A fine-tuned PointNet++ (weights loaded, from_scratch off) trains the same
    whatever the global RNG held when it was built (a warm job process inherits
    another's): its point sampler is seeded from the training seed."""
    grid = _grid()
    depth, valid, labels = _toy_scenes(16, grid, seed=2)
    start = build_model("segmentation", 2, "pointnet2", grid=grid, seed=0, **SMALL).state_dict()
    fit = {**FIT, "epochs": 2, "log_every": 0, "from_scratch": False}
    states = []
    for global_seed in (1, 2):
        torch.manual_seed(global_seed)  # the state a model is built in
        model = build_model("segmentation", 2, "pointnet2", grid=grid, **SMALL)
        model.load_state_dict(start)
        states.append(train(model, depth, valid, labels, cfg=fit, seed=5, compute=CPU).state_dict())
    assert all(torch.equal(states[0][k], states[1][k]) for k in states[0])


def test_range_input_keeps_metres_and_wrong_inputs_are_refused():
    depth = np.array([[[2.0, np.nan], [7.5, 3.0]]], dtype=np.float32)
    x = to_range_input(depth, np.array([[[True, True], [False, True]]]))
    assert x[0, 0].tolist() == [[2.0, 0.0], [0.0, 3.0]] and x[0, 1].tolist() == [[1, 0], [0, 1]]
    model = build_model("segmentation", 2, "pointnet2", grid=_grid(), **SMALL)
    assert torch.equal(model_input(model, depth), to_range_input(depth))
    with pytest.raises(ValueError, match="scan grid"):
        build_model("segmentation", 2, "pointnet2")
    with pytest.raises(ValueError, match="built for"):
        model(torch.zeros(1, 2, 4, 4))
    too_many = {"n_points": 9, "centres": [32], "radii_m": [1.0]}
    with pytest.raises(ValueError, match="centres must decrease"):
        build_model("segmentation", 2, "pointnet2", grid=_grid(), **too_many)


def test_duis_units_are_points_present_in_both_images_by_hand():
    """Points = valid pixels. Observed cloud {0, 1, 2}; variant 1 lost point 2, variant 2
    lost point 0 and has an extra point 3 the observed cloud lacks (it never counts)."""
    q = np.array(
        [
            [[0.8, 0.2], [0.5, 0.5], [1.0, 0.0], [0.5, 0.5]],  # observed
            [[0.6, 0.4], [0.5, 0.5], [0.0, 1.0], [0.5, 0.5]],  # variant 1 (point 2 void)
            [[0.1, 0.9], [0.9, 0.1], [0.4, 0.6], [0.0, 1.0]],  # variant 2 (point 0 void)
        ]
    )[None]
    held = np.array([[[1, 1, 1, 0], [1, 1, 0, 0], [0, 1, 1, 1]]], dtype=bool)
    gamma, d = margin_and_inconsistency(q, image_valid=held)
    qbar = {0: np.array([0.7, 0.3]), 1: np.array([19 / 30, 11 / 30]), 2: np.array([0.7, 0.3])}

    def kl(p, r):
        return sum(pc * np.log(pc / rc) for pc, rc in zip(p, r, strict=True) if pc > 0)

    assert gamma == pytest.approx([np.mean([abs(qbar[u][0] - qbar[u][1]) for u in range(3)])])
    per_image = [
        np.mean([kl(q[0, 0, u], qbar[u]) for u in (0, 1, 2)]),
        np.mean([kl(q[0, 1, u], qbar[u]) for u in (0, 1)]),
        np.mean([kl(q[0, 2, u], qbar[u]) for u in (1, 2)]),
    ]
    assert d == pytest.approx([np.mean(per_image)])


@pytest.fixture(scope="module")
def street():
    data = make_segmentation_dataset(12, image_shape=(16, 64), seed=0, workers=1)
    rng = np.random.default_rng(0)
    variants = np.repeat(data.depth_m[:, None], 2, axis=1)
    variants[rng.random(variants.shape) < 0.2] = np.nan  # a variant's extra voids
    cond = np.ones((len(data), 2))
    return data.with_variants(variants, cond, cond, {"n": 2})


def test_round_trip_on_street_scans(street):
    cfg = {"arch": "pointnet2", **SMALL}
    model = model_for(street, cfg)
    train_idx = street.train_idx
    fit = {**FIT, "epochs": 1, "log_every": 0}
    labels = street.labels[train_idx]
    train(model, street.depth_m[train_idx], street.valid[train_idx], labels, cfg=fit, seed=0)
    test = street.test_idx
    metrics = evaluate(model, street.depth_m[test], street.valid[test], street.labels[test])
    assert 0.0 <= metrics["miou"] <= 1.0
    pred = predict(model, street.depth_m[test], street.valid[test], batch_size=2)
    again = predict(model, street.depth_m[test], street.valid[test], batch_size=5)
    np.testing.assert_allclose(pred.probs, again.probs, atol=1e-6)  # batch-independent
    assert pred.probs.shape == (len(test), 7, 16, 64) and pred.features.shape == (len(test), 8)
    depth, valid = street.groups(train_idx, n_variants=2)
    needs = get("duis").needs | get("badge").needs | get("coreset").needs
    inputs = compute_inputs(
        model,
        needs,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=np.arange(3, len(train_idx)),
        labeled_idx=np.arange(3),
    )
    n_unl = len(train_idx) - 3
    assert inputs.gamma.shape == (n_unl,) and np.isfinite(inputs.inconsistency).all()
    assert inputs.group_features.shape == (n_unl, 8) and inputs.labeled_features.shape == (3, 8)
    # the reloaded model (built from the dataset's grid) predicts the same
    clone = model_for(street, cfg)
    clone.load_state_dict(model.state_dict())
    np.testing.assert_allclose(
        predict(clone, street.depth_m[test], street.valid[test]).probs, pred.probs, atol=1e-6
    )
