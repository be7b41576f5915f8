"""A trained model picks the frames of a folder a person labels next: ``spl-al query``.

    spl-al query --model MODEL --frames DIR --labeled labeled.csv --budget 20
                 --method duis --out BATCH_DIR

- ``MODEL``: a model spl-al exported or trained (``.pt`` or ``.onnx`` with its card
  beside it, ``spl_al.deploy.bundle.open_model``), or an ONNX file of your own without
  a card that takes spl-al's documented input (``depth_m``: (B, H, W) float32 metres,
  NaN or <= 0 at voids) and gives class probabilities, (B, C) or (B, C, H, W), as an
  output named ``probabilities`` or as its last output; its class names come from
  ``--classes``. A ``.pt`` model gives its penultimate features too; with an ONNX
  file the k-means of DUIS and the diversity baselines reads the probabilities
  (``spl_al.acquire``).
- ``DIR``: release-layout frames and raw captures, read exactly as ``spl-al predict``
  reads them (``spl_al.deploy.frames.read_frames``, with the card's reconstruction
  settings and the same capture options).
- ``--labeled``: CSV files whose ``file`` column names frames of ``DIR`` (as
  ``to_label.csv`` and ``predict``'s CSV name them) that are labeled already; a
  filled ``to_label.csv`` of an earlier batch is one.
- ``BATCH_DIR``: the labeling batch the human-oracle workflow writes
  (``spl_al.labeling.write_batch``): a picture per frame (with DUIS's variants),
  ``contact_sheet.png``, ``classes.csv``, ``to_label.csv`` and the Label Studio
  import with the model's predictions as pre-annotations. A frame's sample id is its
  position in the folder's sorted listing.
- ``--variants FILE.npz``: DUIS's SIV variants of the folder's frames, made once and
  read by every later query (they depend on the frames, the seed, the sensor and M,
  never on the model; ``spl_al.acquire.make_variants``): made and written when FILE is
  absent, read when it holds the variants of the same frames and settings, refused in
  one sentence when it holds others. ``--jobs`` makes them in that many processes.

Every input is read and the query made before anything is written; the batch folder
appears complete or not at all. A user error is one line on stderr, exit code 2.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spl_al.acquire import (
    DEFAULT_BATCH_SIZE,
    DEFAULT_N_VARIANTS,
    Request,
    default_conditions,
    make_variants,
    run,
)
from spl_al.atomic import atomic_write
from spl_al.data.dataset import Dataset, sensor_from_dict
from spl_al.data.label_files import read_rows
from spl_al.data.seeds import STREAM_VARIANT
from spl_al.deploy.bundle import onnx_session, open_model
from spl_al.deploy.card import card_path
from spl_al.deploy.cli import capture_arguments, overrides_of
from spl_al.deploy.frames import RELEASE_DEPTH_KEY, capture_options, read_frames
from spl_al.label_codes import IGNORE_INDEX, UNKNOWN_CLASS
from spl_al.labeling import write_batch
from spl_al.photon import SensorParams, synthesize_variants
from spl_al.seeding import sample_rng
from spl_al.strategies import GROUP_NEEDS, get

SENSORS = ("paper_real", "tabletop", "ugv45m", "street")
"""``--sensor`` presets (``SensorParams``) for DUIS's variants."""


@dataclass
class Scorer:
    """A model as ``spl_al.acquire``'s ``predict``, with its classes and card."""

    name: str
    predict: object
    classes: list[str] | None
    card: dict | None
    fixed_shape: tuple | None

    @property
    def sensor(self) -> SensorParams | None:
        """The sensor the model's dataset was observed with (its card), if known."""
        return sensor_from_dict(((self.card or {}).get("data") or {}).get("sensor"))


def _torch_predict(model):
    def predict(depth_m, valid):
        # torch on demand (importing this module does not load it)
        from spl_al.training.compute import Compute
        from spl_al.training.forward import predict as forward

        out = forward(model, depth_m, valid, compute=Compute("cpu"), batch_size=len(depth_m))
        return out.probs, out.features

    return predict


def _onnx_predict(session, path: Path):
    inputs = session.get_inputs()
    outputs = [o.name for o in session.get_outputs()]
    wanted = "probabilities" if "probabilities" in outputs else outputs[-1]

    def predict(depth_m, valid):
        depth = np.ascontiguousarray(np.where(valid, depth_m, np.nan), dtype=np.float32)
        try:
            (probs,) = session.run([wanted], {inputs[0].name: depth})
        except Exception as exc:  # onnxruntime raises its own exception types
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ValueError(
                f"{path}: onnxruntime cannot run it on frames of {depth.shape[1]}x"
                f"{depth.shape[2]} ({first[:200]})."
            ) from None
        return probs

    shape = inputs[0].shape
    fixed = None
    if len(shape) == 3 and all(isinstance(s, int) for s in shape[1:]):
        fixed = tuple(shape[1:])
    return predict, fixed


