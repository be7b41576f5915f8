"""docs/configuration.md from config/schema.yaml's descriptions and config/config.yaml.

Every key the schema names gets a row: what it means (its ``description:``), its unit,
what values it takes and its value in the default config. A description may end with
its unit in square brackets ("signal photons per pixel [photons/pixel]"); the unit goes
to its own column. Keys under a mapping of free names (``datasets``, ``methods``) are
written with a placeholder (``datasets.<dataset>.al.batch``) and their defaults list
every entry of the default config that sets them.

    python -m spl_al.docs.configuration            # writes docs/configuration.md
    python -m spl_al.docs.configuration --check    # exit 1 when the page is out of date

A test compares the committed page with ``render()``, so the two cannot drift.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

from spl_al.docs.markers import markers, replace_block

COMMAND = "python -m spl_al.docs.configuration"
BLOCK = "configuration"
# placeholder names of mappings whose keys are the user's names
PLACEHOLDERS = {
    "datasets": "<dataset>",
    "methods": "<method>",
    "method_params": "<method>",
    "levels": "<level>",
}
_UNIT = re.compile(r"\s*\[([^\[\]]+)\]\s*$")
_MISSING = object()


def split_unit(description: str) -> tuple[str, str]:
    """(meaning, unit) of a description whose unit may close it in square brackets."""
    text = " ".join(str(description).split())
    match = _UNIT.search(text)
    if match is None:
        return text, ""
    return text[: match.start()].rstrip(), match.group(1)


def _resolve(node: dict, root: dict) -> dict:
    """The subschema with a local ``$ref`` into ``#/$defs`` merged under its own keys."""
    ref = node.get("$ref")
    if not ref:
        return node
    if not ref.startswith("#/"):
        raise ValueError(f"only local $ref are supported, got {ref!r}.")
    target: Any = root
    for part in ref[2:].split("/"):
        target = target[part]
    merged = dict(_resolve(target, root))
    merged.update({k: v for k, v in node.items() if k != "$ref"})
    return merged


def _allowed(node: dict) -> str:
    """What values a leaf takes, in words."""
    if "enum" in node:
        return "one of " + ", ".join(_fmt(v) for v in node["enum"])
    if "oneOf" in node or "anyOf" in node:
        return ", or ".join(_allowed(alt) for alt in node.get("oneOf") or node["anyOf"])
    types = node.get("type", "")
    types = [types] if isinstance(types, str) else list(types)
    words = [t for t in types if t and t != "null"]
    text = " or ".join(words) if words else "checked where used"
    if node.get("type") == "array" or "array" in types:
        items = node.get("items", {})
        if isinstance(items, dict) and items.get("type"):
            inner = _allowed(items)
            text = f"list of {inner}"
            if "minItems" in node and node.get("minItems") == node.get("maxItems"):
                text = f"{node['minItems']} x {inner}"
    bounds = []
    if "minimum" in node:
        bounds.append(f">= {_fmt(node['minimum'])}")
    if "exclusiveMinimum" in node:
        bounds.append(f"> {_fmt(node['exclusiveMinimum'])}")
    if "maximum" in node:
        bounds.append(f"<= {_fmt(node['maximum'])}")
    if "exclusiveMaximum" in node:
        bounds.append(f"< {_fmt(node['exclusiveMaximum'])}")
    if bounds:
        text += " " + ", ".join(bounds)
    if "null" in types:
        text += ", or null"
    return text


