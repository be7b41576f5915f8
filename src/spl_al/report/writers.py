"""Atomic writers for tables (CSV + Markdown + LaTeX), JSON summaries and figures.

Every file is written to a temporary name in its own folder and then renamed over the
target, so a killed job never leaves a half-written file that looks complete.
"""

from __future__ import annotations

import csv
from pathlib import Path

import pandas as pd

from spl_al.atomic import atomic_write, atomic_write_text, write_json
from spl_al.report.render import render_latex, render_markdown

__all__ = ["atomic_write", "atomic_write_text", "read_table", "write_json", "write_table"]


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


def read_rows(path) -> list[dict]:
    """A table's CSV as rows of text, as written (what a page quotes: "" for a blank)."""
    with Path(path).open(newline="") as handle:
        return list(csv.DictReader(handle))


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
