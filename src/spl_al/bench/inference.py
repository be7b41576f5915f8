"""Inference speed of the default models in torch and in onnxruntime on this CPU.

python -m spl_al.bench inference [--config config/config.yaml] [--threads 2] [--batch 64]

For every dataset of the config, its model (architecture and parameters, seeded
weights: speed does not depend on what was learned) at the dataset's image shape, fed
raw depth through ``DeployGraph`` (the preprocessing included, as ``predict`` and the
exported ONNX graph run it): the median single-frame latency (batch 1) and the
throughput of one batch, in torch and in onnxruntime (the graph ``export`` writes,
traced here without the test-split check). PointNet++ runs in torch only (not
exportable, ``spl_al.deploy.export``). The inputs are random depth images with 10%
voids; no dataset is read.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from spl_al.bench.timing import markdown_table, median_seconds
from spl_al.deploy.bundle import onnx_session
from spl_al.deploy.export import NOT_EXPORTED, write_onnx
from spl_al.scenes.objects import CATEGORIES
from spl_al.scenes.raycast import ScanGrid
from spl_al.scenes.street import STREET_CLASSES


def _models(config_path: Path):
    """(dataset, task, model_cfg, image_shape, n_classes, grid) of each config dataset."""
    import yaml

    config = yaml.safe_load(config_path.read_text())
    for name, entry in config["datasets"].items():
        task = entry.get("task", "classification")
        shape = tuple(entry.get("synthesis", {}).get("image_shape", (64, 64)))
        n_classes = len(CATEGORIES) if task == "classification" else len(STREET_CLASSES)
        yield name, task, dict(entry.get("train", {}).get("model", {})), shape, n_classes


def _build(task, model_cfg, shape, n_classes):
    # torch on demand (importing this module does not load it)
    from spl_al.models import build_model, needs_grid

    cfg = dict(model_cfg)
    arch = cfg.pop("arch", None)
    if needs_grid(task, arch):
        cfg["grid"] = ScanGrid(shape, (8.0, -22.0), (-45.0, 45.0))
    return build_model(task, n_classes, arch=arch, seed=0, **cfg).eval()


def _frames(n: int, shape, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    depth = rng.uniform(2.0, 60.0, size=(n, *shape)).astype(np.float32)
    depth[rng.random(depth.shape) < 0.1] = np.nan
    return depth


def _time(run, single, batch, repeats) -> tuple[float, float]:
    latency = median_seconds(lambda: run(single), repeats=repeats, warmup=2)
    batch_s = median_seconds(lambda: run(batch), repeats=max(3, repeats // 4), warmup=1)
    return latency, len(batch) / batch_s


def bench_one(task, model_cfg, *, shape, n_classes, threads, batch_size, repeats) -> dict:
    """Latency (ms) and throughput (frames/s) of one model in torch and onnxruntime."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.deploy.graph import DeployGraph

    torch.set_num_threads(threads)
    model = _build(task, model_cfg, shape, n_classes)
    graph = DeployGraph(model)
    single, batch = _frames(1, shape), _frames(batch_size, shape, seed=1)

    def torch_run(depth):
        with torch.inference_mode():
            graph(torch.from_numpy(depth))

    out = {"torch": _time(torch_run, single, batch, repeats)}
    if getattr(model, "arch", "") not in NOT_EXPORTED:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "model.onnx"
            write_onnx(model, path, shape)
            session = onnx_session(path, threads)
            out["onnxruntime"] = _time(
                lambda d: session.run(None, {"depth_m": d}), single, batch, repeats
            )
    return out


def main(argv: list[str]) -> int:
    """Print the inference table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench inference")
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument("--threads", type=int, default=2, help="torch / onnxruntime threads")
    parser.add_argument("--batch", type=int, default=64, help="frames of the throughput batch")
    parser.add_argument("--repeats", type=int, default=21, help="single-frame repeats")
    args = parser.parse_args(argv)
    rows = []
    for name, task, cfg, shape, n_classes in _models(args.config):
        result = bench_one(
            task,
            cfg,
            shape=shape,
            n_classes=n_classes,
            threads=args.threads,
            batch_size=args.batch,
            repeats=args.repeats,
        )
        for backend, (latency_s, fps) in result.items():
            frame = f"{shape[0]}x{shape[1]}"
            timing = [f"{1000 * latency_s:.2f}", f"{fps:.0f}"]
            rows.append([name, cfg.get("arch", "default"), frame, backend, *timing])
        print(f"{name}: done", flush=True)
    header = ["dataset", "model", "frame", "runtime", "latency (ms, batch 1)"]
    header.append(f"throughput (frames/s, batch {args.batch})")
    print(markdown_table(header, rows))
    return 0
