"""torch.compile of a training step: ``python -m spl_al.bench compile [--steps N]``.

For the real_cls classifier and the street_seg U-Net (config/config.yaml's models, each
recipe's batch; the U-Net on its half-width crops), fp32, one CPU thread (as a ``-j2``
job trains): milliseconds per SGD step (forward, masked cross-entropy, backward,
update: ``spl_al.training``'s own step, without input building and augmentation),
eager and under ``torch.compile`` (inductor, default mode), and the seconds the first
compiled step takes in a fresh process, as a job would pay it: once with an empty
inductor cache, once with the cache the first process left on disk. Each measurement
runs in its own Python process.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from spl_al.bench.timing import markdown_table
from spl_al.bench.training import ROOT, case_model, random_data

CASES = {"classifier (real_cls)": "real_cls", "U-Net (street_seg)": "street_seg"}


def _case(dataset: str) -> tuple[str, dict, int, tuple[int, int]]:
    """(task, model cfg, batch, input shape) of a dataset's default model."""
    data = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["datasets"][dataset]
    fit = data["train"]["fit"]
    height, width = data["synthesis"]["image_shape"]
    width = round(width * fit.get("crop_width", 1.0))
    return data["task"], data["train"]["model"], int(fit["batch_size"]), (height, width)


def time_steps(dataset: str, steps: int) -> dict:
    """Eager and compiled ms/step of one model, and the first compiled step's seconds."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.models import model_input, training_outputs
    from spl_al.training.fit import masked_cross_entropy

    torch.set_num_threads(1)
    torch.manual_seed(0)
    task, model_cfg, batch, shape = _case(dataset)
    n_classes = 11 if task == "classification" else 8
    depth, valid, targets = random_data(task, shape, n=batch, n_classes=n_classes)
    model = case_model(task, model_cfg, shape, n_classes).train()
    x, y = model_input(model, depth, valid), torch.from_numpy(targets).long()
    opt = torch.optim.SGD(model.parameters(), lr=0.01, momentum=0.9)

    def step(net) -> None:
        logits, yb = training_outputs(net, x, y)
        loss = masked_cross_entropy(logits, yb, None)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    def ms_per_step(net) -> float:
        for _ in range(3):  # warm-up
            step(net)
        start = time.perf_counter()
        for _ in range(steps):
            step(net)
        return (time.perf_counter() - start) / steps * 1e3

    eager = ms_per_step(model)
    compiled = torch.compile(model)
    start = time.perf_counter()
    step(compiled)
    first = time.perf_counter() - start
    return {"eager_ms": eager, "compiled_ms": ms_per_step(compiled), "first_s": first}


def main(argv: list[str]) -> int:
    """Time each case in fresh processes (empty cache, then warm); print the table."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench compile", description=__doc__)
    parser.add_argument("--steps", type=int, default=40, help="timed steps per measurement")
    parser.add_argument("--only", default=None, help="cases whose label contains this text")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:  # one measurement, in its own process
        print(json.dumps(time_steps(args.child, args.steps)))
        return 0
    rows = []
    for label, dataset in CASES.items():
        if args.only and args.only not in label:
            continue
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "TORCHINDUCTOR_CACHE_DIR": str(Path(cache))}
            for state in ("empty", "warm"):
                cmd = [sys.executable, "-m", "spl_al.bench", "compile", "--child", dataset,
                       "--steps", str(args.steps)]  # fmt: skip
                out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
                got = json.loads(out.stdout.strip().splitlines()[-1])
                rows.append(
                    [label, state, f"{got['first_s']:.1f}", f"{got['eager_ms']:.1f}",
                     f"{got['compiled_ms']:.1f}", f"{got['eager_ms'] / got['compiled_ms']:.2f}"]
                )  # fmt: skip
                print(" | ".join(rows[-1]), flush=True)
    print()
    header = ["model", "inductor cache", "first compiled step s", "eager ms/step"]
    print(markdown_table([*header, "compiled ms/step", "x eager"], rows))
    print(f"\nfp32, 1 thread, load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores.")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
