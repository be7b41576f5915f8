"""What the plan says changed since the last run into a results folder."""

from __future__ import annotations

from spl_al.config import write_config
from spl_al.experiment import provenance


def test_changes_name_each_changed_leaf_and_each_entry_added_or_removed():
    recorded = {
        "methods": {"duis": {"params": {"alpha": 0.5, "n_cand": 80}}},
        "datasets": {"a": {"al": {"batch": [3, 3]}}, "gone": {"task": "x"}},
        "results": "results",
    }
    current = {
        "methods": {"duis": {"params": {"alpha": 0.4, "n_cand": 80}}},
        "datasets": {"a": {"al": {"batch": [3, 4]}}, "new": {"task": "y"}},
        "results": "results",
    }
    assert provenance.config_changes(recorded, current) == [
        "datasets.a.al.batch [3, 3] -> [3, 4]",
        "datasets.gone removed",
        "datasets.new added",
        "methods.duis.params.alpha 0.5 -> 0.4",
    ]
    assert provenance.config_changes(current, current) == []


def test_the_plan_reads_the_folders_config_and_leaves_out_what_the_run_found(tmp_path):
    config = {"device": "cpu", "methods": {"duis": {"params": {"alpha": 0.5}}}}
    path = tmp_path / "results" / "config.yaml"
    assert provenance.changes_text(path, config) is None  # no earlier run
    write_config({**config, "precision_used": {"a": "bf16"}}, path)
    assert provenance.changes_text(path, config) is None  # precision_used is no setting
    assert not provenance.older_results(path)
    changed = {"device": "cpu", "methods": {"duis": {"params": {"alpha": 0.4}}}}
    text = provenance.changes_text(path, changed)
    assert text.splitlines() == [
        f"Changed since the last run into {path.parent}/ (its config.yaml):",
        "  methods.duis.params.alpha 0.5 -> 0.4",
    ]


def test_many_changes_are_listed_up_to_a_dozen_then_counted(tmp_path):
    path = tmp_path / "config.yaml"
    write_config({f"k{i:02d}": 0 for i in range(20)}, path)
    text = provenance.changes_text(path, {f"k{i:02d}": 1 for i in range(20)})
    lines = text.splitlines()
    assert len(lines) == 1 + provenance.SHOWN + 1 and lines[-1] == "  ... and 8 more"


def test_a_folder_of_an_older_spl_al_is_told_apart(tmp_path):
    path = tmp_path / "config.yaml"
    assert not provenance.older_results(path)  # no folder yet: nothing to say
    path.write_text("# The configuration this run used.\ndevice: cpu\n")
    assert provenance.older_results(path)
    sentence = provenance.OLDER_RESULTS.format(results="results")
    assert sentence.count(". ") == 0 and "--rerun-triggers mtime input" in sentence


def test_the_jobs_line_counts_the_jobs_whose_settings_changed():
    assert provenance.rerun_line(0) == ""
    assert "24 because a setting they read changed" in provenance.rerun_line(24)
