"""The docs pages' generated results from a results folder.

Reads what ``snakemake all`` writes per dataset under ``RESULTS/{dataset}/tables``
(budget, levels, ablation, sensitivity, claims and comparisons as CSV and Markdown,
summary.json, robustness_diff.csv), copies the key figures into docs/figures/ as
``{dataset}_{name}.png`` and rewrites docs/results.md between ``<!-- results:start -->``
and ``<!-- results:end -->``: one AUBC table of every dataset (``aubc_overview``), then
per dataset every table, the area under the budget curve, the claims' verdicts (each
claim's reason and evidence folded), the resolved paired comparisons and the figures.

A second run gets its own page: ``--page decisive`` writes docs/decisive.md's
``results`` block and its figures as ``decisive_{dataset}_{name}.png``, so the default
run's stay as they are. The README holds no results of its own but the answer table
(``spl_al.docs.answer``), and links these pages.

Text outside the markers (the hand-written reading of a run, the statistics section)
is left untouched. With ``--keep-absent`` the datasets the folder does not hold keep
what the block said of them (their section and AUBC column), so runs of one dataset
each, made in different folders or on different days, share a page. Run it from the
repository root:

    python -m spl_al.docs.results_blocks results/
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import math
import shutil
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

import yaml

from spl_al.atomic import atomic_write_text
from spl_al.docs.markers import block, replace_block
from spl_al.frameworks import DEFAULT, EMBEDDING, framework_names, get_framework
from spl_al.layout import figure_file, table_file
from spl_al.report.claims import AGAINST, CONTRADICTED, SUPPORTED, VERDICTS
from spl_al.report.display import METRIC_WORDS
from spl_al.report.summary import aubc_text
from spl_al.report.table_kinds import TABLE_KINDS
from spl_al.report.writers import read_rows

COMMAND = "python -m spl_al.docs.results_blocks"
BLOCK = "results"
DEFAULT_CONFIG = Path(__file__).resolve().parents[3] / "config" / "config.yaml"
"""The checkout's default config, whose datasets come first on a page, in its order."""
# results/{dataset}/figures/{source}.png -> docs/figures/{dataset}_{name}.png
FIGURES = (
    ("curves", "budget", "budget curves, mean ± std over seeds"),
    ("level_curves", "levels", "budget curves per MSPPP level"),
    ("aubc", "aubc", "area under the budget curve per method: every seed, mean, 95% interval"),
    ("differences", "differences", "DUIS − each method, AUBC: paired 95% intervals, verdicts"),
    ("batch_conditions", "batch_conditions", "MSPPP and SBR make-up of each method's queries"),
    ("robustness_diff", "robustness_diff", "DUIS minus the best baseline over MSPPP x SBR"),
)
OVERVIEW_TITLE = "**Area under the budget curve over the query rounds** (%) [95% CI]:"
"""The line that opens a page's AUBC overview table (``aubc_overview``)."""
# claims.csv's verdicts a sentence names one by one (all are counted, in VERDICTS' order)
NAMED = (SUPPORTED, CONTRADICTED, AGAINST)


def _table(results: Path, dataset: str, name: str) -> Path:
    """A table of a dataset in a results folder (``spl_al.layout``)."""
    return Path(table_file(results / dataset, name))


def _figure(results: Path, dataset: str, name: str) -> Path:
    return Path(figure_file(results / dataset, name))


def _in_order(names) -> list[str]:
    """``names`` in the default config's order first (``DEFAULT_CONFIG``: the datasets
    a user meets first), then the others alphabetically."""
    names = set(names)
    order = [d for d in default_datasets() if d in names]
    return order + sorted(names - set(order))


@functools.cache
def default_datasets() -> tuple[str, ...]:
    """The datasets the default config defines, in its order (none outside a checkout)."""
    if not DEFAULT_CONFIG.is_file():
        return ()
    return tuple(yaml.safe_load(DEFAULT_CONFIG.read_text()).get("datasets") or {})


