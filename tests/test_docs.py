"""The documentation: links resolve, generated pages match their generators."""

import csv
import importlib
import importlib.util
import json
import re
from pathlib import Path

import pytest
import yaml

from spl_al.docs import configuration, results_blocks
from spl_al.docs.markers import replace_block

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")


def anchors(path: Path) -> set[str]:
    """GitHub's anchors of a Markdown file's headings (duplicates get -1, -2, ...)."""
    seen: dict[str, int] = {}
    out = set()
    in_code = False
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            in_code = not in_code
        if in_code or not line.startswith("#"):
            continue
        text = line.lstrip("#").strip().lower()
        slug = re.sub(r"[^\w\- ]", "", text).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def links(path: Path):
    in_code = False
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            in_code = not in_code
        if in_code:
            continue
        for match in LINK.finditer(line):
            yield match.group(1) or match.group(2)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page):
    broken = []
    for target in links(page):
        if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        dest = (page.parent / file_part).resolve() if file_part else page
        if not dest.exists():
            broken.append(f"{target} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target} (no heading with anchor #{anchor} in {dest.name})")
    assert not broken, f"{page.relative_to(ROOT)}: broken links: {broken}"


def _units() -> list[str]:
    """spl_al's top-level modules and packages, and spl_al.experiment's modules."""
    src = ROOT / "src" / "spl_al"
    units = [
        f"spl_al.{p.stem}"
        for p in sorted(src.iterdir())
        if not p.name.startswith("_")
        and (p.suffix == ".py" or (p.is_dir() and (p / "__init__.py").exists()))
    ]
    return units + [
        f"spl_al.experiment.{p.stem}"
        for p in sorted((src / "experiment").glob("*.py"))
        if not p.name.startswith("_")
    ]


def test_the_design_map_names_every_unit_and_nothing_that_does_not_exist():
    """docs/design.md's map matches the code: every top-level unit and every module of
    spl_al.experiment is named there, and every `spl_al....` name it gives exists."""
    design = (ROOT / "docs" / "design.md").read_text()
    quoted = set(re.findall(r"`([\w.]+)`", design))
    unnamed = [u for u in _units() if u not in quoted and u.rpartition(".")[2] not in quoted]
    assert not unnamed, f"docs/design.md does not name {unnamed}"

    def is_module(name: str) -> bool:
        try:
            return importlib.util.find_spec(name) is not None
        except ModuleNotFoundError:  # a parent that is not a package
            return False

    missing = []
    for name in sorted(n for n in quoted if n.startswith("spl_al.")):
        module, attr = name, None
        while module and not is_module(module):
            module, _, attr = module.rpartition(".")
        if not module or (attr and not hasattr(importlib.import_module(module), attr)):
            missing.append(name)
    assert not missing, f"docs/design.md names what does not exist: {missing}"


def test_configuration_page_is_up_to_date():
    page = ROOT / "docs" / "configuration.md"
    expected = configuration.build(ROOT, page.read_text())
    assert page.read_text() == expected, (
        "docs/configuration.md is out of date with config/schema.yaml or config/config.yaml: "
        "run `python -m spl_al.docs.configuration` and commit the result."
    )


def test_every_schema_key_has_a_description():
    schema = yaml.safe_load((ROOT / "config" / "schema.yaml").read_text())
    assert configuration.undescribed(schema) == []


def test_configuration_page_lists_every_default_key():
    text = (ROOT / "docs" / "configuration.md").read_text()
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    for key in config:
        assert f"| `{key}` |" in text, key
    for key in config["datasets"]["real_cls"]["train"]["fit"]:
        assert f"| `{key}` |" in text, key


def test_split_unit():
    assert configuration.split_unit("ball radius of each level [m]") == (
        "ball radius of each level",
        "m",
    )
    assert configuration.split_unit("no unit here") == ("no unit here", "")


def test_replace_block_keeps_the_outside():
    text = "head\n<!-- x:start -->\nold\n<!-- x:end -->\ntail\n"
    assert replace_block(text, "x", "new") == "head\n<!-- x:start -->\nnew\n<!-- x:end -->\ntail\n"
    with pytest.raises(ValueError, match="x:start"):
        replace_block("no markers", "x", "new")


