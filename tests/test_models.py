"""Models: input normalisation, output shapes, deterministic initialisation."""

import numpy as np
import pytest
import torch

from spl_al.models import ARCHS, build_model, reset_parameters, to_input
from spl_al.models.normalise import CLIP


def test_to_input_marks_voids_and_zeroes_them():
    depth = np.array([[1.0, np.nan], [2.0, 3.0]], dtype=np.float32)
    valid = np.array([[True, True], [False, True]])  # NaN counts as void even if marked valid
    x = to_input(depth, valid)
    assert x.shape == (1, 2, 2, 2) and x.dtype == torch.float32
    assert x[0, 1].tolist() == [[1.0, 0.0], [0.0, 1.0]]
    assert x[0, 0, 0, 1] == 0 and x[0, 0, 1, 0] == 0
    # valid pixels 1 and 3 m: median (lower) 1, MAD 0 -> floor 0.01 * 1 m; 3 m clips
    assert x[0, 0, 0, 0] == 0 and x[0, 0, 1, 1] == CLIP
    assert torch.isfinite(x).all()


def test_to_input_all_void_image_is_zero_and_torch_input_works():
    depth = torch.full((2, 4, 5), float("nan"))
    depth[1, :2] = 2.0
    x = to_input(depth)
    assert x.shape == (2, 2, 4, 5)
    assert (x[0] == 0).all()
    assert x[1, 1].sum() == 10


def test_to_input_ignores_distance_and_outliers():
    rng = np.random.default_rng(0)
    depth = (2.0 + rng.normal(0, 0.2, (16, 16))).astype(np.float32)
    near = to_input(depth)[0, 0]
    far = to_input(depth + 5.0)[0, 0]  # same scene 5 m further away
    assert torch.allclose(near, far, atol=1e-4)
    spiky = depth.copy()
    spiky[3, 4] = 900.0  # a background photon's random depth
    z = to_input(spiky)[0, 0]
    assert z[3, 4] == CLIP
    others = torch.ones_like(z, dtype=torch.bool)
    others[3, 4] = False
    assert (z[others] - near[others]).abs().max() < 0.05


def test_to_input_rejects_bad_shapes():
    with pytest.raises(ValueError, match="depth_m"):
        to_input(np.zeros((1, 1, 4, 4)))
    with pytest.raises(ValueError, match="valid"):
        to_input(np.zeros((2, 4, 4)), np.ones((2, 4, 5), bool))


def _scan_grid(hw):
    from spl_al.scenes.raycast import ScanGrid

    return ScanGrid(hw, (5.0, -25.0), (-40.0, 40.0))


# The shared model contract: every architecture registered in ARCHS has a small case
# here (a new model adds one; test_every_registered_model_has_a_contract_case says so).
CASES = [
    ("classification", "smallcnn", {"width": 4}, (32, 32)),
    ("classification", "resnet18", {"width": 4}, (32, 32)),
    ("classification", "resnet18", {"width": 4, "stem": "cifar", "blocks": (1, 1)}, (9, 11)),
    ("segmentation", "unet", {"width": 4, "depth": 2}, (13, 19)),
    (
        "segmentation",
        "pointnet2",
        {"n_points": 64, "centres": (16, 4), "radii_m": (2.0, 6.0), "neighbours": 8, "width": 8},
        (8, 24),
    ),
]


def test_every_registered_model_has_a_contract_case():
    from spl_al.models import ARCHS

    registered = {(task, arch) for task, archs in ARCHS.items() for arch in archs}
    assert registered == {(task, arch) for task, arch, _, _ in CASES}


@pytest.mark.parametrize(("task", "arch", "params", "hw"), CASES)
def test_model_contract(task, arch, params, hw):
    """Logits and features of the right shapes, finite; a seeded build is the same
    model twice (``init_weights``); ``model_input`` gives what the model takes."""
    from spl_al.models import model_input, needs_grid

    if needs_grid(task, arch):
        params = {**params, "grid": _scan_grid(hw)}
    model = build_model(task, 5, arch, seed=0, **params).eval()
    again = build_model(task, 5, arch, seed=0, **params).eval()
    state, state_again = model.state_dict(), again.state_dict()
    assert all(torch.equal(state[k], state_again[k]) for k in state)
    depth = np.random.default_rng(0).uniform(6, 12, (3, *hw)).astype(np.float32)
    depth[:, 0, :3] = np.nan  # a few voids
    with torch.no_grad():
        torch.manual_seed(0)
        logits, feats = model(model_input(model, depth))
    assert model.task == task and model.n_classes == 5 and model.arch == arch
    if task == "classification":
        assert logits.shape == (3, 5) and feats.shape == (3, model.feature_dim)
    else:
        assert logits.shape == (3, 5, *hw) and feats.shape == (3, model.feature_dim, *hw)
    assert torch.isfinite(logits).all() and torch.isfinite(feats).all()


