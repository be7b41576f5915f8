"""Command line of the photon engine.

python -m spl_al.photon --demo OUT.png            # a scene under a grid of conditions
python -m spl_al.photon --real CAPTURE.mat OUT.png  # reconstruct a real capture
python -m spl_al.photon --real CAPTURE.mat OUT.png --sspi [--weights FOLDER]
                                                    # ... with SSPI beside lmf and pooled
"""

from __future__ import annotations

import argparse
import sys

from spl_al.photon.reconstruct import METHODS
from spl_al.photon.sensor import SensorParams


def main(argv: list[str] | None = None) -> int:
    """Run the ``python -m spl_al.photon`` command of ``argv``; the exit code."""
    parser = argparse.ArgumentParser(
        prog="python -m spl_al.photon", description=__doc__.splitlines()[0]
    )
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--demo", metavar="OUT.png", help="render the condition grid")
    group.add_argument(
        "--real", nargs=2, metavar=("CAPTURE.mat", "OUT.png"), help="reconstruct a real capture"
    )
    parser.add_argument("--method", choices=METHODS, default="pooled")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--sspi", action="store_true", help="--real: add SSPI and its agreement with pooled"
    )
    parser.add_argument(
        "--weights",
        metavar="FOLDER",
        help="SSPI weights folder (ssunet1.pth, ssunet2.pth); default $SPL_AL_SSPI_WEIGHTS",
    )
    args = parser.parse_args(argv)

    from spl_al.photon import demo

    try:
        if args.demo:
            demo.render_condition_grid(
                args.demo, seed=args.seed, method=args.method, weights=args.weights
            )
            print(f"wrote {args.demo}")
        else:
            from spl_al.photon.io import load_mat

            capture, out = args.real
            methods = ("lmf", "pooled", "sspi") if args.sspi else ("lmf", "pooled")
            recs = demo.render_real_capture(
                load_mat(capture),
                SensorParams.ugv45m(),
                out,
                title=capture,
                methods=methods,
                weights=args.weights,
            )
            if args.sspi:
                a = demo.depth_agreement(recs["sspi"].depth_m, recs["pooled"].depth_m)
                print(
                    f"{capture}: sspi vs pooled on {a['n_both']} pixels both reconstruct: "
                    f"median |diff| {100 * a['median_abs_m']:.1f} cm, "
                    f"{100 * a['within_10cm']:.1f}% within 10 cm, "
                    f"{100 * a['within_30cm']:.1f}% within 30 cm"
                )
            print(f"wrote {out}")
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
