"""Atomic writers for tables (CSV + Markdown + LaTeX), JSON summaries and figures.

Every file is written to a temporary name in its own folder and then renamed over the
target, so a killed job never leaves a half-written file that looks complete.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from spl_al.report.render import render_latex, render_markdown


def atomic_write(path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it onto ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, 0o644)  # mkstemp makes 0600; results are meant to be shared
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_table(
    frame: pd.DataFrame,
    stem,
    *,
    caption: str | None = None,
    label: str | None = None,
    decimals: int = 1,
) -> dict[str, Path]:
    """Write ``stem.csv`` (source of truth), ``stem.md`` and ``stem.tex`` of a table frame.

    Markdown and LaTeX are rendered from the CSV as written (read back), so the three
    files cannot disagree. ``label`` defaults to ``tab:<stem name>``. Returns the paths
    by suffix ("csv", "md", "tex").
    """
    stem = Path(stem)
    # Suffixes are appended, not swapped: a stem like "alpha0.5" keeps its dot.
    csv_path = atomic_write(
        stem.parent / f"{stem.name}.csv", lambda tmp: frame.to_csv(tmp, index=False)
    )
    stored = read_table(csv_path)
    md = render_markdown(stored, caption=caption, decimals=decimals)
    tex = render_latex(
        stored, caption=caption, label=label or f"tab:{stem.name}", decimals=decimals
    )
    return {
        "csv": csv_path,
        "md": atomic_write_text(stem.parent / f"{stem.name}.md", md),
        "tex": atomic_write_text(stem.parent / f"{stem.name}.tex", tex),
    }


def read_table(path) -> pd.DataFrame:
    """A table frame back from its CSV (labels kept as text: "40" stays "40", not 40.0)."""
    return pd.read_csv(
        path,
        dtype={"row": str, "col": str, "method": str, "round": "Int64", "n_labeled": "Int64"},
        keep_default_na=True,
    ).assign(
        row=lambda f: f["row"].fillna(""),
        col=lambda f: f["col"].fillna(""),
    )


def write_json(obj, path) -> Path:
    """Write a JSON-serialisable object (e.g. ``summary(df)``) atomically, NaN not allowed."""
    text = json.dumps(obj, indent=2, allow_nan=False) + "\n"
    return atomic_write_text(path, text)