def _fmt(value: Any) -> str:
    """A config value as it would be written in YAML flow style."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_fmt(v)}" for k, v in value.items()) + "}"
    return str(value)


def _values(config: Any, path: tuple[str, ...], label: str = "") -> list[tuple[str, Any]]:
    """(entry name, value) for every default-config entry the path reaches."""
    if not path:
        return [(label, config)]
    head, rest = path[0], path[1:]
    if not isinstance(config, dict):
        return []
    if head.startswith("<"):
        out = []
        for name, sub in config.items():
            out.extend(_values(sub, rest, f"{label}.{name}" if label else name))
        return out
    if head not in config:
        return []
    return _values(config[head], rest, label)


def _default(config: dict, path: tuple[str, ...]) -> str:
    found = _values(config, path)
    if not found:
        return "not set"
    if not any(p.startswith("<") for p in path):
        return f"`{_fmt(found[0][1])}`"
    shown = {_fmt(v) for _, v in found}
    entries = _values(config, path[: max(i for i, p in enumerate(path) if p.startswith("<")) + 1])
    if len(shown) == 1 and len(found) == len(entries):
        return f"`{shown.pop()}` (every entry)"
    return "; ".join(f"{name}: `{_fmt(v)}`" for name, v in found)


def _walk(node: dict, root: dict, path: tuple[str, ...], sections: list) -> None:
    """Collect (path, description, rows) for every object node that has properties."""
    node = _resolve(node, root)
    props = node.get("properties") or {}
    extra = node.get("additionalProperties")
    rows = []
    for key, sub in props.items():
        sub = _resolve(sub, root)
        rows.append(((*path, key), sub))
    if props:
        sections.append((path, node.get("description", ""), rows))
    for key, sub in props.items():
        sub = _resolve(sub, root)
        if sub.get("properties") or isinstance(sub.get("additionalProperties"), dict):
            _walk(sub, root, (*path, key), sections)
    if isinstance(extra, dict):
        name = PLACEHOLDERS.get(path[-1] if path else "", "<name>")
        sub = _resolve(extra, root)
        if sub.get("properties") or isinstance(sub.get("additionalProperties"), dict):
            _walk(sub, root, (*path, name), sections)
        elif not props:
            sections.append((path, node.get("description", ""), [((*path, name), sub)]))


def undescribed(schema: dict) -> list[str]:
    """Dotted paths of schema keys without a description (empty when all have one)."""
    sections: list = []
    _walk(schema, schema, (), sections)
    return [".".join(p) for _, _, rows in sections for p, sub in rows if not sub.get("description")]


def render(schema: dict, config: dict) -> str:
    """The Markdown page: one table per configuration section."""
    sections: list = []
    _walk(schema, schema, (), sections)
    lines = [
        f"<!-- generated by `{COMMAND}` from config/schema.yaml and config/config.yaml:",
        "edit those (or the text above the start marker), not this block -->",
        "",
        "Keys written `<dataset>` or `<method>` stand for the names you give; their default",
        "lists every entry of the default config that sets them. *not set*: the default",
        "config does not set the key and the code's own default applies.",
        "",
    ]
    for path, description, rows in sections:
        title = ".".join(path) if path else "Top level"
        lines += [f"## `{title}`" if path else "## Top level", ""]
        if description and path:
            meaning, unit = split_unit(description)
            lines += [meaning + (f" [{unit}]" if unit else "") + ".", ""]
        lines += ["| key | meaning | unit | values | default |", "|---|---|---|---|---|"]
        for key_path, sub in rows:
            meaning, unit = split_unit(sub.get("description", ""))
            is_section = bool(sub.get("properties")) or (
                isinstance(sub.get("additionalProperties"), dict)
                and bool(_resolve(sub["additionalProperties"], schema).get("properties"))
            )
            if is_section:
                target = key_path
                if not sub.get("properties"):
                    target = (*key_path, PLACEHOLDERS.get(key_path[-1], "<name>"))
                default = f"see [`{'.'.join(target)}`](#{_anchor('.'.join(target))})"
                allowed = "mapping"
            else:
                default = _default(config, key_path)
                allowed = _allowed(sub)
            cells = [f"`{key_path[-1]}`", meaning, unit, allowed, default]
            lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def _anchor(heading: str) -> str:
    """GitHub's anchor of a Markdown heading."""
    text = heading.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


DEFAULT_HEAD = f"""# Configuration

Every key of the workflow's configuration, from `config/schema.yaml` with its value in
`config/config.yaml`. Regenerate the reference below with `{COMMAND}`.

"""


def build(root: Path = Path("."), page: str | None = None) -> str:
    """The page for the repository at ``root``: ``page`` (default: the current
    docs/configuration.md, or a short heading) with its generated block rewritten."""
    import yaml

    schema = yaml.safe_load((root / "config" / "schema.yaml").read_text())
    config = yaml.safe_load((root / "config" / "config.yaml").read_text())
    if page is None:
        path = root / "docs" / "configuration.md"
        start, end = markers(BLOCK)
        page = path.read_text() if path.exists() else f"{DEFAULT_HEAD}{start}\n{end}\n"
    return replace_block(page, BLOCK, render(schema, config))


def main(argv: list[str] | None = None) -> int:
    """Command line: write (or with --check compare) docs/configuration.md."""
    parser = argparse.ArgumentParser(prog=COMMAND, description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path("."), help="repository root")
    parser.add_argument("--out", type=Path, default=None, help="default docs/configuration.md")
    parser.add_argument("--check", action="store_true", help="exit 1 if the page is out of date")
    args = parser.parse_args(argv)
    out = args.out or args.root / "docs" / "configuration.md"
    page = build(args.root, out.read_text() if out.exists() else None)
    if args.check:
        current = out.read_text() if out.exists() else ""
        if current != page:
            print(f"{out} is out of date: run `{COMMAND}`.", file=sys.stderr)
            return 1
        return 0
    from spl_al.atomic import atomic_write_text

    atomic_write_text(out, page)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
