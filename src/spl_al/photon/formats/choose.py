"""Which of a file's variables holds the photons: the one named, or the only candidate."""

from __future__ import annotations

from pathlib import Path


def choose_key(path: Path, names: list[str], key: str | None, kind: tuple[str, str]) -> str:
    """``key`` when it is among ``names``, else the only name when ``key`` is None.

    ``kind`` is (singular, plural) of what ``names`` are, e.g. ("sparse matrix",
    "sparse matrices"), for the one-sentence errors.
    """
    singular, plural = kind
    if key is None:
        if len(names) != 1:
            raise ValueError(
                f"{path}: holds {len(names)} {plural} ({', '.join(names) or 'none'}); "
                "name the one with the photons (option key)."
            )
        return names[0]
    if key not in names:
        raise ValueError(f"{path}: no {singular} {key!r}; {plural} found: {names}.")
    return key
