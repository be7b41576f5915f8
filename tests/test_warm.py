"""Warm job processes: a job run through the server is the job run on its own (files,
log, exit code, streams, environment, numbers), and dies with its client."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from spl_al.warm.server import SOCKET_ENV, Server, plain, run_job, shared_server

JOBS = textwrap.dedent(
    """
    import os, sys, time

    def write(path, text, log=None):
        print("job pid", os.getpid(), "X =", os.environ.get("X"))
        print("to the terminal", file=sys.__stderr__)
        with open(path, "w") as f:
            f.write(f"{text} {os.getcwd()}")
        return {"wrote": path}

    def fail():
        raise ValueError("the input is wrong")

    def slow(path):
        time.sleep(3)
        open(path, "w").write("late")

    def weights(path):
        import io, torch
        from spl_al.models import build_model
        from spl_al.training import Compute, TrainConfig, train
        torch.manual_seed(0)
        x = torch.rand(16, 32, 32).numpy() * 5  # see spl_al.training.precision: no 1x1 maps
        model = build_model("classification", 2, width=4)
        cfg = TrainConfig(epochs=2, batch_size=8, log_every=0)
        at = Compute("cpu", precision="auto")
        train(model, x, x > 0, [0, 1] * 8, cfg=cfg, seed=1, compute=at, log=io.StringIO())
        torch.save(model.state_dict(), path)
    """
)

CLIENT = textwrap.dedent(
    """
    import sys
    from spl_al.warm.server import run_job
    run_job(sys.argv[1], "jobs:" + sys.argv[2], eval(sys.argv[3]), show=True)
    """
)


@pytest.fixture(scope="module")
def code(tmp_path_factory):
    """The folder of jobs.py and client.py, on the PYTHONPATH of the server and clients."""
    folder = tmp_path_factory.mktemp("warm_code")
    (folder / "jobs.py").write_text(JOBS)
    (folder / "client.py").write_text(CLIENT)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PYTHONPATH", f"{folder}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
        yield folder


@pytest.fixture
def folder(code, tmp_path, monkeypatch):
    """The test's own working folder: the client's, so the job's files land there."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.fixture(scope="module")
def server(code):
    """One server for the module's jobs (its imports cost seconds); jobs fork from it."""
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(SOCKET_ENV, raising=False)  # Server.start sets it; undone after the module
        srv = Server.start(code / "server.log")
        yield srv
        srv.stop()


def client(job, kwargs, env=None, wait=True):
    client_py = Path(os.environ["PYTHONPATH"].split(os.pathsep)[0]) / "client.py"
    args = [sys.executable, str(client_py), f"{job}.log", job, repr(kwargs)]
    env = {**os.environ, **(env or {})}
    if not wait:
        return subprocess.Popen(args, env=env)
    return subprocess.run(args, env=env, capture_output=True, text=True, timeout=60)


def test_a_job_through_the_server_writes_its_files_log_and_streams(server, folder):
    run = client("write", {"path": "out.txt", "text": "hi"}, env={"X": "42"})
    assert run.returncode == 0, run.stderr
    assert (folder / "out.txt").read_text() == f"hi {folder}"  # the client's folder
    log = (folder / "write.log").read_text()
    assert "X = 42" in log  # the client's environment
    pid = int(log.split("job pid ")[1].split()[0])
    assert pid != server.process.pid  # a forked child, not the server itself
    assert "{'wrote': 'out.txt'}" in log and log.rstrip().splitlines()[-1].startswith(
        "compute_seconds:"
    )
    assert "to the terminal" in run.stderr  # fd 2 is the client's


def test_a_failing_job_exits_1_with_its_one_sentence(server, folder):
    run = client("fail", {})
    assert run.returncode == 1
    assert "error: the input is wrong (log: fail.log)" in run.stderr
    assert "Traceback" not in run.stderr


def test_without_a_server_the_job_runs_in_its_own_process(folder, monkeypatch):
    monkeypatch.setenv(SOCKET_ENV, str(folder / "nobody-listens"))
    run = client("write", {"path": "out.txt", "text": "cold"})
    assert run.returncode == 0 and (folder / "out.txt").read_text().startswith("cold")


def test_killing_the_client_kills_its_job(server, folder):
    proc = client("slow", {"path": "late.txt"}, wait=False)
    time.sleep(1.0)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    time.sleep(3.5)
    assert not (folder / "late.txt").exists()


def test_a_warm_child_trains_the_weights_of_a_fresh_process(server, folder, monkeypatch):
    import torch

    assert client("weights", {"path": "warm.pt"}).returncode == 0
    monkeypatch.delenv(SOCKET_ENV)
    assert client("weights", {"path": "cold.pt"}).returncode == 0
    warm, cold = (torch.load(folder / f, weights_only=True) for f in ("warm.pt", "cold.pt"))
    assert all(torch.equal(warm[k], cold[k]) for k in cold)


def test_a_run_uses_a_server_started_before_it_and_leaves_it_running(server, monkeypatch):
    """A server named in the environment that imports what this process imports serves
    the run: ``for_run`` starts none and stops nothing. With warm jobs off, the run's
    jobs are told of no server at all (a cluster run's jobs must start fresh)."""
    monkeypatch.setenv(SOCKET_ENV, server.address)
    assert shared_server(server.address)
    assert Server.for_run(server.folder / "run.log", enabled=True) is None
    assert os.environ[SOCKET_ENV] == server.address and server.process.poll() is None
    assert not (server.folder / "run.log").exists()
    assert Server.for_run(server.folder / "run.log", enabled=False) is None
    assert SOCKET_ENV not in os.environ and server.process.poll() is None


