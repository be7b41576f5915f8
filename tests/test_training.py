"""Training, prediction and evaluation: determinism, learning, masking, metrics."""

import io
import json

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from helpers.al_synthetic import shapes_groups, street_groups
from torch import nn

from spl_al.label_codes import IGNORE_INDEX
from spl_al.models import build_model
from spl_al.training import (
    TrainConfig,
    confusion_per_image,
    evaluate,
    flatten_groups,
    masked_cross_entropy,
    predict,
    resolve_device,
    summarise,
    train,
)
from spl_al.training.compute import Compute
from spl_al.training.fit import (
    _soft_targets,
    balanced_class_weights,
    random_affine,
    random_crop_columns,
    random_shift,
)

CPU = Compute("cpu")

FAST = TrainConfig(epochs=4, batch_size=32, lr=0.05, log_every=0)


def _same_weights(a: nn.Module, b: nn.Module) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return all(torch.equal(sa[k], sb[k]) for k in sa)


def test_training_is_deterministic_for_a_seed():
    depth, valid, y = shapes_groups(48, n_groups=1)
    d, v = depth[:, 0], valid[:, 0]
    runs = []
    for seed in (3, 3, 4):
        # from_scratch: init comes from seed; dropout draws from torch's global RNG,
        # which train seeds too (and leaves as the caller had it).
        model = build_model("classification", 3, width=4, dropout=0.5)
        torch.manual_seed(100 + len(runs))
        before = torch.random.get_rng_state()
        runs.append(train(model, d, v, y, cfg=FAST, seed=seed, compute=CPU, log=io.StringIO()))
        assert torch.equal(torch.random.get_rng_state(), before)
    assert _same_weights(runs[0], runs[1])
    assert not _same_weights(runs[0], runs[2])
    p0, p1 = predict(runs[0], d, v, compute=CPU), predict(runs[1], d, v, compute=CPU)
    assert np.array_equal(p0.probs, p1.probs) and np.array_equal(p0.features, p1.features)


def test_classifier_learns_a_separable_task_with_variants(tmp_path):
    depth, valid, y = shapes_groups(200, n_groups=3, seed=1)
    d, v, t = flatten_groups(depth[:140], valid[:140], y[:140], variants=True)
    assert d.shape == (420, 16, 16) and np.array_equal(t, np.repeat(y[:140], 3))
    model = build_model("classification", 3, width=8)
    cfg = TrainConfig(epochs=8, batch_size=64, lr=0.05, log_every=4)
    train(model, d, v, t, cfg=cfg, seed=0, compute=CPU, log=tmp_path / "train.log")
    lines = (tmp_path / "train.log").read_text().splitlines()
    assert lines[0].startswith("train classification") and any("epoch 8/8" in s for s in lines)
    levels = np.array(["high", "low"] * 30)
    m = evaluate(model, depth[140:, 0], valid[140:, 0], y[140:], levels=levels, classes="abc")
    assert m["accuracy"] > 0.9, m
    assert set(m["per_level"]) == {"high", "low"} and m["per_level"]["high"]["n_images"] == 30
    assert np.asarray(m["confusion"]).sum() == 60
    json.dumps(m)


def test_segmentation_loss_ignores_invalid_pixels():
    depth, valid, masks = street_groups(12, n_groups=1)
    d, v = depth[:, 0], valid[:, 0]
    scrambled = masks.copy()
    void = ~v
    scrambled[void] = np.random.default_rng(0).integers(0, 3, void.sum())  # labels at voids
    cfg = TrainConfig(steps=3, batch_size=6, log_every=0)
    runs = [
        train(
            build_model("segmentation", 3, width=4, depth=2),
            d,
            v,
            t,
            cfg=cfg,
            seed=0,
            compute=CPU,
            log=io.StringIO(),
        )
        for t in (masks, scrambled)
    ]
    assert _same_weights(*runs)
    # and the loss itself: only units whose target is not IGNORE_INDEX count
    logits = torch.tensor([[[[2.0, 0.0]], [[0.0, 5.0]]]])  # (1, C=2, 1, 2)
    target = torch.tensor([[[0, IGNORE_INDEX]]])
    expected = -torch.log_softmax(torch.tensor([2.0, 0.0]), 0)[0]
    assert torch.isclose(masked_cross_entropy(logits, target), expected)


