"""Report steps of the workflow: the paper's tables, curves, summaries and paired
statistics from the per-round metrics records (pandas and matplotlib, no torch)."""

from __future__ import annotations

from spl_al.atomic import atomic_write, atomic_write_text, read_json, write_json
from spl_al.config import dataset_precision, write_config
from spl_al.frameworks import get_framework
from spl_al.training.compute import Compute


def framework_notes(df) -> list[str]:
    """The notes a table, figure or summary of these records carries for its framework
    (``FrameworkKind.note``): what it is, and where encoders are its statistics' unit,
    the encoders its runs read (how many, seeds per encoder, which are doubtful)."""
    # pandas on demand (importing this module does not load it)
    from spl_al.report import framework_of

    kind = get_framework(framework_of(df))
    if not kind.note:
        return []
    return [kind.note, *(encoder_notes(df) if kind.unit == "encoder" else [])]


def encoder_notes(df) -> list[str]:
    """'12 encoders x 10 seeds (intervals and tests over the encoders' means)', and
    the doubtful encoders of the records' runs, if any."""
    known = df[df["encoder"] >= 0] if "encoder" in df else df.iloc[:0]
    if known.empty:
        return []
    per = known.groupby("encoder")["seed"].nunique()
    seeds = f"{per.iloc[0]}" if per.nunique() == 1 else f"{per.min()}-{per.max()}"
    k = len(per)
    notes = [
        f"{k} encoder{'s' if k > 1 else ''} (seed {_ranges(per.index)}) x {seeds} seeds "
        f"(intervals and tests over the encoders' means)"
    ]
    doubtful = sorted(known.loc[known["encoder_health"] == "doubtful", "encoder"].unique())
    if doubtful:
        notes.append(
            f"doubtful encoder{'s' if len(doubtful) > 1 else ''} (seed "
            f"{', '.join(str(int(e)) for e in doubtful)}): loss or effective rank near "
            "collapse, docs/method.md"
        )
    return notes


def _ranges(values) -> str:
    """'0-11', '0-3, 7, 9-10' of sorted integers."""
    values = sorted(int(v) for v in values)
    parts, start = [], values[0]
    for prev, cur in zip(values, [*values[1:], None], strict=True):
        if cur is None or cur != prev + 1:
            parts.append(f"{start}-{prev}" if prev > start else str(start))
            start = cur
    return ", ".join(parts)


def make_table(
    metrics_paths, kind: str, *, experiments: dict, sweeps: dict, out_stem, notes=()
) -> None:
    """The table of kind ``kind`` (``spl_al.report.table_kinds``) as CSV + MD + TeX;
    ``notes`` (e.g. ``spl_al.config.training_notes``) go into its caption."""
    # pandas on demand (importing this module does not load it)
    from spl_al import report
    from spl_al.report.table_kinds import TableContext, table_kind

    table = table_kind(kind)
    df = report.load_records(metrics_paths)
    caption = table.caption(df["metric"].iloc[0], experiments[kind])
    notes = [*framework_notes(df), *notes]
    if notes:
        caption += f" ({'; '.join(str(n) for n in notes)})"
    frame = table.build(df, TableContext(experiments, sweeps))
    report.write_table(frame, out_stem, caption=caption)


def make_curves(
    metrics_paths, methods, *, png, pdf, title: str, per_level: bool = False, families=None
) -> None:
    """Budget curves with ±std bands: overall (one panel per family of the budget
    experiment when it has a matched family: ``families``, {"paper": [...],
    "matched": [...]}), or one panel per MSPPP level."""
    # pandas on demand (importing this module does not load it)
    from spl_al import report

    df = report.load_records(metrics_paths)
    df = df[df["method"].isin(methods)]
    kind = get_framework(report.framework_of(df))
    if kind.short:
        title = f"{title}, {kind.name} framework ({kind.short})"
    if per_level:
        report.plot_level_curves(df, png, path_pdf=pdf, methods=methods, title=title)
        return
    panels = None
    if families and len(families.get("matched", [])) > 1 and len(families.get("paper", [])) > 1:
        paper = [m for m in methods if m in families["paper"]]
        matched = [m for m in methods if m in families["matched"]]
        panels = {"baselines on observed images": paper, "matched training": matched}
    report.plot_curves(df, png, path_pdf=pdf, methods=methods, title=title, panels=panels)


