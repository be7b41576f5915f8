#!/usr/bin/env python3
"""Two human-labeled rounds through a real Label Studio, start to finish.

    python scripts/label-studio-roundtrip.py --label-studio /opt/lsvenv/bin/label-studio

1. starts Label Studio on localhost (its data in a temporary folder, a user with an
   API token, legacy token authentication on);
2. runs the workflow on a small synthetic classification dataset with
   ``oracle: human`` until it waits for round 0's labels;
3. for round 0's batch and round 1's (whose tasks carry the round-0 model's
   predictions): creates a project from the batch's ``label_studio.xml``, imports its
   ``label_studio.json``, submits one annotation per task through the API (the hidden
   label of the synthetic sample: this script plays the annotator), exports the project
   as JSON into the labels folder and runs the workflow again;
4. does the same for a segmentation batch through the library (``write_batch`` ->
   Label Studio -> ``read_label_file``), brush masks included;
5. checks that round 1 trained on exactly the labels given, prints the timings and
   stops the server.

``--record DIR`` also saves the exports Label Studio made (the fixtures of
``tests/test_label_studio.py``). Needs Label Studio installed in its own virtual
environment (``python -m venv /opt/lsvenv && /opt/lsvenv/bin/pip install label-studio``);
this environment only needs spl-al and Snakemake.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TOKEN = "5f1e0c3a9b7d4e2f8a6c1b0d9e8f7a6b5c4d3e2f"
USER, PASSWORD = "annotator@example.com", "spl-al-roundtrip"

DATASET = """
    task: classification
    source: synthetic
    synthesis: {n_per_class: 5, image_shape: [32, 32], test_fraction: 0.3, seed: 0, workers: 1}
    variants: {n: 2, shards: 1, seed: 0}
    al: {initial: 6, batch: 4}
    method_params: {duis: {n_cand: 8}}  # at most half the 27 unlabeled samples
    train: {model: {arch: smallcnn}, fit: {epochs: 1, batch_size: 16}}
    experiments:
      budget: {methods: [duis], seeds: [1], rounds: 2}
"""


class LabelStudio:
    """A Label Studio server started here, and the few API calls this script makes."""

    def __init__(self, executable: str, workdir: Path, port: int):
        self.url = f"http://localhost:{port}"
        env = {
            **os.environ,
            "LABEL_STUDIO_DISABLE_SIGNUP_WITHOUT_LINK": "true",
        }
        self.log = open(workdir / "label-studio.log", "w")  # noqa: SIM115 (closed in stop)
        self.proc = subprocess.Popen(
            [
                executable,
                "start",
                "--no-browser",
                "--port",
                str(port),
                "--data-dir",
                str(workdir / "label-studio-data"),
                "--username",
                USER,
                "--password",
                PASSWORD,
                "--user-token",
                TOKEN,
                "--enable-legacy-api-token",
            ],
            env=env,
            stdout=self.log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )

    def wait(self, timeout_s: float = 600) -> float:
        started = time.perf_counter()
        while time.perf_counter() - started < timeout_s:
            if self.proc.poll() is not None:
                raise RuntimeError(f"Label Studio exited ({self.proc.returncode}); see its log.")
            try:
                self.call("GET", "/api/projects")
                return time.perf_counter() - started
            except (urllib.error.URLError, ConnectionError):
                time.sleep(2)
        raise RuntimeError(f"Label Studio did not answer within {timeout_s} s.")

    def call(self, method: str, path: str, body=None):
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(
            self.url + path,
            data=data,
            method=method,
            headers={"Authorization": f"Token {TOKEN}", "Content-Type": "application/json"},
        )
        with urllib.request.urlopen(request, timeout=120) as response:
            text = response.read().decode()
        return json.loads(text) if text else None

    def stop(self) -> None:
        os.killpg(self.proc.pid, 15)
        self.proc.wait(timeout=60)
        self.log.close()

    def label_batch(self, batch: Path, title: str, answer) -> tuple[int, list]:
        """Project from the batch's config, its tasks imported, one annotation per task
        (``answer(task)`` gives the annotation's result), then the JSON export."""
        config = (batch / "label_studio.xml").read_text()
        project = self.call("POST", "/api/projects", {"title": title, "label_config": config})
        tasks = json.loads((batch / "label_studio.json").read_text())
        self.call("POST", f"/api/projects/{project['id']}/import", tasks)
        stored = self.call("GET", f"/api/projects/{project['id']}/tasks?page_size=1000")
        stored = stored["tasks"] if isinstance(stored, dict) else stored
        for task in stored:
            body = {"result": answer(task), "was_cancelled": False, "ground_truth": False}
            self.call("POST", f"/api/tasks/{task['id']}/annotations", body)
        export = self.call("GET", f"/api/projects/{project['id']}/export?exportType=JSON")
        return project["id"], export


def snakemake(workdir: Path, *targets: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "snakemake", "-j2", *targets]
    cmd += ["--configfile", str(workdir / "config.yaml")]
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)


