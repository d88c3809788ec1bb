"""Imports point one way (docs/architecture.md, issue 24): every import in the package goes
to a module of the same layer or a lower one in :data:`LAYERS`, and no import cycle exists.
The package holds no study code (issue 48): no module under a ``studies``/``study`` name and
no import of the top-level ``studies`` tree, whose drivers are the solver's clients.

An import is an ``import``/``from … import`` statement anywhere in a module (also inside a
function), or a module named by a string literal passed to ``importlib.import_module`` or
the CLI's ``_lazy``; a run-time walk of a package (``models.registry``) is not counted.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "dpcollapse"

#: The declared order, lowest first: a module may import from its own layer and below.
#: Names are dotted paths under ``dpcollapse`` (a package stands for all its modules);
#: ``__init__`` is the package's own ``__init__.py``.
LAYERS: list[tuple[str, ...]] = [
    ("errors", "wheel_mpi", "transfer", "reference", "signals", "watchdog", "fronts"),
    ("parallel",),
    ("compat",),
    ("config",),
    ("rheology",),
    ("forms",),
    ("geometry",),
    ("scenes",),
    ("solvers",),
    ("io",),
    ("ale",),
    ("domain",),
    ("models",),
    ("progress", "stop_request", "fingerprint", "step_size", "loop", "simulation"),
    ("plot", "validation", "sweep"),
    ("cli", "config_doc", "__init__"),
]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    return ".".join(parts) if parts != ["__init__"] else "__init__"


def _targets(node: ast.AST, package: str) -> list[str]:
    """The dpcollapse modules an AST node imports (dotted, without ``dpcollapse.``)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            parent = package.split(".")[:len(package.split(".")) - node.level + 1]
            base = ".".join(["dpcollapse", *[p for p in parent if p], *([base] if base else [])])
        return [base] + [f"{base}.{a.name}" for a in node.names]
    if (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
            and getattr(node.func, "attr", getattr(node.func, "id", "")) in ("import_module", "_lazy")):
        return [node.args[0].value]
    return []


def import_graph() -> dict[str, set[str]]:
    """module -> the package's modules it imports."""
    paths = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in paths.items():
        package = name.rsplit(".", 1)[0] if "." in name and path.name != "__init__.py" else \
            ("" if name == "__init__" else name.removesuffix(".__init__"))
        found = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            for target in _targets(node, package):
                if not target.startswith("dpcollapse."):
                    continue
                target = target.removeprefix("dpcollapse.")
                for candidate in (target, f"{target}.__init__"):
                    if candidate in paths and candidate != name:
                        found.add(candidate)
        graph[name] = found
    return graph


def layer_of(module: str) -> int:
    """Index in LAYERS of the longest entry that is ``module`` or a package above it."""
    best, where = -1, None
    for i, names in enumerate(LAYERS):
        for entry in names:
            if (module == entry or module.startswith(entry + ".")) and len(entry) > best:
                best, where = len(entry), i
    if where is None:
        raise AssertionError(f"dpcollapse.{module} is in no layer of LAYERS: add it")
    return where


def arrows_against_the_order(graph: dict[str, set[str]]) -> list[str]:
    return sorted(f"{a} (layer {layer_of(a)}) -> {b} (layer {layer_of(b)})"
                  for a, targets in graph.items() for b in targets if layer_of(b) > layer_of(a))


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
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
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_every_module_has_a_layer():
    for module in import_graph():
        layer_of(module)


def test_imports_point_down_the_declared_order():
    bad = arrows_against_the_order(import_graph())
    assert not bad, "imports against the order of LAYERS:\n" + "\n".join(bad)


def test_there_is_no_import_cycle():
    assert cycles(import_graph()) == []


@pytest.mark.parametrize("edge", [("compat", "geometry.mesher"), ("solvers.linear", "models.registry"),
                                  ("simulation", "cli")])
def test_an_arrow_against_the_order_is_found(edge):
    graph = import_graph()
    graph[edge[0]] = graph[edge[0]] | {edge[1]}
    assert any(line.startswith(f"{edge[0]} (") and f"-> {edge[1]} (" in line
               for line in arrows_against_the_order(graph))


def test_a_cycle_is_found():
    graph = import_graph()
    graph["models.stokes.regularized"] = graph["models.stokes.regularized"] | {"models.stokes.newton"}
    assert ["models.stokes.newton", "models.stokes.regularized"] in cycles(graph)


def test_imports_inside_functions_and_lazy_strings_count(tmp_path):
    source = ("def f():\n    from dpcollapse.cli import main\n"
              "def g():\n    importlib.import_module('dpcollapse.simulation')\n")
    found = {t for node in ast.walk(ast.parse(source)) for t in _targets(node, "compat")}
    assert {"dpcollapse.cli", "dpcollapse.simulation"} <= found


def study_code_in_the_package(package: Path = PACKAGE) -> list[str]:
    """Modules of ``package`` that are study code: named ``studies``/``study…`` (a package or a
    module), or importing the checkout's ``studies`` tree (statement, ``import_module`` or
    ``_lazy`` string)."""
    found = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package)
        if any(part.startswith("stud") for part in rel.with_suffix("").parts):
            found.append(f"dpcollapse/{rel}: a study module inside the solver package")
        name = ".".join(rel.with_suffix("").parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets = _targets(node, name.rsplit(".", 1)[0] if "." in name else "")
            study = [t for t in targets if t == "studies" or t.startswith("studies.")]
            if study:
                found.append(f"dpcollapse/{rel}: imports {study[0]} (the solver imports no study)")
    return found


def test_the_package_holds_no_study_code():
    found = study_code_in_the_package()
    assert not found, "\n".join(found)


@pytest.mark.parametrize("where, source", [
    ("studies/ladder.py", "import numpy\n"),
    ("study_maps.py", "x = 1\n"),
    ("plot.py", "from studies import ladder\n"),
    ("models/savage_hutter/setup.py", "def f():\n    import studies.savage_hutter\n"),
    ("cli.py", "def f():\n    return _lazy('studies.bench', 'run_bench')\n"),
])
def test_a_study_inside_the_package_is_found(tmp_path, where, source):
    package = tmp_path / "dpcollapse"
    (package / where).parent.mkdir(parents=True, exist_ok=True)
    (package / "errors.py").write_text("class E(Exception):\n    pass\n")
    (package / where).write_text(source)
    found = study_code_in_the_package(package)
    assert len(found) == 1 and found[0].startswith(f"dpcollapse/{where}:"), found