def make_summary(metrics_paths, out_path, notes=(), families=None) -> dict:
    """Per method: area under the budget curve and final value (JSON), with ``notes``
    (one sentence each, e.g. why per-level results are missing) and the budget
    experiment's ``families`` ({"paper": [...], "matched": [...]}, when given)."""
    # pandas on demand (importing this module does not load it)
    from spl_al import report

    df = report.load_records(metrics_paths)
    result = report.summary(df)
    result["framework"] = report.framework_of(df)
    result["notes"] = [*framework_notes(df), *(str(n) for n in notes)]
    if families:
        result["families"] = {k: list(v) for k, v in families.items()}
    write_json(result, out_path)
    return result


def make_stats(
    metrics_paths, experiments: dict, sweeps: dict, *, out: dict, claim_notes=None
) -> None:
    """Paired statistics of a dataset: ``comparisons``, ``claims`` and the decomposition
    of DUIS − Random (CSV + Markdown), the AUBC chart and the differences' forest plot.
    ``experiments``: as run (``spl_al.experiment.plan.experiments_of``: the budget's
    ``selection``). ``out``:
    paths by name (comparisons_csv, comparisons_md, claims_csv, claims_md,
    decomposition_csv, decomposition_md, aubc_png, aubc_pdf, differences_png,
    differences_pdf: the forest plot of DUIS − each budget method on the AUBC,
    ``spl_al.report.stat_figures.differences_figure``). ``claim_notes``: claim id
    -> sentence added to its reason (``spl_al.report.claims.encoder_claim_notes``).
    Claims are judged on the comparisons as written, so the two files cannot disagree."""
    # pandas on demand (importing this module does not load it)
    import pandas as pd

    from spl_al import report
    from spl_al.report.claims import (
        at_precision,
        aubc_differences,
        claims,
        render_claims_markdown,
    )
    from spl_al.report.comparisons import render_comparisons_markdown
    from spl_al.report.decomposition import decomposition, render_decomposition_markdown
    from spl_al.report.stat_figures import aubc_figure, differences_figure
    from spl_al.report.stats import query_rounds
    from spl_al.report.table_kinds import comparisons

    df = report.load_records(metrics_paths)
    frame = comparisons(df, experiments, sweeps)
    atomic_write(out["comparisons_csv"], lambda tmp: frame.to_csv(tmp, index=False))
    stored = pd.read_csv(out["comparisons_csv"])
    atomic_write_text(out["comparisons_md"], render_comparisons_markdown(stored))
    budget_exp = experiments.get("budget", {})
    in_paper = experiments.get("levels", {}).get("in_paper", True)
    verdicts = claims(
        stored,
        budget_exp.get("selection"),
        levels_in_paper=in_paper,
        framework=report.framework_of(df),
        notes=claim_notes,
    )
    verdicts = at_precision(verdicts, report.trained_at(df))  # decided in fp32 alone
    verdicts["framework"] = report.framework_of(df)
    atomic_write(out["claims_csv"], lambda tmp: verdicts.to_csv(tmp, index=False))
    name = str(df["dataset"].iloc[0])
    atomic_write_text(out["claims_md"], render_claims_markdown(verdicts, dataset=name))
    parts = decomposition(df, int(budget_exp.get("rounds", df["round"].max() + 1)))
    atomic_write(out["decomposition_csv"], lambda tmp: parts.to_csv(tmp, index=False))
    atomic_write_text(out["decomposition_md"], render_decomposition_markdown(parts))
    methods = budget_exp.get("methods")
    budget = df if methods is None else df[df["method"].isin(methods)]
    budget = query_rounds(budget, budget_exp.get("rounds"))
    report.save_figure(aubc_figure(budget, methods), out["aubc_png"], out["aubc_pdf"])
    diffs = aubc_differences(stored, budget_exp.get("selection"), verdicts)
    standin = ", synthetic stand-in" if bool(df["synthetic_standin"].any()) else ""
    figure = differences_figure(
        diffs, dataset=name, metric=str(df["metric"].iloc[0]), note=standin + _framework_words(df)
    )
    report.save_figure(figure, out["differences_png"], out["differences_pdf"])


