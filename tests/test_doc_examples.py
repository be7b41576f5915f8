"""Every YAML example of README.md and docs/ plans what its marker says.

Each ```yaml block carries a marker line just above it, ``<!-- plans: a, b -->``: the
datasets a run of that file (merged over config/config.yaml as ``--configfile``) plans.
The fast tests resolve each example as the Snakefile does (merge, null removal,
``only_datasets``, schema, the plan's checks); the slow ones dry-run the own-data
examples with placeholder inputs, also with a new dataset added to the defaults.
"""

from __future__ import annotations

import copy
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from helpers.snakemake_cli import snakemake_on
from snakemake.utils import update_config

from spl_al.config import check_config, drop_removed, select_datasets
from spl_al.experiment.plan import check_plan

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"(?:<!-- plans: ([^>]*?) -->\n)?```yaml\n(.*?)```", re.S)
# Paths the examples name, and what stands in for them in a test.
PLACEHOLDERS = (
    "data/frames",
    "data/seed_labels.csv",
    "data/test_labels.csv",
    "/data/scans",
    "/data/released",
)


def examples() -> list[tuple[str, list[str] | None, str]]:
    """(where, the datasets its marker names or None, the YAML text) of every example."""
    out = []
    for page in PAGES:
        text = page.read_text()
        for match in BLOCK.finditer(text):
            line = text[: match.start()].count("\n") + 1
            plans = match.group(1)
            names = [n.strip() for n in plans.split(",")] if plans is not None else None
            out.append((f"{page.relative_to(ROOT)}:{line}", names, match.group(2)))
    return out


EXAMPLES = examples()
OWN = [e for e in EXAMPLES if "only_datasets" in (yaml.safe_load(e[2]) or {})]


def resolve(example: str, defaults: dict) -> list[str]:
    """The datasets a run of ``example`` over ``defaults`` plans, checked as the
    Snakefile checks them."""
    user = yaml.safe_load(example) or {}
    config = copy.deepcopy(defaults)
    update_config(config, copy.deepcopy(user))
    drop_removed(config)
    select_datasets(config, user)
    check_config(config, ROOT / "config" / "schema.yaml")
    check_plan(config)
    return list(config["datasets"])


def defaults_with_a_new_dataset() -> dict:
    """config/config.yaml with one more default dataset (a copy of synth_cls)."""
    defaults = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    defaults["datasets"]["synth_new"] = copy.deepcopy(defaults["datasets"]["synth_cls"])
    return defaults


def test_the_examples_are_found():
    assert len(EXAMPLES) >= 6 and len(OWN) >= 3


@pytest.mark.parametrize("where, plans, text", EXAMPLES, ids=[e[0] for e in EXAMPLES])
def test_every_yaml_example_plans_what_its_marker_says(where, plans, text):
    assert plans is not None, f"{where}: the example has no <!-- plans: ... --> marker"
    defaults = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    assert sorted(resolve(text, defaults)) == sorted(plans), where


@pytest.mark.parametrize("where, plans, text", OWN, ids=[e[0] for e in OWN])
def test_an_own_data_example_plans_its_datasets_whatever_the_defaults_gain(where, plans, text):
    assert sorted(resolve(text, defaults_with_a_new_dataset())) == sorted(plans), where


# ------------------------------------------------------------------ dry runs


def placeholders(tmp_path: Path) -> dict[str, str]:
    """Small stand-ins for the data the examples name: frames and seed labels, capture
    files by class (never read by a dry run), an empty release folder."""
    import numpy as np

    frames = tmp_path / "data" / "frames"
    frames.mkdir(parents=True)
    for i in range(40):
        np.savez(frames / f"frame_{i:04d}.npz", depth_ssp=np.ones((8, 8), np.float32))
    labels = tmp_path / "data" / "seed_labels.csv"
    labels.write_text(
        "file,label,split\nframe_0007.npz,car,test\nframe_0031.npz,person,test\n"
        "frame_0002.npz,car,train\n"
    )
    test_only = tmp_path / "data" / "test_labels.csv"  # no train row: round 0 is chosen
    test_only.write_text("file,label,split\ncar_0001.npz,car,test\nperson_0001.npz,person,test\n")
    scans = tmp_path / "scans"
    scans.mkdir()
    for name in ("car_0001", "car_0002", "person_0001", "person_0002"):
        (scans / f"{name}.mat").write_bytes(b"")
    released = tmp_path / "released"
    for name in ("car", "person"):
        (released / name).mkdir(parents=True)
    return {
        "data/frames": str(frames),
        "data/seed_labels.csv": str(labels),
        "data/test_labels.csv": str(test_only),
        "/data/scans": str(scans),
        "/data/released": str(released),
    }


