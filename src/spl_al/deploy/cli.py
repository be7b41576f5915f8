"""The ``export`` and ``predict`` commands of ``python -m spl_al`` (``spl_al.__main__``);
``query`` (``spl_al.query_frames``) shares their capture options.

python -m spl_al export MODEL.pt OUT.onnx [--dataset DATASET.npz] [--card CARD.json]
python -m spl_al predict MODEL INPUT... --out OUT [capture options]

Errors at this boundary are one line on stderr (exit code 2), never a traceback.
"""

from __future__ import annotations

import argparse
import sys


def _fail(exc: Exception) -> int:
    print(f"error: {exc}", file=sys.stderr)
    return 2


def export_main(argv: list[str]) -> int:
    """``python -m spl_al export``; the exit code."""
    parser = argparse.ArgumentParser(
        prog="python -m spl_al export",
        description="Export a trained model.pt (with its card beside it) to ONNX with a "
        "dynamic batch axis and the input preprocessing inside the graph; onnxruntime is "
        "checked against torch on the dataset's test split and the figures go into the "
        "card written beside OUT.onnx.",
    )
    parser.add_argument("model", metavar="MODEL.pt")
    parser.add_argument("out", metavar="OUT.onnx")
    parser.add_argument("--dataset", help="the model's dataset.npz (default: the card's)")
    parser.add_argument("--card", help="the model's card (default: MODEL.card.json beside it)")
    args = parser.parse_args(argv)
    # numpy on demand (importing this module does not load it)
    from spl_al.deploy.export import export_onnx

    try:
        export_onnx(args.model, args.out, dataset_path=args.dataset, card=args.card)
    except (ValueError, OSError) as exc:
        return _fail(exc)
    return 0


def capture_arguments(parser: argparse.ArgumentParser, method_flag: str = "--method") -> None:
    """The raw-capture options of ``predict`` (and of ``query``, whose ``--method`` is the
    strategy's: it names the reconstruction method ``method_flag``), overriding the card's."""
    # numpy on demand (importing this module does not load it)
    from spl_al.photon.io import FORMATS
    from spl_al.photon.reconstruct import METHODS

    group = parser.add_argument_group(
        "raw captures", "override the reconstruction settings the model's card records"
    )
    group.add_argument(
        method_flag, dest="reconstruction", choices=METHODS, help="reconstruction method"
    )
    group.add_argument("--format", choices=FORMATS, help="capture format")
    group.add_argument("--key", help="variable / array / dataset holding the photons")
    group.add_argument("--time-unit", help="unit of timestamps (ps)")
    group.add_argument("--bin-width-ps", type=float, help="bin width of files that state none")
    group.add_argument("--pulse-sigma-ps", type=float, help="instrument response sigma")
    group.add_argument("--time-axis", type=int, choices=(0, 2, -1), help="cube: axis of time")
    group.add_argument("--channel", type=int, help="PTU: detector channel")
    weights = f"SSPI weights folder ({method_flag} sspi)"
    group.add_argument("--weights", metavar="FOLDER", help=weights)


_OVERRIDES = ("format", "key", "time_unit", "bin_width_ps", "pulse_sigma_ps")


def overrides_of(args: argparse.Namespace) -> dict:
    """The capture options the command line gave (``capture_arguments``; None: the card's)."""
    given = {name: getattr(args, name) for name in (*_OVERRIDES, "time_axis", "channel")}
    return {"method": args.reconstruction, **given}


def predict_main(argv: list[str]) -> int:
    """``python -m spl_al predict``; the exit code."""
    parser = argparse.ArgumentParser(
        prog="python -m spl_al predict",
        description="Classify or segment frames with a trained model (.pt or .onnx, with "
        "its card beside it). INPUT: release-layout .npz files, raw captures in any format "
        "load_capture reads (reconstructed as the model's dataset was), or folders of them.",
    )
    parser.add_argument("model", metavar="MODEL")
    parser.add_argument("inputs", metavar="INPUT", nargs="+")
    parser.add_argument("--out", required=True, help="output folder (predictions.csv, masks/)")
    parser.add_argument("--card", help="the model's card (default: MODEL.card.json beside it)")
    parser.add_argument("--depth-key", default="depth_ssp", help="depth array of release files")
    capture_arguments(parser)
    args = parser.parse_args(argv)
    # numpy on demand (importing this module does not load it)
    from spl_al.deploy.predict import predict

    overrides = overrides_of(args)
    try:
        predict(
            args.model,
            args.inputs,
            args.out,
            card=args.card,
            overrides=overrides,
            depth_key=args.depth_key,
            weights=args.weights,
        )
    except (ValueError, OSError) as exc:
        return _fail(exc)
    return 0