def test_balanced_loss_weights_each_class_by_its_count_by_hand():
    # units: class 0 three times, class 1 once, one ignored; power 1 = inverse frequency
    target = torch.tensor([[0, 0, 0, 1, IGNORE_INDEX]])
    w = balanced_class_weights(target, 3, 1.0)
    # n^-1 = (1/3, 1, 0), scaled to a mean weight of 1 per unit: 4 / (3 * 1/3 + 1 * 1) = 2
    torch.testing.assert_close(w, torch.tensor([2 / 3, 2.0, 0.0]))
    logits = torch.randn(1, 3, 5)
    nll = -torch.log_softmax(logits, 1)[0, target[0, :4], torch.arange(4)]
    expected = (w[0] * nll[:3].sum() + w[1] * nll[3]) / (3 * w[0] + w[1])
    torch.testing.assert_close(masked_cross_entropy(logits, target, w), expected)
    # equal weights are the plain mean
    torch.testing.assert_close(
        masked_cross_entropy(logits, target, torch.ones(3)), masked_cross_entropy(logits, target)
    )


@pytest.mark.parametrize(("crop_width", "balance"), [(1.0, 0.0), (0.5, 0.5)])
def test_segmenter_learns_and_reports_miou(crop_width, balance):
    """Also on half-width windows (prediction still takes whole images) with a
    class-balanced loss."""
    depth, valid, masks = street_groups(60, n_groups=1, seed=2)
    model = build_model("segmentation", 3, width=8, depth=2)
    cfg = TrainConfig(
        epochs=30, batch_size=16, lr=0.05, log_every=0, crop_width=crop_width, balance=balance
    )
    train(model, depth[:40, 0], valid[:40, 0], masks[:40], cfg=cfg, seed=0, compute=CPU)
    m = evaluate(model, depth[40:, 0], valid[40:, 0], masks[40:], levels=["medium"] * 20)
    assert m["miou"] > 0.6, m
    assert m["n_pixels"] == int((masks[40:] != IGNORE_INDEX).sum())
    pred = predict(model, depth[40:42, 0], valid[40:42, 0], features="pixel")
    assert pred.probs.shape == (2, 3, 12, 20) and pred.features.shape == (2, 8, 12, 20)
    assert predict(model, depth[:2, 0], valid[:2, 0]).features.shape == (2, 8)


class FixedModel(nn.Module):
    """Returns preset logits, to check the metrics by hand."""

    def __init__(self, task, logits):
        super().__init__()
        self.task, self.logits = task, torch.as_tensor(logits, dtype=torch.float32)
        self.n_classes = self.logits.shape[1]
        self.dummy = nn.Parameter(torch.zeros(1))

    def forward(self, x):
        return self.logits[: len(x)], torch.zeros(len(x), 1, *x.shape[2:])


def test_classification_metrics_by_hand():
    pred = np.array([0, 1, 1, 2, 2, 0])
    true = np.array([0, 1, 2, 2, 2, 1])
    model = FixedModel("classification", np.eye(3)[pred])
    depth = np.ones((6, 2, 2), np.float32)
    m = evaluate(model, depth, depth > 0, true, levels=["low", "high"] * 3)
    assert m["accuracy"] == pytest.approx(4 / 6)
    assert m["per_class"] == {"0": 1.0, "1": 0.5, "2": pytest.approx(2 / 3)}
    assert m["confusion"] == [[1, 0, 0], [1, 1, 0], [0, 1, 2]]
    assert list(m["per_level"]) == ["high", "low"]  # known levels in MSPPP order
    assert m["per_level"]["low"]["accuracy"] == pytest.approx(2 / 3)  # images 0, 2, 4
    assert m["per_level"]["high"]["accuracy"] == pytest.approx(2 / 3)  # images 1, 3, 5


