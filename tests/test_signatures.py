"""Functions a reader can hold in mind: no function of src/spl_al takes more than ten
parameters or more than six positional ones (``self`` and ``cls`` aside; the rest are
keyword-only), a
public one with more than four parameters at most four, and none runs over 60 lines
of code (its docstring, blank lines and comments aside).

Read from the source with ``ast``, like tests/test_imports.py. ``EXCEPTIONS`` and
``LONG_EXCEPTIONS`` list the functions allowed more, each with its reason; both
lists may only shrink.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "spl_al"
MAX_POSITIONAL = 6
MAX_PARAMETERS = 10
MAX_CODE_LINES = 60

# "module.py:function": why it keeps more than MAX_POSITIONAL positional parameters.
EXCEPTIONS: dict[str, str] = {}

# "module.py:function": why it runs over MAX_CODE_LINES lines of code.
_GEOMETRY = "one object's parts, each placed relative to the last: read top to bottom"
LONG_EXCEPTIONS: dict[str, str] = {
    "scenes/objects.py:ship": _GEOMETRY,
    "scenes/objects.py:human": _GEOMETRY,
    "scenes/objects.py:bin_": _GEOMETRY,
    "scenes/street.py:render_street": "one street's layout, element by element, in one place",
    "bench/projection.py:main": "a command: its arguments, one loop of cases, its table",
    "bench/learnability.py:main": "a command: its arguments, one loop of cases, its table",
}


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


def test_no_function_takes_more_than_ten_parameters():
    """More than ten is a record waiting to be named (``RoundId``, ``ProbeRuns``, ...)."""
    over = []
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
                names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
                count = sum(n not in ("self", "cls") for n in names)
                if count > MAX_PARAMETERS:
                    over.append(f"{path.relative_to(SRC)}:{node.name} ({count})")
    assert not over, f"group related parameters into a small record: {over}"


def code_lines(text: str):
    """(function name, its lines of code) for every def in ``text``: docstring, blank
    lines and comment lines aside (a nested function counts in its parent too)."""
    lines = text.splitlines()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = node.body[0]
            docstring = isinstance(first, ast.Expr) and isinstance(
                getattr(first, "value", None), ast.Constant
            )
            start = first.end_lineno if docstring else first.lineno - 1
            body = lines[start : node.end_lineno]
            yield node.name, sum(1 for ln in body if ln.strip() and not ln.strip().startswith("#"))


def test_public_functions_take_their_options_by_keyword():
    """scikit-learn's style: a public function (or method) with more than four
    parameters takes at most four positionally, the data; the options by keyword."""
    over = []
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
                args = node.args
                positional = [
                    a.arg for a in args.posonlyargs + args.args if a.arg not in ("self", "cls")
                ]
                if len(positional) + len(args.kwonlyargs) > 4 and len(positional) > 4:
                    over.append(f"{path.relative_to(SRC)}:{node.name}")
    assert not over, f"make the options keyword-only: {over}"


def test_no_function_runs_over_sixty_lines_of_code():
    over = []
    for path in sorted(SRC.rglob("*.py")):
        for name, count in code_lines(path.read_text()):
            key = f"{path.relative_to(SRC)}:{name}"
            if count > MAX_CODE_LINES and key not in LONG_EXCEPTIONS:
                over.append(f"{key} ({count})")
    assert not over, f"split these into steps a reader can hold in mind: {over}"


def test_every_listed_exception_still_needs_its_entry():
    counts = {}
    for path in sorted(SRC.rglob("*.py")):
        text = path.read_text()
        for name, n in code_lines(text):
            counts[f"{path.relative_to(SRC)}:{name}"] = n
    assert all(counts.get(key, 0) > MAX_CODE_LINES for key in LONG_EXCEPTIONS)


def test_the_count_sees_positional_parameters_and_not_keyword_only_ones():
    text = "def f(a, b, c, d, e, f, g): ...\ndef g(self, a, *, b, c, d, e, f, h): ...\n"
    assert dict(positional_counts(text)) == {"f": 7, "g": 1}


def test_the_line_count_leaves_out_the_docstring_blanks_and_comments():
    text = 'def f():\n    """Doc\n    string."""\n    a = 1\n\n    # why\n    return a\n'
    assert dict(code_lines(text)) == {"f": 2}
