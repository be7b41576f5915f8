"""The imaging conditions of the frames each method queried, against the pool's: does
DUIS, condition-aware, ask for more low-photon frames than the other methods?

``queried_frames`` turns each run's labeled sets, round by round, into the frames
each query round added (round r's set less round r − 1's); ``pool_bins`` puts every
frame of the training pool in a bin per condition: its MSPPP level (``level``: low,
medium, high) and its signal-to-background ratio (SBR: each value where the pool
has a few, else the pool's tertiles); ``batch_conditions`` counts the queried frames
per method and bin over every query round and seed, with the pool as a reference row
(``POOL``), each row's shares summing to 1 per condition; ``batch_conditions_figure``
draws it as stacked bars. matplotlib is imported only when the figure is made.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence

import numpy as np
import pandas as pd

from spl_al.plotting import fit_texts, new_figure
from spl_al.report.display import LEVEL_LABELS, method_label

POOL = "pool"
"""The reference row of ``batch_conditions``: the training pool's make-up."""

CONDITIONS = ("msppp_level", "sbr")
"""The conditions ``batch_conditions`` splits by: the MSPPP level, the SBR."""

CONDITION_TITLES = {"msppp_level": "MSPPP level (signal photons per pixel)", "sbr": "SBR"}

LEVEL_ORDER = ("low", "medium", "high", "unknown")
"""MSPPP levels from the fewest photons up (``unknown``: a frame without one)."""

UNKNOWN = "unknown"

MAX_SBR_VALUES = 6
"""Up to this many distinct SBR values in the pool, each is its own bin; beyond, the
pool's tertiles."""

COLUMNS = ("method", "condition", "bin", "order", "n_frames", "share", "n_runs", "rounds")


def queried_frames(sets: Iterable[tuple[str, int, int, Sequence[int]]]) -> pd.DataFrame:
    """The frames each query round added: ``sets`` holds (method, seed, round,
    pool_indices), each run's labeled set at each round (round 0 the set it started
    from; indices into the training pool). Returns columns method, seed, round,
    pool_index: at each round r >= 1 of a run, the frames of round r's set not in round
    r − 1's (a round whose predecessor is missing adds nothing)."""
    by_run: dict[tuple[str, int], dict[int, set[int]]] = {}
    for method, seed, round_, indices in sets:
        by_run.setdefault((str(method), int(seed)), {})[int(round_)] = {int(i) for i in indices}
    rows = []
    for (method, seed), rounds in sorted(by_run.items()):
        for r in sorted(rounds):
            if r == 0 or r - 1 not in rounds:
                continue
            for index in sorted(rounds[r] - rounds[r - 1]):
                rows.append((method, seed, r, index))
    return pd.DataFrame(rows, columns=["method", "seed", "round", "pool_index"])


def sbr_bins(sbr) -> tuple[np.ndarray, list[str]]:
    """Each frame's SBR bin label and the bins in ascending order: each distinct value
    (``MAX_SBR_VALUES`` at most), else the tertiles of the finite values ("0.2–1.3");
    NaN is ``UNKNOWN`` (last)."""
    sbr = np.asarray(sbr, dtype=float)
    finite = np.isfinite(sbr)
    labels = np.full(sbr.shape, UNKNOWN, dtype=object)
    values = np.unique(sbr[finite])
    if values.size <= MAX_SBR_VALUES:
        order = [f"{v:.3g}" for v in values]
        labels[finite] = [f"{v:.3g}" for v in sbr[finite]]
    else:
        edges = np.quantile(sbr[finite], [0, 1 / 3, 2 / 3, 1])
        order = [f"{lo:.2g}–{hi:.2g}" for lo, hi in itertools.pairwise(edges)]
        which = np.clip(np.searchsorted(edges[1:-1], sbr[finite], side="right"), 0, 2)
        labels[finite] = np.asarray(order, dtype=object)[which]
    if not finite.all():
        order.append(UNKNOWN)
    return labels, order


def pool_bins(level, sbr) -> tuple[pd.DataFrame, dict[str, list[str]]]:
    """The training pool's frames by condition: ``level`` and ``sbr`` (N,) of the pool
    in pool-index order. Returns (a frame indexed by pool index with one column per
    ``CONDITIONS``, each condition's bins in order)."""
    level = np.asarray(level).astype(str)
    level = np.where(np.isin(level, LEVEL_ORDER), level, UNKNOWN)
    sbr_label, sbr_order = sbr_bins(sbr)
    frame = pd.DataFrame({"msppp_level": level, "sbr": sbr_label})
    frame.index.name = "pool_index"
    levels = [lv for lv in LEVEL_ORDER if lv in set(level)]
    return frame, {"msppp_level": levels, "sbr": sbr_order}


def batch_conditions(
    queried: pd.DataFrame, level, sbr, methods: Sequence[str] | None = None
) -> pd.DataFrame:
    """Per method, the share of the frames it queried (``queried_frames``, over every
    query round and seed) in each bin of each condition (``pool_bins`` of the pool's
    ``level`` and ``sbr``), the pool's own shares first as the row ``POOL``.

    Columns ``COLUMNS``: method, condition (``CONDITIONS``), bin, order (of the bin in
    its condition), n_frames, share (of the method's frames; per method and condition
    the shares sum to 1), n_runs (runs, (method, seed), behind the row; 0 for the
    pool), rounds ("1-3": the query rounds counted). ``methods``: rows in this order
    (default: as ``queried`` first names them); a method with no queried frame is
    left out."""
    bins, orders = pool_bins(level, sbr)
    names = list(methods) if methods is not None else list(dict.fromkeys(queried["method"]))
    rows = []
    groups = [(POOL, bins, 0, "")]
    for method in names:
        mine = queried[queried["method"] == method]
        if mine.empty:
            continue
        lo, hi = int(mine["round"].min()), int(mine["round"].max())
        runs = int(mine[["method", "seed"]].drop_duplicates().shape[0])
        frames = bins.loc[mine["pool_index"].to_numpy()]
        groups.append((method, frames, runs, f"{lo}-{hi}" if hi > lo else str(lo)))
    for method, frames, runs, rounds in groups:
        for condition in CONDITIONS:
            counts = frames[condition].value_counts()
            total = int(counts.sum())
            for k, name in enumerate(orders[condition]):
                n = int(counts.get(name, 0))
                rows.append(
                    {
                        "method": method,
                        "condition": condition,
                        "bin": name,
                        "order": k,
                        "n_frames": n,
                        "share": n / total if total else np.nan,
                        "n_runs": runs,
                        "rounds": rounds,
                    }
                )
    return pd.DataFrame(rows, columns=list(COLUMNS))