def choice(task: dict, classes, class_of: dict) -> list:
    name = classes[class_of[int(task["data"]["sample"])]]
    value = {"choices": [name]}
    return [{"from_name": "label", "to_name": "image", "type": "choices", "value": value}]


def classification_rounds(ls: LabelStudio, workdir: Path, record: Path | None) -> dict:
    from spl_al.data import Dataset

    results, labels = workdir / "results", workdir / "labels"
    (workdir / "config.yaml").write_text(
        f"results: {results}\ndevice: cpu\n"
        "datasets:\n  real_cls: null\n  synth_cls: null\n  street_seg: null\n"
        f"  hum:\n    oracle: human\n    labels_dir: {labels}{DATASET}"
    )
    target = str(results / "hum/duis/seed1/round1/metrics.json")
    times = {}
    started = time.perf_counter()
    run = snakemake(workdir, target)
    assert run.returncode != 0 and "waiting for labels" in run.stderr, run.stderr[-2000:]
    times["workflow to round 0's batch (s)"] = time.perf_counter() - started
    data = Dataset.load(results / "hum/data/dataset.npz")
    class_of = {int(u): int(c) for u, c in zip(data.uid, data.labels, strict=True)}
    if record is not None:  # what the tests need to read the recorded exports back
        train_uid = [int(u) for u in data.uid[data.train_idx]]
        facts = {"classes": data.classes, "train_uid": train_uid}
        facts["labels"] = {str(u): data.classes[class_of[u]] for u in train_uid}
        (record / "classification_dataset.json").write_text(json.dumps(facts, indent=1) + "\n")
    batches = [
        ("initial", results / "hum/initial/seed1/to_label", labels / "initial/seed1.json"),
        ("round1", results / "hum/duis/seed1/round1/to_label", labels / "duis/seed1/round1.json"),
    ]
    for name, batch, export_path in batches:
        started = time.perf_counter()
        tasks = json.loads((batch / "label_studio.json").read_text())
        has_predictions = all("predictions" in t for t in tasks)
        assert has_predictions == (name != "initial"), f"{name}: predictions {has_predictions}"
        _, export = ls.label_batch(
            batch, f"hum {name}", lambda t: choice(t, data.classes, class_of)
        )
        export_path.parent.mkdir(parents=True, exist_ok=True)
        export_path.write_text(json.dumps(export, indent=1))
        if record is not None:
            shutil.copy(export_path, record / f"classification_{name}_export.json")
        times[f"{name}: Label Studio project, import, annotate, export (s)"] = (
            time.perf_counter() - started
        )
        started = time.perf_counter()
        run = snakemake(workdir, target)
        done = name == "round1"
        assert (run.returncode == 0) == done, run.stderr[-3000:]
        times[f"{name}: workflow on the export (s)"] = time.perf_counter() - started
    given = np.load(results / "hum/duis/seed1/round1/labels.npz")
    pool = data.train_idx[given["pool_indices"]]
    assert np.array_equal(given["labels"], data.labels[pool]), "labels differ from those given"
    times["labels given"] = int(given["labels"].size)
    return times