def _write_csv(path: Path, rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _fake_dataset(results: Path, name: str, metric: str, standin: bool) -> None:
    tables = results / name / "tables"
    budget = []
    for pos, (method, label) in enumerate((("random", "Random"), ("duis", "DUIS"))):
        for col, (ratio, mean) in enumerate(((2.0, 30.0 + pos), (4.0, 50.0 + 5 * pos))):
            budget.append(
                dict(method=method, round=col, n_labeled=10 * (col + 1), ratio=ratio / 100,
                     mean=mean, std=1.5, n_seeds=3, n_expected=3, partial=False,
                     mark="bold" if (pos, col) == (1, 1) else "", row=label, col=f"{ratio}%",
                     row_pos=pos, col_pos=col, table="budget", dataset=name, metric=metric,
                     scale=100.0, synthetic_standin=standin)
            )  # fmt: skip
    _write_csv(tables / "budget.csv", budget)
    for table in ("budget", "levels", "ablation", "sensitivity", "claims"):
        (tables / f"{table}.md").write_text(f"**{table} of {name}**\n\n| a |\n|---|\n| 1 |\n")
    _write_csv(
        tables / "claims.csv",
        [
            dict(claim_id="best", claim="DUIS has the highest metric at every budget.",
                 verdict="supported", dataset=name),
            dict(claim_id="aubc", claim="DUIS has the largest AUBC.", verdict="inconclusive",
                 dataset=name),
        ],
    )  # fmt: skip
    _write_csv(
        tables / "comparisons.csv",
        [
            dict(experiment="budget", point="round 1 (4.0%)", parameter="", method_a="duis",
                 method_b="random", n=3, diff=5.0, ci_low=1.0, ci_high=9.0, p_value=0.25,
                 resolved=True),
        ],
    )  # fmt: skip
    summary = {
        "dataset": name,
        "n_seeds": 3,
        "methods": {
            m: {"final_mean": 0.5, "final_std": 0.01, "n_seeds": 3,
                "aubc": {"mean": 0.4, "ci_low": 0.35, "ci_high": 0.45}}
            for m in ("random", "duis")
        },
        "notes": [],
    }  # fmt: skip
    (tables / "summary.json").write_text(json.dumps(summary))
    figures = results / name / "figures"
    figures.mkdir(parents=True)
    (figures / "curves.png").write_bytes(b"\x89PNG fake")


def test_pages_generator_writes_every_dataset_and_keeps_the_outside(tmp_path):
    results = tmp_path / "results"
    _fake_dataset(results, "real_cls", "accuracy", True)
    _fake_dataset(results, "street_seg", "miou", False)
    (results / "logs").mkdir()  # not a dataset
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "results.md").write_text(
        "# Results\n\nhand-written reading\n\n<!-- results:start -->\nold\n<!-- results:end -->\n"
        "\n## Statistics\n\nhand-written rule\n"
    )

    assert results_blocks.main([str(results), "--docs", str(docs)]) == 0

    page = (docs / "results.md").read_text()
    assert page.startswith("# Results\n\nhand-written reading\n\n<!-- results:start -->")
    assert page.endswith("<!-- results:end -->\n\n## Statistics\n\nhand-written rule\n")
    assert "old" not in page
    # one AUBC table of both datasets first, then each dataset's section
    assert "| DUIS | 40.0 [35.0, 45.0] | 40.0 [35.0, 45.0] |" in page
    assert page.index("| DUIS | 40.0") < page.index("## real_cls") < page.index("## street_seg")
    for name in ("real_cls", "street_seg"):
        for table in ("budget", "levels", "ablation", "sensitivity", "claims"):
            assert f"**{table} of {name}**" in page
        assert f"![{name}: budget curves, mean ± std over seeds](figures/{name}_budget.png)" in page
        assert (docs / "figures" / f"{name}_budget.png").read_bytes() == b"\x89PNG fake"
        # the verdicts in a sentence, every claim's table folded under it
        assert f"<summary>Every claim on {name} (2)" in page
    assert "1 supported, 1 inconclusive (of 2)" in page
    assert "synthetic stand-in" in page
    assert "1 of 1 paired comparisons are resolved" in page


def test_pages_generator_refuses_a_folder_without_results(tmp_path, capsys):
    assert results_blocks.main([str(tmp_path), "--docs", str(tmp_path)]) == 1
    assert "holds no dataset" in capsys.readouterr().err


