"""Budget curves: test metric vs labeling ratio, mean over seeds with a +-std band.

Figures are built on ``matplotlib.figure.Figure`` with the Agg canvas (no pyplot, no
global state, no display needed); matplotlib is imported only when a figure is made.
Each method keeps its colour, marker and line style across figures (``display``);
DUIS is drawn last, on top, with a thicker line. A point averaged over fewer seeds
than the figure's others is drawn with a hollow marker.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from spl_al.plotting import fit_texts, new_figure
from spl_al.report.aggregate import method_curves
from spl_al.report.display import (
    FULL_METHOD,
    LEVEL_LABELS,
    METHOD_LABELS,
    METRIC_LABELS,
    method_colors,
    method_label,
    method_style,
    ordered_methods,
)
from spl_al.report.records import LEVELS, one_dataset
from spl_al.report.writers import atomic_write

STANDIN_NOTE = "synthetic stand-in"


def _title(d: pd.DataFrame, title: str | None, default: str) -> str:
    title = title or default
    if d["synthetic_standin"].any() and STANDIN_NOTE not in title.lower():
        title += f" ({STANDIN_NOTE})"
    return title


def _metric_axis_label(d: pd.DataFrame, scale: float) -> str:
    metric = METRIC_LABELS.get(d["metric"].iloc[0], d["metric"].iloc[0])
    return f"{metric} (%)" if scale == 100 else metric


def _draw_order(d: pd.DataFrame, methods: Sequence[str] | None) -> list[str]:
    methods = ordered_methods(d["method"]) if methods is None else list(dict.fromkeys(methods))
    # DUIS last so that its line is drawn over the others.
    return [m for m in methods if m != FULL_METHOD] + [m for m in methods if m == FULL_METHOD]


def _draw(
    ax,
    d: pd.DataFrame,
    methods: list[str],
    value_col: str,
    scale: float,
    labels: Mapping[str, str],
) -> bool:
    """Draw the mean curves and bands of ``methods`` on ``ax``; True if any point is partial."""
    n_expected = d.loc[d["method"].isin(methods), "seed"].nunique()
    curves = method_curves(d[d["method"].isin(methods)], value_col)
    colors = method_colors(methods)
    any_partial = False
    for method in methods:
        c = curves[curves["method"] == method].sort_values("round")
        if c.empty:
            continue
        x = 100.0 * c["ratio"].to_numpy()
        y = scale * c["mean"].to_numpy()
        # One seed has no spread: no band there rather than a gap.
        s = scale * np.nan_to_num(c["std"].to_numpy(dtype=float), nan=0.0)
        full = method == FULL_METHOD
        style = method_style(method)
        z = 3 if full else 2
        ax.fill_between(x, y - s, y + s, color=colors[method], alpha=0.15, lw=0, zorder=z)
        ax.plot(
            x,
            y,
            color=colors[method],
            lw=2.8 if full else 1.6,
            ms=9 if full else 5,
            label=method_label(method, labels),
            zorder=z + 0.5,
            **style,
        )
        partial = c["n_seeds"].to_numpy() < n_expected
        if partial.any():
            any_partial = True
            ax.scatter(
                x[partial],
                y[partial],
                s=40,
                marker=style["marker"],
                facecolors="white",
                edgecolors=colors[method],
                zorder=z + 0.6,
            )
    ax.grid(True, color="0.88", lw=0.6)
    ax.set_axisbelow(True)
    return any_partial


def _with_partial_key(handles: list, names: list[str], partial: bool) -> tuple[list, list]:
    """Legend entries, plus a key for hollow markers when some point is partial."""
    if not partial:
        return handles, names
    from matplotlib.lines import Line2D

    # A proxy artist: it lives only in the legend, never among the Axes' lines.
    key = Line2D([], [], marker="o", ls="none", mfc="white", mec="0.3", color="0.3")
    return [*handles, key], [*names, "fewer seeds (hollow)"]


def curves_figure(
    df: pd.DataFrame,
    *,
    methods: Sequence[str] | None = None,
    title: str | None = None,
    metric_scale: float = 100,
    level: str | None = None,
    labels: Mapping[str, str] | None = None,
    dataset: str | None = None,
    panels: Mapping[str, Sequence[str]] | None = None,
):
    """A Figure of metric (percent) vs labeling ratio (percent) per method: one Axes, or
    one per entry of ``panels`` (title -> methods, e.g. the budget experiment's two
    families) side by side on a shared y axis.

    ``level`` ("high" / "medium" / "low") plots that MSPPP level's metric instead of the
    overall one. Lines are drawn in display order with DUIS last. The title says
    "synthetic stand-in" when any record of the dataset is one.
    """
    d = one_dataset(df, dataset)
    if level is not None and level not in LEVELS:
        raise ValueError(f"level must be one of {list(LEVELS)}, got {level!r}.")
    value_col = "value" if level is None else f"level_{level}"
    groups = dict(panels) if panels else {"": _draw_order(d, methods)}
    fig = new_figure(6.4 if len(groups) == 1 else 5.2 * len(groups), 4.4)
    axes = fig.subplots(1, len(groups), sharey=True, squeeze=False)[0]
    partial = False
    for ax, (name, members) in zip(axes, groups.items(), strict=True):
        order = _draw_order(d, members)
        partial |= _draw(ax, d, order, value_col, metric_scale, labels or METHOD_LABELS)
        ax.set_xlabel("Labeling ratio (%)")
        if name:
            ax.set_title(name, fontsize=10)
        if ax.get_lines():
            handles, names = ax.get_legend_handles_labels()
            ax.legend(*_with_partial_key(handles, names, partial), loc="best", fontsize=8)
    axes[0].set_ylabel(_metric_axis_label(d, metric_scale))
    what = _metric_axis_label(d, metric_scale).split(" (")[0]
    default = f"{d['dataset'].iloc[0]}: {what} vs labeling ratio"
    if level is not None:
        default += f", {LEVEL_LABELS[level]} MSPPP"
    if len(groups) == 1:
        axes[0].set_title(_title(d, title, default), fontsize=11)
    else:
        fig.suptitle(_title(d, title, default), fontsize=11)
    return fit_texts(fig)


def level_curves_figure(
    df: pd.DataFrame,
    *,
    methods: Sequence[str] | None = None,
    title: str | None = None,
    metric_scale: float = 100,
    labels: Mapping[str, str] | None = None,
    dataset: str | None = None,
):
    """A Figure with one Axes per MSPPP level (High, Medium, Low), shared y axis.

    A level without any value shows "no data" instead of failing.
    """
    d = one_dataset(df, dataset)
    order = _draw_order(d, methods)
    fig = new_figure(12.0, 4.0)
    axes = fig.subplots(1, len(LEVELS), sharey=True)
    partial = False
    for ax, level in zip(axes, LEVELS, strict=True):
        partial |= _draw(ax, d, order, f"level_{level}", metric_scale, labels or METHOD_LABELS)
        ax.set_title(f"{LEVEL_LABELS[level]} MSPPP", fontsize=10)
        ax.set_xlabel("Labeling ratio (%)")
        if not ax.get_lines():
            ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", color="0.5")
    axes[0].set_ylabel(_metric_axis_label(d, metric_scale))
    handles, names = next(
        (ax.get_legend_handles_labels() for ax in axes if ax.get_lines()), ([], [])
    )
    if handles:
        axes[-1].legend(*_with_partial_key(handles, names, partial), loc="best", fontsize=8)
    what = _metric_axis_label(d, metric_scale).split(" (")[0]
    default = f"{d['dataset'].iloc[0]}: {what} by MSPPP level vs labeling ratio"
    fig.suptitle(_title(d, title, default), fontsize=11)
    return fit_texts(fig)


def save_figure(fig, path_png, path_pdf, dpi: int = 150) -> tuple:
    """Save ``fig`` as PNG and PDF atomically. Returns the two paths."""
    return tuple(
        atomic_write(path, lambda tmp, fmt=fmt: fig.savefig(tmp, format=fmt, dpi=dpi))
        for path, fmt in ((path_png, "png"), (path_pdf, "pdf"))
    )


def plot_curves(
    df: pd.DataFrame,
    path_png,
    *,
    path_pdf,
    methods: Sequence[str] | None = None,
    title: str | None = None,
    metric_scale: float = 100,
    level: str | None = None,
    labels: Mapping[str, str] | None = None,
    dataset: str | None = None,
    panels: Mapping[str, Sequence[str]] | None = None,
) -> tuple:
    """Write the budget curves (``curves_figure``) to ``path_png`` and ``path_pdf``."""
    fig = curves_figure(
        df,
        methods=methods,
        title=title,
        metric_scale=metric_scale,
        level=level,
        labels=labels,
        dataset=dataset,
        panels=panels,
    )
    return save_figure(fig, path_png, path_pdf)


def plot_level_curves(
    df: pd.DataFrame,
    path_png,
    *,
    path_pdf,
    methods: Sequence[str] | None = None,
    title: str | None = None,
    metric_scale: float = 100,
    labels: Mapping[str, str] | None = None,
    dataset: str | None = None,
) -> tuple:
    """Write the per-MSPPP-level curves (``level_curves_figure``) to PNG and PDF."""
    fig = level_curves_figure(
        df, methods=methods, title=title, metric_scale=metric_scale, labels=labels, dataset=dataset
    )
    return save_figure(fig, path_png, path_pdf)