def test_miou_by_hand_ignores_voids_and_ignore_label():
    # one 2x3 image, classes 0..2; pixel (1, 2) is void, pixel (1, 1) has IGNORE_INDEX
    pred = np.array([[0, 0, 1], [1, 2, 2]])
    true = np.array([[0, 1, 1], [1, IGNORE_INDEX, 0]], dtype=np.uint8)
    depth = np.ones((1, 2, 3), np.float32)
    depth[0, 1, 2] = np.nan
    model = FixedModel("segmentation", np.eye(3)[pred].transpose(2, 0, 1)[None])
    m = evaluate(model, depth, np.isfinite(depth), true[None])
    # counted: (0,0) 0->0, (0,1) 1->0, (0,2) 1->1, (1,0) 1->1
    assert m["confusion"] == [[1, 0, 0], [1, 2, 0], [0, 0, 0]]
    assert m["per_class_iou"] == {"0": 0.5, "1": pytest.approx(2 / 3), "2": None}
    assert m["miou"] == pytest.approx((0.5 + 2 / 3) / 2)
    assert m["pixel_accuracy"] == 0.75


def test_summarise_and_confusion_validate_levels():
    conf = confusion_per_image(np.array([0, 1]), np.array([0, 0]), 2)
    assert conf.shape == (2, 2, 2) and conf[1, 0, 1] == 1
    with pytest.raises(ValueError, match="levels"):
        summarise(conf, "classification", levels=["high"])
    with pytest.raises(ValueError, match="classes"):
        summarise(conf, "classification", classes=["a"])


def test_train_config_from_dict_and_steps():
    cfg = TrainConfig.from_dict({"epochs": 3, "batch_size": 10, "min_steps": 20})
    assert cfg.total_steps(35) == 20 and TrainConfig(epochs=3, batch_size=10).total_steps(35) == 9
    assert TrainConfig(steps=7).total_steps(1000) == 7
    # steps per labeled group: five images per group (variants) train no longer than one
    per_group = TrainConfig(epochs=3, batch_size=10, min_steps=20, steps_per_group=4)
    assert per_group.total_steps(50, n_groups=10) == per_group.total_steps(10, n_groups=10) == 40
    assert per_group.total_steps(3, n_groups=3) == 20 and per_group.total_steps(30) == 120
    paper = TrainConfig.paper()
    assert (paper.epochs, paper.batch_size, paper.lr, paper.momentum) == (200, 512, 0.1, 0.9)
    assert TrainConfig.from_dict(cfg.to_dict()) == cfg
    for bad in (
        {"epoch": 3},
        {"lr": -1},
        {"batch_size": 0},
        {"epochs": None},
        {"cosine": "yes"},
        {"shift": 0.5},
        {"rotate_deg": 200},
        {"scale": 1.5},
        {"mixup": -0.1},
        {"label_smoothing": 1.0},
        {"crop_width": 0},
        {"steps_per_group": -1},
        {"steps_by": "scans"},
        {"balance": -0.5},
        {"crop_width": 1.5},
    ):
        with pytest.raises(ValueError):
            TrainConfig.from_dict(bad)


def test_train_rejects_bad_targets():
    depth, valid, y = shapes_groups(4, n_groups=1)
    model = build_model("classification", 3, width=2)
    with pytest.raises(ValueError, match="targets"):
        train(
            model,
            depth[:, 0],
            valid[:, 0],
            y + 3,
            cfg=FAST,
            seed=0,
            compute=CPU,
            log=io.StringIO(),
        )
    with pytest.raises(ValueError, match="targets"):
        train(
            model,
            depth[:, 0],
            valid[:, 0],
            y[:3],
            cfg=FAST,
            seed=0,
            compute=CPU,
            log=io.StringIO(),
        )
    with pytest.raises(ValueError, match="groups must lie in"):
        train(
            model,
            depth[:, 0],
            valid[:, 0],
            y,
            cfg=FAST,
            seed=0,
            compute=CPU,
            log=io.StringIO(),
            groups=5,
        )


