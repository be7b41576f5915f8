"""Compute what acquisition strategies need from a trained model: ``compute_inputs``.

This is the only place where a model meets the unlabeled pool. It takes images and
index sets, never labels, and returns ``StrategyInputs`` holding only the parts the
strategies asked for (``spl_al.strategies.inputs.NEEDS``):

- Only the observed image of each unlabeled group is run through the model, unless
  a need in ``GROUP_NEEDS`` (DUIS's group features and margin/inconsistency) asks
  for all M+1 images; labeled groups are run only for "labeled_features".
- Segmentation memory stays bounded: per-pixel probabilities and features live
  only within one batch and are reduced there to per-group quantities, exactly:
  entropy, margin, gamma and d are means over the observed image's valid pixels
  (the pixels the oracle labels); a variant counts only at the pixels it holds (its
  void pixels carry no prediction: qbar at a pixel averages the images that hold it,
  see ``margin_and_inconsistency``), features are averaged over the same pixels,
  and BADGE's embedding is the pixel-averaged C x d gradient matrix. Nothing per
  pixel is stored, so the output is O(groups x (C x d)) whatever the image size.
  For PointNet++ the valid pixels are the cloud's points, so Coreset's and DUIS's
  per-cloud features are the mean of the per-point features over the observed
  cloud's points, and BADGE's embedding the point-averaged gradient matrix.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from spl_al.strategies.inputs import GROUP_NEEDS, StrategyInputs, as_index_array, check_needs
from spl_al.strategies.scores import scores_from_outputs
from spl_al.training.compute import LOCAL, Compute
from spl_al.training.forward import iter_forward, pool_pixels

DEFAULT_BATCH_IMAGES = {"classification": 256, "segmentation": 16}


def _group_outputs(model, depth_m, valid, *, idx, n_images, compute, pixel_features=False):
    """Forward the first ``n_images`` images of groups ``idx`` in one pass.

    Returns probs (b, G, units, C) float32, pixel features (b, G, units, d) (segmentation
    with ``pixel_features`` only, else None), pooled features (b, G, d), and the unit
    masks of every image (b, G, units) or None (classification).
    """
    b = len(idx)
    d = np.asarray(depth_m[idx, :n_images]).reshape(b * n_images, *depth_m.shape[2:])
    v = np.asarray(valid[idx, :n_images]).reshape(b * n_images, *depth_m.shape[2:])
    ((_, probs, feats, vmask),) = iter_forward(model, d, v, compute=compute, batch_size=len(d))
    if model.task == "classification":
        return (
            probs.view(b, n_images, 1, -1).cpu().numpy(),
            None,
            feats.view(b, n_images, -1).cpu().numpy(),
            None,
        )
    c, dim = probs.shape[1], feats.shape[1]
    image_valid = vmask.view(b, n_images, -1)  # (b, G, units)
    obs_valid = image_valid[:, 0]
    pooled = pool_pixels(feats, obs_valid.repeat_interleave(n_images, 0).view_as(vmask))

    def per_unit(t: torch.Tensor, k: int) -> np.ndarray:  # (b*G, k, H, W) -> (b, G, units, k)
        return t.reshape(b, n_images, k, -1).transpose(2, 3).cpu().numpy()

    return (
        per_unit(probs, c),
        per_unit(feats, dim) if pixel_features else None,
        pooled.view(b, n_images, dim).cpu().numpy(),
        image_valid.cpu().numpy(),
    )


def compute_inputs(
    model: nn.Module,
    needs,
    *,
    depth_m,
    valid,
    unlabeled_idx,
    labeled_idx,
    compute: Compute | None = None,
    batch_size: int | None = None,
) -> StrategyInputs:
    """The inputs a strategy with ``needs`` selects from, computed with ``model``.

    Args:
        model: a trained model from ``spl_al.models.build_model``.
        needs: names from ``NEEDS`` (e.g. ``strategy.needs``).
        depth_m, valid: (N, G, H, W) images of every training group, observed image
            first, G = M + 1 (G = 1 without variants); numpy arrays or memory maps.
        unlabeled_idx, labeled_idx: disjoint training-set indices.
        compute: device and precision of the forward passes (``Compute``, resolved
            once here for the model unless it is already; None: ``LOCAL``, fp32).
        batch_size: images per forward pass (default 256 for classification,
            16 for segmentation).

    Returns:
        ``StrategyInputs`` with the index sets and exactly the needed parts.
    """
    needs = check_needs(needs)
    if np.ndim(depth_m) != 4 or np.shape(valid) != np.shape(depth_m):
        raise ValueError(
            f"depth_m and valid must both be (N, G, H, W), got {np.shape(depth_m)} "
            f"and {np.shape(valid)}."
        )
    n_train = depth_m.shape[0]
    unl = as_index_array("unlabeled_idx", unlabeled_idx)
    lab = as_index_array("labeled_idx", labeled_idx)
    for name, idx in (("unlabeled_idx", unl), ("labeled_idx", lab)):
        if idx.size and idx.max() >= n_train:
            raise ValueError(f"{name} must index the {n_train} training groups, found {idx.max()}.")
    compute = (compute or LOCAL).resolved(model)
    task = model.task
    batch_size = batch_size or DEFAULT_BATCH_IMAGES[task]
    n_images = depth_m.shape[1] if needs & GROUP_NEEDS else 1
    per_batch = max(1, batch_size // n_images)
    parts: dict[str, list[np.ndarray]] = {}

    def add(name: str, value: np.ndarray) -> None:
        parts.setdefault(name, []).append(value)

    scored = needs - {"labeled_features"}
    badge_pixels = task == "segmentation" and "grad_embedding" in needs
    for s in range(0, len(unl) if scored else 0, per_batch):
        probs, pix_feats, feats, image_valid = _group_outputs(
            model,
            depth_m,
            valid,
            idx=unl[s : s + per_batch],
            n_images=n_images,
            compute=compute,
            pixel_features=badge_pixels,
        )
        for name, value in scores_from_outputs(
            needs, task, probs, feats, pix_feats=pix_feats, image_valid=image_valid
        ):
            add(name, value)
    if "labeled_features" in needs:
        dim = getattr(model, "feature_dim", 0)
        parts["labeled_features"] = [np.zeros((0, dim), dtype=np.float32)]
        for s in range(0, len(lab), batch_size):
            outputs = _group_outputs(
                model,
                depth_m,
                valid,
                idx=lab[s : s + batch_size],
                n_images=1,
                compute=compute,
            )
            add("labeled_features", outputs[2][:, 0])
    arrays = {}
    for name, chunks in parts.items():
        value = np.concatenate(chunks)
        arrays[name] = value.astype(np.float32) if value.ndim == 2 else value.astype(np.float64)
    if "head" in needs:
        weight, bias, dropout = classifier_head(model)
        arrays.update(head_weight=weight, head_bias=bias, head_dropout=np.float64(dropout))
    return StrategyInputs(unlabeled_idx=unl, labeled_idx=lab, **arrays)


def classifier_head(model: nn.Module) -> tuple[np.ndarray, np.ndarray, float]:
    """(W (C, d) float32, b (C,) float64, p): a classifier's last linear layer, logits
    = W f + b on its penultimate features f (its dropout is off when scoring), and the
    dropout rate p its features were trained with before it (0 without one), or a
    ValueError for a model without one (a segmenter)."""
    fc = getattr(model, "fc", None)
    if getattr(model, "task", None) != "classification" or not isinstance(fc, nn.Linear):
        raise ValueError(
            f"{type(model).__name__} has no classifier head (a last linear layer on its "
            "features); strategies that read it (dropquery) are for classification."
        )
    weight = fc.weight.detach().float().cpu().numpy()
    bias = fc.bias.detach().double().cpu().numpy() if fc.bias is not None else np.zeros(len(weight))
    dropout = getattr(model, "dropout", None)
    return weight, bias, float(dropout.p) if isinstance(dropout, nn.Dropout) else 0.0
