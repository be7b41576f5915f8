"""Figures that a run, a dry run or the test suite produces have one home, and the
pages that repeat one agree with it: the default run's length (docs/benchmarks.md's
latest run, quoted once in the README), job counts stated as today's (checked by
``snakemake -n``), the suite's size in the README (checked against what pytest
collects) and the slow files CONTRIBUTING lists (checked against their marker)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest
from helpers.snakemake_cli import SNAKEMAKE, from_checkout

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BENCHMARKS = ROOT / "docs" / "benchmarks.md"


def _pages() -> list[Path]:
    """Every hand-written page and config a user reads figures in."""
    pages = [README, ROOT / "CONTRIBUTING.md", *sorted((ROOT / "docs").glob("*.md"))]
    return [*pages, *sorted((ROOT / "config").glob("*.yaml"))]


def _sentences(text: str) -> list[str]:
    """Sentences (and the clauses a semicolon ends) of a page, a line break inside one
    read as a space (YAML comment marks too)."""
    flat = re.sub(r"\s*\n\s*#?\s*", " ", text)
    return re.split(r"(?<=[.:])\s+(?=[A-Z`(*])|;\s+", flat)


def default_run_minutes() -> str:
    """The default run's length, as its one home states it: docs/benchmarks.md's
    "The default run", its latest run."""
    section = BENCHMARKS.read_text().split("## The default run", 1)[1]
    latest = section.split("Latest", 1)[1].split("\n\n", 1)[0]
    found = re.search(r"\*\*(\d+(?:\.\d+)?) min\*\*", latest)
    assert found, "docs/benchmarks.md's latest default run states no '**N min**'"
    return found.group(1)


def test_the_default_run_time_is_stated_once_and_quoted_as_measured():
    minutes = default_run_minutes()
    assert f"The default config took **{minutes} min**" in README.read_text()
    restated = []
    for page in _pages():
        if page in (BENCHMARKS, README) or page.name == "configuration.md":
            continue
        for sentence in _sentences(page.read_text()):
            if re.search(r"default (run|config)", sentence) and re.search(
                r"\b\d+(\.\d+)? min(utes)?\b", sentence
            ):
                restated.append(f"{page.relative_to(ROOT)}: {sentence[:160]}")
    assert not restated, (
        "the default run's length has one home (docs/benchmarks.md#the-default-run); "
        "link it instead of restating a number:\n" + "\n".join(restated)
    )


def test_the_slow_table_lists_exactly_the_files_marked_slow():
    marked = {
        path.name
        for path in (ROOT / "tests").glob("test_*.py")
        if re.search(r"pytest\.mark\.slow\b", path.read_text())
    }
    table = (ROOT / "CONTRIBUTING.md").read_text().split("The `slow` marker", 1)[1]
    table = table.split("\n\n", 2)[1]
    listed = set(re.findall(r"^\| `tests/(test_\w+\.py)`", table, flags=re.M))
    assert listed == marked


JOBS_TODAY = re.compile(r"([\d,]+) jobs by `snakemake -n(?: --configfile (config/[\w.-]+))?`")


def stated_job_counts() -> dict[str, set[int]]:
    """config file (or "" for the default) -> the counts pages state as today's."""
    out: dict[str, set[int]] = {}
    for page in _pages():
        for sentence in _sentences(page.read_text()):
            for count, config in JOBS_TODAY.findall(sentence):
                out.setdefault(config, set()).add(int(count.replace(",", "")))
    return out


def test_job_counts_are_stated_in_one_checkable_form():
    """Today's job counts are written "N jobs by `snakemake -n --configfile X`", which
    the slow test below checks; the form is found where it is used."""
    stated = stated_job_counts()
    assert "config/ci.yaml" in stated
    assert all(len(counts) == 1 for counts in stated.values()), stated


@pytest.mark.slow
def test_job_counts_stated_as_todays_are_what_snakemake_plans(tmp_path):
    """The counts are a plain checkout's: real captures named in the environment add
    a picture job each (the README says so), so the dry runs go without them."""
    env = {k: v for k, v in os.environ.items() if k != "SPL_AL_REAL_CAPTURES"}
    for config, (count,) in sorted(stated_job_counts().items()):
        args = ["-n", "--cores", "1", "--quiet", "rules"]
        args += ["--configfile", config] if config else []
        run = subprocess.run(
            [*SNAKEMAKE, *from_checkout(args), "--config", f"results={tmp_path / 'r'}"],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0, run.stderr[-2000:]
        total = re.search(r"^total\s+(\d+)$", run.stdout + run.stderr, flags=re.M)
        assert total, (run.stdout + run.stderr)[-2000:]
        assert int(total.group(1)) == count, f"{config or 'config/config.yaml'}"


def test_the_readme_test_count_is_what_pytest_collects(request):
    """The README's "N passed, M skipped" adds up to the suite as collected now: a test
    added or removed without the README's line fails here (on a whole-suite run)."""
    cfg = request.config
    whole = cfg.args in ([], ["tests"], [str(ROOT / "tests")])
    if not whole or cfg.option.markexpr or cfg.option.keyword or cfg.option.lf:
        pytest.skip("counts the suite only when the whole of it is collected")
    found = re.search(r"`(\d+) passed, (\d+) skipped`", README.read_text())
    assert found, "the README states no '`N passed, M skipped`'"
    stated = int(found.group(1)) + int(found.group(2))
    assert stated == len(request.session.items)
