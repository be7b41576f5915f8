"""Warm job processes: run each workflow step in a child forked from a process that has
already imported torch, numpy, scikit-learn and the library.

A job of the workflow is a fresh Python process, and ~1.5 s of a training job's
start-up is ``import torch`` and friends: a fifth of a default run's core time went
to imports before this module. Here one server process imports them once and waits on
a Unix socket; each job's process (the client) connects, hands over its standard
streams, working folder and environment, and the server forks a child that runs the
step and reports its exit code. Fork copies the imported modules in ~10 ms, so a job
starts in about the time of an empty Python.

What does not change: every job stays its own Snakemake job (its own inputs, outputs,
log, benchmark and exit code), its output goes to the job's own stdout/stderr (the
file descriptors are passed over the socket), a job killed by Snakemake takes its
child with it, and the numbers are the same bit for bit (the parent never runs a
torch operation, so each child starts from the state of a fresh import; every draw
is seeded explicitly). Without a server (``SPL_AL_WARM_SOCKET`` unset or nobody
listening), ``run_job`` runs the step in its own process as before.

The server is local by nature: the workflow starts it only for local execution (not
on a cluster, not with per-rule conda environments). POSIX only (fork, SCM_RIGHTS).

One server can serve several runs: started on its own (``python -m
spl_al.warm.server SOCKET``, until SIGTERM) with ``$SPL_AL_WARM_SOCKET`` naming its
socket, every run started from that shell uses it instead of importing everything again
(~7 CPU-s on a 2-core AVX2 laptop), and leaves it running. A run uses it only when it
would import the same library: same Python environment (``sys.prefix``), same
``PYTHONPATH`` and the same ``spl_al`` folder (``SOCKET.json`` beside the socket says
which); otherwise it starts its own as usual.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import os
import pickle
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

from spl_al.warm.client import (
    CODE,
    LENGTH,
    SOCKET_ENV,
    Job,
    recv_exactly,
    run_in_server,
    run_script,
)
from spl_al.warm.joblog import job_log

FOLDER_PREFIX = "spl-al-warm-"
"""The name of the private folder ``Server.start`` makes for a server's socket."""

PRELOAD = (
    "numpy",
    "torch",
    "sklearn.cluster",
    "scipy.spatial",
    "pandas",
    "matplotlib.pyplot",
    "matplotlib.backends.backend_pdf",  # every figure is also saved as PDF
    "torch.onnx",  # the export step: ~0.5 s of its first export is these imports
    "onnx",  # (not onnxruntime: importing it starts a thread, and fork copies none)
    "spl_al.deploy.export",
    "spl_al.data",
    "spl_al.training",
    "spl_al.scoring",
    "spl_al.strategies",
    "spl_al.experiment.data_steps",
    "spl_al.experiment.round0",
    "spl_al.experiment.round_steps",
    "spl_al.experiment.report_steps",
    "spl_al.report",
)
"""What the server imports once: everything a step of the workflow imports."""


def resolve(target: str):
    """The function named ``"package.module:function"``."""
    module, _, name = target.partition(":")
    if not name:
        raise ValueError(f"job target must read 'module:function', got {target!r}.")
    return getattr(importlib.import_module(module), name)


def execute(request: dict) -> None:
    """Run one job in this process: a workflow script with its job's ``snakemake``
    object (a request of ``spl_al.warm.client``), or ``target(**kwargs)`` inside ``job_log``
    (its output to the log file, ``compute_seconds`` last), with the open log as
    ``log=`` when ``pass_log``, and its return value printed to the log when ``show``."""
    if "script" in request:
        run_script(request["script"], Job(*request["job"]))
        return
    func = resolve(request["target"])
    with job_log(request["log_path"], preload=request.get("preload", ())) as log:
        extra = {"log": log} if request.get("pass_log") else {}
        result = func(**request["kwargs"], **extra)
        if request.get("show"):
            print(result)