def segmentation_batch(ls: LabelStudio, workdir: Path, record: Path | None) -> dict:
    """A segmentation batch through the library: brush masks both ways."""
    sys.path.insert(0, str(ROOT / "tests"))
    from helpers.label_studio_data import probabilities, segmentation_dataset

    from spl_al.labeling import read_label_file, write_batch
    from spl_al.labeling.label_studio import mask_to_rle

    started = time.perf_counter()
    data = segmentation_dataset()
    pool = np.array([0, 2, 3])
    batch = write_batch(
        data,
        pool,
        workdir / "seg/to_label",
        "round1.csv",
        probs=probabilities(data, pool),
        model_version="fixture model",
    )
    truth = {int(data.uid[data.train_idx[p]]): data.labels[data.train_idx[p]] for p in pool}
    h, w = data.image_shape

    def brush(task: dict) -> list:
        mask = truth[int(task["data"]["sample"])]
        out = []
        for k, name in enumerate(data.classes):
            if (mask == k).any():
                value = {"format": "rle", "rle": mask_to_rle(mask == k), "brushlabels": [name]}
                out.append(
                    {
                        "from_name": "label",
                        "to_name": "image",
                        "type": "brushlabels",
                        "original_width": w,
                        "original_height": h,
                        "image_rotation": 0,
                        "value": value,
                    }
                )
        return out

    project, export = ls.label_batch(batch, "segmentation", brush)
    path = workdir / "seg/round1.json"
    path.write_text(json.dumps(export, indent=1))
    got = read_label_file(path, data, pool)
    assert np.array_equal(got, np.stack([data.labels[data.train_idx[p]] for p in pool]))
    if record is not None:
        shutil.copy(path, record / "segmentation_export.json")
    return {
        "segmentation: write, Label Studio, read back (s)": time.perf_counter() - started,
        "segmentation project": project,
    }


def browser_step(ls: LabelStudio, workdir: Path, args) -> dict:
    """In a real browser: a screenshot of a task with its pre-annotations, and a brush
    stroke painted and submitted on another (the front end's own RLE), exported."""
    started = time.perf_counter()
    batch = workdir / "seg/to_label"
    config = (batch / "label_studio.xml").read_text()
    project = ls.call("POST", "/api/projects", {"title": "browser", "label_config": config})
    ls.call(
        "POST",
        f"/api/projects/{project['id']}/import",
        json.loads((batch / "label_studio.json").read_text()),
    )
    stored = ls.call("GET", f"/api/projects/{project['id']}/tasks?page_size=1000")
    stored = stored["tasks"] if isinstance(stored, dict) else stored
    ids = sorted(t["id"] for t in stored)
    python = Path(args.label_studio).with_name("python")
    browser = [str(python), str(ROOT / "scripts/label-studio-browser.py")]
    login = ["--user", USER, "--password", PASSWORD, "--width", "1280", "--height", "800"]
    page = f"{ls.url}/projects/{project['id']}/data?task="
    shot = args.screenshot or workdir / "label-studio-batch.png"
    subprocess.run([*browser, page + str(ids[0]), str(shot), *login], check=True)
    subprocess.run(
        [
            *browser,
            page + str(ids[1]),
            str(workdir / "painted.png"),
            *login,
            "--paint",
            "car",
            "--submit",
        ],
        check=True,
    )
    export = ls.call("GET", f"/api/projects/{project['id']}/export?exportType=JSON")
    painted = [t for t in export if t["annotations"]]
    assert len(painted) == 1 and any(
        r.get("origin") == "manual" for r in painted[0]["annotations"][0]["result"]
    ), "the browser's stroke is not in the export"
    path = workdir / "seg/browser_export.json"
    path.write_text(json.dumps(export, indent=1))
    if args.record is not None:
        shutil.copy(path, args.record / "segmentation_browser_export.json")
    return {"browser: screenshot, paint, submit, export (s)": time.perf_counter() - started}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label-studio", required=True, help="the label-studio executable")
    parser.add_argument("--port", type=int, default=8089)
    parser.add_argument("--workdir", type=Path, default=None, help="kept (default: temporary)")
    parser.add_argument("--record", type=Path, default=None, help="save the exports here")
    parser.add_argument("--keep-running", action="store_true", help="leave the server up")
    parser.add_argument(
        "--browser",
        action="store_true",
        help="also screenshot and paint in Chromium (Playwright in Label Studio's venv)",
    )
    parser.add_argument("--screenshot", type=Path, default=None, help="where to save it")
    args = parser.parse_args()
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="spl-al-ls-"))
    workdir.mkdir(parents=True, exist_ok=True)
    if args.record:
        args.record.mkdir(parents=True, exist_ok=True)
    total = time.perf_counter()
    ls = LabelStudio(args.label_studio, workdir, args.port)
    try:
        times = {"Label Studio start (s)": ls.wait()}
        times |= classification_rounds(ls, workdir, args.record)
        times |= segmentation_batch(ls, workdir, args.record)
        if args.browser:
            times |= browser_step(ls, workdir, args)
    finally:
        if not args.keep_running:
            ls.stop()
    times["total (s)"] = time.perf_counter() - total
    for key, value in times.items():
        print(f"{key}: {value:.1f}" if isinstance(value, float) else f"{key}: {value}")
    print(f"OK: two rounds labeled in Label Studio; work folder {workdir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
