"""The studies are clients of the solver (issue 48, docs/architecture.md "Studies"): the
drivers in ``studies/`` import only the public API the architecture doc lists (two benchmark
drivers excepted by name), the ``dpcollapse`` command keeps the solver's commands and sends a
study's name to ``python -m studies`` in one line, and the wheel holds no study."""

from __future__ import annotations

import ast
import re
import tomllib
from pathlib import Path

import pytest

from tests.helpers import ROOT

STUDIES = ROOT / "studies"
STUDY_COMMANDS = ["bench", "compare", "ladder", "stability", "wellposed"]

#: Drivers that measure the 2D model's linear algebra and reach past the public API on
#: purpose (the architecture doc names them with the same modules).
MEASURED_INTERNALS = {
    "bench.py": {"dpcollapse.models.stokes.discretization"},
    "bench_krylov.py": {"dpcollapse.solvers.linear"},
}


def public_api() -> list[str]:
    """The modules of the architecture doc's public-API list (``- `dpcollapse.x`: …``)."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("**Public API**", 1)[1].split("\n\n", 2)[1]
    return re.findall(r"^- `(dpcollapse(?:\.\w+)*)`", section, flags=re.M)


def imported_dpcollapse_modules(source: str) -> set[str]:
    """The ``dpcollapse`` modules a source imports (``from dpcollapse import compat`` is
    ``dpcollapse.compat``), also inside functions."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "dpcollapse"}
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module \
                and node.module.split(".")[0] == "dpcollapse":
            if node.module == "dpcollapse":
                found |= {f"dpcollapse.{a.name}" for a in node.names}
            else:
                found.add(node.module)
    return found


def reaches_past_the_api(name: str, source: str, api: list[str]) -> list[str]:
    allowed = MEASURED_INTERNALS.get(name, set())
    return sorted(f"studies/{name}: imports {m}" for m in imported_dpcollapse_modules(source)
                  if m not in allowed and not any(m == p or m.startswith(p + ".") for p in api))


def test_the_public_api_list_is_read():
    api = public_api()
    assert {"dpcollapse.config", "dpcollapse.simulation", "dpcollapse.errors"} <= set(api)
    assert len(api) == len(set(api)) >= 10


def test_the_drivers_import_only_the_public_api():
    api = public_api()
    bad = [line for path in sorted(STUDIES.glob("*.py"))
           for line in reaches_past_the_api(path.name, path.read_text(encoding="utf-8"), api)]
    assert not bad, "studies reaching past the public API (docs/architecture.md):\n" + "\n".join(bad)


@pytest.mark.parametrize("name, source", [
    ("ladder.py", "from dpcollapse.models.stokes.regularized import RegularizedFlow\n"),
    ("compare.py", "def f():\n    from dpcollapse.forms import momentum\n"),
    ("stability.py", "import dpcollapse.domain.moving\n"),
    ("bench.py", "from dpcollapse import solvers\n"),
])
def test_an_internal_import_is_found(name, source):
    assert len(reaches_past_the_api(name, source, public_api())) == 1


def test_a_study_given_to_the_solver_command_is_one_line_naming_python_m_studies(capsys):
    from dpcollapse.cli import STUDY_COMMANDS as moved
    from dpcollapse.cli import main

    assert sorted(moved) == STUDY_COMMANDS
    for name in STUDY_COMMANDS:
        assert main([name, "--quick"]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and f"python -m studies {name}" in lines[0], lines


def test_the_solver_command_lists_no_study_and_the_studies_command_lists_all():
    import click

    from dpcollapse.cli import cli as solver
    from studies.cli import cli as studies

    with click.Context(solver) as ctx:
        assert not set(solver.list_commands(ctx)) & set(STUDY_COMMANDS)
        assert {"check", "run", "mesh", "plot", "validate", "sweep"} <= set(solver.list_commands(ctx))
    with click.Context(studies) as ctx:
        assert sorted(studies.list_commands(ctx)) == STUDY_COMMANDS


def test_the_wheel_holds_no_study():
    """The packages setuptools puts in the wheel (pyproject's ``packages.find``) are the
    solver's; the report (docs/benchmarks/2026-12-07-studies-out.md) lists a built wheel."""
    from setuptools import find_packages

    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    packages = find_packages(where=ROOT, include=find["include"])
    assert "dpcollapse" in packages and "studies" in {p.name for p in ROOT.iterdir()}
    assert not [p for p in packages if not p.startswith("dpcollapse")], packages
    assert not [p for p in packages if "stud" in p], packages
    assert Path(STUDIES / "__init__.py").is_file()