def open_scorer(path, *, card=None, classes=None) -> Scorer:
    """The model at ``path`` as a ``predict`` function (module docstring)."""
    path = Path(path)
    has_card = card is not None or card_path(path).is_file()
    if path.suffix == ".onnx" and not has_card:
        if not path.is_file():
            raise ValueError(f"{path}: no such model file.")
        if not classes:
            raise ValueError(
                f"{path}: an ONNX file without a model card needs --classes, its class "
                "names in output order."
            )
        predict, fixed = _onnx_predict(onnx_session(path), path)
        return Scorer(path.name, predict, list(classes), None, fixed)
    deployed = open_model(path, card)
    if classes and list(classes) != deployed.classes:
        raise ValueError(
            f"--classes {','.join(classes)} differ from the classes of {path.name}'s card "
            f"({','.join(deployed.classes)}); leave --classes out."
        )
    if deployed.backend == "torch":
        predict = _torch_predict(deployed.runner.model)
        fixed = None
    else:
        predict, fixed = _onnx_predict(deployed.runner, path)
    return Scorer(path.name, predict, deployed.classes, deployed.card, fixed)


def labeled_frames(paths, names: list[str]) -> np.ndarray:
    """Indices into ``names`` of the frames the CSV files ``paths`` list (``file``)."""
    position = {name: k for k, name in enumerate(names)}
    found: dict[int, str] = {}
    for path in map(Path, paths):
        rows, header = read_rows(path)
        if "file" not in header:
            raise ValueError(
                f"{path}: needs a 'file' column naming frames of the folder; found "
                f"{', '.join(header) or 'none'}."
            )
        for line, row in rows:
            name = (row.get("file") or "").strip()
            if name not in position:
                raise ValueError(f"{path} line {line}: file {name!r} is no frame of the folder.")
            found.setdefault(position[name], f"{path} line {line}")
    return np.array(sorted(found), dtype=np.int64)


def _frames_array(frames, fixed_shape) -> np.ndarray:
    shapes = sorted({f.depth_m.shape for f in frames})
    if len(shapes) > 1:
        raise ValueError(
            f"the frames have {len(shapes)} image shapes ({', '.join(map(str, shapes[:4]))}); "
            "a query compares frames of one shape."
        )
    if fixed_shape and shapes[0] != tuple(fixed_shape):
        raise ValueError(
            f"the frames are {shapes[0][0]}x{shapes[0][1]}, but the ONNX model takes "
            f"{fixed_shape[0]}x{fixed_shape[1]} only."
        )
    return np.stack([f.depth_m for f in frames]).astype(np.float32)


@dataclass
class FolderQuery:
    """One ``spl-al query`` (module docstring).

    Attributes:
        model, frames, out: the model file, the folder of frames, the batch folder.
        budget, method, params, seed: how many frames, which strategy, its parameters,
            the seed of every random choice.
        labeled: CSV files listing the frames labeled already (column ``file``).
        card, classes: the model's card (default beside it); class names in output
            order (an ONNX file without a card).
        labels_file: where the filled ``to_label.csv`` is to be saved (default
            ``{out}.csv`` beside the batch).
        overrides, depth_key, weights: how frames are read, as ``spl-al predict``'s.
        sensor: DUIS's variants' sensor (default the card's, else the paper's scanning
            sensor); n_variants: their number, M; batch_size: frames per forward pass.
        variants: the .npz file DUIS's variants are kept in between queries (module
            docstring); n_jobs: processes that make them.
    """

    model: str | Path
    frames: str | Path
    out: str | Path
    budget: int
    method: str = "duis"
    labeled: tuple = ()
    params: dict | None = None
    seed: int = 0
    card: str | Path | None = None
    classes: list[str] | None = None
    labels_file: str | Path | None = None
    overrides: dict | None = None
    depth_key: str = RELEASE_DEPTH_KEY
    weights: str | Path | None = None
    sensor: SensorParams | None = None
    n_variants: int = DEFAULT_N_VARIANTS
    batch_size: int = DEFAULT_BATCH_SIZE
    variants: str | Path | None = None
    n_jobs: int = 1


