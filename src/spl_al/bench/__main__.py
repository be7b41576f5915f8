"""Dispatch ``python -m spl_al.bench NAME [options]`` to ``spl_al.bench.NAME.main``."""

from __future__ import annotations

import importlib
import pkgutil
import sys

import spl_al.bench

HELPERS = ("timing",)
"""Modules of the package that are shared helpers, not benchmarks (no ``main``)."""


def available() -> list[str]:
    """Names of the benchmarks ``python -m spl_al.bench NAME`` runs."""
    return sorted(
        m.name
        for m in pkgutil.iter_modules(spl_al.bench.__path__)
        if not m.name.startswith("_") and m.name not in HELPERS
    )


def main(argv: list[str]) -> int:
    """Run the benchmark named by ``argv[0]`` with the rest of ``argv``; the exit code."""
    names = available()
    if not argv or argv[0] in ("-h", "--help"):
        print(f"usage: python -m spl_al.bench NAME [options]; NAME is one of {', '.join(names)}")
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in names:
        print(f"unknown benchmark {name!r}; expected one of {', '.join(names)}", file=sys.stderr)
        return 2
    return int(importlib.import_module(f"spl_al.bench.{name}").main(rest) or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
