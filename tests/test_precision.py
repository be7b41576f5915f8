"""Mixed precision: what ``precision`` resolves to, that training and prediction honour
it deterministically, and that weights and outputs stay fp32."""

import io

import numpy as np
import pytest
import torch
from helpers.al_synthetic import shapes_groups

from spl_al.models import build_model
from spl_al.training import TrainConfig, evaluate, predict, train
from spl_al.training.compute import Compute
from spl_al.training.precision import LossScaler, native_bf16, resolve_precision
from spl_al.training.sgd import SGD

CPU = torch.device("cpu")
FAST = TrainConfig(epochs=6, batch_size=16, lr=0.05, log_every=0)


def test_auto_is_bf16_exactly_where_the_cpu_computes_it():
    assert resolve_precision("auto", CPU) == ("bf16" if native_bf16(CPU) else "fp32")
    assert resolve_precision("fp32", CPU) == "fp32"
    assert resolve_precision("bf16", CPU) == "bf16"  # emulated where not native, but allowed


def test_fp16_off_cuda_and_unknown_names_are_refused():
    with pytest.raises(ValueError, match="'fp16' needs a CUDA device"):
        resolve_precision("fp16", CPU)
    with pytest.raises(ValueError, match="precision must be one of"):
        resolve_precision("half", CPU)
    with pytest.raises(ValueError, match="precision must be one of"):
        Compute("cpu", precision="fp8").resolved()
    with pytest.raises(ValueError, match=r"unknown .*precision"):
        TrainConfig.from_dict({"precision": "fp32"})  # where a model runs is Compute's


def _fit(precision: str, seed: int = 0):
    depth, valid, y = shapes_groups(48, n_groups=1, seed=2)
    model = build_model("classification", 3, width=4)
    at = Compute("cpu", precision=precision)
    train(model, depth[:, 0], valid[:, 0], y, cfg=FAST, seed=seed, compute=at, log=io.StringIO())
    return model, depth[:, 0], valid[:, 0], y


def test_bf16_training_is_deterministic_keeps_fp32_weights_and_learns():
    a, d, v, y = _fit("bf16")
    b, *_ = _fit("bf16")
    c, *_ = _fit("fp32")
    assert all(p.dtype == torch.float32 for p in a.state_dict().values() if p.is_floating_point())
    assert all(torch.equal(a.state_dict()[k], b.state_dict()[k]) for k in a.state_dict())
    # autocast really ran: the same seed at fp32 ends elsewhere
    assert any(not torch.equal(a.state_dict()[k], c.state_dict()[k]) for k in a.state_dict())
    metrics = evaluate(a, d, v, y, compute=Compute("cpu", precision="bf16"))
    assert metrics["accuracy"] > 0.8


def test_bf16_prediction_is_float32_and_agrees_with_fp32():
    model, d, v, _ = _fit("fp32")
    full = predict(model, d, v, compute=Compute("cpu"))
    half = predict(model, d, v, compute=Compute("cpu", precision="bf16"))
    assert half.probs.dtype == np.float32 and half.features.dtype == np.float32
    np.testing.assert_allclose(half.probs.sum(axis=1), 1.0, atol=1e-5)
    assert np.mean(half.probs.argmax(1) == full.probs.argmax(1)) > 0.9
    assert not np.array_equal(half.probs, full.probs)


def test_fp16_loss_scaling_unscales_the_step_and_skips_an_overflow():
    torch.manual_seed(0)
    layer = torch.nn.Linear(4, 2)
    start = [p.detach().clone() for p in layer.parameters()]
    x = torch.randn(8, 4)
    reference = torch.autograd.grad(layer(x).square().mean(), list(layer.parameters()))
    opt = SGD(layer.parameters(), lr=0.1)
    scaler = LossScaler("fp16", CPU)  # GradScaler("cpu"): the code path of CUDA's fp16
    scaler.backward(layer(x).square().mean())
    assert layer.weight.grad.abs().sum() > 1000 * reference[0].abs().sum()  # scaled
    scaler.step(opt)
    for p, p0, g in zip(layer.parameters(), start, reference, strict=True):
        torch.testing.assert_close(p.detach(), p0 - 0.1 * g)  # the unscaled update
    before = [p.detach().clone() for p in layer.parameters()]
    scale = scaler._scaler.get_scale()
    opt.zero_grad()
    scaler.backward(layer(x).sum() * float("inf"))
    scaler.step(opt)  # an overflow: no step, and a lower scale
    assert all(torch.equal(p, q) for p, q in zip(layer.parameters(), before, strict=True))
    assert scaler._scaler.get_scale() < scale


def test_auto_keeps_pointnet_fp32_where_bf16_does_not_pay():
    from spl_al.scenes.street import default_grid

    model = build_model("segmentation", 3, "pointnet2", grid=default_grid((16, 32)), n_points=64,
                        centres=[16, 4], radii_m=[2, 6], neighbours=8, width=8)  # fmt: skip
    assert resolve_precision("auto", CPU, model) == "fp32"
    assert resolve_precision("bf16", CPU, model) == "bf16"  # asked for: given
    conv = build_model("classification", 3, width=4)
    assert resolve_precision("auto", CPU, conv) == resolve_precision("auto", CPU)


