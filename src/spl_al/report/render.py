"""Markdown and LaTeX (booktabs) rendering of a long-form table frame.

The renderers read only the frame's columns (see ``spl_al.report.tables``), so a table
read back from its CSV renders to the same text. Cells are "mean ± std" with
``decimals`` places; a cell averaged over fewer seeds than the table's others shows
"(n=k)"; an empty cell is a dash. Per column of a method table (per parameter of the
sensitivity table) the highest mean is bold when the table's ``mark`` column says its
paired difference to the runner-up is resolved (``spl_al.report.stats``) and carries a
dagger when it is not (a tie at this number of seeds). A frame without ``mark`` (an
older CSV) bolds the best printed mean, values that print alike together.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from spl_al.report.display import METRIC_LABELS, format_ratio
from spl_al.report.stats import rule_text

_LATEX_SPECIALS = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "±": r"$\pm$",
    "α": r"$\alpha$",
    "—": "--",
    "†": r"$^\dagger$",
}
_LATEX_RE = re.compile("|".join(re.escape(c) for c in _LATEX_SPECIALS))


def latex_escape(text: str) -> str:
    """Text safe inside a LaTeX tabular or caption: specials escaped in one pass."""
    return _LATEX_RE.sub(lambda m: _LATEX_SPECIALS[m.group(0)], str(text))


def _markdown_escape(text: str) -> str:
    return str(text).replace("|", r"\|")


def _is_blocks(frame: pd.DataFrame) -> bool:
    return str(frame["table"].iloc[0]) == "sensitivity"


def _grid(frame: pd.DataFrame):
    """Row labels, column labels and a {(row, col): cell} map, in table order."""
    frame = frame.sort_values(["row_pos", "col_pos"])
    rows = list(dict.fromkeys(frame["row"]))
    cells = {}
    cols_of_row: dict[str, list[str]] = {r: [] for r in rows}
    for _, cell in frame.iterrows():
        if int(cell["col_pos"]) < 0:  # placeholder row of a method without any record
            continue
        cells[cell["row"], cell["col"]] = cell
        cols_of_row[cell["row"]].append(cell["col"])
    col_frame = frame[frame["col_pos"] >= 0].drop_duplicates("col").sort_values("col_pos")
    return rows, list(col_frame["col"]), cols_of_row, cells


def _has_value(cell) -> bool:
    return cell is not None and int(cell["n_seeds"]) > 0 and np.isfinite(cell["mean"])


def _best(cells: list, decimals: int) -> tuple[set[int], set[int]]:
    """Indices of the bold cells and of the tied leaders (dagger) among ``cells``.

    From the ``mark`` column when the frame has one; otherwise the highest printed
    mean is bold, when at least two cells have a value.
    """
    if any(c is not None and "mark" in c.index for c in cells):
        bold = {i for i, c in enumerate(cells) if c is not None and c.get("mark") == "bold"}
        tie = {i for i, c in enumerate(cells) if c is not None and c.get("mark") == "tie"}
        return bold, tie
    valued = [(i, round(float(c["mean"]), decimals)) for i, c in enumerate(cells) if _has_value(c)]
    if len(valued) < 2:
        return set(), set()
    top = max(v for _, v in valued)
    return {i for i, v in valued if v == top}, set()


def _cell_text(cell, decimals: int, pm: str, dash: str) -> str:
    if not _has_value(cell):
        return dash
    n, n_expected = int(cell["n_seeds"]), int(cell["n_expected"])
    text = f"{cell['mean']:.{decimals}f}"
    if n >= 2 and math.isfinite(cell["std"]):
        text += f" {pm} {cell['std']:.{decimals}f}"
    if n < n_expected or n == 1:
        text += f" (n={n})"
    return text


def _metric_label(frame: pd.DataFrame) -> str:
    first = frame.iloc[0]
    metric = METRIC_LABELS.get(first["metric"], first["metric"])
    return metric + " (%)" if float(first["scale"]) == 100.0 else metric


def table_caption(frame: pd.DataFrame) -> str:
    """One-sentence caption of a table frame, from its own columns."""
    first = frame.iloc[0]
    metric = _metric_label(frame)
    dataset = first["dataset"]
    seeds = f"mean ± std over {int(first['n_expected'])} seeds"
    kind = first["table"]
    if kind == "budget":
        return f"{metric} on {dataset} vs labeling ratio, {seeds}."
    rounds = frame["round"].dropna().astype(int).unique()
    if kind == "level":
        valued = frame.dropna(subset=["n_labeled"])
        at = f"round {rounds[0]}" if len(rounds) else "one round"
        if not valued.empty:
            n_lab = int(valued["n_labeled"].iloc[0])
            at += f" ({n_lab} labeled, {format_ratio(valued['ratio'].dropna().mean())})"
        return f"{metric} on {dataset} by MSPPP level at {at}, {seeds}."
    if kind == "ablation":
        return f"Ablation on {dataset}: {metric}, {seeds}."
    if kind == "sensitivity":
        return (
            f"Parameter sensitivity on {dataset}: {metric} with one parameter varied and "
            f"the others at their defaults, {seeds}."
        )
    return f"{metric} on {dataset}, {seeds}."


def table_notes(frame: pd.DataFrame) -> list[str]:
    """Notes under a table: partial cells and the synthetic stand-in flag."""
    notes = []
    per = "per parameter" if _is_blocks(frame) else "per column"
    if "mark" not in frame.columns:
        notes.append(f"Best mean {per} in bold.")
    else:
        marks = frame["mark"].astype(object).fillna("")
        seeds = int(frame["n_expected"].iloc[0])
        encoders = int(frame["n_encoders"].iloc[0]) if "n_encoders" in frame else 0
        unit = "encoders" if encoders else "seeds"
        n = (
            f"{seeds} seeds per cell, reading {encoders} encoders (the mean and std are over "
            f"the seeds; the tests pair the {encoders} encoders' means, the units a rerun "
            "draws again)"
            if encoders
            else f"{seeds} seeds per cell"
        )
        notes.append(
            f"n = {n}. Bold: the highest mean {per}, resolved from the runner-up "
            f"({rule_text(unit=unit[:-1])})."
        )
        if (marks == "tie").any():
            notes.append(
                "†: the highest mean (every one, when several are equal), not resolved "
                f"from the runner-up: a tie at this number of {unit}."
            )
    if frame["partial"].astype(bool).any() or (frame["n_seeds"] == 1).any():
        notes.append(
            f"(n=k): averaged over the k seeds present out of {int(frame['n_expected'].iloc[0])}."
        )
    if frame["synthetic_standin"].astype(bool).any():
        notes.append(
            f"{frame['dataset'].iloc[0]} is a synthetic stand-in for real data, "
            "not the paper's dataset."
        )
    return notes


def _check_frame(frame: pd.DataFrame) -> None:
    need = {"row", "col", "row_pos", "col_pos", "mean", "std", "n_seeds", "n_expected", "table"}
    missing = sorted(need - set(frame.columns))
    if missing:
        raise ValueError(f"frame is not a report table: missing columns {missing}.")
    if frame.empty:
        raise ValueError("frame is empty; a report table has at least one row.")


def render_markdown(frame: pd.DataFrame, caption: str | None = None, decimals: int = 1) -> str:
    """GitHub-flavoured Markdown: caption paragraph, table, notes in italics."""
    _check_frame(frame)
    rows, cols, cols_of_row, cells = _grid(frame)
    esc = _markdown_escape

    def fmt(row_cells: list) -> list[str]:
        best, tie = _best(row_cells, decimals)
        out = []
        for i, c in enumerate(row_cells):
            text = _cell_text(c, decimals, "±", "—")
            out.append(f"**{text}**" if i in best else f"{text} †" if i in tie else text)
        return out

    lines = [f"**{caption or table_caption(frame)}**", ""]
    if _is_blocks(frame):
        width = max((len(v) for v in cols_of_row.values()), default=0)
        lines.append("| Parameter |" + " |" * width)
        lines.append("|:---|" + "---:|" * width)
        for r in rows:
            own = cols_of_row[r]
            pad = [""] * (width - len(own))
            lines.append("| " + " | ".join([esc(r), *map(esc, own), *pad]) + " |")
            texts = fmt([cells[r, c] for c in own])
            lines.append("| " + " | ".join(["", *texts, *pad]) + " |")
    else:
        lines.append("| Method | " + " | ".join(map(esc, cols)) + " |")
        lines.append("|:---|" + "---:|" * len(cols))
        per_col = {c: fmt([cells.get((r, c)) for r in rows]) for c in cols}
        for i, r in enumerate(rows):
            lines.append("| " + " | ".join([esc(r), *(per_col[c][i] for c in cols)]) + " |")
    lines.append("")
    lines += [f"*{esc(note)}*" for note in table_notes(frame)]
    return "\n".join(lines) + "\n"


def render_latex(
    frame: pd.DataFrame,
    caption: str | None = None,
    label: str | None = None,
    decimals: int = 1,
) -> str:
    r"""A LaTeX ``table`` with a booktabs ``tabular`` (needs ``\usepackage{booktabs}``).

    The caption carries the notes (partial cells, synthetic stand-in) so they travel
    with the table.
    """
    _check_frame(frame)
    rows, cols, cols_of_row, cells = _grid(frame)
    esc = latex_escape

    def fmt(row_cells: list) -> list[str]:
        best, tie = _best(row_cells, decimals)
        out = []
        for i, c in enumerate(row_cells):
            text = _cell_text(c, decimals, r"$\pm$", "--")
            if i in best:
                text = rf"\textbf{{{text}}}"
            elif i in tie:
                text += r"$^\dagger$"
            out.append(text)
        return out

    blocks = _is_blocks(frame)
    width = max((len(v) for v in cols_of_row.values()), default=0) if blocks else len(cols)
    text = " ".join([caption or table_caption(frame), *table_notes(frame)])
    lines = [
        "% Rendered from the CSV beside this file (the source of truth); needs booktabs.",
        r"\begin{table}[t]",
        r"\centering",
        rf"\caption{{{esc(text)}}}",
    ]
    if label:
        lines.append(rf"\label{{{label}}}")
    lines += [rf"\begin{{tabular}}{{l{'c' * width}}}", r"\toprule"]
    if blocks:
        metric = esc(_metric_label(frame))
        lines.append(rf"Parameter & \multicolumn{{{width}}}{{c}}{{Value / {metric}}} \\")
        for k, r in enumerate(rows):
            own = cols_of_row[r]
            pad = [""] * (width - len(own))
            lines.append(r"\midrule" if k == 0 else rf"\cmidrule(lr){{1-{width + 1}}}")
            lines.append(" & ".join([esc(r), *map(esc, own), *pad]) + r" \\")
            lines.append(" & ".join(["", *fmt([cells[r, c] for c in own]), *pad]) + r" \\")
    else:
        lines.append(" & ".join(["Method", *map(esc, cols)]) + r" \\")
        lines.append(r"\midrule")
        per_col = {c: fmt([cells.get((r, c)) for r in rows]) for c in cols}
        for i, r in enumerate(rows):
            lines.append(" & ".join([esc(r), *(per_col[c][i] for c in cols)]) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"
