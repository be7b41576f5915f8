"""``spl-al COMMAND [options]`` (the console script; also ``python -m spl_al``).

Commands are a table: name -> (module, function, one line of help). A command's
function takes the rest of the command line and returns the exit code; it is imported
only when run, so ``python -m spl_al --help`` costs no torch import. To add one, add
a row to ``COMMANDS``.
"""

from __future__ import annotations

import importlib
import sys

COMMANDS: dict[str, tuple[str, str, str]] = {
    "estimate": (
        "spl_al.bench.estimate",
        "main",
        "predict a config's wall time on this machine (python -m spl_al.bench estimate)",
    ),
    "reconstruct": (
        "spl_al.photon.__main__",
        "reconstruct_main",
        "a raw photon capture to a release-layout depth frame (python -m spl_al.photon)",
    ),
    "export": (
        "spl_al.deploy.cli",
        "export_main",
        "a trained model.pt to ONNX, checked against torch, with its model card",
    ),
    "predict": (
        "spl_al.deploy.cli",
        "predict_main",
        "classify or segment release-layout frames and raw captures with a model",
    ),
    "query": (
        "spl_al.query_frames",
        "main",
        "pick the frames a person labels next (DUIS by default) and write their batch",
    ),
}


def usage() -> str:
    """The list of commands, one per line."""
    width = max(map(len, COMMANDS))
    lines = [f"  {name:<{width}}  {help_}" for name, (_, _, help_) in COMMANDS.items()]
    return (
        "usage: spl-al COMMAND [options]   (or python -m spl_al COMMAND [options]; "
        "spl-al COMMAND --help for a command's)\n\ncommands:\n" + "\n".join(lines)
    )


def main(argv: list[str] | None = None) -> int:
    """Run the command named by ``argv[0]`` with the rest of ``argv``; the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(usage())
        return 0 if argv else 2
    if argv[0] not in COMMANDS:
        print(
            f"error: unknown command {argv[0]!r}; expected one of {', '.join(COMMANDS)}.",
            file=sys.stderr,
        )
        return 2
    module, function, _ = COMMANDS[argv[0]]
    return int(getattr(importlib.import_module(module), function)(argv[1:]) or 0)


if __name__ == "__main__":
    sys.exit(main())
