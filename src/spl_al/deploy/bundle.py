"""A model file with its card, ready to run: torch weights (``.pt``) or ONNX (``.onnx``).

``open_model(path)`` finds the card beside the file (``{stem}.card.json``, or the one
given), checks that the file is the model the card describes, and returns a
``DeployedModel`` whose ``run(depth_m)`` gives logits and probabilities from raw depth
(the preprocessing of ``spl_al.deploy.graph`` in front, in torch or in the ONNX graph).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spl_al.deploy.card import card_path, file_sha256, read_card
from spl_al.scenes.raycast import ScanGrid

MODEL_SUFFIXES = (".pt", ".onnx")


@dataclass
class DeployedModel:
    """A model and its card; ``backend`` is "torch" or "onnxruntime"."""

    path: Path
    card: dict
    backend: str
    runner: object  # DeployGraph (torch) or onnxruntime.InferenceSession

    @property
    def classes(self) -> list[str]:
        """The class names, in logit order."""
        return list(self.card["data"]["classes"])

    @property
    def image_shape(self) -> tuple[int, int]:
        """(H, W) of the images the model trained on."""
        return tuple(self.card["data"]["image_shape"])

    def fixed_shape(self) -> bool:
        """Whether the model takes its training shape only (an ONNX graph does)."""
        return self.backend == "onnxruntime"

    def run(self, depth_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, H, W) depth in metres (NaN or <= 0 at voids) -> float32 logits and
        probabilities, (B, C) or (B, C, H, W)."""
        depth = np.ascontiguousarray(depth_m, dtype=np.float32)
        if self.backend == "onnxruntime":
            logits, probs = self.runner.run(None, {"depth_m": depth})
            return logits, probs
        import torch

        with torch.inference_mode():
            logits, probs = self.runner(torch.from_numpy(depth))
        return logits.numpy(), probs.numpy()


def build_torch_model(card: dict):
    """The card's architecture with fresh weights (``spl_al.models.build_model``)."""
    # torch on demand (importing this module does not load it)
    from spl_al.models import build_model, needs_grid

    model = card["model"]
    params = dict(model["params"])
    if needs_grid(model["task"], model["arch"]):
        grid = model.get("grid") or {}
        params["grid"] = ScanGrid(
            tuple(card["data"]["image_shape"]),
            tuple(grid["elevation_deg"]),
            tuple(grid["azimuth_deg"]),
        )
    return build_model(model["task"], model["n_classes"], arch=model["arch"], **params)


def load_weights(card: dict, weights_path):
    """The torch model of ``card`` with the weights of ``weights_path``, in eval mode."""
    import torch

    model = build_torch_model(card)
    try:
        state = torch.load(weights_path, map_location="cpu", weights_only=True)
        model.load_state_dict(state)
    except (RuntimeError, KeyError, TypeError, OSError) as exc:
        first = str(exc).strip().splitlines()[0].rstrip(".:") if str(exc).strip() else ""
        raise ValueError(
            f"{weights_path}: not weights of the {card['model']['arch']} its card describes "
            f"({card['data']['name']}, {card['model']['n_classes']} classes): {first}."
        ) from None
    return model.eval()


def _find_card(path: Path, card) -> tuple[dict, Path]:
    where = Path(card) if card is not None else card_path(path)
    if not where.is_file():
        raise ValueError(
            f"{path}: no model card at {where}; export or build the model with spl-al "
            "(its card says what the model takes), or name the card with --card."
        )
    return read_card(where), where


def _check_file(path: Path, card: dict, where: Path, key: str) -> None:
    expected = (card.get("onnx") or {}).get("sha256") if key == "onnx" else card["model"]["sha256"]
    if expected and file_sha256(path) != expected:
        raise ValueError(
            f"{path}: not the model its card {where} describes (sha256 differs); a model "
            "from another run, dataset or version needs its own card."
        )


def open_model(path, card=None, threads: int | None = None) -> DeployedModel:
    """The model at ``path`` (``.pt`` weights or ``.onnx``) with its card.

    Raises:
        ValueError: one sentence for a missing file or card, another spl-al version's
            card, or a file that is not the model its card describes.
    """
    path = Path(path)
    if path.suffix not in MODEL_SUFFIXES:
        raise ValueError(f"{path}: a model must be a .pt (torch weights) or .onnx file.")
    if not path.is_file():
        raise ValueError(f"{path}: no such model file.")
    card_dict, where = _find_card(path, card)
    if path.suffix == ".onnx":
        if not card_dict.get("onnx"):
            raise ValueError(f"{where}: the card records no ONNX export for {path}.")
        _check_file(path, card_dict, where, "onnx")
        return DeployedModel(path, card_dict, "onnxruntime", onnx_session(path, threads))
    _check_file(path, card_dict, where, "model")
    # torch on demand (importing this module does not load it)
    from spl_al.deploy.graph import DeployGraph

    if threads:
        import torch

        torch.set_num_threads(int(threads))
    return DeployedModel(path, card_dict, "torch", DeployGraph(load_weights(card_dict, path)))


def onnx_session(path, threads: int | None = None):
    """An onnxruntime CPU session of ``path`` (``threads``: intra-op threads)."""
    try:
        import onnxruntime as ort
    except ImportError:
        raise ValueError(
            "onnxruntime is not installed; pip install onnxruntime (scripts/install.sh does)."
        ) from None
    options = ort.SessionOptions()
    if threads:
        options.intra_op_num_threads = int(threads)
    options.log_severity_level = 3
    try:
        return ort.InferenceSession(
            str(path), sess_options=options, providers=["CPUExecutionProvider"]
        )
    except Exception as exc:  # onnxruntime raises its own exception types
        raise ValueError(f"{path}: onnxruntime cannot load it ({type(exc).__name__}).") from None
