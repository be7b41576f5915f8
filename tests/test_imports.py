"""The import graph of src/spl_al: no cycle, no upward arrow, no private name shared.

Read from the source with ``ast`` (nothing is imported): every ``import`` and
``from ... import`` of an spl_al module counts, at module level or inside a
function, so a function-local import cannot hide a cycle or an upward arrow.

Layers, top to bottom (docs/design.md, "Layers"): a module may import its own
top-level unit (``spl_al.data`` for ``spl_al.data.pictures``) and any unit of a
lower layer, never one of its own layer or above. ``UPWARD`` lists the arrows that
still point up, each with its reason; the list may only shrink.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"

LAYERS: list[tuple[str, list[str]]] = [
    ("tools", ["spl_al.__main__", "spl_al.bench", "spl_al.docs", "spl_al.query_frames"]),
    ("workflow steps", ["spl_al.experiment", "spl_al.warm"]),
    ("outputs", ["spl_al.deploy", "spl_al.labeling", "spl_al.report"]),
    ("round 0", ["spl_al.cold_start"]),
    (
        "active learning",
        [
            "spl_al.pool",
            "spl_al.round_query",
            "spl_al.acquire",
            "spl_al.scoring",
            "spl_al.linear_probe",
            "spl_al.dense_probe",
        ],
    ),
    ("learning", ["spl_al.strategies", "spl_al.training", "spl_al.multinomial"]),
    ("models", ["spl_al.models"]),
    ("data", ["spl_al.data"]),
    ("physics and geometry", ["spl_al.photon", "spl_al.scenes"]),
    ("kit", ["spl_al.config", "spl_al.frameworks", "spl_al.plotting"]),
    (
        "ground",
        [
            "spl_al",
            "spl_al.atomic",
            "spl_al.blas_threads",
            "spl_al.label_codes",
            "spl_al.layout",
            "spl_al.seeding",
        ],
    ),
]

# (importer, imported): why the arrow still points up. Remove an entry with its arrow.
UPWARD: dict[tuple[str, str], str] = {
    ("spl_al", "spl_al.acquire"): "spl_al.query, the public acquisition call, is the package "
    "root's name (issue 71); the root loads it on first use (PEP 562 __getattr__), so "
    "`import spl_al` loads nothing above the ground layer",
}


def modules() -> dict[str, Path]:
    """Dotted name -> file of every module of src/spl_al (a package by its __init__)."""
    out = {}
    for path in sorted((SRC / "spl_al").rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = modules()


def is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def owner(dotted: str) -> str | None:
    """The longest spl_al module that ``dotted`` names or lies in."""
    while dotted and dotted not in MODULES:
        dotted = dotted.rpartition(".")[0]
    return dotted or None


def base_of(module: str, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` reads from (relative ones resolved)."""
    if not node.level:
        return node.module or ""
    package = module if MODULES[module].name == "__init__.py" else module.rpartition(".")[0]
    for _ in range(node.level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{node.module}" if node.module else package


def imports(module: str) -> Iterator[tuple[int, str, str]]:
    """(line, imported module, the name as written) of every spl_al import of ``module``."""
    tree = ast.parse(MODULES[module].read_text(), filename=str(MODULES[module]))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if owner(alias.name) and alias.name.split(".")[0] == "spl_al":
                    yield node.lineno, owner(alias.name), alias.name
        elif isinstance(node, ast.ImportFrom):
            base = base_of(module, node)
            if base.split(".")[0] != "spl_al":
                continue
            for alias in node.names:
                full = f"{base}.{alias.name}"
                yield node.lineno, owner(full) if full in MODULES else owner(base), full


def graph() -> dict[str, set[str]]:
    return {m: {target for _, target, _ in imports(m) if target and target != m} for m in MODULES}


def unit(module: str) -> str:
    """The top-level unit a module belongs to: spl_al.data for spl_al.data.pictures."""
    return ".".join(module.split(".")[:2])


def layer_of(module: str) -> int:
    for depth, (_, units) in enumerate(LAYERS):
        if unit(module) in units:
            return depth
    raise AssertionError(f"{module} is in no layer of tests/test_imports.py; give it one.")


def defined_names(module: str) -> set[str]:
    """Names a module binds at its top level (defs, classes, assignments, imports)."""
    tree = ast.parse(MODULES[module].read_text())
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names |= {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                # a package that loads its API on first use (PEP 562 __getattr__)
                names |= {e.value for e in ast.walk(node.value) if isinstance(e, ast.Constant)}
        elif isinstance(node, (ast.If, ast.Try)):  # guarded imports and definitions
            for sub in ast.walk(node):
                if isinstance(sub, (ast.Import, ast.ImportFrom)):
                    names |= {(a.asname or a.name).split(".")[0] for a in sub.names}
                elif isinstance(sub, (ast.FunctionDef, ast.ClassDef)):
                    names.add(sub.name)
    return names


def test_every_spl_al_import_names_something_that_exists():
    """A module moved or removed leaves no import of it behind, a function-local one
    included (ruff cannot tell; the job that runs it fails only at run time)."""
    missing = []
    for module in MODULES:
        tree = ast.parse(MODULES[module].read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "spl_al" and alias.name not in MODULES:
                        missing.append(f"{module}:{node.lineno} import {alias.name}")
            elif isinstance(node, ast.ImportFrom):
                base = base_of(module, node)
                if base.split(".")[0] != "spl_al":
                    continue
                if base not in MODULES:
                    missing.append(f"{module}:{node.lineno} from {base}")
                    continue
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    if full not in MODULES and alias.name not in defined_names(base):
                        missing.append(f"{module}:{node.lineno} from {base} import {alias.name}")
    assert not missing, missing


def test_every_module_has_a_layer():
    for module in MODULES:
        layer_of(module)


def test_no_import_cycle_among_spl_al_modules():
    edges = graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles among spl_al modules: {cycles}"


def test_no_module_imports_its_own_layer_or_above():
    wrong = []
    for module in MODULES:
        for line, target, name in imports(module):
            if not target or unit(target) == unit(module) or (module, target) in UPWARD:
                continue
            if layer_of(target) <= layer_of(module):
                what = "its own layer" if layer_of(target) == layer_of(module) else "upward"
                where = f"{MODULES[module].relative_to(SRC.parent)}:{line}"
                wrong.append(f"{where}: {name} ({what})")
    assert not wrong, "imports against the layers (tests/test_imports.py):\n" + "\n".join(wrong)


STEP_MODULES = frozenset(
    f"spl_al.experiment.{name}"
    for name in (
        "data_steps",
        "round_steps",
        "embedding_steps",
        "report_steps",
        "deploy_steps",
        "human",
        "robustness",
    )
)
"""The modules whose functions the workflow's scripts call: what two share lives in a
module of its own (spl_al.experiment's docstring), so none imports another."""


def test_no_step_module_imports_a_sibling_step_module():
    assert set(MODULES) >= STEP_MODULES
    found = [
        f"{module}:{line} imports {target}"
        for module in sorted(STEP_MODULES)
        for line, target, _name in imports(module)
        if owner(target) in STEP_MODULES - {module}
    ]
    assert not found, "\n".join(found)


def test_every_listed_upward_arrow_still_exists():
    edges = graph()
    gone = [pair for pair in UPWARD if pair[1] not in edges.get(pair[0], set())]
    assert not gone, f"remove these from UPWARD, the arrows are gone: {gone}"


def test_no_private_name_is_imported_across_modules():
    wrong = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        aliases: dict[str, str] = {}  # local name -> spl_al module it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = base_of(module, node)
                if base.split(".")[0] != "spl_al":
                    continue
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    if full in MODULES:
                        aliases[alias.asname or alias.name] = full
                    elif is_private(alias.name) and base != module:
                        wrong.append(f"{path.relative_to(SRC.parent)}:{node.lineno}: {full}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "spl_al":
                        bound = alias.name if alias.asname else alias.name.split(".")[0]
                        aliases[alias.asname or bound] = bound
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and is_private(node.attr)):
                continue
            chain, value = [], node.value
            while isinstance(value, ast.Attribute):
                chain.append(value.attr)
                value = value.value
            if isinstance(value, ast.Name) and value.id in aliases:
                target = ".".join([aliases[value.id], *reversed(chain)])
                if target in MODULES and target != module:
                    wrong.append(
                        f"{path.relative_to(SRC.parent)}:{node.lineno}: {target}.{node.attr}"
                    )
    assert not wrong, "private names used outside their module:\n" + "\n".join(wrong)


def fake_package(tmp_path, monkeypatch, files: dict[str, str]) -> None:
    """Point the checks of this module at a made-up src/spl_al of ``files``."""
    for name, text in {"__init__.py": "", **files}.items():
        path = tmp_path / "spl_al" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    this = __import__(__name__)
    monkeypatch.setattr(this, "SRC", tmp_path)
    monkeypatch.setattr(this, "MODULES", modules())


@pytest.mark.parametrize("text", ["from spl_al.x import _y", "import spl_al.x as m\nm._y"])
def test_the_private_check_sees_both_ways_in(text, monkeypatch, tmp_path):
    fake_package(tmp_path, monkeypatch, {"x/__init__.py": "_y = 1\n", "z.py": text + "\n"})
    with pytest.raises(AssertionError, match=r"spl_al/z\.py:\d+: spl_al\.x\._y"):
        test_no_private_name_is_imported_across_modules()


def test_the_graph_checks_see_a_hidden_cycle_and_an_upward_arrow(monkeypatch, tmp_path):
    fake_package(
        tmp_path,
        monkeypatch,
        {
            "data/__init__.py": "def f():\n    from spl_al.labeling import g\n",
            "labeling.py": "from spl_al.data import f\n",
        },
    )
    with pytest.raises(AssertionError, match=r"spl_al\.data.*spl_al\.labeling"):
        test_no_import_cycle_among_spl_al_modules()
    with pytest.raises(AssertionError, match=r"spl_al/data/__init__\.py:2: spl_al\.labeling\.g"):
        test_no_module_imports_its_own_layer_or_above()


def top_level_names(module: str) -> set[str]:
    tree = ast.parse(MODULES[module].read_text())
    names = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names |= {a.asname or a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names |= {t.id for t in targets if isinstance(t, ast.Name)}
    return names


NAMED = re.compile(r"[\"'](spl_al(?:\.\w+)*)(?::(\w+))?[\"']")


def test_every_module_named_in_a_string_exists():
    """Jobs (``"spl_al.experiment.human:accept_labels"``), warm-worker preloads and the
    command table name modules in strings, which a move would leave behind."""
    places = [
        *sorted((ROOT / "workflow" / "scripts").glob("*.py")),
        *sorted((ROOT / "workflow" / "rules").rglob("*.smk")),
        SRC / "spl_al" / "__main__.py",
        SRC / "spl_al" / "warm" / "server.py",
    ]
    named = [
        (path, module, function)
        for path in places
        for module, function in re.findall(
            r"[\"'](spl_al(?:\.\w+)*)(?::(\w+))?[\"']", path.read_text()
        )
    ]
    assert len(named) > 20
    missing = [
        f"{path.relative_to(ROOT)}: {module}{':' + function if function else ''}"
        for path, module, function in named
        if module not in MODULES or (function and function not in top_level_names(module))
    ]
    assert not missing, "no such module or function: " + ", ".join(missing)


def test_every_workflow_step_names_a_function_that_exists():
    """workflow/scripts hand their step to the warm server as "module:function"."""
    steps = set()
    for script in sorted((ROOT / "workflow" / "scripts").glob("*.py")):
        steps |= set(re.findall(r"\"(spl_al[\w.]+):(\w+)\"", script.read_text()))
    assert len(steps) > 15
    missing = [
        f"{m}:{f}" for m, f in sorted(steps) if m not in MODULES or f not in defined_names(m)
    ]
    assert not missing, missing


def test_a_package_that_loads_its_api_on_first_use_gives_every_name_it_lists():
    """``spl_al.training`` loads its names when first asked (job scripts import
    ``spl_al.training.compute`` without torch); each one it lists must load, and be
    the object itself, not a submodule of the same name."""
    import importlib
    import types

    for module in MODULES:
        tree = ast.parse(MODULES[module].read_text())
        if not any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in tree.body):
            continue
        package = importlib.import_module(module)
        for name in package.__all__:
            assert not isinstance(getattr(package, name), types.ModuleType), f"{module}.{name}"


def test_a_function_local_import_says_why_it_is_not_at_the_top():
    """An spl_al import inside a function is there because import time matters (torch,
    pandas, scipy... only when the function runs); a comment on its run of imports
    says so. Any other import belongs at the top of its module."""
    silent = []
    for module, path in MODULES.items():
        lines = path.read_text().splitlines()
        tree = ast.parse("\n".join(lines))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                if not isinstance(node, ast.ImportFrom) or node.level:
                    continue
                if not (node.module or "").startswith("spl_al"):
                    continue
                k, said = node.lineno - 1, "#" in lines[node.lineno - 1]
                while not said and k > 0:  # up through the run of imports
                    k -= 1
                    text = lines[k].strip()
                    if text.startswith("#"):
                        said = True
                    elif not (text == "" or text.startswith(("import ", "from ", ")")) or
                              text.endswith(",") or text.endswith("(")):  # fmt: skip
                        break
                if not said:
                    silent.append(f"{module}:{node.lineno} from {node.module}")
    assert not silent, silent
