"""What a run gives of a dataset in one framework: the files `snakemake all` asks for.

One function for every framework (``spl_al.frameworks``): the two frameworks' outputs
differ only where their kinds do (the subfolder, the experiments they run). The
workflow's ``all`` adds what belongs to the dataset rather than to a framework
(pictures, robustness maps, model cards, exports, encoder cards).
"""

from __future__ import annotations

from spl_al.data.sources import has_levels
from spl_al.experiment.plan import dataset_runs
from spl_al.frameworks import get_framework
from spl_al.layout import figure_file, table_file
from spl_al.report.table_kinds import table_names

TABLE_FORMATS = ("csv", "md", "tex")
FIGURE_FORMATS = ("png", "pdf")
STATISTICS = ("comparisons", "claims", "decomposition")
"""The stats job's tables (CSV and Markdown), made wherever a table is."""


def framework_outputs(config: dict, dataset: str, framework, *, results) -> list[str]:
    """The tables, summary, statistics and budget figures of ``dataset``'s experiments
    in ``framework`` (a kind or its name), under ``results``: nothing when it runs none
    there. The per-level table and curves, and the conditions of the queried frames
    (``batch_conditions``: its CSV and figure), only for images with MSPPP levels; the
    forest plot of DUIS − each method (``differences``) with the statistics."""
    kind = get_framework(framework)
    entry = config["datasets"][dataset]
    experiments = kind.experiments(entry)
    levels = has_levels(entry)
    base = kind.folder(results, dataset)
    tables = table_names(experiments, has_levels=levels)
    out = [table_file(base, f"{t}.{ext}") for t in tables for ext in TABLE_FORMATS]
    if dataset_runs(config, dataset, kind):
        out.append(table_file(base, "summary.json"))
    if tables:
        out += [table_file(base, f"{name}.{ext}") for name in STATISTICS for ext in ("csv", "md")]
    if "budget" in experiments:
        figures = ["curves", "aubc", "differences", *(["level_curves"] if levels else [])]
        if levels:
            figures.append("batch_conditions")
            out.append(table_file(base, "batch_conditions.csv"))
        out += [figure_file(base, f"{f}.{ext}") for f in figures for ext in FIGURE_FORMATS]
    return out