def test_pages_generator_gives_a_second_run_its_own_page_and_figures(tmp_path):
    results = tmp_path / "results-decisive"
    _fake_dataset(results, "real_cls", "accuracy", True)
    docs = tmp_path / "docs"
    (docs / "figures").mkdir(parents=True)
    (docs / "figures" / "real_cls_budget.png").write_bytes(b"default run's")
    (docs / "decisive.md").write_text(
        "# 24 seeds\n\n<!-- results:start -->\n<!-- results:end -->\n"
    )

    argv = [str(results), "--docs", str(docs), "--page", "decisive"]
    assert results_blocks.main(argv) == 0

    page = (docs / "decisive.md").read_text()
    assert "(figures/decisive_real_cls_budget.png)" in page
    assert (docs / "figures" / "decisive_real_cls_budget.png").read_bytes() == b"\x89PNG fake"
    assert (docs / "figures" / "real_cls_budget.png").read_bytes() == b"default run's"
    # a results folder outside the checkout is named as the run names it, not by the
    # path of the machine that made the page
    assert "`results-decisive/real_cls/tables/comparisons.md`" in page
    assert str(tmp_path) not in page


def test_pages_generator_reads_the_embedding_framework_of_a_run(tmp_path):
    results = tmp_path / "results"
    _fake_dataset(results / "real_cls", "embedding", "accuracy", True)  # real_cls/embedding/
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "embedding.md").write_text(
        "# Embedding\n\n<!-- results:start -->\n<!-- results:end -->\n"
    )
    argv = [str(results), "--docs", str(docs), "--page", "embedding"]
    assert results_blocks.main([*argv, "--framework", "embedding"]) == 0
    page = (docs / "embedding.md").read_text()
    assert "| DUIS | 40.0 [35.0, 45.0] |" in page
    assert "`results/real_cls/embedding/tables/comparisons.md`" in page
    assert (docs / "figures" / "embedding_real_cls_budget.png").exists()


def test_pages_generator_writes_nothing_when_the_page_lacks_its_block(tmp_path, capsys):
    results = tmp_path / "results"
    _fake_dataset(results, "real_cls", "accuracy", True)
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "results.md").write_text("# no block\n")

    assert results_blocks.main([str(results), "--docs", str(docs)]) == 1
    assert "<!-- results:start -->" in capsys.readouterr().err
    assert (docs / "results.md").read_text() == "# no block\n"
    assert not (docs / "figures").exists()


def test_readme_table_shows_the_matched_family_first_and_the_aubc_range(tmp_path):
    results = tmp_path / "results"
    _fake_dataset(results, "real_cls", "accuracy", False)
    tables = results / "real_cls" / "tables"
    budget = list(csv.DictReader((tables / "budget.csv").open()))
    twin = [dict(r, method="syn_random", row="Syn+Random", row_pos=2) for r in budget[:2]]
    for r in budget:
        r["row_pos"] = {"random": 0, "duis": 3}[r["method"]]
    _write_csv(tables / "budget.csv", budget + twin)
    summary = json.loads((tables / "summary.json").read_text())
    summary["methods"]["syn_random"] = dict(summary["methods"]["random"])
    for entry in summary["methods"].values():
        entry["aubc"] = dict(entry["aubc"], span="rounds 1-1 (4.0%)")
    summary["families"] = {"paper": ["random", "duis"], "matched": ["syn_random", "duis"]}
    (tables / "summary.json").write_text(json.dumps(summary))
    _write_csv(
        tables / "claims.csv",
        [
            dict(claim_id="a", claim="Paper claim.", verdict="seeds agree (untested)",
                 source="paper"),
            dict(claim_id="b", claim="Extension claim.", verdict="seeds against (untested)",
                 source="extension"),
        ],
    )  # fmt: skip
    lines = results_blocks.compact_table(results, "real_cls")
    assert "AUBC rounds 1-1 (4.0%) [95% CI]" in lines[0]
    rows = [line.split(" | ")[0].lstrip("| ") for line in lines[2:]]
    assert rows == [
        "*matched training (every method trained on the variants)*",
        "Syn+Random",
        "DUIS",
        "*baselines on observed images only (as the paper trains them)*",
        "Random",
    ]
    line = results_blocks.verdict_line(results_blocks.claims(results, "real_cls"))
    assert line == (
        "The paper's claims: 1 seeds agree (untested) (of 1). Extensions: 1 seeds against "
        "(untested) (of 1). Seeds against (untested): Extension claim."
    )


