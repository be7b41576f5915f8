"""Figures of the paired statistics: AUBC with intervals, the paired differences of
DUIS against each method (a forest plot), robustness heatmaps.

matplotlib is imported only when a figure is made (``spl_al.plotting.new_figure``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from spl_al.plotting import fit_texts, new_figure
from spl_al.report.claims import (
    AGAINST,
    AGREE,
    CONTRADICTED,
    INCONCLUSIVE,
    NO_CLAIM,
    SUPPORTED,
)
from spl_al.report.display import (
    METRIC_LABELS,
    METRIC_WORDS,
    method_colors,
    method_label,
    ordered_methods,
)
from spl_al.report.records import one_dataset
from spl_al.report.stats import aubc_per_seed, mean_interval, span_text, unit_means


def _metric_name(metric: str) -> str:
    return METRIC_LABELS.get(metric, metric)


def aubc_figure(df: pd.DataFrame, methods: Sequence[str] | None = None, dataset=None):
    """AUBC (percent) per method: every unit (a seed, or an encoder's mean over its run
    seeds) as a dot, the mean with its 95% t-interval over the units.

    ``methods``: the budget methods in display order (default: every method of ``df``);
    each method's curve spans the same rounds as the others' (``df`` holds the rounds
    to integrate: the query rounds), named in the title.
    """
    d = one_dataset(df, dataset)
    methods = list(methods) if methods is not None else ordered_methods(d["method"])
    areas = aubc_per_seed(d[d["method"].isin(methods)])
    colors = method_colors(methods)
    fig = new_figure(6.4, 0.5 * len(methods) + 1.6)
    ax = fig.add_subplot()
    units = unit_means(areas.rename(columns={"aubc": "value"}))
    for y, method in enumerate(methods):
        # the dots are the units the interval is over: seeds, or encoders' means
        values = 100 * units.loc[units["method"] == method, "value"].to_numpy()
        if values.size == 0:
            continue
        # the interval over the units of replication: seeds, or encoders' means
        stats = mean_interval(100 * units.loc[units["method"] == method, "value"].to_numpy())
        ax.scatter(values, np.full(values.size, y), s=14, color=colors[method], alpha=0.5)
        if np.isfinite(stats["ci_low"]):
            ax.errorbar(
                stats["mean"],
                y,
                xerr=[[stats["mean"] - stats["ci_low"]], [stats["ci_high"] - stats["mean"]]],
                fmt="o",
                color=colors[method],
                capsize=4,
                markersize=7,
            )
        else:
            ax.plot(stats["mean"], y, "o", color=colors[method], markersize=7)
    ax.set_yticks(range(len(methods)), [method_label(m) for m in methods])
    ax.invert_yaxis()
    n = int(areas["seed"].nunique()) if not areas.empty else 0
    k = int(units["seed"].nunique()) if not units.empty else 0
    over = f"n = {n} seeds" if k == n else f"n = {k} encoders' means ({n} seeds)"
    dots = "single seeds" if k == n else "the encoders' means"
    metric = _metric_name(d["metric"].iloc[0])
    standin = ", synthetic stand-in" if bool(d["synthetic_standin"].any()) else ""
    span = span_text(d[d["method"].isin(methods)])
    ax.set_title(
        f"{d['dataset'].iloc[0]}{standin}: area under the budget curve, {span}\n"
        f"mean and 95% t-interval over {over}; small dots: {dots}",
        fontsize=10,
    )
    ax.set_xlabel(f"AUBC: mean {metric} (%) over the labeling-ratio range")
    ax.grid(axis="x", alpha=0.3)
    return fit_texts(fig)


VERDICT_STYLES = {
    SUPPORTED: {"color": "#1a9850", "marker": "o", "filled": True},
    AGREE: {"color": "#1a9850", "marker": "o", "filled": False},
    CONTRADICTED: {"color": "#d73027", "marker": "s", "filled": True},
    AGAINST: {"color": "#d73027", "marker": "s", "filled": False},
    INCONCLUSIVE: {"color": "#7f7f7f", "marker": "D", "filled": True},
    NO_CLAIM: {"color": "#404040", "marker": "x", "filled": True},
}
"""How ``differences_figure`` marks a comparison's verdict (``claims.aubc_differences``):
green for DUIS, red against, grey undecided; hollow where the small-n rule reads it
(fewer than 6 units: untested)."""

DIFFERENCES_XLABEL = "DUIS − method, AUBC (points)"


def _verdict_marker(ax, x: float, y: float, verdict: str, gid: str):
    style = VERDICT_STYLES.get(verdict, VERDICT_STYLES[INCONCLUSIVE])
    face = style["color"] if style["filled"] else "white"
    (line,) = ax.plot(
        [x],
        [y],
        linestyle="none",
        marker=style["marker"],
        markersize=7,
        color=style["color"],
        markerfacecolor=face,
        markeredgecolor=style["color"],
        zorder=3,
        gid=gid,
        label=verdict if verdict != NO_CLAIM else "in no claim",
    )
    return line


def differences_figure(diffs: pd.DataFrame, *, dataset: str, metric: str = "", note: str = ""):
    """A forest plot of DUIS − each budget method on the AUBC over the query rounds
    (``spl_al.report.claims.aubc_differences``): per comparator its mean paired
    difference (points) and 95% t-interval over the units (seeds, or encoders' means),
    the marker saying the comparison's verdict under its family's claim
    (``VERDICT_STYLES``, a legend), the comparators grouped under their family's
    heading (the claim's verdict beside it), a line at zero. ``note``: added to the
    title (a stand-in, the framework). Each marker's ``gid`` is its method, each
    interval's ``METHOD:ci``, each heading's ``family:FAMILY``."""
    rows = diffs.reset_index(drop=True)
    n_lines = len(rows) + rows["family"].nunique() if not rows.empty else 1
    fig = new_figure(7.2, 0.3 * n_lines + 2.0)
    ax = fig.add_subplot()
    if rows.empty:
        ax.set_axis_off()
        ax.set_title(
            f"{dataset}{note}: no paired AUBC comparison of DUIS with another method",
            fontsize=10,
        )
        return fit_texts(fig)
    handles = _forest_rows(ax, rows)
    lo = float(np.nanmin([rows["ci_low"].min(), rows["diff"].min(), 0.0]))
    hi = float(np.nanmax([rows["ci_high"].max(), rows["diff"].max(), 0.0]))
    pad = 0.08 * (hi - lo or 1.0)
    ax.set_xlim(lo - pad, hi + pad)
    ax.set_xlabel(DIFFERENCES_XLABEL)
    ax.grid(axis="x", alpha=0.3)
    order = [v for v in VERDICT_STYLES if v in handles]
    fig.legend(
        [handles[v] for v in order],
        [handles[v].get_label() for v in order],
        loc="outside lower center",
        ncols=len(order),
        fontsize=7,
        frameon=False,
    )
    n, n_seeds, unit = int(rows["n"].max()), int(rows["n_seeds"].max()), rows["unit"].iloc[0]
    over = f"n = {n} seeds" if unit == "seed" else f"n = {n} encoders' means ({n_seeds} seeds)"
    span = f"query {rows['span'].iloc[0]}" if rows["span"].iloc[0] else "the query rounds"
    what = f" of {METRIC_WORDS.get(metric, metric)}" if metric else ""
    ax.set_title(
        f"{dataset}{note}: DUIS − each method, AUBC{what} over {span}\n"
        f"mean paired difference and 95% t-interval over {over}",
        fontsize=10,
    )
    return fit_texts(fig)


def _forest_rows(ax, rows: pd.DataFrame) -> dict:
    """Draw each family's heading on a row of its own, then its comparators' intervals
    and markers, a line at zero; {verdict: a marker of it} for the legend."""
    from matplotlib.transforms import blended_transform_factory

    # the headings sit on rows of their own, from the left edge of the axes
    across = blended_transform_factory(ax.transAxes, ax.transData)
    ticks, labels, y = [], [], 0
    handles = {}
    for family, part in rows.groupby("family", sort=False):
        first = part.iloc[0]
        head = str(first["heading"])
        if first["claim_verdict"]:
            head += f" (claim: {first['claim_verdict']})"
        ax.text(
            0.01,
            y,
            head,
            transform=across,
            fontsize=8,
            fontweight="bold",
            fontstyle="italic",
            va="center",
            gid=f"family:{family}",
        )
        y += 1
        for _, row in part.iterrows():
            if np.isfinite(row["ci_low"]) and np.isfinite(row["ci_high"]):
                style = VERDICT_STYLES.get(row["verdict"], VERDICT_STYLES[INCONCLUSIVE])
                ax.hlines(
                    y,
                    row["ci_low"],
                    row["ci_high"],
                    color=style["color"],
                    lw=1.6,
                    gid=f"{row['method']}:ci",
                )
            line = _verdict_marker(ax, row["diff"], y, row["verdict"], str(row["method"]))
            handles.setdefault(row["verdict"], line)
            ticks.append(y)
            labels.append(method_label(row["method"]))
            y += 1
        y += 0.4  # a gap between families
    ax.axvline(0.0, color="black", lw=0.8, zorder=1)
    ax.set_yticks(ticks, labels, fontsize=8)
    ax.set_ylim(y - 0.4, -0.6)
    return handles


def heatmap_figure(cells: pd.DataFrame, *, note: str = ""):
    """One heatmap per method of the robustness grid (mean over seeds, percent).

    ``cells``: ``spl_al.experiment.robustness.robustness_table`` rows (method, msppp,
    sbr, mean, n_seeds, trained_range). Cells outside the training conditions are
    outlined with a dashed line.
    """
    methods = ordered_methods(cells["method"])
    msppp = np.sort(cells["msppp"].unique())
    sbr = np.sort(cells["sbr"].unique())
    cols = min(3, len(methods))
    rows = -(-len(methods) // cols)
    fig = new_figure(3.4 * cols + 0.8, 2.9 * rows + 0.9)
    lo, hi = float(np.nanmin(cells["mean"])), float(np.nanmax(cells["mean"]))
    image = None
    for k, method in enumerate(methods):
        ax = fig.add_subplot(rows, cols, k + 1)
        grid = _grid(cells[cells["method"] == method], msppp, sbr, "mean")
        image = ax.imshow(grid, origin="lower", cmap="viridis", vmin=lo, vmax=hi, aspect="auto")
        for i in range(len(msppp)):
            for j in range(len(sbr)):
                if np.isfinite(grid[i, j]):
                    ax.text(
                        j,
                        i,
                        f"{grid[i, j]:.0f}",
                        ha="center",
                        va="center",
                        fontsize=7,
                        color="white" if grid[i, j] < (lo + hi) / 2 else "black",
                    )
        _outline_training(ax, cells[cells["method"] == method], msppp, sbr)
        _axes(ax, msppp, sbr)
        n = int(cells.loc[cells["method"] == method, "n_seeds"].max())
        ax.set_title(f"{method_label(method)} (n = {n})", fontsize=9)
    first = cells.iloc[0]
    fig.suptitle(
        f"{first['dataset']}: {_metric_name(first['metric'])} (%) of the final-round model "
        f"over MSPPP x SBR{note}",
        fontsize=10,
    )
    if image is not None:
        fig.colorbar(image, ax=fig.axes, shrink=0.8)
    return fit_texts(fig)


def difference_figure(diff: pd.DataFrame, *, note: str = ""):
    """DUIS minus the best baseline per grid cell (pp); a cell whose paired 95%
    interval spans zero is hatched and its number greyed."""
    msppp = np.sort(diff["msppp"].unique())
    sbr = np.sort(diff["sbr"].unique())
    fig = new_figure(5.2, 4.2)
    ax = fig.add_subplot()
    grid = _grid(diff, msppp, sbr, "diff")
    bound = float(np.nanmax(np.abs(grid))) if np.isfinite(grid).any() else 1.0
    image = ax.imshow(grid, origin="lower", cmap="RdBu", vmin=-bound, vmax=bound, aspect="auto")
    spans = _grid(diff.assign(s=diff["spans_zero"].astype(float)), msppp, sbr, "s")
    for i in range(len(msppp)):
        for j in range(len(sbr)):
            if not np.isfinite(grid[i, j]):
                continue
            unsure = spans[i, j] != 0
            ax.text(
                j,
                i,
                f"{grid[i, j]:+.1f}",
                ha="center",
                va="center",
                fontsize=7,
                color="0.45" if unsure else "black",
            )
            if unsure:
                ax.add_patch(_hatch(j, i))
    _outline_training(ax, diff, msppp, sbr)
    _axes(ax, msppp, sbr)
    first = diff.iloc[0]
    ax.set_title(
        f"{first['dataset']}: DUIS − {method_label(first['baseline'])} (best baseline), pp"
        f"{note}\nhatched: 95% paired interval spans zero (n = {int(diff['n'].max())})",
        fontsize=9,
    )
    fig.colorbar(image, ax=ax, shrink=0.8)
    return fit_texts(fig)


def _grid(cells: pd.DataFrame, msppp, sbr, column: str) -> np.ndarray:
    grid = np.full((len(msppp), len(sbr)), np.nan)
    i = np.searchsorted(msppp, cells["msppp"].to_numpy())
    j = np.searchsorted(sbr, cells["sbr"].to_numpy())
    grid[i, j] = cells[column].to_numpy(dtype=float)
    return grid


def _axes(ax, msppp, sbr) -> None:
    ax.set_xticks(range(len(sbr)), [f"{v:g}" for v in sbr], fontsize=7)
    ax.set_yticks(range(len(msppp)), [f"{v:g}" for v in msppp], fontsize=7)
    ax.set_xlabel("SBR", fontsize=8)
    ax.set_ylabel("MSPPP (signal photons / pixel)", fontsize=8)


def _hatch(j: int, i: int):
    from matplotlib.patches import Rectangle

    return Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch="///", edgecolor="0.6", lw=0)


def _outline_training(ax, cells: pd.DataFrame, msppp, sbr) -> None:
    """Dashed outline around the cells inside the training conditions' range."""
    from matplotlib.patches import Rectangle

    inside = cells[cells["trained_range"].astype(bool)]
    if inside.empty:
        return
    i = np.searchsorted(msppp, inside["msppp"].to_numpy())
    j = np.searchsorted(sbr, inside["sbr"].to_numpy())
    ax.add_patch(
        Rectangle(
            (j.min() - 0.5, i.min() - 0.5),
            j.max() - j.min() + 1,
            i.max() - i.min() + 1,
            fill=False,
            linestyle="--",
            edgecolor="white",
            lw=1.2,
        )
    )
