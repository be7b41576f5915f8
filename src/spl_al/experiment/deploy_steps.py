"""Deployment steps of the workflow: a final model's card, and its ONNX export.

``model_card`` writes the card of one round's ``model.pt`` beside it
(``spl_al.deploy.card``); ``export_model`` exports that model to ONNX, checked against
torch on the test split, with the exported card beside it (``spl_al.deploy.export``).
"""

from __future__ import annotations

from spl_al.training.compute import LOCAL, Compute


def model_card(
    model_path,
    dataset_path,
    *,
    labeled_path,
    metrics_path,
    facts: dict,
    out_path,
    robustness_path=None,
) -> dict:
    """Write the card of a round's model (``out_path``: ``model.card.json``, with the
    Markdown beside it); ``facts``: the fields of ``RunFacts``."""
    # numpy on demand (importing this module does not load it)
    from spl_al.deploy.card import RunFacts, build_card, write_card

    card = build_card(
        model_path,
        dataset_path,
        labeled_path=labeled_path,
        metrics_path=metrics_path,
        facts=RunFacts(**facts),
        robustness_path=robustness_path,
    )
    write_card(card, out_path)
    return card


def export_model(
    model_path, card_path, *, dataset_path, out_path, compute: Compute = LOCAL
) -> dict:
    """Export ``model_path`` (its card at ``card_path``) to ``out_path`` (.onnx), checked
    on ``dataset_path``'s test split; the exported card goes beside it."""
    # numpy on demand (importing this module does not load it)
    from spl_al.deploy.export import export_onnx

    compute.apply()
    return export_onnx(model_path, out_path, dataset_path=dataset_path, card=card_path)
