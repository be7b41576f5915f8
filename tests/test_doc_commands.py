"""Every Snakemake command the docs show for a shipped config plans as written.

tests/test_doc_examples.py checks the YAML examples and the order of a command's
words; here each distinct documented ``snakemake`` command that names only files of
this repository runs as a dry run (``-n``), its cores and output options aside. The
long runs' configs (paper, decisive: thousands of jobs, 15-18 s a dry run) are
resolved in-process instead, as the Snakefile resolves them before its first job
(merge, null removal, ``only_datasets``, schema, the plan's checks). A command that
names a user's file (``my.yaml``), or changes state (``--unlock``, ``--report``), is
not one to dry-run here.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
from pathlib import Path

import pytest
from helpers.snakemake_cli import SNAKEMAKE, from_checkout
from test_doc_examples import shell_commands

ROOT = Path(__file__).resolve().parents[1]
STATEFUL = ("--unlock", "--report")
DROPPED = re.compile(r"^(-j\d*|--cores|-n|--dry-run|--quiet)$")


def dry_runs() -> dict[str, list[str]]:
    """{command as documented: its dry-run arguments} of every shipped-config command."""
    out = {}
    for _, command in shell_commands("snakemake "):
        words = command.split()[1:]
        if any(w in STATEFUL for w in words) or words[-1] == "--config":
            continue
        files = [words[i + 1] for i, w in enumerate(words[:-1]) if w == "--configfile"]
        if any(not (ROOT / f).is_file() for f in files):
            continue  # a file of the user's own
        args = [w.strip("'") for w in words if not DROPPED.match(w)]
        if args in ([], ["all"]):
            args = ["all"]  # the default target
        out.setdefault(" ".join(args), args)
    return out


def _long(args: list[str]) -> bool:
    return any(re.search(r"config/(paper|decisive)", w) for w in args)


def _split(args: list[str]) -> tuple[tuple[str, ...], list[str]]:
    """(the options with their values, the targets) of a command's arguments."""
    targets = [
        w
        for i, w in enumerate(args)
        # (KEY=VALUE: a --config value, however many follow the flag)
        if not w.startswith("-") and "=" not in w and (i == 0 or not args[i - 1].startswith("-"))
    ]
    return tuple(w for w in args if w not in targets), targets


def grouped(commands: dict[str, list[str]]) -> dict[str, list[str]]:
    """Commands that differ only in their targets as one dry run of all those targets:
    each target must still plan, and a Snakemake start (seconds) is paid once."""
    groups: dict[tuple[str, ...], tuple[list[str], list[str]]] = {}
    for name, args in commands.items():
        options, targets = _split(args)
        names, all_targets = groups.setdefault(options, ([], []))
        names.append(name)
        all_targets += [t for t in targets if t not in all_targets]
    return {" + ".join(n): [*t, *o] for o, (n, t) in groups.items()}


COMMANDS = dry_runs()
DRY_RUNS = grouped({k: v for k, v in COMMANDS.items() if not _long(v)})
RESOLVED = {k: v for k, v in COMMANDS.items() if _long(v)}


def test_the_documented_commands_are_found():
    found = {name for group in DRY_RUNS for name in group.split(" + ")}
    assert {"all", "all --configfile config/street.yaml", "--configfile config/ci.yaml"} <= found
    assert any("profiles/slurm" in c for c in found)
    assert len(found) >= 8 and len(DRY_RUNS) < len(found)
    assert {"--configfile config/decisive.yaml", "all --configfile config/paper.yaml"} <= set(
        RESOLVED
    )


@pytest.mark.parametrize("args", list(RESOLVED.values()), ids=list(RESOLVED))
def test_every_long_run_command_resolves(args):
    import yaml
    from snakemake.utils import update_config

    from spl_al.config import check_config, drop_removed, select_datasets
    from spl_al.experiment.plan import check_plan

    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    user: dict = {}
    files = [args[i + 1] for i, w in enumerate(args[:-1]) if w == "--configfile"]
    for name in files:
        update_config(user, yaml.safe_load((ROOT / name).read_text()))
    update_config(config, user)
    drop_removed(config)
    select_datasets(config, user)
    check_config(config, ROOT / "config" / "schema.yaml")
    check_plan(config)
    targets = [
        w
        for i, w in enumerate(args)
        if not w.startswith("-") and (i == 0 or not args[i - 1].startswith("-")) and w not in files
    ]
    assert targets in ([], ["all"]) or all(t.startswith(config["results"]) for t in targets)
    if "--profile" in args:
        assert (ROOT / args[args.index("--profile") + 1] / "config.yaml").is_file()


@pytest.mark.parametrize("args", list(DRY_RUNS.values()), ids=list(DRY_RUNS))
def test_every_documented_command_dry_runs(args, tmp_path):
    """As a user runs it in a fresh clone: from a folder with no results/ and no
    .snakemake/ (the checkout's, complete or half-done, change nothing here)."""
    if (
        "profiles/slurm" in args
        and importlib.util.find_spec("snakemake_executor_plugin_slurm") is None
    ):
        pytest.skip("the SLURM executor plugin is not installed (pip install -e '.[cluster]')")
    env = {**os.environ, "SPL_AL_ESTIMATE": "0"}
    slurm = "profiles/slurm" in args
    cmd = [*SNAKEMAKE, "-n", *from_checkout(args), *([] if slurm else ["--quiet", "rules"])]
    run = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    if slurm:  # a round's train and the query it feeds: one submission, one group job
        assert "Group job round_real_cls_duis_1_0" in run.stdout + run.stderr
