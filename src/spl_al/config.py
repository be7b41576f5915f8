"""Validation of a workflow configuration against its JSON schema, with one-line errors."""

from __future__ import annotations

from pathlib import Path


def check_config(config: dict, schema_path) -> None:
    """Raise ValueError naming the first offending key when ``config`` breaks the schema.

    The message is one sentence: the dotted key path, the value found and what the
    schema expects (for example ``config key 'photon.reconstruct_method': 'sspi' is
    not one of ['pooled', 'lmf']``).
    """
    import jsonschema
    import yaml

    schema = yaml.safe_load(Path(schema_path).read_text())
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(config), key=lambda e: (len(e.path), list(e.path)))
    if not errors:
        return
    err = errors[0]
    where = ".".join(str(p) for p in err.path) or "(top level)"
    raise ValueError(f"config key {where!r}: {err.message} (checked against {schema_path}).")