def plain(value):
    """``value`` with str and list subclasses (Snakemake's file names and named lists)
    turned into plain str, list and dict, so that it pickles without Snakemake."""
    if isinstance(value, str):
        return str(value)
    if isinstance(value, dict):
        return {plain(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    return value


def run_job(
    log_path, target: str, kwargs: dict, *, preload=(), pass_log: bool = False, show: bool = False
) -> None:
    """Run ``target(**kwargs)`` as one job: in a warm child when a server listens at
    ``$SPL_AL_WARM_SOCKET``, else here. Exits with the job's code when it fails.

    Args:
        log_path: the job's log file (``job_log``).
        target: ``"package.module:function"``.
        kwargs: its keyword arguments (picklable: paths as str, numbers, dicts).
        preload: modules to import before the job's clock starts (``job_log``).
        pass_log: give the open log stream to the function as ``log=``.
        show: print the function's return value into the log.
    """
    request = {
        "log_path": str(log_path),
        "target": target,
        "kwargs": plain(kwargs),
        "preload": tuple(preload),
        "pass_log": pass_log,
        "show": show,
    }
    address = os.environ.get(SOCKET_ENV)
    code = run_in_server(address, request) if address else None
    if code is None:
        execute(request)
    elif code != 0:
        sys.exit(code)


# ---------------------------------------------------------------- server


def _child(conn: socket.socket) -> None:
    """In the forked child: take over the client's streams, folder and environment,
    run the job, send its exit code, exit. Never returns."""
    code = 1
    try:
        msg, fds, _, _ = socket.recv_fds(conn, LENGTH.size, 3)
        for target_fd, fd in enumerate(fds):
            os.dup2(fd, target_fd)
            os.close(fd)
        request = pickle.loads(recv_exactly(conn, LENGTH.unpack(msg)[0]))
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        os.environ.pop(SOCKET_ENV, None)  # the script's run_job runs here, not in a grandchild
        conn.sendall(CODE.pack(os.getpid()))

        def watch_client():  # the client died (killed by Snakemake): so does the job
            if not conn.recv(1):
                os.kill(os.getpid(), signal.SIGKILL)

        threading.Thread(target=watch_client, daemon=True).start()
        try:
            execute(request)
            code = 0
        except SystemExit as err:
            code = err.code if isinstance(err.code, int) else (0 if err.code is None else 1)
        except BaseException:
            traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        try:
            conn.sendall(CODE.pack(code))
        finally:
            os._exit(code)


def serve(address: str, preload=PRELOAD, parent_pid: int | None = None) -> None:
    """Listen at ``address`` and fork a child per job until SIGTERM, or until
    ``parent_pid`` (the Snakemake that started it) is gone, even if killed with SIGKILL;
    then remove the socket, its ``.json`` (what the server imports, for
    ``shared_server``) and the folder ``Server.start`` made for them.

    The socket is bound before the imports, so jobs that connect meanwhile wait in the
    backlog instead of running cold. The parent never runs a torch operation: forking
    after one would copy torch's thread pool in a broken state.
    """
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(address)
    owner = os.getpid()
    signal.signal(signal.SIGTERM, _exit_cleanly)
    try:
        server.listen(128)
        Path(f"{address}.json").write_text(json.dumps({"pid": os.getpid(), **_identity()}))
        for module in preload:
            importlib.import_module(module)
        signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # children are reaped by the kernel
        server.settimeout(1.0)
        print(f"warm server {os.getpid()} ready at {address}", flush=True)
        while parent_pid is None or _alive(parent_pid):
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            sys.stdout.flush()
            sys.stderr.flush()
            if os.fork() == 0:
                server.close()
                signal.signal(signal.SIGCHLD, signal.SIG_DFL)
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                conn.settimeout(None)
                _child(conn)
            conn.close()
    finally:
        server.close()
        if os.getpid() == owner:  # not a child caught between fork and its own handlers
            for path in (address, f"{address}.json"):
                Path(path).unlink(missing_ok=True)
            folder = Path(address).parent
            if folder.name.startswith(FOLDER_PREFIX):  # ours (Server.start): gone with us
                with contextlib.suppress(OSError):
                    folder.rmdir()


def _exit_cleanly(_signum, _frame):
    raise SystemExit(0)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _identity() -> dict:
    """What a forked job imports: the Python environment, its PYTHONPATH, this library."""
    pythonpath = os.environ.get("PYTHONPATH", "")
    library = str(Path(__file__).resolve().parents[1])
    return {"prefix": sys.prefix, "pythonpath": pythonpath, "library": library}


def shared_server(address: str | None) -> bool:
    """Whether a server started before this process listens at ``address`` and its
    jobs would import what this process imports (``_identity``): then a run may use it."""
    if not address or not Path(address).exists():
        return False
    try:
        info = json.loads(Path(f"{address}.json").read_text())
    except (OSError, ValueError):
        return False
    pid = int(info.pop("pid", 0))
    return pid > 0 and _alive(pid) and info == _identity()


class Server:
    """A warm server process and its socket folder, started by ``start``.

    ``start`` also sets ``$SPL_AL_WARM_SOCKET`` in this process, so the jobs it starts
    afterwards find the server; ``stop`` ends the server and removes the folder.
    """

    def __init__(self, process: subprocess.Popen, folder: Path) -> None:
        self.process = process
        self.folder = folder
        self.address = str(folder / "socket")

    @classmethod
    def start(cls, log_path, wait_s: float = 10.0) -> Server:
        """Start a server whose output goes to ``log_path``; returns once it listens."""
        folder = Path(tempfile.mkdtemp(prefix=FOLDER_PREFIX))  # private (0700)
        Path(log_path).parent.mkdir(parents=True, exist_ok=True)
        with open(log_path, "w") as log:
            process = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "spl_al.warm.server",
                    str(folder / "socket"),
                    "--parent",
                    str(os.getpid()),
                ],
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,  # a Ctrl-C for Snakemake is forwarded per job
            )
        server = cls(process, folder)
        deadline = time.monotonic() + wait_s
        while not Path(server.address).exists() and process.poll() is None:
            if time.monotonic() > deadline:
                break
            time.sleep(0.02)
        os.environ[SOCKET_ENV] = server.address
        return server

    @classmethod
    def for_run(cls, log_path, *, enabled: bool) -> Server | None:
        """The server a run's jobs use, set in ``$SPL_AL_WARM_SOCKET``: None when the run
        uses a shared one (``shared_server``: left running) or none (``enabled`` false:
        its jobs run in their own processes, even if the environment names a server);
        else a new one, started here, for ``stop`` at the end of the run."""
        if not enabled:
            os.environ.pop(SOCKET_ENV, None)
            return None
        if shared_server(os.environ.get(SOCKET_ENV)):
            return None
        return cls.start(log_path)

    def stop(self) -> None:
        """End the server (jobs already forked finish) and remove its socket folder."""
        os.environ.pop(SOCKET_ENV, None)
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
        shutil.rmtree(self.folder, ignore_errors=True)


def main(argv: list[str] | None = None) -> None:
    """Command line: ``python -m spl_al.warm.server SOCKET [--parent PID]``."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.warm.server")
    parser.add_argument("address", help="Unix socket path to listen at")
    parser.add_argument("--parent", type=int, default=None, help="exit when this pid is gone")
    args = parser.parse_args(argv)
    serve(args.address, parent_pid=args.parent)


if __name__ == "__main__":
    main()