def test_a_pages_aubc_overview_is_one_table_of_every_dataset(tmp_path):
    """A page opens with one AUBC row per method, a column per dataset with its range and
    seeds, "-" where a run lacks the method, the matched family first."""
    results = tmp_path / "results-decisive"
    _fake_dataset(results, "real_cls", "accuracy", True)
    _fake_dataset(results, "street_seg", "miou", False)
    tables = results / "real_cls" / "tables"
    budget = list(csv.DictReader((tables / "budget.csv").open()))
    twin = [dict(r, method="syn_random", row="Syn+Random", row_pos=2) for r in budget[:2]]
    _write_csv(tables / "budget.csv", budget + twin)
    summary = json.loads((tables / "summary.json").read_text())
    summary["methods"]["syn_random"] = {"aubc": {"mean": 0.6, "ci_low": 0.5, "ci_high": 0.7}}
    for entry in summary["methods"].values():
        entry["aubc"]["span"] = "rounds 1-1 (4.0%)"
    summary["families"] = {"paper": ["random", "duis"], "matched": ["syn_random", "duis"]}
    (tables / "summary.json").write_text(json.dumps(summary))

    lines = results_blocks.aubc_overview(results)
    assert lines[0] == (
        "| Method | real_cls (accuracy, 3 seeds): rounds 1-1 (4.0%) | street_seg (mIoU, 3 seeds) |"
    )
    assert lines[2:] == [
        "| *matched training (every method trained on the variants)* | | |",
        "| Syn+Random | 60.0 [50.0, 70.0] | - |",
        "| DUIS | 40.0 [35.0, 45.0] | 40.0 [35.0, 45.0] |",
        "| *baselines on observed images only (as the paper trains them)* | | |",
        "| Random | 40.0 [35.0, 45.0] | 40.0 [35.0, 45.0] |",
    ]
    page = results_blocks.results_block(results, page="decisive")
    assert "\n".join(lines) in page
    assert results_blocks.overview_columns(page).keys() == {"real_cls", "street_seg"}
    # a block written before pages had an overview: its dataset tables are no overview
    # (--keep-absent took a budget table's rounds for datasets)
    older = (
        "## real_cls\n\n| Method | 1.8% (round 0) | 3.6% |\n|:---|---:|---:|\n"
        "| Random | 30.0 | 40.0 |\n"
    )
    assert results_blocks.overview_columns(older) == {}


def test_keep_absent_updates_one_dataset_of_a_shared_page(tmp_path):
    """A decisive run of one dataset, made in a folder of its own, rewrites that
    dataset's section and AUBC column and keeps the others' as they were; without
    --keep-absent the page holds only the folder's datasets."""
    first, second = tmp_path / "first", tmp_path / "second"
    _fake_dataset(first, "real_cls", "accuracy", True)
    _fake_dataset(first, "synth_cls", "accuracy", False)
    _fake_dataset(second, "real_cls", "accuracy", True)
    summary_path = second / "real_cls" / "tables" / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["methods"]["duis"]["aubc"] = {"mean": 0.7, "ci_low": 0.65, "ci_high": 0.75}
    summary_path.write_text(json.dumps(summary))
    (second / "real_cls" / "tables" / "budget.md").write_text("**budget of real_cls, 24**\n")
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "decisive.md").write_text("# D\n\n<!-- results:start -->\n<!-- results:end -->\n")

    def run(results, *extra):
        argv = [str(results), "--docs", str(docs)]
        assert results_blocks.main([*argv, "--page", "decisive", *extra]) == 0
        return (docs / "decisive.md").read_text()

    page = run(first)
    synth_section = results_blocks.page_sections(page)["synth_cls"]
    page = run(second, "--keep-absent")
    assert "**budget of real_cls, 24**" in page and "**budget of real_cls**" not in page
    assert results_blocks.page_sections(page)["synth_cls"] == synth_section
    assert page.index("## real_cls") < page.index("## synth_cls")
    assert "--keep-absent` (tables of" in page and "; synth_cls kept from an earlier run)" in page
    assert "| DUIS | 70.0 [65.0, 75.0] | 40.0 [35.0, 45.0] |" in page

    page = run(second)
    assert "## synth_cls" not in page and "synth_cls" not in page
    # --drop: a dataset such a run no longer makes loses its earlier part, others keep theirs
    run(first)
    _fake_dataset(first, "street_seg", "miou", False)
    run(first)
    page = run(second, "--keep-absent", "--drop", "synth_cls")
    assert "## synth_cls" not in page and "synth_cls" not in page
    assert "## street_seg" in page and "street_seg (mIoU" in page


