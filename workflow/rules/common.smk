from pathlib import Path

RESULTS = config["results"]


def real_capture_names():
    """Names of the real .mat captures in config photon.real_captures (none if absent)."""
    folder = Path(config["photon"].get("real_captures", ""))
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.glob("*.mat"))


def photon_pictures():
    return [f"{RESULTS}/photon/conditions.png"] + expand(
        f"{RESULTS}/photon/real/{{capture}}.png", capture=real_capture_names()
    )