def _framework_words(df) -> str:
    """', embedding framework (linear probe)' of records in a framework with a short name."""
    # pandas on demand (importing this module does not load it)
    from spl_al import report

    kind = get_framework(report.framework_of(df))
    return f", {kind.name} framework ({kind.short})" if kind.short else ""


def make_batch_conditions(
    dataset_path,
    *,
    methods,
    rounds: int,
    out: dict,
    title: str,
    framework: str,
    labeled_paths=(),
    labeled_runs=(),
    runs_paths=(),
) -> None:
    """The MSPPP levels and SBRs of the frames each budget method queried over every
    query round (rounds 1 to ``rounds`` - 1) and seed, against the training pool's
    (``spl_al.report.conditions``): ``out["csv"]`` and the figure ``out["png"]``,
    ``out["pdf"]``.

    The labeled sets: in the supervised framework each run's files, round 0 first
    (``labeled_paths``, in the order of ``labeled_runs``: [method, seed, files] each);
    in the embedding framework the methods' runs files (``runs_paths``), whose records
    hold each round's ``pool_indices``. ``title``: the dataset's name."""
    # pandas and matplotlib on demand (importing this module does not load them)
    from spl_al.data.dataset import load_conditions
    from spl_al.pool import read_labeled
    from spl_al.report.conditions import batch_conditions, batch_conditions_figure, queried_frames
    from spl_al.report.curves import save_figure

    sets = []
    paths = iter([labeled_paths] if isinstance(labeled_paths, str) else labeled_paths)
    for method, seed, n_files in labeled_runs:
        for r in range(int(n_files)):
            sets.append((method, int(seed), r, read_labeled(next(paths))))
    for path in [runs_paths] if isinstance(runs_paths, str) else runs_paths:
        for record in read_json(path):
            if record["method"] in methods and int(record["round"]) < int(rounds):
                sets.append(
                    (record["method"], record["seed"], record["round"], record["pool_indices"])
                )
    arrays, meta = load_conditions(dataset_path)
    train = arrays["split"] == "train"
    queried = queried_frames(sets)
    table = batch_conditions(queried, arrays["level"][train], arrays["sbr"][train], methods)
    atomic_write(out["csv"], lambda tmp: table.to_csv(tmp, index=False))
    kind = get_framework(framework)
    where = f", {kind.name} framework ({kind.short})" if kind.short else ""
    standin = ", synthetic stand-in" if meta.get("synthetic_standin") else ""
    figure = batch_conditions_figure(
        table,
        title=f"{title}{standin}{where}: conditions of the queried frames against the pool's",
    )
    save_figure(figure, out["png"], out["pdf"])


def write_run_config(config: dict, out_path) -> dict:
    """Write the run's effective configuration with ``precision_used``: per dataset, the
    precision its models run at on the configured device (what ``precision: auto``
    resolved to here). Returns that mapping."""
    # torch on demand (importing this module does not load it)
    from spl_al.models import model_class

    used = {}
    for name, entry in config["datasets"].items():
        cls = model_class(entry["task"], entry["train"].get("model", {}).get("arch"))
        compute = Compute(config.get("device", "auto"), precision=dataset_precision(config, name))
        used[name] = compute.resolved(cls).precision
    write_config({**config, "precision_used": used}, out_path)
    return used