def test_epochs_count_groups_by_default_and_images_when_asked():
    # 40 labeled groups of 5 images (observed + 4 variants) against 40 observed images
    groups = TrainConfig(epochs=10, batch_size=8)
    assert groups.steps_by == "groups"
    assert groups.total_steps(200, n_groups=40) == groups.total_steps(40, n_groups=40) == 50
    assert groups.total_steps(200) == 250  # no groups given: each image is its own
    assert groups.images_seen(200, n_groups=40) == 50 * 8
    images = TrainConfig(epochs=10, batch_size=8, steps_by="images")
    assert images.total_steps(200, n_groups=40) == 250  # variants add steps
    assert images.total_steps(40, n_groups=40) == 50
    # the floors and explicit steps hold under both policies
    for by in ("groups", "images"):
        floor = TrainConfig(epochs=10, batch_size=8, min_steps=300, steps_by=by)
        assert floor.total_steps(200, n_groups=40) == floor.total_steps(40, n_groups=40) == 300
        per_group = TrainConfig(epochs=10, batch_size=8, steps_per_group=20, steps_by=by)
        assert per_group.total_steps(200, n_groups=40) == 800
        assert TrainConfig(steps=7, steps_by=by).total_steps(200, n_groups=40) == 7
    # fewer images than a batch: one step of all of them per epoch
    small = TrainConfig(epochs=3, batch_size=32)
    assert small.total_steps(15, n_groups=3) == 3 and small.images_seen(15, n_groups=3) == 45
    with pytest.raises(ValueError, match="steps_by"):
        TrainConfig(steps_by="scans")


def test_train_takes_the_steps_of_its_policy():
    depth, valid, y = shapes_groups(12, n_groups=1)  # 12 images from 3 labeled groups
    for by, steps in (("groups", 2), ("images", 12)):
        cfg = TrainConfig(epochs=2, batch_size=2, steps_by=by, log_every=0)
        assert cfg.total_steps(12, 3) == steps
        log = io.StringIO()
        model = build_model("classification", 3, width=2)
        train(model, depth[:, 0], valid[:, 0], y, cfg=cfg, seed=0, compute=CPU, log=log, groups=3)
        assert f", {steps} steps (" in log.getvalue()


def test_steps_per_group_counts_the_labeled_groups_not_the_images():
    depth, valid, y = shapes_groups(4, n_groups=1)
    cfg = TrainConfig(epochs=1, batch_size=4, steps_per_group=5, log_every=0)
    for groups, steps in [(2, 10), (None, 20)]:
        log = io.StringIO()
        model = build_model("classification", 3, width=2)
        train(
            model,
            depth[:, 0],
            valid[:, 0],
            y,
            cfg=cfg,
            seed=0,
            compute=CPU,
            log=log,
            groups=groups,
        )
        assert f", {steps} steps (" in log.getvalue()


def test_resolve_device():
    assert resolve_device("cpu").type == "cpu"
    assert resolve_device(None).type == ("cuda" if torch.cuda.is_available() else "cpu")
    assert resolve_device("auto") == resolve_device(None)
    with pytest.raises(ValueError):
        resolve_device("tpu")
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="CUDA"):
            resolve_device("cuda")


