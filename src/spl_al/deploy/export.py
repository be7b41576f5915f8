"""Export a trained model to ONNX, checked against torch with onnxruntime.

``export_onnx(model.pt, OUT.onnx)`` traces ``DeployGraph`` (the preprocessing in
front of the model, ``spl_al.deploy.graph``) with a dynamic batch axis and the
training image shape, runs the test split of the model's dataset through onnxruntime
and through torch's own path (``model_input`` then the model, exactly as evaluation
does), and keeps the file only when the largest logit difference is at most
``MAX_LOGIT_DIFF`` and the argmax agrees on at least ``MIN_AGREEMENT`` of the test
samples (classification) or of their valid pixels (segmentation). The figures go into
the card written beside the file (``OUT.card.json`` / ``.card.md``). Nothing is left at
``OUT.onnx`` or its card when any step fails.

PointNet++ is not exported: its farthest point sampling and neighbour searches are
numpy / scipy cKDTree loops on the CPU that a trace would freeze into constants (and
the number of valid pixels it samples from varies per scan); run ``model.pt`` with
``python -m spl_al predict`` (torch) instead.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.deploy.bundle import onnx_session, open_model
from spl_al.deploy.card import card_path, file_sha256, write_card

OPSET = 17
MAX_LOGIT_DIFF = 1e-3
MIN_AGREEMENT = 0.999
NOT_EXPORTED = {
    "pointnet2": (
        "PointNet++ (pointnet2) cannot be exported to ONNX: its farthest point sampling "
        "and ball query are numpy / scipy cKDTree loops that torch.onnx.export would "
        "freeze into constants; run the .pt model with `python -m spl_al predict` instead."
    )
}


def _check_out(out_path: Path) -> None:
    """Refuse early, in one sentence, an OUT that is not a writable .onnx path."""
    if out_path.suffix != ".onnx":
        raise ValueError(f"{out_path}: the exported model must be a .onnx file.")
    folder = out_path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{out_path}: cannot create its folder ({exc.strerror}).") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{out_path}: its folder {folder} is not writable.")


def _test_split(card: dict, dataset_path) -> tuple[np.ndarray, np.ndarray]:
    """The test split's depth (NaN at voids) and validity, with their shape checked.

    Validity is the deployed model's rule (``valid_of``: finite and positive depth),
    so torch and onnxruntime see the same voids: a reconstruction can mark a pixel
    valid at exactly 0 m (7 of 2.5 million pixels of real_cls), which the deployed
    graph treats as a void."""
    path = dataset_path or card["data"].get("path")
    if not path or not Path(path).is_file():
        raise ValueError(
            f"the test split to check the export on is not at {path!r}; give the model's "
            "dataset.npz with --dataset."
        )
    dataset = Dataset.load(path, skip=SCENE_FIELDS)
    if list(dataset.classes) != list(card["data"]["classes"]):
        raise ValueError(
            f"{path}: its classes {list(dataset.classes)} are not the model's "
            f"{card['data']['classes']}; give the dataset the model was trained on."
        )
    test = dataset.test_idx
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.deploy.graph import valid_of

    depth = dataset.depth_m[test]
    valid = dataset.valid[test] & valid_of(torch.from_numpy(depth)).numpy()
    return np.where(valid, depth, np.nan).astype(np.float32), valid


def torch_logits(model, depth_m, valid, batch_size: int = 64) -> np.ndarray:
    """Logits of the library's own path (``model_input`` then the model), in batches."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.models import model_input

    out = []
    with torch.inference_mode():
        for s in range(0, len(depth_m), batch_size):
            x = model_input(model, depth_m[s : s + batch_size], valid[s : s + batch_size])
            out.append(model(x)[0].numpy())
    return np.concatenate(out)


def compare(reference: np.ndarray, logits: np.ndarray, valid: np.ndarray) -> dict:
    """Max |logit difference| and argmax agreement (over samples, or valid pixels)."""
    diff = float(np.abs(reference - logits).max()) if reference.size else 0.0
    same = reference.argmax(1) == logits.argmax(1)
    if same.ndim == 3:  # segmentation: the pixels the metric counts
        same = same[valid]
    return {
        "max_abs_logit_diff": diff,
        "argmax_agreement": float(same.mean()) if same.size else 1.0,
        "n_units": int(same.size),
        "unit": "pixel" if reference.ndim == 4 else "sample",
    }