def datasets(results: Path) -> list[str]:
    """Datasets of a results folder: the folders that hold tables/budget.csv."""
    return _in_order(p.parent.parent.name for p in results.glob(table_file("*", "budget.csv")))


def _named_chunks(block: str, opens) -> dict[str, str]:
    """{name: its lines} of ``block``, cut where ``opens(line)`` gives a name (a chunk
    starts) or "" (the chunk ends); None continues the current one."""
    chunks: dict[str, list[str]] = {}
    current = None
    for line in block.split("\n"):
        name = opens(line)
        if name is not None:
            current = name or None
            if current:
                chunks[current] = []
        if current is not None:
            chunks[current].append(line)
    return {name: "\n".join(lines).rstrip() for name, lines in chunks.items()}


def page_sections(block: str) -> dict[str, str]:
    """{dataset: its section} of a generated page block: the text from each
    ``## dataset`` line to the next (the block's first comment line left out)."""
    return _named_chunks(block, lambda line: line[3:].strip() if line.startswith("## ") else None)


Column = tuple[str, dict[str, str], dict[str, str]]
"""One dataset's column of an AUBC overview: (header, {row label: cell}, {row label:
family key})."""


def overview_columns(block: str) -> dict[str, Column]:
    """{dataset: its column} of the AUBC overview table of a generated page block ({}
    for a block without one: a page's dataset tables are not the overview)."""
    if OVERVIEW_TITLE not in block:
        return {}
    lines = []
    # the contiguous table that starts "| Method |" after the overview's title
    for line in block.split(OVERVIEW_TITLE, 1)[1].split("\n"):
        if line.startswith("| Method |") or (lines and line.startswith("|")):
            lines.append(line)
        elif lines:
            break
    lines = [line for line in lines if line.startswith("| ")]  # the rule line goes
    if not lines:
        return {}
    headers = [c.strip() for c in lines[0].strip("|").split("|")][1:]
    names = [h.split(" (")[0] for h in headers]
    columns: dict[str, Column] = {n: (h, {}, {}) for n, h in zip(names, headers, strict=True)}
    family = "paper"
    for line in lines[1:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0].startswith("*") and cells[0].endswith("*"):
            family = "matched" if cells[0].startswith("*matched") else "paper"
            continue
        for name, cell in zip(names, cells[1:], strict=False):
            if cell != "-":
                columns[name][1][cells[0]] = cell
                columns[name][2][cells[0]] = family
    return columns


