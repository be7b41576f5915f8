"""The framework and feature-space declarations (spl_al.frameworks) are the only place
either is named: a scan of src/ and workflow/ finds no literal of theirs elsewhere, and
a framework registered here reaches the plan, the outputs `all` asks for and the
tables, as the table-kind contract test does for a table kind."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import pandas as pd
import pytest
import yaml

from spl_al import frameworks
from spl_al.experiment.outputs import framework_outputs
from spl_al.experiment.plan import check_plan, dataset_runs, experiments_of
from spl_al.experiment.report_steps import framework_notes, make_table
from spl_al.frameworks import FrameworkKind, register_framework, unregister_framework
from spl_al.report import load_records
from spl_al.report.claims import COLUMNS, render_claims_markdown

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "spl_al"
DECLARATION = SRC / "frameworks.py"


def _names() -> set[str]:
    """Framework names and the feature spaces' names that no other word shares
    (``model`` is every config's model key too: its comparisons are scanned instead)."""
    spaces = set(frameworks.feature_space_names()) - {frameworks.MODEL_FEATURES.name}
    return set(frameworks.framework_names()) | spaces


def _feature_comparison(node: ast.AST) -> bool:
    """``x.features == "..."`` (or ``!=``, ``in``) against a string literal."""
    if not isinstance(node, ast.Compare):
        return False
    sides = [node.left, *node.comparators]
    named = any(isinstance(s, ast.Attribute) and s.attr == "features" for s in sides)
    literal = any(isinstance(s, ast.Constant) and isinstance(s.value, str) for s in sides)
    return named and literal


def test_no_module_of_src_names_a_framework_or_feature_space_by_a_literal():
    names = _names()
    found = []
    for path in sorted(SRC.rglob("*.py")):
        if path == DECLARATION:
            continue
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Constant) and node.value in names:
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.value!r}")
            elif _feature_comparison(node):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: features compared")
    assert not found, "name them through spl_al.frameworks:\n" + "\n".join(found)


def test_no_workflow_file_names_a_framework_or_feature_space_by_a_literal():
    names = "|".join(sorted(_names()))
    literal = re.compile(rf"""["']({names})["']|/({names})/|\.features\s*[!=]=""")
    files = [ROOT / "Snakefile", *sorted((ROOT / "workflow").rglob("*.smk"))]
    files += sorted((ROOT / "workflow" / "scripts").glob("*.py"))
    found = [
        f"{path.relative_to(ROOT)}:{i}: {line.strip()}"
        for path in files
        for i, line in enumerate(path.read_text().splitlines(), 1)
        if literal.search(line.split("#")[0])
    ]
    assert not found, "name them through spl_al.frameworks:\n" + "\n".join(found)


def test_the_scan_catches_a_literal():
    """The source scan is not vacuous: the code it reads would be flagged."""
    tree = ast.parse('if method.features == "embedding":\n    kind = "supervised"\n')
    assert sum(_feature_comparison(n) for n in ast.walk(tree)) == 1
    assert {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant)} <= _names()


def test_a_name_is_registered_once_and_an_unknown_one_is_refused():
    with pytest.raises(ValueError, match="already registered"):
        register_framework(frameworks.EMBEDDING)
    with pytest.raises(ValueError, match="framework must be one of"):
        frameworks.get_framework("fewshot")
    with pytest.raises(ValueError, match="features must be one of"):
        frameworks.get_feature_space("pixels")
    with pytest.raises(ValueError, match="built in"):
        unregister_framework(frameworks.SUPERVISED.name)


def test_the_schema_lists_exactly_the_registered_names():
    """config/schema.yaml is the one other place the names are written (a config is
    checked against it before any job runs): a method's ``features`` and an
    experiment's ``framework`` key list exactly the registered ones."""
    schema = yaml.safe_load((ROOT / "config" / "schema.yaml").read_text())
    method = schema["properties"]["methods"]["additionalProperties"]["properties"]
    assert method["features"]["enum"] == list(frameworks.feature_space_names())
    budget = schema["$defs"]["dataset"]["properties"]["experiments"]["properties"]["budget"]
    assert budget["properties"]["framework"]["enum"] == list(frameworks.framework_names())


