"""Which self-supervised encoders a dataset trains, which one each run seed reads, and
their embeddings (``load_embeddings``).

A dataset's ``embedding.encoder`` block holds the recipe (``spl_al.training.contrastive
.EncoderConfig``) and two plan keys: ``seeds``, the encoder seeds (one encoder each, one
Snakemake job each), and ``block``, the run seeds per encoder. Run seed s reads encoder
number (s - 1) // block, so adding run seeds or encoders never moves a run already made
to another encoder. With one encoder (``seeds`` of one, or the recipe's ``seed`` alone)
every run seed reads it.

The encoder is a random draw a rerun makes again, like a run seed: the embedding
framework's statistics average the runs within each encoder and count encoders
(``spl_al.report.stats``, a cluster design).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import read_json
from spl_al.frameworks import EMBEDDING
from spl_al.layout import ENCODER_CARD

PLAN_KEYS = ("seeds", "block")
"""Keys of ``embedding.encoder`` that plan encoders rather than describe one."""


def _block(entry: dict) -> dict:
    return dict(EMBEDDING.settings(entry).get("encoder") or {})


def encoder_recipe(entry: dict) -> dict:
    """The recipe every encoder of the dataset shares (``embedding.encoder`` without its
    plan keys and seed)."""
    return {k: v for k, v in _block(entry).items() if k not in (*PLAN_KEYS, "seed")}


def encoder_seeds(entry: dict) -> list[int]:
    """The dataset's encoder seeds, in order: ``seeds``, else ``[seed]`` (default 0)."""
    block = _block(entry)
    if "seeds" in block:
        return [int(s) for s in block["seeds"]]
    return [int(block.get("seed", 0))]


def encoder_of(entry: dict, run_seed: int) -> int:
    """The seed of the encoder run seed ``run_seed`` reads: number (s - 1) // block of
    ``encoder_seeds``, or the one encoder."""
    seeds = encoder_seeds(entry)
    if len(seeds) == 1:
        return seeds[0]
    return seeds[(int(run_seed) - 1) // int(_block(entry)["block"])]


def check_encoders(dataset: str, entry: dict, run_seeds, embedding_seeds) -> None:
    """A ValueError, one sentence naming the key, unless the encoder plan is sound.

    ``run_seeds``: every run seed that reads an encoder (both frameworks);
    ``embedding_seeds``: the embedding framework's run seeds. Refused: ``seed`` and
    ``seeds`` together, an encoder seed listed twice, several encoders without
    ``block``, more encoders than the embedding framework has run seeds, and a run seed
    whose block has no encoder.
    """
    block = _block(entry)
    key = f"datasets.{dataset}.embedding.encoder"
    if "seeds" in block and "seed" in block:
        raise ValueError(
            f"config key '{key}' sets both 'seed' and 'seeds'; keep 'seeds' (the encoders) "
            "and drop 'seed'."
        )
    seeds = encoder_seeds(entry)
    twice = sorted({s for s in seeds if seeds.count(s) > 1})
    if twice:
        raise ValueError(
            f"config key '{key}.seeds' lists encoder seed {twice[0]} more than once; each "
            "encoder needs a seed of its own."
        )
    if len(seeds) == 1:
        return
    if "block" not in block:
        raise ValueError(
            f"config key '{key}.block' is missing: with {len(seeds)} encoders it says how many "
            "run seeds read each one (run seed s reads encoder number (s - 1) // block)."
        )
    embedding_seeds = sorted(set(embedding_seeds))
    if embedding_seeds and len(seeds) > len(embedding_seeds):
        raise ValueError(
            f"config key '{key}.seeds' lists {len(seeds)} encoders, more than the "
            f"{len(embedding_seeds)} run seeds of the embedding experiments; an encoder "
            "no run reads is wasted, so list at most one encoder per run seed."
        )
    b = int(block["block"])
    for s in sorted(set(run_seeds)):
        number = (int(s) - 1) // b
        if not 0 <= number < len(seeds):
            raise ValueError(
                f"config key '{key}.seeds' lists {len(seeds)} encoders, but run seed {s} reads "
                f"encoder number {number} (run seed s reads number (s - 1) // block, block "
                f"{b}); use run seeds 1 to {b * len(seeds)} or add encoder seeds."
            )


def load_embeddings(path, data) -> tuple[np.ndarray, np.ndarray]:
    """(train (n_train, G, d), test (n_test, d)) of ``train_encoder``'s file, checked
    against the dataset's split."""
    with np.load(path, allow_pickle=False) as f:
        if "train_units" in f.files:
            raise ValueError(
                f"{path}: a dense encoder's per-pixel features, which only the embedding "
                "framework's segmentation runs read; select on the trained model's features "
                "(features: model) on a segmentation dataset."
            )
        check_split(f, data, path)
        return f["train"], f["test"]


def check_split(embeddings, data, path) -> None:
    """A ValueError, one sentence, unless an embeddings file (an open ``np.load``)
    holds ``data``'s train/test split."""
    if not (
        np.array_equal(embeddings["train_idx"], data.train_idx)
        and np.array_equal(embeddings["test_idx"], data.test_idx)
    ):
        raise ValueError(
            f"{path}: embeddings of another train/test split than the dataset's; train "
            "the encoder again (remove it and rerun)."
        )


def embeddings_source(path) -> dict:
    """What a round-0 record says of the encoder behind an embeddings file: its seed
    and weights' hash, from the card beside it (``train_encoder``'s layout), and the
    file itself."""
    card_path = Path(path).with_name(ENCODER_CARD)
    card = read_json(card_path) if card_path.is_file() else {}
    return {
        "embeddings": str(path),
        "encoder_seed": (card.get("encoder") or {}).get("seed"),
        "weights_sha256": card.get("weights_sha256"),
    }
