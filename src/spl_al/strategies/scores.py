"""Every score and feature a strategy may need, from one batch's model outputs:
``scores_from_outputs``, shared by the supervised framework's forward passes
(``spl_al.scoring``) and the embedding framework's linear classifier
(``spl_al.linear_probe``). numpy only."""

from __future__ import annotations

from spl_al.strategies.badge import gradient_embedding_factors, pixel_gradient_embedding
from spl_al.strategies.duis import margin_and_inconsistency
from spl_al.strategies.entropy import entropy_score
from spl_al.strategies.margin import margin_score


def scores_from_outputs(needs, task, probs, feats, *, pix_feats=None, image_valid=None):
    """(name, array) of every score and feature ``needs`` asks of one batch of groups.

    Args:
        needs: names from ``NEEDS`` (``spl_al.strategies.inputs``; not
            ``labeled_features``: it is no score).
        task: "classification" or "segmentation".
        probs: (b, G, units, C) probabilities of every image of each group (one unit
            per image for classification).
        feats: (b, G, d) features of every image (pixel-averaged for segmentation).
        pix_feats: (b, G, units, d) pixel features (segmentation's BADGE only).
        image_valid: (b, G, units) units each image holds, or None (classification).

    A new forward-pass output is one more ``if`` here and its fields in ``NEEDS``;
    the embedding framework (``spl_al.linear_probe``) computes the same scores from a
    linear classifier's probabilities and the embeddings.
    """
    units_valid = None if image_valid is None else image_valid[:, 0]
    if "entropy" in needs:
        yield "entropy", entropy_score(probs[:, 0], units_valid)
    if "margin" in needs:
        yield "margin", margin_score(probs[:, 0], units_valid)
    if "margin_inconsistency" in needs:
        gamma, d = margin_and_inconsistency(probs, units_valid, image_valid)
        yield "gamma", gamma
        yield "inconsistency", d
    if "features" in needs:
        yield "features", feats[:, 0]
    if "group_features" in needs:
        yield "group_features", feats.mean(axis=1)
    if "grad_embedding" in needs and task == "classification":
        q, h = gradient_embedding_factors(probs[:, 0, 0], feats[:, 0])
        yield "grad_q", q
        yield "grad_h", h
    elif "grad_embedding" in needs:
        yield "grad_embedding", pixel_gradient_embedding(probs[:, 0], pix_feats[:, 0], units_valid)