@pytest.mark.parametrize("augment", ["shift", "affine"])
def test_geometric_augmentations_move_masks_with_their_pixels(augment):
    """Every augmented pixel keeps the label of the depth it carries; what comes in from
    outside the frame is void in the image and ignored in the mask."""
    gen = torch.Generator().manual_seed(0)
    y = torch.randint(0, 5, (8, 12, 20))
    # Channel 0 carries each pixel's own label (+1, so 0 means void), channel 1 validity.
    x = torch.stack([(y + 1).float(), torch.ones(y.shape)], dim=1)
    if augment == "shift":
        x2, y2 = random_shift(x, y, (3, 5), gen)
    else:
        x2, y2 = random_affine(x, y, rotate_deg=30, scale=0.3, gen=gen)
    inside = y2 != IGNORE_INDEX
    assert torch.equal(x2[:, 0][inside], (y2[inside] + 1).float())
    assert torch.all(x2[:, 1][inside] == 1)
    assert torch.all(x2.permute(1, 0, 2, 3)[:, ~inside] == 0)
    assert 0 < (~inside).float().mean() < 0.5  # something moved out of the frame
    assert not torch.equal(y2, y)


def test_random_shift_translates_each_image_by_its_own_offset():
    """out[b, :, r, c] = x[b, :, r - dy_b, c - dx_b], voids (0, IGNORE_INDEX) shifted in;
    the offsets are the generator's, so a seed gives the same batch on any device."""
    x = torch.randn(64, 2, 5, 7)
    y = torch.randint(0, 5, (64, 5, 7))
    max_px = (6, 8)  # larger than the frame: some images leave it entirely
    out, y_out = random_shift(x, y, max_px, torch.Generator().manual_seed(3))
    gen = torch.Generator().manual_seed(3)
    dy = torch.randint(-6, 7, (64,), generator=gen)
    dx = torch.randint(-8, 9, (64,), generator=gen)
    for b in range(64):
        for r in range(5):
            for c in range(7):
                sr, sc = r - int(dy[b]), c - int(dx[b])
                inside = 0 <= sr < 5 and 0 <= sc < 7
                want = x[b, :, sr, sc] if inside else torch.zeros(2)
                assert torch.equal(out[b, :, r, c], want)
                assert int(y_out[b, r, c]) == (int(y[b, sr, sc]) if inside else IGNORE_INDEX)
    assert (out == 0).all(dim=(1, 2, 3)).any()  # an image shifted out of the frame


def test_column_crops_keep_each_pixel_with_its_label_and_vary_per_image():
    gen = torch.Generator().manual_seed(0)
    y = torch.randint(0, 5, (16, 6, 40))
    cols = torch.arange(40).expand(16, 6, 40)
    # Channel 0 is the label, channel 1 the column a pixel came from.
    x = torch.stack([y.float(), cols.float()], dim=1)
    x2, y2 = random_crop_columns(x, y, 16, gen)
    assert x2.shape == (16, 2, 6, 16) and y2.shape == (16, 6, 16)
    assert torch.equal(x2[:, 0], y2.float())
    start = x2[:, 1, 0, 0].long()
    # each window is 16 consecutive columns of its own image, starting anywhere allowed
    assert torch.equal(x2[:, 1].long(), (start[:, None, None] + torch.arange(16)).expand(16, 6, 16))
    assert torch.equal(y2, torch.stack([y[i, :, s : s + 16] for i, s in enumerate(start)]))
    assert start.min() >= 0 and start.max() <= 24 and len(set(start.tolist())) > 4


def test_affine_augmentation_without_rotation_or_zoom_is_the_identity():
    gen = torch.Generator().manual_seed(0)
    x, y = torch.randn(4, 2, 16, 40), torch.randint(0, 3, (4, 16, 40))
    x2, y2 = random_affine(x, y, rotate_deg=0.0, scale=0.0, gen=gen)
    assert torch.equal(x2, x) and torch.equal(y2, y)


