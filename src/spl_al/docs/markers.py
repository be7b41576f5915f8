"""Generated blocks inside hand-written Markdown pages.

A block is the text between ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` (each
on its own line); everything outside the markers is left as it is.
"""

from __future__ import annotations


def markers(name: str) -> tuple[str, str]:
    """The start and end marker lines of block ``name``."""
    return f"<!-- {name}:start -->", f"<!-- {name}:end -->"


def replace_block(text: str, name: str, body: str) -> str:
    """``text`` with block ``name``'s content replaced by ``body``.

    Raises ValueError naming the marker when the block is missing or malformed.
    """
    start, end = markers(name)
    lines = text.split("\n")
    starts = [i for i, line in enumerate(lines) if line.strip() == start]
    ends = [i for i, line in enumerate(lines) if line.strip() == end]
    if len(starts) != 1 or len(ends) != 1 or ends[0] < starts[0]:
        raise ValueError(
            f"expected one {start!r} line followed by one {end!r} line, found "
            f"{len(starts)} and {len(ends)}."
        )
    inner = body.strip("\n")
    return "\n".join(lines[: starts[0] + 1] + ([inner] if inner else []) + lines[ends[0] :])


def block(text: str, name: str) -> str | None:
    """The content of block ``name`` (without its markers); None when ``text`` lacks
    either marker."""
    start, end = markers(name)
    lines = [line.strip() for line in text.split("\n")]
    if start not in lines or end not in lines:
        return None
    return "\n".join(text.split("\n")[lines.index(start) + 1 : lines.index(end)])