def planned_datasets(text: str, workflow: Path, tmp_path: Path) -> set[str]:
    """The datasets whose jobs a dry run of the example (placeholders in) plans, on the
    workflow in folder ``workflow``, run from ``tmp_path``."""
    for old, new in placeholders(tmp_path).items():
        text = re.sub(rf"(?<![\w/]){re.escape(old)}\b", new, text)
    user = yaml.safe_load(text)
    user["results"] = str(tmp_path / "results")
    config = tmp_path / "example.yaml"
    config.write_text(yaml.safe_dump(user))
    run = subprocess.run(
        [*snakemake_on(workflow / "Snakefile"), "-n", "--cores", "1", "--configfile", str(config)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert "Plan: " in run.stdout + run.stderr  # the plan prints before the jobs
    return set(re.findall(r"\bdataset=([\w.-]+)", run.stdout + run.stderr))


FRAMES_AND_SCANS = [e for e in OWN if yaml.safe_load(e[2])["only_datasets"] != ["real_cls"]]
DRY = [e[0] for e in FRAMES_AND_SCANS]


@pytest.mark.slow
@pytest.mark.parametrize("where, plans, text", FRAMES_AND_SCANS, ids=DRY)
def test_an_own_data_example_dry_runs_its_datasets_alone(where, plans, text, tmp_path):
    assert planned_datasets(text, ROOT, tmp_path) == set(plans), where


@pytest.mark.slow
def test_the_labeling_example_dry_runs_alone_beside_a_new_default_dataset(tmp_path):
    """A copy of the workflow whose config/config.yaml gained a dataset."""
    tree = tmp_path / "tree"
    tree.mkdir()
    for name in ("Snakefile", "workflow", "profiles"):
        src = ROOT / name
        (shutil.copytree if src.is_dir() else shutil.copy)(src, tree / name)
    (tree / "config").mkdir()
    shutil.copy(ROOT / "config" / "schema.yaml", tree / "config")
    (tree / "config" / "config.yaml").write_text(yaml.safe_dump(defaults_with_a_new_dataset()))
    _, plans, text = next(e for e in OWN if "docs/labeling.md" in e[0])
    assert planned_datasets(text, tree, tmp_path) == set(plans) == {"frames"}


# ------------------------------------------------------------------ shell commands

SOURCES = [*PAGES, *sorted((ROOT / "config").glob("*.yaml")), ROOT / "profiles/slurm/config.yaml"]


def shell_commands(prefix: str) -> list[tuple[str, str]]:
    """(where, command) of every documented line that starts with ``prefix`` (in code
    blocks, inline code and config comments), continuation lines joined."""
    out = []
    for page in SOURCES:
        text = page.read_text().replace("\\\n", " ")
        for line_no, line in enumerate(text.splitlines(), 1):
            for match in re.finditer(rf"(?:^|`|#\s*|\$ ){re.escape(prefix)}[^`#\n]*", line):
                command = match.group(0).lstrip("`#$ ").strip()
                out.append((f"{page.relative_to(ROOT)}:{line_no}", command))
    return out


def _target_order_ok(command: str) -> bool:
    words = command.split()
    if "--configfile" not in words:
        return True
    after = words[words.index("--configfile") + 1 :]
    options = [i for i, w in enumerate(after) if w.startswith("-")]
    files = after[: options[0]] if options else after
    return all(f.endswith((".yaml", ".yml")) for f in files)


def test_no_snakemake_command_puts_its_target_after_configfile():
    """--configfile takes several files, so a target after it is read as one more."""
    bad, commands = [], shell_commands("snakemake ")
    assert len(commands) > 10
    old = "snakemake --profile profiles/slurm --configfile config/paper.yaml all"
    assert not _target_order_ok(old)
    for where, command in commands:
        if not _target_order_ok(command):
            bad.append(f"{where}: {command}")
    assert not bad, bad


def cli_commands() -> list[list[str]]:
    """Every distinct `python -m spl_al...` module (with its subcommand) the docs show,
    but the benches, whose --help tests/test_bench.py runs."""
    seen = {}
    for _, command in shell_commands("python -m spl_al"):
        words = command.split()
        module = words[2]
        if module == "spl_al.bench":
            continue
        sub = [words[3]] if len(words) > 3 and re.fullmatch(r"[a-z_]+", words[3]) else []
        seen.setdefault(" ".join([module, *sub]), [module, *sub])
    return list(seen.values())


@pytest.mark.parametrize("command", cli_commands(), ids=" ".join)
def test_every_documented_cli_answers_help(command):
    run = subprocess.run(
        [sys.executable, "-m", *command, "--help"], capture_output=True, text=True, cwd=ROOT
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert "usage" in run.stdout.lower()