def query_frames(job: FolderQuery, log=print) -> Path:
    """Pick ``job.budget`` frames of ``job.frames`` with ``job.method`` and ``job.model``;
    write their labeling batch to ``job.out`` (module docstring). Returns the folder."""
    out = Path(job.out)
    if out.exists() and not (out / "to_label.csv").is_file() and any(out.iterdir()):
        raise ValueError(f"{out}: exists and holds no to_label.csv; give an empty or new folder.")
    scorer = open_scorer(job.model, card=job.card, classes=job.classes)
    reconstruction = ((scorer.card or {}).get("data") or {}).get("reconstruction")
    options = capture_options(reconstruction, job.overrides)
    frames = read_frames([job.frames], options, job.depth_key, job.weights)
    depth = _frames_array(frames, scorer.fixed_shape)
    known = labeled_frames(job.labeled, [f.name for f in frames])
    request = Request(
        method=job.method,
        predict=scorer.predict,
        depth_m=depth,
        valid=np.isfinite(depth) & (depth > 0),
        labeled=known,
        budget=job.budget,
        seed=job.seed,
        params=job.params,
        sensor=job.sensor or scorer.sensor,
        batch_size=job.batch_size,
        n_variants=job.n_variants,
        n_jobs=job.n_jobs,
    )
    if job.variants and frozenset(get(job.method, **(job.params or {})).needs) & GROUP_NEEDS:
        request.variants = kept_variants(Path(job.variants), request, log)
    picked = run(request).indices
    batch, probs = _batch(request, scorer, frames, picked)
    labels_file = Path(job.labels_file) if job.labels_file else out.with_name(f"{out.name}.csv")
    unlabeled = len(frames) - len(known)
    chosen = (
        f"These {len(picked)} frames were chosen by {job.method}"
        + (f" ({json.dumps(job.params, sort_keys=True)})" if job.params else "")
        + f", seed {job.seed}, from the {unlabeled} unlabeled frames of {job.frames} "
        f"({len(known)} labeled), scored by {scorer.name}; no label was read to choose them."
    )
    write_batch(
        batch,
        np.arange(len(picked)),
        out_dir=out,
        labels_file=labels_file,
        probs=probs,
        model_version=scorer.name,
        chosen_by=chosen,
        then="train your model on them, and give the file to --labeled of the next query",
    )
    log(
        f"{out}: {len(picked)} of {unlabeled} unlabeled frames to label, chosen by "
        f"{job.method} with {scorer.name}; fill in {out / 'to_label.csv'} and save it as "
        f"{labels_file}, or label {out / 'label_studio.json'} in Label Studio"
    )
    return out


def _batch(request: Request, scorer: Scorer, frames, picked) -> tuple[Dataset, np.ndarray]:
    """The picked frames as a labeling batch's ``Dataset`` (with the variants DUIS saw,
    for its pictures) and the model's probabilities of them (the pre-annotations)."""
    depth = np.asarray(request.depth_m)
    valid = np.asarray(request.valid)
    probs, _ = _split(scorer.predict(depth[picked], valid[picked]))
    classes = scorer.classes or []
    if len(classes) != probs.shape[1]:
        raise ValueError(
            f"{scorer.name} gives {probs.shape[1]} classes but {len(classes)} names are known "
            f"({','.join(classes)})."
        )
    variants = None if request.variants is None else request.variants[picked]
    if variants is None and frozenset(get(request.method, **(request.params or {})).needs) & (
        GROUP_NEEDS
    ):
        variants = synthesize_variants(
            depth[picked],
            valid[picked],
            default_conditions(request.n_variants),
            rng=[sample_rng(request.seed, STREAM_VARIANT, int(i)) for i in picked],
            sensor=request.sensor,
        )
    task = "segmentation" if probs.ndim == 4 else "classification"
    return _batch_dataset(
        frames, picked, depth, task=task, classes=classes, variants=variants
    ), probs


def variants_key(request: Request) -> str:
    """What a query's variants depend on, as one hash: the frames' depth, the seed, the
    sensor, M and the reconstruction method."""
    digest = hashlib.sha256(np.ascontiguousarray(request.depth_m, np.float32).tobytes())
    settings = {
        "seed": request.seed,
        "sensor": repr(request.sensor or SensorParams.paper_real()),
        "conditions": default_conditions(request.n_variants),
        "reconstruct_method": request.reconstruct_method,
    }
    digest.update(json.dumps(settings, sort_keys=True).encode())
    return digest.hexdigest()


def kept_variants(path: Path, request: Request, log=print) -> np.ndarray:
    """The variants of ``request``'s frames kept in ``path``: read when they are the
    same frames and settings (``variants_key``), else made and written there when
    ``path`` does not exist; a file of other frames or settings is refused."""
    key = variants_key(request)
    if path.exists():
        try:
            with np.load(path) as kept:
                kept_key, variants = str(kept["key"]), kept["variant_depth_m"]
        except (OSError, ValueError, KeyError) as exc:
            raise ValueError(
                f"{path}: not a variants file of spl-al query ({exc}); give a new path."
            ) from None
        if kept_key != key:
            raise ValueError(
                f"{path}: holds the variants of other frames or settings (the frames, "
                "--seed, --sensor, --n-variants or --reconstruct-method differ); give a new "
                "path or delete it to make them anew."
            )
        log(f"{path}: read the variants of {len(variants)} frames")
        return variants
    variants = make_variants(
        request.depth_m,
        request.valid,
        seed=request.seed,
        n_variants=request.n_variants,
        sensor=request.sensor,
        reconstruct_method=request.reconstruct_method,
        n_jobs=request.n_jobs,
    )

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:  # a file object: np.savez would append .npz to a name
            np.savez(f, key=np.array(key), variant_depth_m=variants)

    atomic_write(path, write)
    log(f"{path}: wrote the variants of {len(variants)} frames for the next queries")
    return variants