def test_soft_targets_mix_images_and_labels_alike():
    cfg = TrainConfig(mixup=0.4, label_smoothing=0.1)
    y = torch.tensor([0, 1, 2, 2])
    x = F.one_hot(y, 3).float()[:, :, None, None].expand(4, 3, 2, 2)  # image = its label
    mixed, q = _soft_targets(x, y, 3, cfg, np.random.default_rng(0))
    assert torch.allclose(q.sum(1), torch.ones(4))
    # Each mixed image is the same convex combination of the two labels as its target.
    assert torch.allclose((q - 0.1 / 3) / 0.9, mixed[:, :, 0, 0], atol=1e-6)
    _, plain = _soft_targets(x, y, 3, TrainConfig(label_smoothing=0.1), None)
    assert torch.allclose(plain, 0.9 * F.one_hot(y, 3) + 0.1 / 3)


def test_training_with_every_augmentation_is_deterministic_and_learns():
    depth, valid, y = shapes_groups(200, n_groups=1, seed=1)
    d, v = depth[:140, 0], valid[:140, 0]
    cfg = TrainConfig(
        epochs=12,
        batch_size=32,
        lr=0.05,
        log_every=0,
        shift=0.1,
        rotate_deg=15,
        scale=0.1,
        mixup=0.4,
        label_smoothing=0.05,
    )
    runs = [
        train(
            build_model("classification", 3, width=8),
            d,
            v,
            y[:140],
            cfg=cfg,
            seed=0,
            compute=CPU,
            log=io.StringIO(),
        )
        for _ in range(2)
    ]
    assert _same_weights(*runs)
    assert evaluate(runs[0], depth[140:, 0], valid[140:, 0], y[140:])["accuracy"] > 0.8


@pytest.mark.parametrize(
    ("momentum", "nesterov", "weight_decay"),
    [(0.9, False, 5e-4), (0.9, True, 1e-3), (0.0, False, 0.0)],
)
def test_sgd_makes_torch_optim_sgd_update_bit_for_bit(momentum, nesterov, weight_decay):
    from spl_al.training.sgd import SGD

    def run(make_opt):
        torch.manual_seed(0)
        model = nn.Sequential(nn.Linear(6, 5), nn.ReLU(), nn.Linear(5, 3), nn.Linear(4, 4))
        opt = make_opt(model.parameters())
        x = torch.randn(40, 6, generator=torch.Generator().manual_seed(1))
        for step in range(7):
            opt.param_groups[0]["lr"] = 0.1 / (step + 1)
            loss = model[:3](x[step * 5 : step * 5 + 5]).square().mean()
            if step >= 3:  # a parameter that gets a gradient only from step 3 on
                loss = loss + model[3].weight.square().sum()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
        return model

    kw = dict(lr=0.1, momentum=momentum, nesterov=nesterov, weight_decay=weight_decay)
    assert _same_weights(run(lambda p: SGD(p, **kw)), run(lambda p: torch.optim.SGD(p, **kw)))


def test_training_does_not_load_the_torch_compiler(tmp_path):
    # torch.optim and torch.use_deterministic_algorithms import torch._dynamo (~1 s of
    # every training job's start-up); train must reach neither beyond what importing
    # torch loads by itself (torch 2.5 imports torch._inductor on `import torch`)
    import subprocess
    import sys

    code = (
        "import sys, numpy as np, torch\n"
        "compiler = ('torch._dynamo', 'torch._inductor')\n"
        "before = {m for m in compiler if m in sys.modules}\n"
        "from spl_al.models import build_model\n"
        "from spl_al.training import TrainConfig, train\n"
        "m = build_model('classification', 2, seed=0, width=4, stages=2)\n"
        "d = np.random.default_rng(0).uniform(1, 5, (8, 16, 16)).astype(np.float32)\n"
        "train(m, d, np.ones(d.shape, bool), np.arange(8) % 2,\n"
        "      cfg=TrainConfig(steps=2, batch_size=4, log_every=0), seed=0)\n"
        "print(sorted(m for m in compiler if m in sys.modules and m not in before))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
