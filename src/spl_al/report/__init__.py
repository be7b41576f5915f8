"""Tables and figures of the paper from per-round metrics records of active-learning runs.

Flow: ``load_records(paths)`` (or ``records_frame(records)``) gives one row per round
record; the table functions turn it into long-form frames (one row per cell, CSV as the
source of truth) that ``write_table`` writes as CSV + Markdown + LaTeX; ``plot_curves``
draws metric vs labeling ratio; ``summary`` gives per-method curve area and final values.
pandas is needed; matplotlib is imported only when a figure is made.
"""

from spl_al.report.curves import (
    curves_figure,
    level_curves_figure,
    plot_curves,
    plot_level_curves,
    save_figure,
)
from spl_al.report.display import (
    ABLATION_LABELS,
    ABLATION_ROWS,
    METHOD_LABELS,
    METHOD_ORDER,
    PALETTE,
    format_ratio,
    method_colors,
)
from spl_al.report.records import (
    LEVELS,
    framework_of,
    load_records,
    one_dataset,
    records_frame,
    round_for_budget,
    round_record,
    trained_at,
    validate_record,
)
from spl_al.report.render import latex_escape, render_latex, render_markdown
from spl_al.report.stats import curve_area
from spl_al.report.summary import summary
from spl_al.report.tables import ablation_table, budget_table, level_table, sensitivity_table
from spl_al.report.writers import read_table, write_json, write_table

__all__ = [
    "ABLATION_LABELS",
    "ABLATION_ROWS",
    "LEVELS",
    "METHOD_LABELS",
    "METHOD_ORDER",
    "PALETTE",
    "ablation_table",
    "budget_table",
    "curve_area",
    "curves_figure",
    "format_ratio",
    "framework_of",
    "latex_escape",
    "level_curves_figure",
    "level_table",
    "load_records",
    "method_colors",
    "one_dataset",
    "plot_curves",
    "plot_level_curves",
    "read_table",
    "records_frame",
    "render_latex",
    "render_markdown",
    "round_for_budget",
    "round_record",
    "save_figure",
    "sensitivity_table",
    "summary",
    "trained_at",
    "validate_record",
    "write_json",
    "write_table",
]
