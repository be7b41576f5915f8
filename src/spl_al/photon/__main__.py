"""Command line of the photon engine.

python -m spl_al.photon reconstruct CAPTURE OUT.npz   # a capture -> the release layout
python -m spl_al.photon --demo OUT.png                # a scene under a grid of conditions
python -m spl_al.photon --real CAPTURE OUT.png        # pictures of a real capture
python -m spl_al.photon --real CAPTURE OUT.png --sspi [--weights FOLDER]
                                                      # ... with SSPI beside lmf and pooled

CAPTURE is any format ``spl_al.photon.io.load_capture`` reads (.mat sparse matrix or
timestamp cell array, count cube in .mat/.npy/.npz/.h5, PicoQuant .ptu).
"""

from __future__ import annotations

import argparse
import sys

from spl_al.photon import pictures
from spl_al.photon.io import FORMATS, READ_KEYS, ReadOptions
from spl_al.photon.reconstruct import METHODS


def _capture_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--format", choices=FORMATS, default="auto", help="capture format")
    parser.add_argument("--key", help="variable / array / dataset holding the photons")
    parser.add_argument(
        "--time-unit", default="ps", help="unit of timestamps and of a plain bin_width / gate"
    )
    parser.add_argument(
        "--bin-width-ps",
        type=float,
        help="bin timestamps at this width; the width of files that state none",
    )
    parser.add_argument(
        "--pulse-sigma-ps", type=float, help="instrument response sigma (default: estimated)"
    )
    parser.add_argument("--time-axis", type=int, choices=(0, 2, -1), help="cube: axis of time")
    parser.add_argument("--channel", type=int, help="PTU: detector channel (default: all)")
    parser.add_argument(
        "--weights",
        metavar="FOLDER",
        help="SSPI weights folder (ssunet1.pth, ssunet2.pth); default $SPL_AL_SSPI_WEIGHTS",
    )


def _options(args):
    """The reader options of the command line: those of a dataset's ``captures:``."""
    return ReadOptions(**{name: getattr(args, name) for name in READ_KEYS})


def _load(args):
    """The capture, read as ``source: captures`` and the pictures read theirs."""
    return _options(args).load(args.capture)


def _sigma_s(args) -> float | None:
    return _options(args).pulse_sigma_s


def reconstruct_main(argv: list[str]) -> int:
    """``python -m spl_al.photon reconstruct CAPTURE OUT.npz [options]``; the exit code."""
    parser = argparse.ArgumentParser(
        prog="python -m spl_al.photon reconstruct",
        description="Reconstruct a photon capture into the release layout (depth_ssp, "
        "intensity, msppp, sbr, pulse_sigma_s, bin_width_s).",
    )
    parser.add_argument("capture", metavar="CAPTURE")
    parser.add_argument("out", metavar="OUT.npz")
    parser.add_argument("--method", choices=METHODS, default="pooled")
    _capture_options(parser)
    args = parser.parse_args(argv)
    # scipy on demand (importing this module does not load it)
    from spl_al.photon.release import reconstruct_capture, save_release

    try:
        if not args.out.endswith(".npz"):
            raise ValueError(f"OUT must be a .npz file, got {args.out!r}.")
        capture = _load(args)
        result = reconstruct_capture(
            capture, method=args.method, pulse_sigma_s=_sigma_s(args), weights=args.weights
        )
        save_release(args.out, result)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{args.capture}: {result.summary()}; wrote {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the ``python -m spl_al.photon`` command of ``argv``; the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["reconstruct"]:
        return reconstruct_main(argv[1:])
    parser = argparse.ArgumentParser(
        prog="python -m spl_al.photon", description=__doc__.splitlines()[0]
    )
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--demo", metavar="OUT.png", help="render the condition grid")
    group.add_argument(
        "--real", nargs=2, metavar=("CAPTURE", "OUT.png"), help="pictures of a real capture"
    )
    parser.add_argument("--method", choices=METHODS, default="pooled")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--sspi", action="store_true", help="--real: add SSPI and its agreement with pooled"
    )
    _capture_options(parser)
    args = parser.parse_args(argv)

    try:
        if args.demo:
            pictures.render_condition_grid(
                args.demo, seed=args.seed, method=args.method, weights=args.weights
            )
            print(f"wrote {args.demo}")
        else:
            _real(args, pictures)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


def _real(args, pictures) -> None:
    """--real: pictures of a capture with the sensor from its file and its photons."""
    # scipy on demand (importing this module does not load it)
    from spl_al.photon.calibration import estimate_pulse_sigma

    args.capture, out = args.real
    capture = _load(args)
    sigma_s = _sigma_s(args) or capture.pulse_sigma_s
    if sigma_s is None:
        sigma_s = estimate_pulse_sigma(capture.events, capture.n_bins).sigma_bins
        sigma_s *= capture.bin_width_s
    methods = ("lmf", "pooled", "sspi") if args.sspi else ("lmf", "pooled")
    binned = capture.for_reconstruction(sigma_s)
    recs = pictures.render_real_capture(
        binned.events,
        binned.sensor(sigma_s),
        out,
        title=args.capture,
        methods=methods,
        weights=args.weights,
        depth_offset_m=binned.gate_depth_m,
    )
    print(f"{args.capture}: {capture.describe()}, pulse sigma {sigma_s * 1e12:.0f} ps")
    if args.sspi:
        a = pictures.depth_agreement(recs["sspi"].depth_m, recs["pooled"].depth_m)
        print(
            f"{args.capture}: sspi vs pooled on {a['n_both']} pixels both reconstruct: "
            f"median |diff| {100 * a['median_abs_m']:.1f} cm, "
            f"{100 * a['within_10cm']:.1f}% within 10 cm, "
            f"{100 * a['within_30cm']:.1f}% within 30 cm"
        )
    print(f"wrote {out}")


if __name__ == "__main__":
    sys.exit(main())