def test_a_server_importing_something_else_is_not_shared(server, folder, monkeypatch):
    assert not shared_server(str(folder / "nobody-listens"))
    monkeypatch.setenv("PYTHONPATH", f"{folder}{os.pathsep}{os.environ['PYTHONPATH']}")
    assert not shared_server(server.address)  # its jobs would miss this folder
    monkeypatch.undo()
    # a socket left behind by a server that is gone (its pid exited, or none recorded)
    stale = folder / "stale"
    stale.write_text("")
    info = json.loads(Path(f"{server.address}.json").read_text())
    for pid in (
        subprocess.run(
            [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
        ).stdout.strip(),
        0,
    ):
        Path(f"{stale}.json").write_text(json.dumps({**info, "pid": int(pid)}))
        assert not shared_server(str(stale))


def test_a_standalone_server_stops_on_sigterm_and_removes_its_socket(folder):
    address = folder / "socket"
    code = f"from spl_al.warm.server import serve; serve({str(address)!r}, preload=())"
    proc = subprocess.Popen([sys.executable, "-c", code])
    deadline = time.monotonic() + 30
    while not shared_server(str(address)):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    proc.terminate()
    assert proc.wait(10) == 0
    assert not address.exists() and not Path(f"{address}.json").exists()


def test_snakemake_names_pickle_as_plain_values():
    class Name(str):
        pass

    class Names(list):
        pass

    value = plain({"a": Names([Name("x")]), "b": (1, Name("y"))})
    assert value == {"a": ["x"], "b": [1, "y"]}
    assert type(value["a"]) is list and type(value["a"][0]) is str


def test_run_job_in_process_passes_the_log(tmp_path, monkeypatch):
    monkeypatch.delenv(SOCKET_ENV, raising=False)
    seen = {}
    monkeypatch.setattr(
        "spl_al.warm.server.resolve", lambda target: lambda log: seen.update(log=log)
    )
    run_job(tmp_path / "job.log", "any:thing", {}, pass_log=True)
    assert seen["log"].name == str(Path(tmp_path / "job.log"))


# A workflow script as rules run it (`shell: python_job(NAME)`): it reads its job from
# `snakemake` and writes back what it saw.
SCRIPT = textwrap.dedent(
    """
    import json, os
    import numpy  # from site-packages, which the client's `python -S` leaves out at first
    s = snakemake
    seen = {
        "pid": os.getpid(),
        "input": list(s.input), "named": s.input.shards, "data": s.input.data,
        "get": [s.input.get("data"), s.input.get("model")], "has_model": hasattr(s.input, "model"),
        "output": dict(s.output.items()), "log": s.log[0], "threads": s.threads,
        "sweeps": {str(k): v for k, v in s.params.sweeps.items()},
        "key_types": sorted({type(k).__name__ for k in s.params.sweeps}),
        "seed": s.wildcards.seed,
    }
    open(s.output.seen, "w").write(json.dumps(seen))
    if s.params.fail:
        raise SystemExit(3)
    """
)


def script_job(folder: Path, fail=False) -> list[str]:
    """The command a rule runs for SCRIPT: python -S -P client.py SCRIPT LOG THREADS
    FILES SETTINGS, with the files written from Snakemake's own named lists."""
    from snakemake.iocontainers import Namedlist

    from spl_al.warm import client as warm_client

    (folder / "script.py").write_text(SCRIPT)
    inputs = Namedlist(toclone=["data.npz", "s0.npz", "s1.npz"])
    inputs._set_name("data", 0)
    inputs._set_name("shards", 1, end=3)
    outputs = Namedlist(fromdict={"seen": str(folder / "seen.json")})
    wildcards = Namedlist(fromdict={"seed": "7"})
    params = {"sweeps": {0.25: "duis_alpha0.25", 12: "duis"}, "fail": fail}
    files = warm_client.files_text(inputs, outputs, wildcards)
    settings = repr(warm_client.job_settings(params))
    client = [sys.executable, "-S", "-P", warm_client.__file__, str(folder / "script.py")]
    return [*client, str(folder / "job.log"), "3", files, settings]


@pytest.mark.parametrize("warm", [True, False])
def test_a_script_run_by_the_warm_client_reads_its_job_as_snakemake_gives_it(
    server, folder, monkeypatch, warm
):
    if not warm:
        monkeypatch.delenv(SOCKET_ENV)  # no server: the client runs the script itself
    proc = subprocess.Popen(script_job(folder), stderr=subprocess.PIPE, text=True)
    assert proc.wait(60) == 0, proc.stderr.read()
    seen = json.loads((folder / "seen.json").read_text())
    # a child forked from the server, or the client itself without one
    assert (seen["pid"] not in (proc.pid, server.process.pid)) if warm else seen["pid"] == proc.pid
    assert seen["input"] == ["data.npz", "s0.npz", "s1.npz"]
    assert seen["named"] == ["s0.npz", "s1.npz"] and seen["data"] == "data.npz"
    assert seen["get"] == ["data.npz", None] and not seen["has_model"]
    assert seen["output"] == {"seen": str(folder / "seen.json")}
    assert seen["log"] == str(folder / "job.log") and seen["threads"] == 3
    # number keys come back as numbers (a JSON job would have made them strings)
    assert seen["sweeps"] == {"0.25": "duis_alpha0.25", "12": "duis"}
    assert seen["key_types"] == ["float", "int"] and seen["seed"] == "7"
    failed = subprocess.run(script_job(folder, fail=True), capture_output=True, timeout=60)
    assert failed.returncode == 3


def test_a_job_with_params_that_do_not_read_back_is_refused(tmp_path):
    from spl_al.warm import client as warm_client

    with pytest.raises(ValueError, match="plain values"):
        warm_client.job_settings({"path": tmp_path})