def _split(out):
    if isinstance(out, tuple):
        return np.asarray(out[0]), out[1]
    return np.asarray(out), None


def _batch_dataset(frames, picked, depth, *, task, classes, variants) -> Dataset:
    """The picked frames as the ``Dataset`` a labeling batch is written from: unlabeled,
    every frame in the training pool, its sample id its position in the folder."""
    k = len(picked)
    shape = depth.shape[1:]
    labels = (
        np.full(k, UNKNOWN_CLASS, np.int64)
        if task == "classification"
        else np.full((k, *shape), IGNORE_INDEX, np.uint8)
    )
    extra = {}
    if variants is not None:
        conds = np.array([list(c) for c in default_conditions(variants.shape[1])])
        extra = {
            "variant_depth_m": variants,
            "variant_msppp": np.tile(conds[:, 0], (k, 1)),
            "variant_sbr": np.tile(conds[:, 1], (k, 1)),
        }
    return Dataset(
        task=task,
        classes=classes,
        depth_m=depth[picked],
        labels=labels,
        split=np.full(k, "train"),
        msppp=np.array([frames[i].msppp for i in picked], dtype=np.float64),
        sbr=np.array([frames[i].sbr for i in picked], dtype=np.float64),
        level=np.full(k, "unknown"),
        uid=np.asarray(picked, dtype=np.int64),
        meta={"source": "query", "files": [frames[i].name for i in picked]},
        **extra,
    )


def _params(text: str | None) -> dict | None:
    if not text:
        return None
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        value = None
    if not isinstance(value, dict):
        raise ValueError(f'--params must be a JSON object such as {{"n_cand": 24}}, got {text!r}.')
    return value


def main(argv: list[str] | None = None) -> int:
    """``spl-al query``; the exit code."""
    parser = argparse.ArgumentParser(
        prog="spl-al query",
        description="Pick the frames of a folder to label next with a trained model and an "
        "acquisition strategy (DUIS by default), and write them as a labeling batch "
        "(pictures, to_label.csv, Label Studio tasks with the model's predictions).",
    )
    add = parser.add_argument
    add("--model", required=True, help="model.pt or .onnx with its card, or an ONNX file")
    add("--frames", required=True, metavar="DIR", help="release-layout frames, raw captures")
    add("--labeled", action="append", default=[], metavar="CSV", help="labeled frames ('file')")
    add("--budget", type=int, required=True, help="how many frames to pick")
    add("--method", default="duis", help="a registered strategy (default: duis)")
    add("--out", required=True, metavar="BATCH_DIR", help="the labeling batch folder")
    add("--params", help="the strategy's parameters as JSON, e.g. '{\"n_cand\": 24}'")
    add("--seed", type=int, default=0, help="seed of every random choice")
    add("--classes", help="class names in output order, comma-separated (ONNX without card)")
    add("--labels-file", help="where the filled to_label.csv goes (default: BATCH_DIR.csv)")
    add("--card", help="the model's card (default: MODEL.card.json beside it)")
    add("--depth-key", default=RELEASE_DEPTH_KEY, help="depth array of release files")
    add("--sensor", choices=SENSORS, help="sensor of DUIS's variants (default: card's)")
    add("--n-variants", type=int, default=DEFAULT_N_VARIANTS, help="DUIS's variants per frame")
    add("--batch-size", type=int, default=DEFAULT_BATCH_SIZE, help="frames per forward pass")
    add("--variants", metavar="FILE.npz", help="keep DUIS's variants here for the next queries")
    add("--jobs", type=int, default=1, help="processes that make DUIS's variants")
    capture_arguments(parser, method_flag="--reconstruct-method")
    args = parser.parse_args(argv)
    try:
        query_frames(
            FolderQuery(
                args.model,
                args.frames,
                args.out,
                args.budget,
                method=args.method,
                labeled=tuple(args.labeled),
                params=_params(args.params),
                seed=args.seed,
                card=args.card,
                classes=[c.strip() for c in args.classes.split(",")] if args.classes else None,
                labels_file=args.labels_file,
                overrides=overrides_of(args),
                depth_key=args.depth_key,
                weights=args.weights,
                sensor=getattr(SensorParams, args.sensor)() if args.sensor else None,
                n_variants=args.n_variants,
                batch_size=args.batch_size,
                variants=args.variants,
                n_jobs=args.jobs,
            )
        )
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
