# The warm job server of a local run (workflow/rules/warm.smk).
from spl_al.warm.server import Server

_warm = {}


def start_warm_worker():
    enabled = (
        config.get("warm_worker", True) and workflow.local_exec and not PER_RULE_ENVS
    )
    server = Server.for_run(f"{RESULTS}/logs/warm_server.log", enabled=enabled)
    if server:
        _warm["server"] = server


def stop_warm_worker():
    if "server" in _warm:
        _warm.pop("server").stop()
