"""Display names, orders, colours and number formats shared by every table and figure.

A method keeps the same label, colour, marker and line style in every figure: the
paper's baselines and DUIS have fixed colours; each ablation row ``syn_X`` takes the
colour of its strategy ``X`` with a dashed line; other method names (sensitivity
sweeps) get a colour from a fixed fallback list chosen by a hash of the name.
"""

from __future__ import annotations

import re
import zlib
from numbers import Real

from spl_al.cold_start import split_start_name

METHOD_LABELS = {
    "badge": "BADGE",
    "entropy": "Entropy",
    "margin": "Margin",
    "coreset": "Coreset",
    "random": "Random",
    "syn_badge": "Syn+BADGE",
    "syn_entropy": "Syn+Entropy",
    "syn_margin": "Syn+Margin",
    "syn_coreset": "Syn+Coreset",
    "syn_random": "Syn+Random",
    "syn_diversity": "Syn+Diversity",
    # the low-budget baselines and DUIS's generic twin, after the paper's rows
    "typiclust": "TypiClust",
    "probcover": "ProbCover",
    "maxherding": "MaxHerding",
    "syn_typiclust": "Syn+TypiClust",
    "syn_probcover": "Syn+ProbCover",
    "syn_maxherding": "Syn+MaxHerding",
    "dropquery": "DropQuery",
    "syn_dropquery": "Syn+DropQuery",
    # the same, selecting on the self-supervised embedding (features: embedding)
    "typiclust_ssl": "TypiClust (SSL)",
    "probcover_ssl": "ProbCover (SSL)",
    "maxherding_ssl": "MaxHerding (SSL)",
    "syn_typiclust_ssl": "Syn+TypiClust (SSL)",
    "syn_probcover_ssl": "Syn+ProbCover (SSL)",
    "syn_maxherding_ssl": "Syn+MaxHerding (SSL)",
    "duis": "DUIS",
}

METHOD_ORDER = tuple(METHOD_LABELS)
"""Row order of the paper: baselines, ablation rows, DUIS last. Unknown names go before DUIS."""

ABLATION_ROWS = (
    "syn_badge",
    "syn_entropy",
    "syn_margin",
    "syn_coreset",
    "syn_random",
    "syn_diversity",
    "duis",
)
ABLATION_LABELS = {**METHOD_LABELS, "duis": "Full"}

LEVEL_LABELS = {"high": "High", "medium": "Medium", "low": "Low"}

METRIC_LABELS = {"accuracy": "Accuracy", "miou": "mIoU"}

PARAMETER_LABELS = {"n_cand": "N_cand", "alpha": "α", "m": "M"}

FULL_METHOD = "duis"
"""The method the experiments are about: the one both families of a budget table hold."""

METRIC_WORDS = {"accuracy": "accuracy", "miou": "mIoU"}
"""A metric's name inside a sentence (``METRIC_LABELS`` heads a column)."""

_STRATEGY_COLORS = {
    "random": "#7f7f7f",
    "entropy": "#1f77b4",
    "margin": "#ff7f0e",
    "coreset": "#2ca02c",
    "badge": "#9467bd",
    "diversity": "#8c564b",
    "typiclust": "#e377c2",
    "probcover": "#17becf",
    "maxherding": "#bcbd22",
    "dropquery": "#393b79",
}
PALETTE = {
    **_STRATEGY_COLORS,
    **{f"syn_{k}": v for k, v in _STRATEGY_COLORS.items()},
    **{f"{k}_ssl": v for k, v in _STRATEGY_COLORS.items()},
    **{f"syn_{k}_ssl": v for k, v in _STRATEGY_COLORS.items()},
    "duis": "#d62728",
}
"""Fixed colour of every known method; ``syn_X`` shares the colour of ``X``."""

MARKERS = {
    "random": "o",
    "entropy": "s",
    "margin": "^",
    "coreset": "D",
    "badge": "v",
    "diversity": "P",
    "duis": "*",
}

FALLBACK_COLORS = (
    # Chosen away from the palette's hues so a sweep never looks like a baseline.
    "#17becf",
    "#bcbd22",
    "#e377c2",
    "#393b79",
    "#637939",
    "#e7ba52",
    "#7b4173",
    "#008080",
    "#222222",
    "#9edae5",
)


def method_label(method: str, labels: dict[str, str] | None = None) -> str:
    """Display name of a method; unknown names are shown as they are. A cold-start arm
    ``X_from_S`` reads "X from S" (its round 0 chosen by S)."""
    labels = labels or METHOD_LABELS
    if method not in labels and (arm := split_start_name(method)):
        return f"{labels.get(arm[0], arm[0])} from {labels.get(arm[1], arm[1])}"
    return labels.get(method, method)


def _natural_key(name: str) -> tuple:
    # "duis_ncand40" before "duis_ncand120": compare digit runs as numbers.
    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name))


def method_sort_key(method: str) -> tuple:
    """Sort key giving the paper's order; unknown names sit before DUIS, naturally sorted."""
    if method in METHOD_ORDER:
        pos = METHOD_ORDER.index(method)
        return (pos if method != FULL_METHOD else len(METHOD_ORDER) + 1, ())
    return (len(METHOD_ORDER), _natural_key(method))


def ordered_methods(methods) -> list[str]:
    """Distinct methods in display order."""
    return sorted(set(methods), key=method_sort_key)


def method_style(method: str) -> dict:
    """Marker and line style of a method: dashed for ablation rows ``syn_X``."""
    base = method.removeprefix("syn_")
    return {
        "marker": MARKERS.get(base, "o"),
        "linestyle": "--" if method.startswith("syn_") else "-",
    }


def method_colors(methods) -> dict[str, str]:
    """Colour of each method: the fixed palette, else a hashed fallback colour.

    The fallback index is crc32(name) (stable across processes), probed forward so
    that two unknown methods of the same figure never share a colour while any is free.
    """
    colors = {m: PALETTE[m] for m in methods if m in PALETTE}
    taken = set()
    for method in sorted(set(methods) - set(colors), key=_natural_key):
        start = zlib.crc32(method.encode())
        for k in range(len(FALLBACK_COLORS)):
            color = FALLBACK_COLORS[(start + k) % len(FALLBACK_COLORS)]
            if color not in taken or len(taken) >= len(FALLBACK_COLORS):
                break
        taken.add(color)
        colors[method] = color
    return colors


def format_ratio(ratio: float, decimals: int = 1) -> str:
    """Labeling ratio as the paper prints it: 0.02857 -> '2.9%'."""
    return f"{100.0 * ratio:.{decimals}f}%"


def unique_ratio_labels(ratios, decimals: int = 1) -> list[str]:
    """Labels of distinct ratios, with more decimals where two would otherwise print alike."""
    ratios = list(ratios)
    for d in range(decimals, decimals + 4):
        labels = [format_ratio(r, d) for r in ratios]
        if len(set(labels)) == len(set(ratios)):
            return labels
    return labels


def format_number(x) -> str:
    """A swept parameter value as a short label: 40 -> '40', 0.25 -> '0.25'."""
    if isinstance(x, bool) or not isinstance(x, Real):
        return str(x)
    return f"{float(x):g}"