def check_onnx(onnx_path, model, *, depth_m, valid, batch_size: int = 64) -> dict:
    """onnxruntime on ``onnx_path`` against torch on the same (n, H, W) images."""
    import onnxruntime as ort

    session = onnx_session(onnx_path)
    ort_logits = np.concatenate(
        [
            session.run(["logits"], {"depth_m": depth_m[s : s + batch_size]})[0]
            for s in range(0, len(depth_m), batch_size)
        ]
    )
    figures = compare(torch_logits(model, depth_m, valid, batch_size), ort_logits, valid)
    return {
        "onnxruntime": ort.__version__,
        "split": "test",
        "n_samples": len(depth_m),
        **figures,
        "bound_logit": MAX_LOGIT_DIFF,
        "bound_agreement": MIN_AGREEMENT,
    }


def write_onnx(model, tmp: Path, shape) -> None:
    """Export ``model`` behind its preprocessing (``DeployGraph``) to the ONNX file ``tmp``:
    opset ``OPSET``, dynamic batch, traced on a batch of two ``shape`` images."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.deploy.graph import INPUT_NAME, OUTPUT_NAMES, DeployGraph

    example = torch.rand(2, *shape) * 10 + 1
    axes = {INPUT_NAME: {0: "batch"}, **{name: {0: "batch"} for name in OUTPUT_NAMES}}
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            DeployGraph(model),
            (example,),
            str(tmp),
            dynamo=False,
            input_names=[INPUT_NAME],
            output_names=list(OUTPUT_NAMES),
            dynamic_axes=axes,
            opset_version=OPSET,
        )


def _onnx_section(out_path: Path, tmp: Path, check: dict) -> dict:
    # torch and onnx on demand (importing this module does not load them)
    import onnx

    from spl_al.deploy.graph import INPUT_NAME, OUTPUT_NAMES

    onnx.checker.check_model(str(tmp))
    return {
        "file": out_path.name,
        "sha256": file_sha256(tmp),
        "opset": OPSET,
        "onnx": onnx.__version__,
        "input": INPUT_NAME,
        "outputs": list(OUTPUT_NAMES),
        "dynamic_axes": ["batch"],
        "check": check,
    }


def export_onnx(model_path, out_path, *, dataset_path=None, card=None, log=print) -> dict:
    """Export ``model_path`` (``.pt`` with its card) to ``out_path`` (``.onnx``).

    Writes ``out_path`` and its card (``{stem}.card.json`` / ``.card.md``: the model's
    card with an ``onnx`` section holding the check's figures) only when the check
    passes; returns that card.

    Raises:
        ValueError: one sentence for an unwritable ``out_path``, a model without card
            or not matching it, an architecture that cannot be exported, a dataset
            that is not the model's, or a check outside the bounds.
    """
    out_path = Path(out_path)
    _check_out(out_path)
    deployed = open_model(model_path, card)
    if deployed.backend != "torch":
        raise ValueError(f"{model_path}: export takes torch weights (.pt), not an ONNX file.")
    arch = deployed.card["model"]["arch"]
    if arch in NOT_EXPORTED:
        raise ValueError(NOT_EXPORTED[arch])
    model = deployed.runner.model
    depth, valid = _test_split(deployed.card, dataset_path)
    exported = {}

    def write_checked(tmp: Path) -> None:  # raising here leaves nothing at out_path
        write_onnx(model, tmp, deployed.image_shape)
        check = check_onnx(tmp, model, depth_m=depth, valid=valid)
        log(
            f"{out_path}: onnxruntime vs torch on {check['n_samples']} test samples: max "
            f"|logit diff| {check['max_abs_logit_diff']:.3g}, argmax agreement "
            f"{100 * check['argmax_agreement']:.3f}% of {check['n_units']} {check['unit']}s"
        )
        if check["max_abs_logit_diff"] > MAX_LOGIT_DIFF or check["argmax_agreement"] < (
            MIN_AGREEMENT
        ):
            raise ValueError(
                f"{out_path}: onnxruntime differs from torch beyond the bounds (max |logit "
                f"diff| {check['max_abs_logit_diff']:.3g} > {MAX_LOGIT_DIFF:g} or argmax "
                f"agreement {check['argmax_agreement']:.4f} < {MIN_AGREEMENT}); not written."
            )
        exported.update({**deployed.card, "onnx": _onnx_section(out_path, tmp, check)})
        write_card(exported, card_path(out_path))

    atomic_write(out_path, write_checked)
    return exported
