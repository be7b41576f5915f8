"""The Snakemake workflow: dry runs and config validation."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
import yaml
from helpers.snakemake_cli import SNAKEMAKE

from spl_al.config import drop_removed

ROOT = Path(__file__).resolve().parents[1]
pytestmark = [
    pytest.mark.slow,
    pytest.mark.usefixtures("warm_server"),  # tests/conftest.py: one server for every run
    pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed"),
]


def snakemake(*args):
    """Snakemake on this checkout's Snakefile from a folder of its own (results/ and
    .snakemake/ there, not in the checkout)."""
    with tempfile.TemporaryDirectory(prefix="spl-al-test-") as workdir:
        return subprocess.run([*SNAKEMAKE, *args], cwd=workdir, capture_output=True, text=True)


def test_unknown_config_key_fails_before_any_job_with_the_key_named():
    run = snakemake("-n", "--cores", "1", "--config", "bogus_key=1")
    assert run.returncode != 0
    assert "bogus_key" in run.stderr


def effective_config(tmp_path, *args) -> dict:
    """The configuration Snakemake really ran with: its run_config job writes it."""
    results = tmp_path / "results"
    run = snakemake(str(results / "config.yaml"), "-j1", *args, "--config", f"results={results}")
    assert run.returncode == 0, run.stderr[-3000:]
    written = yaml.safe_load((results / "config.yaml").read_text())
    # what precision each dataset's models ran at, beside the configuration itself
    used = written.pop("precision_used")
    assert set(used) == set(written["datasets"])
    assert set(used.values()) <= {"fp32", "bf16", "fp16"}
    return written


def test_override_file_changes_only_the_values_it_names(tmp_path):
    override = tmp_path / "override.yaml"
    override.write_text("device: cpu\ndatasets:\n  real_cls: {al: {batch: 7}}\n")
    got = effective_config(tmp_path, "--configfile", str(override))

    expected = drop_removed(yaml.safe_load((ROOT / "config" / "config.yaml").read_text()))
    expected["device"] = "cpu"
    expected["datasets"]["real_cls"]["al"]["batch"] = 7
    expected["results"] = str(tmp_path / "results")
    for name in [n for n in expected["datasets"] if n not in expected["only_datasets"]]:
        del expected["datasets"][name]  # defined, not in the default run
    assert got == expected


def test_a_missing_real_captures_folder_is_one_line_naming_the_variable(tmp_path):
    env = {**os.environ, "SPL_AL_REAL_CAPTURES": str(tmp_path / "nowhere")}
    run = subprocess.run(
        [*SNAKEMAKE, "-n", "--cores", "1"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
    )
    assert run.returncode != 0
    assert "environment variable SPL_AL_REAL_CAPTURES names" in run.stderr


def test_real_capture_pictures_take_npy_and_hdf5_cubes_with_the_configured_timing(tmp_path):
    """photon.real_captures: .npy and HDF5 cubes are pictured, read with
    photon.real_capture_options; another file is named in one line; a cube without a
    bin width stops the run before any job, naming the key to set."""
    import h5py
    import numpy as np

    folder = tmp_path / "real"
    folder.mkdir()
    cube = np.zeros((8, 8, 64), np.uint16)
    cube[..., 10] = 3
    np.save(folder / "a.npy", cube)
    with h5py.File(folder / "b.h5", "w") as f:
        f.create_dataset("counts", data=cube)
    (folder / "notes.txt").write_text("not a capture")
    results = tmp_path / "results"
    targets = [str(results / "photon" / "real" / f"{name}.png") for name in ("a", "b")]
    photon = {"real_captures": str(folder), "real_capture_options": {"bin_width_ps": 80}}
    override = tmp_path / "pictures.yaml"
    override.write_text(yaml.safe_dump({"photon": photon}))
    args = ("--configfile", str(override), "--config", f"results={results}")
    run = snakemake("-n", "-p", "--cores", "1", *targets, *args)
    assert run.returncode == 0, run.stderr[-3000:]
    out = run.stdout + run.stderr
    assert out.count("rule photon_real_capture:") == 2
    assert "--real " in out and "--bin-width-ps 80" in out
    assert "notes.txt is not read, not a capture format (supported: .mat, .ptu, HDF5" in out

    override.write_text(yaml.safe_dump({"photon": {"real_captures": str(folder)}}))
    run = snakemake("-n", "--cores", "1", *targets, *args)
    assert run.returncode != 0
    assert "a.npy: a count cube that states no bin width" in run.stderr
    assert "set photon.real_capture_options.bin_width_ps" in run.stderr


def test_every_script_runs_through_the_warm_client():
    """A rule that runs a workflow script does it with `shell: python_job(NAME)`:
    Snakemake's `script:` would import Snakemake in every job's process (~0.25 CPU-s a
    job); each named script exists, and no script is left without a rule."""
    rules = "\n".join(p.read_text() for p in sorted((ROOT / "workflow" / "rules").rglob("*.smk")))
    assert not re.search(r"^\s+script:", rules, re.MULTILINE)
    named = re.findall(r'python_job\("(\w+)"\)', rules)
    scripts = {p.stem for p in (ROOT / "workflow" / "scripts").glob("*.py")}
    assert sorted(set(named)) == sorted(scripts)  # (curves and query serve two rules each)
    # every such rule hands its params over as the job (python_job's command reads them
    # and nothing else), a rule derived with `use rule ... with:` included
    assert len(re.findall(r"^\s+job=job_params\(", rules, re.MULTILINE)) >= len(named)
    blocks = re.split(r"^(?=rule |use rule )", rules, flags=re.MULTILINE)
    jobs = [b for b in blocks if "python_job(" in b or b.startswith("use rule ")]
    for block in jobs:
        params = re.search(r"^\s+params:\n\s+(\S[^\n]*)", block, re.MULTILINE)
        assert params is None or params[1].startswith("job=job_params("), block
        # ... and its files: the script's snakemake.input, .output and .wildcards
        assert params is None or re.search(r"^\s+files=job_files,$", block, re.MULTILINE)


def test_common_smk_holds_only_what_rule_files_share():
    """workflow/rules/common.smk stays the shared part (at most 250 lines, the
    snakemake-workflows layout's size); a rule file's own functions live in
    workflow/rules/functions/ under its name, and no file mixes rules and functions
    (snakemake --lint)."""
    rules = ROOT / "workflow" / "rules"
    assert len((rules / "common.smk").read_text().splitlines()) <= 250
    functions = {p.stem for p in (rules / "functions").glob("*.smk")}
    assert functions <= {p.stem for p in rules.glob("*.smk")}
    for path in [*rules.glob("*.smk"), *(rules / "functions").glob("*.smk")]:
        text = path.read_text()
        defines = re.search(r"^def ", text, re.MULTILINE)
        has_rules = re.search(r"^(rule|use rule) ", text, re.MULTILINE)
        assert not (defines and has_rules), f"{path.name} mixes rules and functions"


def _merged(base: dict, over: dict) -> dict:
    out = dict(base)
    for key, value in over.items():
        out[key] = _merged(out.get(key) or {}, value) if isinstance(value, dict) else value
    return out


def test_a_dataset_in_the_embedding_framework_alone_plans_no_supervised_report(tmp_path):
    """A lab that wants the fast framework alone (`experiments: {}`) gets its encoders,
    runs and reports, and no supervised summary that would find no metrics."""
    default = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    ci = yaml.safe_load((ROOT / "config" / "ci.yaml").read_text())
    entry = _merged(default["datasets"]["real_cls"], ci["datasets"]["real_cls"])
    entry["experiments"] = {}
    override = tmp_path / "lab.yaml"
    override.write_text(
        yaml.safe_dump({"only_datasets": ["lab_cls"], "datasets": {"lab_cls": entry}})
    )
    args = ("--configfile", str(ROOT / "config" / "ci.yaml"), str(override))
    run = snakemake("-n", "--cores", "1", *args, "--config", f"results={tmp_path / 'r'}")
    assert run.returncode == 0, run.stderr[-3000:]
    jobs = {
        line.split()[0]
        for line in run.stdout.splitlines()
        if line.strip() and line.split()[-1].isdigit()
    }
    assert {"encoder", "probe_runs", "embedding_stats", "embedding_summary"} <= jobs
    assert not jobs & {"summary", "train", "train_initial", "stats", "table"}
