"""The plotting kit every picture and chart of spl-al is drawn with.

- Figures: ``figure`` for pictures of depth images (100 dpi, saved as PNG by
  ``save_png``: dataset sheets, labeling batches); ``new_figure`` for charts (an Agg
  canvas attached, saved at the caller's dpi: curves, statistics, robustness maps).
  ``fit_texts`` wraps every title and axis label that would reach past the figure's
  edges (``save_png`` and every chart call it), and ``texts_outside`` names those that
  still do (the tests' check).
- Depth images: ``depth_range`` (the colour range of a sample: 2nd to 98th percentile
  of its first image with a finite value), ``show_image`` (an image without ticks,
  voids black), ``condition_title`` (a condition as a short title).
- Colour maps: ``depth_cmap`` (turbo, voids black), ``label_cmap`` and
  ``class_colours`` (one colour per class, the same in pictures, ``classes.csv`` and
  Label Studio).

matplotlib is imported inside each function, through its object API (no pyplot state,
no global backend change), so importing this module costs nothing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write

_LEVEL_TAG = {"high": "H", "medium": "M", "low": "L", "unknown": "?"}


def figure(width_in: float, height_in: float):
    """A picture's figure: 100 dpi, constrained layout."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), dpi=100, layout="constrained")


def new_figure(width_in: float, height_in: float):
    """A chart's figure: constrained layout, with an Agg canvas to draw on."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_png(fig, path) -> Path:
    """Write ``fig`` to ``path`` as PNG at its own dpi, atomically, its titles and
    labels fitted to it first (``fit_texts``)."""
    fit_texts(fig)
    return atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))


def _texts(fig) -> list:
    """The titles and labels of ``fig``: its own texts (suptitle included), each Axes'
    three titles and two axis labels (colour bars' too), and figure legends' entries."""
    texts = list(fig.texts)
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
    for legend in fig.legends:
        texts += list(legend.get_texts())
    return [t for t in texts if t.get_visible() and t.get_text().strip()]


def texts_outside(fig, tolerance_px: float = 1.0) -> list[str]:
    """The titles and labels of ``fig`` that reach past its edges once it is laid out
    (each as its text): what would be cut off when it is saved."""
    fig.draw_without_rendering()
    edge = fig.bbox
    out = []
    for text in _texts(fig):
        box = text.get_window_extent()
        if (
            box.x0 < edge.x0 - tolerance_px
            or box.x1 > edge.x1 + tolerance_px
            or box.y0 < edge.y0 - tolerance_px
            or box.y1 > edge.y1 + tolerance_px
        ):
            out.append(text.get_text())
    return out


def fit_texts(fig, margin_px: float = 4.0, tries: int = 4):
    """Wrap (``textwrap``, at word boundaries) every title and label of ``fig`` that
    reaches past the figure's left or right edge (top or bottom for a vertical label),
    at the width its place leaves it, then lay the figure out again; a few rounds, as
    the layout moves with the wrapped texts. The line breaks a text already has are
    kept. Returns ``fig``."""
    import textwrap

    original: dict = {}
    for _ in range(tries):
        fig.draw_without_rendering()
        edge = fig.bbox
        wrapped = False
        for text in _texts(fig):
            box = text.get_window_extent()
            vertical = abs(text.get_rotation() % 180 - 90) < 45
            lo, hi, along = (
                (box.y0 - edge.y0, edge.y1 - box.y1, box.height)
                if vertical
                else (box.x0 - edge.x0, edge.x1 - box.x1, box.width)
            )
            if min(lo, hi) >= -0.5 or along <= 0:
                continue
            # the room it has where it is anchored: centred texts grow both ways
            centre = along / 2 + lo
            room = 2 * min(centre, along / 2 + hi) - 2 * margin_px
            align = text.get_verticalalignment() if vertical else text.get_horizontalalignment()
            if align in ("left", "bottom"):
                room = along + hi - margin_px
            elif align in ("right", "top"):
                room = along + lo - margin_px
            source = original.setdefault(text, text.get_text())
            longest = max(len(line) for line in text.get_text().split("\n"))
            width = max(8, int(longest * max(room, 1.0) / along))
            if width >= longest:
                width = longest - 1
            text.set_text(
                "\n".join(
                    textwrap.fill(line, width, break_long_words=False) or line
                    for line in source.split("\n")
                )
            )
            wrapped = True
        if not wrapped:
            break
    return fig


def depth_cmap():
    """Depth colours: turbo (near blue to far red), voids (NaN) black."""
    import matplotlib

    return matplotlib.colormaps["turbo"].with_extremes(bad="black")


def label_cmap(n_classes: int):
    """One colour per class index (tab10, or tab20 beyond 10 classes), NaN black."""
    import matplotlib
    from matplotlib.colors import ListedColormap

    base = matplotlib.colormaps["tab10" if n_classes <= 10 else "tab20"]
    return ListedColormap([base(i % base.N) for i in range(n_classes)]).with_extremes(bad="black")


def class_colours(classes) -> list[str]:
    """The colour of each class (hex), as in classes.csv and the pictures."""
    from matplotlib.colors import to_hex

    cmap = label_cmap(len(classes))
    return [to_hex(cmap(k)) for k in range(len(classes))]


def depth_range(*images) -> tuple[float, float]:
    """(low, high) colour range: the 2nd and 98th percentile of the first image that
    has a finite value (None skipped); (0, 1) when none has."""
    for img in images:
        if img is not None and np.isfinite(img).any():
            lo, hi = np.nanpercentile(img, [2, 98])
            return float(lo), float(max(hi, lo + 1e-3))
    return 0.0, 1.0


def show_image(ax, image, *, vmin, vmax, title=None, cmap=None) -> None:
    """Draw ``image`` on ``ax`` from ``vmin`` to ``vmax`` (default colours: depth), no
    ticks, pixels unsmoothed, with a small ``title``."""
    ax.imshow(image, cmap=cmap or depth_cmap(), vmin=vmin, vmax=vmax, interpolation="nearest")
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=7, pad=2)


def condition_title(msppp, sbr, level=None) -> str:
    """A short title of a condition, e.g. "M 5 ppp, SBR 1" (the level's letter if given)."""
    tag = f"{_LEVEL_TAG.get(str(level), '')} " if level is not None else ""
    if not np.isfinite(msppp):
        return f"{tag}condition unknown".strip()
    return f"{tag}{msppp:.3g} ppp, SBR {sbr:.3g}"