def _bin_label(condition: str, name: str) -> str:
    if condition == "msppp_level":
        return LEVEL_LABELS.get(name, name)
    return name if name == UNKNOWN else f"SBR {name}"


def _bin_colours(condition: str, names: list[str]) -> dict[str, tuple]:
    """Fewest photons (low level, low SBR) darkest; ``UNKNOWN`` light grey."""
    from matplotlib import colormaps

    cmap = colormaps["viridis" if condition == "msppp_level" else "cividis"]
    known = [n for n in names if n != UNKNOWN]
    colours = {n: cmap(0.15 + 0.7 * k / max(len(known) - 1, 1)) for k, n in enumerate(known)}
    colours[UNKNOWN] = (0.85, 0.85, 0.85, 1.0)
    return colours


def batch_conditions_figure(table: pd.DataFrame, *, title: str):
    """Stacked bars of ``batch_conditions``: one panel per condition side by side, one
    bar per method (the pool on top, hatched, and a dashed line at each of its bin
    edges), each segment a bin's share, labelled where wide enough. Each segment's
    ``gid`` is "METHOD|CONDITION|BIN"."""
    from matplotlib.patches import Patch
    from matplotlib.transforms import offset_copy

    conditions = [c for c in CONDITIONS if c in set(table["condition"])]
    methods = list(dict.fromkeys(table["method"]))
    fig = new_figure(4.2 * max(len(conditions), 1) + 2.0, 0.3 * len(methods) + 2.2)
    if table.empty:
        ax = fig.add_subplot()
        ax.set_axis_off()
        ax.set_title(f"{title}: no query round to count", fontsize=10)
        return fit_texts(fig)
    axes = fig.subplots(1, len(conditions), squeeze=False, sharey=True)[0]
    for ax, condition in zip(axes, conditions, strict=True):
        part = table[table["condition"] == condition].sort_values("order", kind="stable")
        names = list(dict.fromkeys(part["bin"]))
        colours = _bin_colours(condition, names)
        for y, method in enumerate(methods):
            _stacked_bar(ax, part[part["method"] == method], y, method, colours)
        edges = np.cumsum(part.loc[part["method"] == POOL, "share"].fillna(0).to_numpy())[:-1]
        for edge in edges:
            ax.axvline(edge, color="black", lw=0.8, linestyle="--", zorder=3)
        ax.set_xlim(0, 1)
        ticks = np.linspace(0, 1, 5)
        ax.set_xticks(ticks, [f"{round(100 * v)}%" for v in ticks], fontsize=7)
        ax.set_title(CONDITION_TITLES[condition], fontsize=9)
        ax.set_xlabel("share of the queried frames", fontsize=8)
        ax.legend(
            handles=[Patch(color=colours[n], label=_bin_label(condition, n)) for n in names],
            loc="upper center",
            bbox_to_anchor=(0.5, 0.0),
            # below the tick labels and the axis label, whatever the axes' height
            bbox_transform=offset_copy(ax.transAxes, fig=fig, y=-30, units="points"),
            ncols=min(len(names), 4),
            fontsize=7,
            frameon=False,
        )
    labels = [
        "pool (all frames)" if m == POOL else f"{method_label(m)} ({_runs(table, m)})"
        for m in methods
    ]
    axes[0].set_yticks(range(len(methods)), labels, fontsize=7)
    axes[0].set_ylim(len(methods) - 0.5, -0.5)
    fig.suptitle(
        f"{title}\nover every query round and seed; hatched and dashed: the pool's make-up",
        fontsize=9,
    )
    return fit_texts(fig)


def _stacked_bar(ax, rows: pd.DataFrame, y: float, method: str, colours: dict) -> None:
    """One method's bar on ``ax`` at ``y``: a segment per bin's share (``rows`` in the
    bins' order), the pool's hatched, each labelled where 10% or wider."""
    left = 0.0
    for _, row in rows.iterrows():
        share = 0.0 if not np.isfinite(row["share"]) else float(row["share"])
        ax.barh(
            y,
            share,
            left=left,
            height=0.75,
            color=colours[row["bin"]],
            edgecolor="white",
            hatch="//" if method == POOL else None,
            gid=f"{method}|{row['condition']}|{row['bin']}",
        )
        if share >= 0.1:
            dark = sum(colours[row["bin"]][:3]) < 1.5
            ax.text(
                left + share / 2,
                y,
                f"{100 * share:.0f}%",
                ha="center",
                va="center",
                fontsize=6.5,
                color="white" if dark else "black",
            )
        left += share


def _runs(table: pd.DataFrame, method: str) -> str:
    """'3 runs, rounds 1-2' of a method's rows."""
    row = table[table["method"] == method].iloc[0]
    n, rounds = int(row["n_runs"]), str(row["rounds"])
    return f"{n} run{'s' if n != 1 else ''}, round{'s' if '-' in rounds else ''} {rounds}"
