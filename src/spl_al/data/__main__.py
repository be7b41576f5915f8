"""Command line for the data side: ``python -m spl_al.data COMMAND ...``.

Commands (each writes its output atomically; a user error prints one line and exits 2):

    classification OUT.npz   synthetic object dataset with observed images
    segmentation OUT.npz     synthetic street dataset with observed images
    import ROOT OUT.npz      a folder of external SPL depth images (load_folder)
    variants DATA.npz OUT.npz [--shard I/N]   SIV variants of one shard
    attach DATA.npz SHARD.npz... --out OUT.npz   merge shards into the dataset
    sheets DATA.npz OUT_DIR  contact.png (and variants.png when it has variants)
    summary DATA.npz         counts per split and MSPPP level
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from spl_al.data import Dataset, make_classification_dataset, make_segmentation_dataset
from spl_al.data.dataset import TASKS
from spl_al.data.external import load_folder
from spl_al.data.pictures import contact_sheet, variants_sheet
from spl_al.data.variants import attach_variants, generate_variants


def _shape(text: str) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected ROWSxCOLS such as 64x64, got {text!r}"
        ) from None
    return rows, cols


def _shard(text: str) -> tuple[int, int]:
    try:
        index, count = (int(v) for v in text.split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected INDEX/COUNT such as 0/4, got {text!r}"
        ) from None
    return index, count


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m spl_al.data", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)

    def common(q, samples_flag, samples_default, shape_default):
        q.add_argument("out", type=Path)
        q.add_argument(samples_flag, type=int, default=samples_default)
        q.add_argument("--image-shape", type=_shape, default=shape_default, help="ROWSxCOLS")
        q.add_argument("--seed", type=int, default=0)
        q.add_argument("--test-fraction", type=float, default=0.3)
        q.add_argument("--method", default="pooled", help="reconstruction method")
        q.add_argument("--workers", type=int, default=None)

    common(sub.add_parser("classification"), "--n-per-class", 100, (64, 64))
    common(sub.add_parser("segmentation"), "--n-samples", 300, (64, 256))

    q = sub.add_parser("import")
    q.add_argument("root", type=Path)
    q.add_argument("out", type=Path)
    q.add_argument("--depth-key", default="depth_ssp")
    q.add_argument("--clean-key", default="Z_true")
    q.add_argument("--label-key", default=None)
    q.add_argument("--classes", nargs="+", default=None)
    q.add_argument("--image-shape", type=_shape, default=None, help="ROWSxCOLS to resize to")
    q.add_argument("--depth-scale", type=float, default=1.0)
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("--test-fraction", type=float, default=0.3)

    q = sub.add_parser("variants")
    q.add_argument("dataset", type=Path)
    q.add_argument("out", type=Path)
    q.add_argument("--n-variants", type=int, default=4)
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("--shard", type=_shard, default=(0, 1), help="INDEX/COUNT")
    q.add_argument("--workers", type=int, default=None)

    q = sub.add_parser("attach")
    q.add_argument("dataset", type=Path)
    q.add_argument("shards", type=Path, nargs="+")
    q.add_argument("--out", type=Path, required=True)

    q = sub.add_parser("sheets")
    q.add_argument("dataset", type=Path)
    q.add_argument("out_dir", type=Path)
    q.add_argument("--per-class", type=int, default=4)
    q.add_argument("--index", type=int, default=None, help="sample of the variants sheet")

    q = sub.add_parser("summary")
    q.add_argument("dataset", type=Path)
    return p


def run(args: argparse.Namespace) -> str:
    """Execute one command; returns what to print."""
    if args.command in TASKS:
        kw = {
            "image_shape": args.image_shape,
            "seed": args.seed,
            "test_fraction": args.test_fraction,
            "reconstruct_method": args.method,
            "workers": args.workers,
        }
        if args.command == "classification":
            data = make_classification_dataset(n_per_class=args.n_per_class, **kw)
        else:
            data = make_segmentation_dataset(n_samples=args.n_samples, **kw)
        data.save(args.out)
        return data.summary()
    if args.command == "import":
        data = load_folder(
            args.root,
            depth_key=args.depth_key,
            label_key=args.label_key,
            clean_key=args.clean_key or None,
            classes=args.classes,
            image_shape=args.image_shape,
            depth_scale=args.depth_scale,
            test_fraction=args.test_fraction,
            seed=args.seed,
        )
        data.save(args.out)
        return data.summary()
    if args.command == "variants":
        data = Dataset.load(args.dataset)
        shard = generate_variants(
            data, n_variants=args.n_variants, seed=args.seed, shard=args.shard, workers=args.workers
        )
        shard.save(args.out)
        return f"{len(shard.indices)} samples x {args.n_variants} variants -> {args.out}"
    if args.command == "attach":
        data = attach_variants(Dataset.load(args.dataset), args.shards)
        data.save(args.out)
        return data.summary()
    if args.command == "sheets":
        data = Dataset.load(args.dataset)
        written = [contact_sheet(data, args.out_dir / "contact.png", per_class=args.per_class)]
        if data.n_variants:
            index = (
                args.index
                if args.index is not None
                else int(data.test_idx[0] if data.test_idx.size else 0)
            )
            written.append(variants_sheet(data, index, args.out_dir / "variants.png"))
        return "\n".join(str(p) for p in written)
    if args.command == "summary":
        return Dataset.load(args.dataset).summary()
    raise AssertionError(args.command)


def main(argv: list[str] | None = None) -> int:
    """Run the ``python -m spl_al.data`` command of ``argv``; the exit code."""
    args = _parser().parse_args(argv)
    try:
        print(run(args))
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
