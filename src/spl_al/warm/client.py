"""The job side of the warm job server (``spl_al.warm.server``), standard library only.

A rule of the workflow runs its script through this file, not through Snakemake's
``script:`` directive, whose preamble imports Snakemake in every job's process
(~0.25 CPU-s a job on a 2-core AVX2 CPU, a third of the test suite's CPU):

    python -S -P .../spl_al/warm/client.py SCRIPT LOG THREADS FILES SETTINGS

``FILES`` and ``SETTINGS`` hold what the script reads from its ``snakemake`` object: the
job's ``input``, ``output`` and ``wildcards`` (``files_text``), and its ``params``
(``job_settings``), each as a Python literal written in the Snakemake process. The client
hands the script, the job and its standard streams to the warm server, whose forked
child runs the script with a ``Job`` as ``snakemake``; with no server listening it runs
the script itself, after the site-packages it skipped (``-S``) at start-up. Either way
the script sees the same object and does the same.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import socket
import struct
import sys
from types import SimpleNamespace

SOCKET_ENV = "SPL_AL_WARM_SOCKET"
"""Environment variable naming the server's socket; jobs inherit it from Snakemake."""

LENGTH = struct.Struct("!Q")
CODE = struct.Struct("!i")


class Files(list):
    """A job's files as its script reads them: a list of every path, in order, and each
    named entry as an attribute (a path, or a list of paths), as Snakemake's own."""

    def __init__(self, values=(), names=None) -> None:
        super().__init__(values)
        self._names = dict(names or {})

    def __getattr__(self, name: str):
        try:
            return self.__dict__["_names"][name]
        except KeyError:
            raise AttributeError(name) from None

    def get(self, name: str, default=None):
        """The named entry ``name``, else ``default``."""
        return self._names.get(name, default)

    def keys(self):
        """The names of the named entries."""
        return self._names.keys()

    def items(self):
        """(name, path or list of paths) of the named entries."""
        return self._names.items()


class Job:
    """The ``snakemake`` object of a script run through this client: ``input``,
    ``output``, ``log`` (``Files``), ``params`` and ``wildcards`` (attributes), and
    ``threads``, from the job's files (``files_text``) and settings (``job_settings``)."""

    def __init__(self, files: str, settings: str, log: str, threads: int) -> None:
        import ast

        job = ast.literal_eval(files)
        self.input = Files(**job["input"])
        self.output = Files(**job["output"])
        self.log = Files([log])
        self.params = SimpleNamespace(**ast.literal_eval(settings))
        self.wildcards = SimpleNamespace(**job["wildcards"])
        self.threads = int(threads)


def job_settings(params: dict) -> dict:
    """``params`` (plain values: a job's settings), checked to read back as themselves
    from their ``repr``, the form the job's command carries them in (a literal, not
    JSON, so that number keys and tuples come back as they were).

    Raises:
        ValueError: a value that does not read back as itself.
    """
    import ast  # (here and in Job: not at the top, where every job's client would pay it)

    try:
        same = ast.literal_eval(repr(params)) == params
    except (ValueError, SyntaxError):
        same = False
    if not same:
        raise ValueError(
            f"a job's params must be plain values (str, numbers, lists, dicts): {params!r}."
        )
    return params


def files_text(input, output, wildcards) -> str:
    """A job's files and wildcards as a Python literal for ``Job``: ``input``/``output``
    are Snakemake's named file lists (each name maps to a path or a list of paths)."""

    def files(named) -> dict:
        names = {}
        for name in named.keys():  # noqa: SIM118 (iterating a named list gives its paths)
            value = getattr(named, name)
            names[name] = str(value) if isinstance(value, str) else [str(v) for v in value]
        return {"values": [str(v) for v in named], "names": names}

    wildcard_names = {name: str(getattr(wildcards, name)) for name in wildcards.keys()}  # noqa: SIM118
    return repr({"input": files(input), "output": files(output), "wildcards": wildcard_names})


def run_script(script: str, job: Job) -> None:
    """Run ``script`` in this process with ``snakemake`` set to ``job``."""
    import runpy

    runpy.run_path(script, init_globals={"snakemake": job}, run_name="__main__")


def recv_exactly(conn: socket.socket, n: int) -> bytes | None:
    """``n`` bytes from ``conn``, or None when it closes first."""
    data = b""
    while len(data) < n:
        chunk = conn.recv(n - len(data))
        if not chunk:
            return None
        data += chunk
    return data


def run_in_server(address: str, request: dict) -> int | None:
    """The job's exit code from a warm child, or None when no server answers. The
    request travels with this process's folder, environment and standard streams."""
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        conn.connect(address)
    except OSError:
        conn.close()
        return None
    with conn:
        request = {**request, "cwd": os.getcwd(), "env": dict(os.environ)}
        payload = pickle.dumps(request)
        sys.stdout.flush()
        sys.stderr.flush()
        socket.send_fds(conn, [LENGTH.pack(len(payload))], [0, 1, 2])
        conn.sendall(payload)
        head = recv_exactly(conn, CODE.size)
        if head is None:
            return None  # the server went away before forking: run here
        (pid,) = CODE.unpack(head)

        def forward(signum, _frame):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signum)

        for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(signum, forward)
        tail = recv_exactly(conn, CODE.size)
        return 1 if tail is None else CODE.unpack(tail)[0]


def main(argv: list[str] | None = None) -> None:
    """Command line: ``client.py SCRIPT LOG THREADS FILES SETTINGS`` (the module)."""
    script, log, threads, files, settings = sys.argv[1:] if argv is None else argv
    request = {"script": script, "job": (files, settings, log, int(threads))}
    address = os.environ.get(SOCKET_ENV)
    code = run_in_server(address, request) if address else None
    if code is None:
        import site

        site.main()  # the site-packages that -S left out: the script imports the library
        run_script(script, Job(files, settings, log, int(threads)))
    elif code != 0:
        sys.exit(code)


if __name__ == "__main__":
    main()
