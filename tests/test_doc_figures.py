"""Figures that a run, a dry run or the test suite produces have one home, and the
pages that repeat one agree with it: the default run's length (docs/benchmarks.md's
latest run, quoted once in the README), job counts stated as today's (checked by
``snakemake -n``), the suite's size in the README (checked against what pytest
collects), the slow files CONTRIBUTING lists (checked against their marker), and the
figures of ``QUOTED``, which every page that quotes one states as its home does."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path
from typing import NamedTuple

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
    read as a space (YAML comment marks too); a list item starts a sentence."""
    flat = re.sub(r"\s*\n\s*#?\s*", " ", text)
    return re.split(r"(?<=[.:])\s+(?:-\s+)?(?=[A-Z`(*])|;\s+", flat)


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


class Quoted(NamedTuple):
    """A figure several pages quote: a key, what it is, the page it is measured on (its
    home), a regex read per sentence (a YAML comment's too) whose first group that matched
    is the figure, and a regex of the sentences that quote another figure in the same
    words. (Job counts stated as today's have their own checkable form, JOBS_TODAY.)"""

    key: str
    name: str
    home: str
    pattern: str
    unless: str | None = None


QUOTED = [
    Quoted(
        "bf16_speedup",
        "bf16's training speed-up of the classifier on the AVX512-BF16 EPYC "
        "(benchmarks.md#training-throughput)",
        "docs/benchmarks.md",
        r"\bbf16 (?:trains|adds)\b[^;]*?(\d+\.\d+)x",
    ),
    Quoted(
        "bench_estimate_time",
        "the time `bench estimate` takes on the default config (benchmarks.md#estimate)",
        "docs/benchmarks.md",
        r"(?:bench estimate` \(|times each model [\w ]*?first[:,] )(\d+(?:-\d+)?) s\b",
    ),
    Quoted(
        "street_prediction",
        "the street scenes' predicted time on the AVX2-only EPYC (benchmarks.md#the-default-run)",
        "docs/benchmarks.md",
        r"street[^;]*?(?:predicted (\d+(?:\.\d+)?) min|(\d+(?:\.\d+)?) min predicted)",
    ),
    Quoted(
        "duis_vs_typiclust_papers_settings",
        "DUIS − Syn+TypiClust, real_cls at 24 seeds, the papers' settings (decisive-lowbudget.md)",
        "docs/decisive-lowbudget.md",
        r"(?:DUIS − Syn\+TypiClust \**−|Syn\+TypiClust by )(\d+\.\d) \[",
        unless=r"scikit-activeml",  # the superseded row, quoted as such
    ),
]


@pytest.mark.parametrize("figure", QUOTED, ids=[f.key for f in QUOTED])
def test_a_figure_quoted_on_several_pages_states_its_home_value(figure):
    """Every page that quotes one of ``QUOTED`` states the value its home states; a page
    that quotes none of them (a README without the figure) passes."""
    found: dict[str, list[str]] = {}
    for page in _pages():
        for sentence in _sentences(page.read_text()):
            if figure.unless and re.search(figure.unless, sentence):
                continue
            for match in re.finditer(figure.pattern, sentence):
                value = next(group for group in match.groups() if group)
                where = f"{page.relative_to(ROOT)}: {match.group(0)[:100]}"
                found.setdefault(value, []).append(where)
    homes = [w for where in found.values() for w in where if w.startswith(f"{figure.home}:")]
    assert homes, f"{figure.home}, the home of {figure.name}, no longer states it in the form read"
    assert len(found) == 1, (
        f"{figure.name} is stated as {len(found)} values: keep its home's ({figure.home}) "
        "and quote it exactly or link it\n"
        + "\n".join(f"{value}: {w}" for value, where in found.items() for w in where)
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