def test_the_run_config_records_the_precision_each_dataset_ran_at(tmp_path):
    import yaml

    from spl_al.experiment.report_steps import write_run_config

    config = {
        "device": "cpu",
        "precision": "auto",
        "datasets": {
            "cls": {"task": "classification", "train": {"model": {"arch": "smallcnn"}}},
            "pc": {"task": "segmentation", "train": {"model": {"arch": "pointnet2"}}},
            "forced": {"task": "segmentation", "precision": "fp32", "train": {"model": {}}},
        },
    }
    used = write_run_config(config, tmp_path / "config.yaml")
    auto = resolve_precision("auto", CPU)
    assert used == {"cls": auto, "pc": "fp32", "forced": "fp32"}
    written = yaml.safe_load((tmp_path / "config.yaml").read_text())
    assert written["precision_used"] == used and written["precision"] == "auto"


def test_a_step_resolves_its_compute_once_into_a_device_and_a_concrete_precision():
    from spl_al.models.pointnet import PointNet2Seg

    cnn = Compute("cpu", 1, "auto").resolved(build_model("classification", 3, arch="smallcnn"))
    assert cnn == Compute("cpu", 1, "bf16" if native_bf16(torch.device("cpu")) else "fp32")
    assert Compute("cpu", precision="auto").resolved(PointNet2Seg).precision == "fp32"
    assert Compute("cpu", precision="bf16").resolved().precision == "bf16"  # as asked
    with pytest.raises(ValueError, match="precision 'fp16' needs a CUDA device"):
        Compute("cpu", precision="fp16").resolved()


def _conv_error(device: str) -> float:
    """Largest relative error of an fp32 convolution on ``device`` against float64."""
    gen = torch.Generator().manual_seed(0)
    x = torch.randn(8, 64, 32, 32, generator=gen)
    w = torch.randn(64, 64, 3, 3, generator=gen)
    ref = torch.nn.functional.conv2d(x.double(), w.double(), padding=1)
    out = torch.nn.functional.conv2d(x.to(device), w.to(device), padding=1).cpu().double()
    return float(((out - ref).abs() / ref.abs().clamp_min(1.0)).max())


NEW_TF32_API = hasattr(getattr(torch.backends.cudnn, "conv", None), "fp32_precision")
"""torch >= 2.9 sets TF32 by ``fp32_precision``; older torch by ``allow_tf32`` flags."""


def _set_tf32(allowed: bool) -> None:
    """cuDNN's and cuBLAS's fp32 as TF32 (their default on CUDA) or not, by the API of
    the installed torch."""
    if NEW_TF32_API:
        torch.backends.cudnn.conv.fp32_precision = "tf32" if allowed else "ieee"
        torch.backends.cuda.matmul.fp32_precision = "tf32" if allowed else "ieee"
    else:
        torch.backends.cudnn.allow_tf32 = allowed
        torch.backends.cuda.matmul.allow_tf32 = allowed


def _tf32_allowed() -> bool:
    if NEW_TF32_API:
        return "tf32" in (
            torch.backends.cudnn.conv.fp32_precision,
            torch.backends.cuda.matmul.fp32_precision,
        )
    return bool(torch.backends.cudnn.allow_tf32 or torch.backends.cuda.matmul.allow_tf32)


def test_fp32_means_ieee_fp32_not_tf32_once_a_step_applies_its_compute():
    _set_tf32(True)  # cuDNN's own default
    Compute("cpu", threads=None).apply()
    assert not _tf32_allowed()
    assert _conv_error("cpu") < 1e-3


def test_ieee_fp32_on_a_torch_without_the_fp32_precision_api(monkeypatch):
    """A torch older than 2.9 (a CUDA build scripts/install.sh keeps) has no
    ``fp32_precision``: IEEE fp32 is set by the flags it had instead."""
    from types import SimpleNamespace

    from spl_al.training.device import ieee_fp32

    cudnn = SimpleNamespace(allow_tf32=True, deterministic=False, benchmark=False)
    matmul = SimpleNamespace(allow_tf32=True)
    monkeypatch.setattr(torch.backends, "cudnn", cudnn)
    monkeypatch.setattr(torch.backends.cuda, "matmul", matmul)
    ieee_fp32()
    assert cudnn.allow_tf32 is False and matmul.allow_tf32 is False


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_an_fp32_convolution_on_cuda_is_ieee_fp32():
    _set_tf32(True)
    tf32 = _conv_error("cuda")
    Compute("cuda").apply()
    # TF32 keeps 10 mantissa bits (~1e-2 on these 576-term sums); IEEE fp32 23 (~1e-5)
    ieee = _conv_error("cuda")
    assert ieee < 1e-3
    if torch.cuda.get_device_capability()[0] >= 8:  # Ampere and later have TF32
        assert tf32 > 1e-3