def _num(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _cell(row: dict, decimals: int = 1) -> str:
    """A table cell as the report renders it: mean ± std, bold leader, dagger tie."""
    mean, std = _num(row["mean"]), _num(row["std"])
    if math.isnan(mean):
        return "-"
    text = (
        f"{mean:.{decimals}f}" if math.isnan(std) else f"{mean:.{decimals}f} ± {std:.{decimals}f}"
    )
    if str(row.get("partial", "")).lower() == "true":
        text += f" (n={row['n_seeds']})"
    mark = row.get("mark", "")
    return f"**{text}**" if mark == "bold" else f"{text} †" if mark == "tie" else text


def _summary(results: Path, dataset: str) -> dict:
    path = _table(results, dataset, "summary.json")
    return json.loads(path.read_text()) if path.exists() else {}


def _metric(budget: list[dict]) -> str:
    name = budget[0].get("metric", "") if budget else ""
    return METRIC_WORDS.get(name, name)


def _is_standin(budget: list[dict]) -> bool:
    return any(str(r.get("synthetic_standin", "")).lower() == "true" for r in budget)


def _span(summary: dict, methods) -> str:
    """The rounds and ratios the AUBC of ``methods`` covers, when they share them."""
    spans = {summary.get("methods", {}).get(m, {}).get("aubc", {}).get("span") for m in methods}
    spans.discard(None)
    return f" {spans.pop()}" if len(spans) == 1 else ""


def _families(summary: dict, methods: list[str]) -> list[tuple[str, list[str]]]:
    """(heading, methods) of the budget table's families, matched training first; one
    group of every method when the run has no matched family."""
    families = summary.get("families") or {}
    matched = [m for m in families.get("matched", []) if m in methods]
    paper = [m for m in families.get("paper", []) if m in methods and m not in matched]
    if len(matched) < 2:
        return [("", methods)]
    rest = [m for m in methods if m not in matched and m not in paper]
    return [
        ("matched training (every method trained on the variants)", matched),
        ("baselines on observed images only (as the paper trains them)", paper + rest),
    ]


def compact_table(results: Path, dataset: str) -> list[str]:
    """Budget columns per method and the AUBC over the query rounds with its 95%
    interval, as Markdown lines; the matched-training family first, then the paper's
    comparison (DUIS in both)."""
    budget = read_rows(_table(results, dataset, "budget.csv"))
    summary = _summary(results, dataset)
    scale = _num(budget[0].get("scale", 100)) if budget else 100.0
    cols = sorted({(int(r["col_pos"]), r["col"]) for r in budget})
    rows = sorted({(int(r["row_pos"]), r["row"], r["method"]) for r in budget})
    label = {method: row for _, row, method in rows}
    cells = {(r["row"], r["col"]): r for r in budget}
    methods = [method for _, _, method in rows]
    lines = [
        "| Method | "
        + " | ".join(c for _, c in cols)
        + f" | AUBC{_span(summary, methods)} [95% CI] |",
        "|:---|" + "---:|" * len(cols) + "---:|",
    ]
    for heading, family in _families(summary, methods):
        if heading:
            lines.append(f"| *{heading}* |" + " |" * (len(cols) + 1))
        for method in family:
            row = label[method]
            values = [_cell(cells[(row, c)]) if (row, c) in cells else "-" for _, c in cols]
            aubc = aubc_text(summary, method, scale)
            lines.append(f"| {row} | " + " | ".join(values) + f" | {aubc} |")
    return lines


def claims(results: Path, dataset: str) -> list[dict]:
    """The rows of a dataset's claims.csv (none when the run made no claims)."""
    path = _table(results, dataset, "claims.csv")
    return read_rows(path) if path.exists() else []


def verdict_line(rows: list[dict]) -> str:
    """One sentence per source (the paper's claims, then the extensions): how many
    claims got each verdict, naming the supported and contradicted ones (and those
    every seed goes against, below 6 seeds)."""
    if not rows:
        return "No claim is checked on this dataset."
    sentences = []
    for source, title in (("paper", "The paper's claims"), ("extension", "Extensions")):
        part = [r for r in rows if (r.get("source") or "paper") == source]
        if not part:
            continue
        counts = {v: sum(r["verdict"] == v for r in part) for v in VERDICTS}
        parts = [f"{counts[v]} {v}" for v in VERDICTS if counts[v]]
        text = f"{title}: {', '.join(parts)} (of {len(part)})."
        for verdict in NAMED:
            named = [r["claim"].rstrip(".") for r in part if r["verdict"] == verdict]
            if named:
                text += f" {verdict[:1].upper()}{verdict[1:]}: " + "; ".join(named) + "."
        sentences.append(text)
    return " ".join(sentences)


def _seeds(summary: dict, budget: list[dict]) -> str:
    """The runs' units in words: '3 seeds', or '12 encoders x 10 seeds' where the runs
    read several encoders (``summary.json``'s ``encoders``: the statistics' units)."""
    encoders = summary.get("encoders") or []
    if len(encoders) > 1:
        per = sorted({len(e.get("run_seeds") or []) for e in encoders})
        each = str(per[0]) if len(per) == 1 else f"{per[0]}-{per[-1]}"
        return f"{len(encoders)} encoders x {each} seeds"
    n = summary.get("n_seeds")
    if n is None and budget:
        n = max(int(_num(r.get("n_seeds")) or 0) for r in budget)
    return f"{n} seed{'s' if n != 1 else ''}" if n is not None else "seeds"


def _heading(results: Path, dataset: str) -> str:
    budget = read_rows(_table(results, dataset, "budget.csv"))
    summary = _summary(results, dataset)
    text = f"{_metric(budget)} (%), mean ± std over {_seeds(summary, budget)}"
    if _is_standin(budget):
        text += "; synthetic stand-in for real data"
    return text


def _column(results: Path, dataset: str) -> Column:
    """A dataset's column of the AUBC overview, rows in its families' order."""
    budget = read_rows(_table(results, dataset, "budget.csv"))
    summary = _summary(results, dataset)
    scale = _num(budget[0].get("scale", 100)) if budget else 100.0
    order = sorted({(int(r["row_pos"]), r["row"], r["method"]) for r in budget})
    methods = [method for _, _, method in order]
    label = {method: row for _, row, method in order}
    groups = [family for _, family in _families(summary, methods)]
    keys = ["matched", "paper"] if len(groups) == 2 else ["paper"]
    family_of = {label[m]: key for key, group in zip(keys, groups, strict=True) for m in group}
    cells = {label[m]: aubc_text(summary, m, scale) for group in groups for m in group}
    span = _span(summary, methods).strip()
    header = f"{dataset} ({_metric(budget)}, {_seeds(summary, budget)})"
    return (f"{header}: {span}" if span else header), cells, family_of


def aubc_overview(results: Path, kept: dict[str, Column] | None = None) -> list[str]:
    """One Markdown table of every dataset's AUBC over its query rounds per method, with
    the 95% interval (a column per dataset, its range and seeds in the header); the
    matched-training family first, each method on one row; "-" where a dataset's run
    has no such method. ``kept``: columns of datasets the folder lacks (from
    ``overview_columns``), placed in dataset order."""
    columns = dict(kept or {})
    columns.update({dataset: _column(results, dataset) for dataset in datasets(results)})
    order = _in_order(columns)
    rows: dict[str, dict[str, str]] = {}
    families: dict[str, list[str]] = {"matched": [], "paper": []}
    for dataset in order:
        _, cells, family_of = columns[dataset]
        for row, cell in cells.items():
            rows.setdefault(row, {})[dataset] = cell
            families[family_of[row]].append(row)
    lines = [
        "| Method | " + " | ".join(columns[d][0] for d in order) + " |",
        "|:---|" + "---:|" * len(order),
    ]
    headings = {
        "matched": "matched training (every method trained on the variants)",
        "paper": "baselines on observed images only (as the paper trains them)",
    }
    shown: set[str] = set()
    for key in ("matched", "paper"):
        family = [row for row in dict.fromkeys(families[key]) if row not in shown]
        if not family:
            continue
        if families["matched"]:
            lines.append(f"| *{headings[key]}* |" + " |" * len(order))
        for row in family:
            cells = [rows[row].get(d, "-") for d in order]
            lines.append(f"| {row} | " + " | ".join(cells) + " |")
        shown.update(family)
    return lines


def _md_table(results: Path, dataset: str, name: str) -> str | None:
    path = _table(results, dataset, f"{name}.md")
    return path.read_text().strip() if path.exists() else None


def _shown(results: Path) -> str:
    """The results folder as a reader of the page would have it: relative to the
    checkout, or, for a folder elsewhere, its own name (a run's ``results`` key)."""
    try:
        return results.resolve().relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return results.name


def _dataset_shown(results: Path, dataset: str) -> str:
    """A dataset's folder as the page names it: ``RESULTS/{dataset}``, or through a
    ``framework_view``, ``RESULTS/{dataset}/embedding``."""
    where = results / dataset
    if where.is_symlink():
        target = where.resolve()
        return f"{target.parents[1].name}/{target.parent.name}/{target.name}"
    return f"{_shown(results)}/{dataset}"


def _resolved_comparisons(results: Path, dataset: str) -> list[str]:
    path = _table(results, dataset, "comparisons.csv")
    if not path.exists():
        return []
    rows = read_rows(path)
    resolved = [r for r in rows if str(r.get("resolved", "")).lower() == "true"]
    lines = [
        f"{len(resolved)} of {len(rows)} paired comparisons are resolved "
        f"(all of them: `{_dataset_shown(results, dataset)}/tables/comparisons.md`)."
    ]
    if resolved:
        lines += [
            "",
            "| experiment | point | A − B | difference [95% CI] | p | n |",
            "|:---|:---|:---|---:|---:|---:|",
        ]
        for r in resolved:
            label = r.get("parameter") or r.get("point", "")
            diff, low, high = (_num(r[k]) for k in ("diff", "ci_low", "ci_high"))
            lines.append(
                f"| {r['experiment']} | {r.get('point', '') or label} | "
                f"{r['method_a']} − {r['method_b']} | {diff:+.1f} [{low:+.1f}, {high:+.1f}] | "
                f"{_num(r['p_value']):.3g} | {r['n']} |"
            )
    return lines


def _robustness(results: Path, dataset: str) -> list[str]:
    path = _table(results, dataset, "robustness_diff.csv")
    if not path.exists():
        return []
    rows = read_rows(path)
    better = sum(str(r.get("resolved", "")).lower() == "true" and _num(r["diff"]) > 0 for r in rows)
    worse = sum(str(r.get("resolved", "")).lower() == "true" and _num(r["diff"]) < 0 for r in rows)
    baseline = rows[0].get("baseline", "the best baseline") if rows else ""
    return [
        f"Condition robustness map (DUIS − {baseline}, {len(rows)} cells of MSPPP x SBR): "
        f"{better} cells resolved in DUIS's favour, {worse} against, "
        f"{len(rows) - better - worse} unresolved."
    ]


def figure_name(dataset: str, name: str, page: str = BLOCK) -> str:
    """File name of a dataset's figure copied into docs/figures."""
    prefix = "" if page == BLOCK else f"{page}_"
    return f"{prefix}{dataset}_{name}.png"


def _figures_of(results: Path, dataset: str) -> list[tuple[str, str]]:
    """(name, caption) of each key figure the dataset's run made."""
    return [
        (name, caption)
        for source, name, caption in FIGURES
        if (_figure(results, dataset, f"{source}.png")).exists()
    ]


def copy_figures(
    results: Path, figures: Path, page: str = BLOCK
) -> dict[str, list[tuple[str, str]]]:
    """Copy each dataset's key figures; {dataset: [(file name, caption), ...]}."""
    copied: dict[str, list[tuple[str, str]]] = {}
    sources = {name: source for source, name, _ in FIGURES}
    for dataset in datasets(results):
        for name, caption in _figures_of(results, dataset):
            figures.mkdir(parents=True, exist_ok=True)
            dest = figures / figure_name(dataset, name, page)
            shutil.copyfile(_figure(results, dataset, f"{sources[name]}.png"), dest)
            copied.setdefault(dataset, []).append((dest.name, caption))
    return copied


def _generated_by(
    page: str, *, kept: list[str], stamp: str = "", framework: str = DEFAULT.name
) -> str:
    """The comment line that opens a page's generated block (the text outside the
    markers is hand-written): the command that wrote it and, with ``--keep-absent``,
    the datasets kept from the block before."""
    option = ("" if page == BLOCK else f" --page {page}") + (" --keep-absent" if kept else "")
    option += "" if framework == DEFAULT.name else f" --framework {framework}"
    if kept:
        stamp = f"{stamp[:-1]}; " if stamp else " ("
        stamp += f"{', '.join(_in_order(kept))} kept from an earlier run)"
    return (
        f"<!-- generated by `{COMMAND} RESULTS{option}`{stamp}: edit the generator"
        " or the text outside the markers, not this block -->"
    )


def results_block(
    results: Path,
    figures: dict | None = None,
    *,
    figures_dir: str = "figures",
    page: str = BLOCK,
    earlier: str | None = None,
    framework: str = DEFAULT.name,
    drop: frozenset = frozenset(),
) -> str:
    """docs/{page}.md's generated part: every dataset's tables, verdicts and figures.
    It opens with one AUBC table of every dataset (``aubc_overview``); each dataset's
    claims table is folded under its verdicts. ``earlier``: the block as it was, whose
    datasets the folder lacks keep their sections and AUBC columns
    (``--keep-absent``), but those in ``drop``."""
    figures = figures or {}
    stamp = ""
    stamps = [p.stat().st_mtime for p in results.glob(table_file("*", "summary.json"))]
    if stamps:
        stamp = datetime.fromtimestamp(max(stamps), tz=UTC).strftime(" (tables of %Y-%m-%d)")
    present = datasets(results)
    gone = set(present) | set(drop)
    kept = {d: s for d, s in page_sections(earlier or "").items() if d not in gone}
    columns = {d: c for d, c in overview_columns(earlier or "").items() if d not in gone}
    sections: dict[str, list[str]] = {d: [s, ""] for d, s in kept.items()}
    for dataset in present:
        sections[dataset] = _dataset_section(
            results, dataset, figures.get(dataset, []), figures_dir
        )
    lines = [
        _generated_by(page, kept=list(kept), stamp=stamp, framework=framework),
        "",
        OVERVIEW_TITLE,
        "",
        *aubc_overview(results, columns),
        "",
    ]
    for dataset in _in_order(sections):
        lines += sections[dataset]
    return "\n".join(lines).rstrip()


def _dataset_section(
    results: Path, dataset: str, figures: list[tuple[str, str]], figures_dir: str
) -> list[str]:
    """One dataset's part of a page: heading, notes, figures, tables, AUBC,
    decomposition, verdicts with the claims table folded, resolved comparisons."""
    summary = _summary(results, dataset)
    lines = [f"## {dataset}", "", f"{_heading(results, dataset)}.", ""]
    for note in summary.get("notes", []):
        lines += [f"*{note}*", ""]
    for file_name, caption in figures:
        lines += [f"![{dataset}: {caption}]({figures_dir}/{file_name})", ""]
    for name, kind in TABLE_KINDS.items():
        title = kind.title
        table = _md_table(results, dataset, name)
        if table:
            lines += [f"### {dataset}: {title[:1].lower()}{title[1:]}", "", table, ""]
    lines += _aubc_table(results, dataset, summary)
    decomposition = _md_table(results, dataset, "decomposition")
    if decomposition and not decomposition.startswith("**No decomposition"):
        lines += [f"### {dataset}: what DUIS's gain is made of", "", decomposition, ""]
    rows = claims(results, dataset)
    if rows:
        lines += [f"### {dataset}: claims", "", verdict_line(rows), ""]
        table = _md_table(results, dataset, "claims")
        if table:
            summary_line = (
                f"Every claim on {dataset} ({len(rows)}): its verdict, reason, units "
                "needed and evidence"
            )
            lines += ["<details>", f"<summary>{summary_line}</summary>", "", table, ""]
            lines += ["</details>", ""]
    comparisons = _resolved_comparisons(results, dataset)
    robustness = _robustness(results, dataset)
    if comparisons or robustness:
        lines += [f"### {dataset}: paired comparisons", "", *comparisons, ""]
        if robustness:
            lines += [*robustness, ""]
    return lines


def _aubc_table(results: Path, dataset: str, summary: dict) -> list[str]:
    """The lines of a dataset's AUBC table (each method's range, AUBC with its interval,
    seeds and final mean): none when the summary names no method."""
    methods = summary.get("methods", {})
    if not methods:
        return []
    scale = 100.0
    budget = read_rows(_table(results, dataset, "budget.csv"))
    if budget:
        scale = _num(budget[0].get("scale", 100))
    lines = [
        f"### {dataset}: area under the budget curve over the query rounds",
        "",
        "| method | rounds | AUBC [95% CI] | seeds | final mean ± std |",
        "|:---|:---|---:|---:|---:|",
    ]
    names = {r["method"]: r["row"] for r in budget}
    for method, entry in methods.items():
        final = (
            f"{_num(entry.get('final_mean')) * scale:.1f} ± "
            f"{_num(entry.get('final_std')) * scale:.1f}"
        )
        span = (entry.get("aubc") or {}).get("span", "")
        lines.append(
            f"| {names.get(method, method)} | {span} | {aubc_text(summary, method, scale)} | "
            f"{entry.get('n_seeds', '')} | {final} |"
        )
    return [*lines, ""]


DEFAULT_RESULTS_PAGE = """# Results

<!-- results:start -->
<!-- results:end -->
"""


@contextlib.contextmanager
def framework_view(results: Path, framework=EMBEDDING):
    """A results folder holding ``framework``'s outputs: ``results`` itself for a
    framework that writes into each dataset's folder, else, while the context lasts, a
    temporary folder with one link per dataset, ``{dataset}`` ->
    ``results/{dataset}/{subfolder}`` (``FrameworkKind.folder``)."""
    kind = get_framework(framework)
    if not kind.subfolder:
        yield Path(results)
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / Path(results).name
        folder.mkdir()
        for dataset_dir in sorted(p for p in Path(results).iterdir() if p.is_dir()):
            own = Path(kind.folder(results, dataset_dir.name))
            if Path(table_file(own, "budget.csv")).is_file():
                (folder / dataset_dir.name).symlink_to(own.resolve())
        yield folder


def update(
    results: Path,
    docs: Path = Path("docs"),
    *,
    page: str = BLOCK,
    keep_absent: bool = False,
    framework: str = DEFAULT.name,
    drop=(),
) -> list[Path]:
    """Copy the figures and rewrite docs/{page}.md's generated block from the run's
    ``framework`` outputs (``framework_view``). With ``keep_absent`` the datasets the
    folder lacks keep what the block said of them, but those ``drop`` names (a dataset
    such a run no longer makes). Returns the files written."""
    if framework not in framework_names():
        raise ValueError(
            f"--framework must be one of {', '.join(framework_names())}, got {framework!r}."
        )
    docs = Path(docs)
    drop = frozenset(drop)
    with framework_view(results, framework) as results:
        if not datasets(results):
            raise ValueError(f"{results} holds no dataset with tables/budget.csv.")
        if not page.replace("-", "").replace("_", "").isalnum():
            raise ValueError(f"--page must be a plain name like 'decisive', got {page!r}.")
        path = docs / f"{page}.md"
        names = {
            d: [(figure_name(d, n, page), c) for n, c in _figures_of(results, d)]
            for d in datasets(results)
        }
        text = path.read_text() if path.exists() else DEFAULT_RESULTS_PAGE
        earlier = block(text, BLOCK) if keep_absent else None
        body = results_block(
            results, names, page=page, earlier=earlier, framework=framework, drop=drop
        )
        # made before anything is written: a page without its block stays as it was
        content = replace_block(text, BLOCK, body)
        copy_figures(results, docs / "figures", page)
    atomic_write_text(path, content)
    return [path]


def main(argv: list[str] | None = None) -> int:
    """Command line: regenerate a docs page's results block from a results folder."""
    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path, help="a results folder (snakemake all's)")
    parser.add_argument("--docs", type=Path, default=Path("docs"))
    parser.add_argument(
        "--page",
        default=BLOCK,
        help="docs/PAGE.md (default: results, the default run's supervised framework)",
    )
    parser.add_argument(
        "--keep-absent",
        action="store_true",
        help="keep what the blocks say of datasets RESULTS does not hold (a run of one "
        "dataset into its own folder updates its part of a shared page)",
    )
    parser.add_argument(
        "--drop",
        nargs="+",
        default=[],
        metavar="DATASET",
        help="with --keep-absent: datasets whose earlier part goes (the run no longer makes "
        "them); their figures on the page's folder stay until overwritten",
    )
    parser.add_argument(
        "--framework",
        default=DEFAULT.name,
        choices=framework_names(),
        help="the framework whose outputs to read (embedding: RESULTS/{dataset}/embedding/)",
    )
    args = parser.parse_args(argv)
    try:
        written = update(
            args.results,
            args.docs,
            page=args.page,
            keep_absent=args.keep_absent,
            framework=args.framework,
            drop=args.drop,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {', '.join(map(str, written))} and {args.docs / 'figures'}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
