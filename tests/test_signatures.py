"""Signatures a reader can hold in mind: no function of src/spl_al takes more than six
positional parameters (``self`` and ``cls`` aside); the rest are keyword-only.

Read from the source with ``ast``, like tests/test_imports.py. ``EXCEPTIONS`` lists
the functions allowed more, each with its reason; it may only shrink.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "spl_al"
MAX_POSITIONAL = 6

# "module.py:function": why it keeps more than MAX_POSITIONAL positional parameters.
EXCEPTIONS: dict[str, str] = {}


def positional_counts(text: str):
    """(function name, its number of positional parameters) for every def in ``text``."""
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = node.args.posonlyargs + node.args.args
            yield node.name, sum(a.arg not in ("self", "cls") for a in args)


def test_no_function_takes_more_than_six_positional_parameters():
    over = []
    for path in sorted(SRC.rglob("*.py")):
        for name, count in positional_counts(path.read_text()):
            key = f"{path.relative_to(SRC)}:{name}"
            if count > MAX_POSITIONAL and key not in EXCEPTIONS:
                over.append(f"{key} ({count})")
    assert not over, f"make the parameters after the first few keyword-only: {over}"


def test_the_count_sees_positional_parameters_and_not_keyword_only_ones():
    text = "def f(a, b, c, d, e, f, g): ...\ndef g(self, a, *, b, c, d, e, f, h): ...\n"
    assert dict(positional_counts(text)) == {"f": 7, "g": 1}