def _fake_claims(tables: Path, unit: str, n: int, rows: list[tuple], claim="...") -> None:
    """claims.csv with rows (claim_id, verdict, effect_pair, effect, low, high, n_comparisons)."""
    _write_csv(
        tables / "claims.csv",
        [
            dict(claim_id=cid, claim=claim, verdict=verdict, effect_pair=pair, effect=d,
                 effect_low=lo, effect_high=hi, n_comparisons=m, min_n=n, unit=unit)
            for cid, verdict, pair, d, lo, hi, m in rows
        ],
    )  # fmt: skip


def test_the_readme_answer_is_one_table_of_both_frameworks(tmp_path, capsys):
    from spl_al.docs import answer

    emb, sup = tmp_path / "results", tmp_path / "results-decisive"
    _fake_claims(
        emb / "real_cls" / "embedding" / "tables",
        "encoder",
        12,
        [
            ("duis_best_aubc", "contradicted", "duis - margin", -1.1, -1.7, -0.5, 5),
            ("variant_training", "supported", "syn_random - random", 1.0, 0.4, 1.6, 1),
        ],
    )
    _fake_claims(
        sup / "real_cls" / "tables",
        "seed",
        24,
        [("duis_best_aubc", "supported", "duis - random", 5.6, 3.4, 7.8, 1)],
        claim="DUIS has the largest AUBC, as the paper compares (against Random only).",
    )
    # the run's effective config says which datasets are procedural stand-ins
    (emb / "config.yaml").write_text("datasets: {real_cls: {source: synthetic}}\n")
    readme = tmp_path / "README.md"
    readme.write_text("# x\n\n<!-- answer:start -->\nold\n<!-- answer:end -->\n\nrest\n")
    assert answer.main([str(emb), str(sup), "--readme", str(readme)]) == 0
    text = readme.read_text()
    assert text.startswith("# x\n\n<!-- answer:start -->\n") and text.endswith("\n\nrest\n")
    assert (
        "| Question | embedding: real_cls (stand-in), 12 encoders "
        "| supervised: real_cls, 24 seeds |" in text
    )
    row = next(line for line in text.split("\n") if "as the paper compares" in line)
    assert "**contradicted**: −1.1 [−1.7, −0.5] vs Margin" in row
    # one comparator: not named, but a declared family the run has in part says so
    assert "**supported**: +5.6 [+3.4, +7.8] (vs Random only) |" in row
    assert "training on the variants help" in text and "| - |" in text
    assert "low-budget" not in text  # a question no run answers has no row
    # the street scans' embedding framework from config/street.yaml's own folder
    street = tmp_path / "results-street"
    _fake_claims(
        street / "street_seg" / "embedding" / "tables",
        "encoder",
        12,
        [("duis_best_aubc", "inconclusive", "duis - coreset", -0.3, -1.0, 0.4, 5)],
    )
    more = ["--also-embedding", str(street)]
    assert answer.main([str(emb), str(sup), *more, "--readme", str(readme)]) == 0
    both = readme.read_text()
    assert "| embedding: real_cls (stand-in), 12 encoders | embedding: street_seg, 12" in both
    assert "**inconclusive**: −0.3 [−1.0, +0.4] vs Coreset" in both
    # street_pc shares street_seg's embedding runs (its claims the same): one column
    _fake_claims(
        street / "street_pc" / "embedding" / "tables",
        "encoder",
        12,
        [("duis_best_aubc", "inconclusive", "duis - coreset", -0.3, -1.0, 0.4, 5)],
    )
    (street / "config.yaml").write_text(
        "datasets: {street_pc: {embedding: {shared: street_seg}}}\n"
    )
    assert answer.main([str(emb), str(sup), *more, "--readme", str(readme)]) == 0
    both = readme.read_text()
    assert "| embedding: street_seg and street_pc, 12 encoders |" in both
    assert "embedding: street_pc" not in both
    # nothing to read: one sentence, the README as it was
    assert answer.main([str(tmp_path / "a"), str(tmp_path / "b"), "--readme", str(readme)]) == 1
    assert "holds claims of real_cls or synth_cls or street_seg" in capsys.readouterr().err
    assert readme.read_text() == both