def test_the_builtin_kinds_keep_their_config_and_results_layout():
    entry = {
        "experiments": {"budget": {"seeds": [1]}},
        "embedding": {"encoder": {"steps": 5}, "experiments": {"levels": {"round": 1}}},
    }
    assert frameworks.SUPERVISED.experiments(entry) == {"budget": {"seeds": [1]}}
    assert frameworks.EMBEDDING.experiments(entry) == {"levels": {"round": 1}}
    assert frameworks.EMBEDDING.key == "embedding.experiments"
    assert frameworks.EMBEDDING.settings(entry)["encoder"] == {"steps": 5}
    assert frameworks.SUPERVISED.folder("results", "d") == "results/d"
    assert frameworks.EMBEDDING.folder("results", "d") == "results/d/embedding"
    assert not frameworks.EMBEDDING.enabled({"experiments": {}})


FEWSHOT = FrameworkKind(
    "fewshot",
    ("fewshot", "experiments"),
    block="fewshot",
    subfolder="fewshot",
    model="a nearest-class-mean classifier on the encoder's embeddings",
    short="nearest class mean",
    measured_at="fp32",
    features=frameworks.EMBEDDING_FEATURES.name,
)


def _record(method: str, seed: int, r: int) -> dict:
    value = 0.5 + 0.05 * r + (0.05 if method == "duis" else 0.0)
    return {
        "dataset": "real_cls",
        "method": method,
        "seed": seed,
        "round": r,
        "n_labeled": (20, 40)[r],
        "n_total": 200,
        "metric": "accuracy",
        "value": value,
        "per_level": {},
        "synthetic_standin": False,
        "framework": FEWSHOT.name,
    }


def test_a_third_framework_reaches_the_plan_the_outputs_and_the_tables(tmp_path):
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    entry = config["datasets"]["real_cls"]
    budget = {"methods": ["random", "duis"], "seeds": [1, 2], "rounds": 2}
    entry["fewshot"] = {"experiments": {"budget": budget}}
    register_framework(FEWSHOT)
    try:
        # the plan: its runs, its experiments as run, and its methods checked
        runs = dataset_runs(config, "real_cls", FEWSHOT.name)
        assert runs == {(m, s): 2 for m in ("random", "duis") for s in (1, 2)}
        assert experiments_of(config, "real_cls", framework=FEWSHOT)["budget"]["methods"][-1] == (
            "duis"
        )
        check_plan(config)
        entry["fewshot"]["experiments"]["budget"] = {**budget, "methods": ["nobody"]}
        with pytest.raises(ValueError, match="'nobody' is not defined"):
            check_plan(config)
        entry["fewshot"]["experiments"]["budget"] = budget

        # the outputs `all` asks for, in its own subfolder
        out = framework_outputs(config, "real_cls", FEWSHOT, results="R")
        assert "R/real_cls/fewshot/tables/budget.csv" in out
        assert "R/real_cls/fewshot/tables/summary.json" in out
        assert "R/real_cls/fewshot/figures/curves.png" in out
        assert all(p.startswith("R/real_cls/fewshot/") for p in out)

        # the tables: its records load, and its note reaches the caption and the claims
        paths = []
        for m, s in runs:
            for r in range(2):
                path = tmp_path / f"{m}_{s}_{r}.json"
                path.write_text(json.dumps(_record(m, s, r)))
                paths.append(path)
        df = load_records(paths)
        assert framework_notes(df) == [FEWSHOT.note]
        make_table(
            paths,
            "budget",
            experiments={"budget": budget},
            sweeps={},
            out_stem=tmp_path / "budget",
        )
        assert FEWSHOT.note in (tmp_path / "budget.md").read_text()
        row = dict.fromkeys(COLUMNS, "")
        row.update(verdict="supported", rule="5%", unit="seed", source="paper", min_n=2)
        claims = pd.DataFrame([{**row, "framework": FEWSHOT.name, "precision": "fp32"}])
        title = render_claims_markdown(claims, "real_cls").splitlines()[0]
        assert title == (
            "**Claims checked on real_cls in the fewshot framework (a nearest-class-mean "
            "classifier on the encoder's embeddings, fp32).**"
        )
    finally:
        unregister_framework(FEWSHOT.name)
    # once it is gone, its records are refused by name
    with pytest.raises(ValueError, match="key 'framework' must be one of"):
        load_records(paths)