def test_absolute_unet_sees_where_a_return_is():
    """The default U-Net's input is standardised per image, so a scene moved twice as
    far gives the same logits; with ``absolute`` the range and the row position are
    inputs too, so it does not (road and building differ in where they are)."""
    from spl_al.models import model_input

    depth = np.random.default_rng(0).uniform(5, 20, (2, 16, 24)).astype(np.float32)
    depth[:, :3] = np.nan  # sky
    logits = {}
    for absolute in (False, True):
        model = build_model("segmentation", 4, "unet", seed=0, width=4, depth=2, absolute=absolute)
        with torch.no_grad():
            out = [model.eval()(model_input(model, d))[0] for d in (depth, 2 * depth)]
        assert out[0].shape == (2, 4, 16, 24)
        logits[absolute] = out
    torch.testing.assert_close(logits[False][0], logits[False][1])
    assert not torch.allclose(logits[True][0], logits[True][1], atol=1e-4)


def test_default_arch_per_task():
    assert build_model("classification", 3).arch == next(iter(ARCHS["classification"]))
    assert build_model("segmentation", 3, width=2, depth=1).arch == "unet"


@pytest.mark.parametrize(
    "kwargs",
    [
        {"task": "detection", "n_classes": 3},
        {"task": "classification", "n_classes": 1},
        {"task": "classification", "n_classes": 3, "arch": "vgg"},
        {"task": "classification", "n_classes": 3, "arch": "smallcnn", "depth": 3},
        {"task": "classification", "n_classes": 3, "arch": "resnet18", "stem": "big"},
    ],
)
def test_build_model_rejects_bad_arguments(kwargs):
    with pytest.raises(ValueError):
        build_model(**kwargs)


def test_seeded_initialisation_is_reproducible_and_leaves_global_rng_alone():
    state = torch.get_rng_state()
    a = build_model("classification", 3, width=4, seed=7)
    b = build_model("classification", 3, width=4, seed=7)
    c = build_model("classification", 3, width=4, seed=8)
    assert torch.equal(torch.get_rng_state(), state)
    sa, sb, sc = a.state_dict(), b.state_dict(), c.state_dict()
    assert all(torch.equal(sa[k], sb[k]) for k in sa)
    assert not all(torch.equal(sa[k], sc[k]) for k in sa)
    with torch.no_grad():
        next(a.parameters()).add_(1.0)
    reset_parameters(a, 7)
    assert all(torch.equal(a.state_dict()[k], sb[k]) for k in sa)


def test_the_config_schema_names_exactly_the_registered_architectures():
    """A newly registered model must also enter config/schema.yaml's `arch` enum (and
    its description), else a config naming it fails validation."""
    import re
    from pathlib import Path

    import yaml

    schema = (Path(__file__).resolve().parents[1] / "config" / "schema.yaml").read_text()
    arch = re.search(r"^(\s+)arch:\n\1  type: string\n\1  enum: (\[.*\])", schema, re.M)
    assert arch is not None, "config/schema.yaml lost the train.model.arch enum"
    registered = {name for archs in ARCHS.values() for name in archs}
    assert set(yaml.safe_load(arch[2])) == registered


def test_register_adds_an_architecture_and_refuses_a_taken_name(monkeypatch):
    from spl_al.models import registry

    monkeypatch.setitem(registry.ARCHS, "classification", dict(ARCHS["classification"]))

    class Tiny(torch.nn.Module):
        pass

    registry.register("classification", "tiny")(Tiny)
    assert list(registry.ARCHS["classification"])[-1] == "tiny"
    registry.register("classification", "tiny2", default=True)(Tiny)
    assert next(iter(registry.ARCHS["classification"])) == "tiny2"
    with pytest.raises(ValueError, match="'smallcnn' for task 'classification' is already"):
        registry.register("classification", "smallcnn")(Tiny)
    with pytest.raises(ValueError, match="task must be one of"):
        registry.register("detection", "x")
