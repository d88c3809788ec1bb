"""The pip path's pieces that run without the wheel: ``scripts/setup.sh --pip``'s refusals
(one line, exit 2) and the import-order hook ``dpcollapse/wheel_mpi.py`` (the wheel's MPI
loaded before DOLFINx, and only when DOLFINx is imported)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _checkout(tmp_path: Path) -> Path:
    """A copy of the set-up scripts and pyproject.toml: what setup.sh reads before installing."""
    (tmp_path / "scripts").mkdir(parents=True)
    for name in ("setup.sh", "setup-pip.sh"):
        shutil.copy2(ROOT / "scripts" / name, tmp_path / "scripts" / name)
    shutil.copy2(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    return tmp_path


def _fake_python(tmp_path: Path, version: str) -> Path:
    """A Python that reports ``version`` to the set-up's version check and is the real
    interpreter otherwise."""
    old = tuple(int(v) for v in version.split(".")[:2]) < (3, 12)
    fake = tmp_path / "python-fake"
    fake.write_text(textwrap.dedent(f"""\
        #!/bin/sh
        case "$*" in
          *version_info*) exit {1 if old else 0} ;;
          *python_version*) echo {version}; exit 0 ;;
        esac
        exec {sys.executable} "$@"
        """))
    fake.chmod(0o755)
    return fake


def _setup(root: Path, *args: str, python: Path | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "DPCOLLAPSE_SETUP"}
    if python is not None:
        env["PYTHON"] = str(python)
    return subprocess.run(["bash", str(root / "scripts" / "setup.sh"), *args], cwd=root, env=env,
                          capture_output=True, text=True, timeout=60)


def test_unknown_option_is_refused_in_one_line(tmp_path):
    proc = _setup(_checkout(tmp_path), "--wheel")
    assert proc.returncode == 2
    assert proc.stderr.strip() == "setup: unknown option --wheel (allowed: --pip, --apt)"


def test_python_older_than_3_12_is_refused_in_one_line(tmp_path):
    root = _checkout(tmp_path / "repo")
    proc = _setup(root, "--pip", python=_fake_python(tmp_path, "3.11.2"))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Python 3.11.2 is too old" in lines[0] and "3.12" in lines[0]
    assert not (root / ".venv").exists()


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                    reason="no C compiler: the set-up stops at that check first")
def test_a_venv_of_the_apt_path_is_not_taken_over(tmp_path):
    """A .venv without the pip path's marker is the apt path's: --pip refuses to touch it."""
    root = _checkout(tmp_path / "repo")
    (root / ".venv" / "bin").mkdir(parents=True)
    (root / ".venv" / "bin" / "python").symlink_to(sys.executable)
    proc = _setup(root, "--pip", python=_fake_python(tmp_path, "3.13.5"))
    if "no Python.h" in proc.stderr:
        pytest.skip("this Python has no headers: the set-up stops at that check first")
    assert proc.returncode == 2, proc.stderr
    assert "made by the apt path" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_wheel_mpi_loads_mpi_first_and_only_for_dolfinx(tmp_path):
    """With a (stand-in) dolfinx_solver installed: importing dpcollapse imports nothing of
    it; the first ``import dolfinx`` imports dolfinx_solver just before dolfinx."""
    fake = tmp_path / "site"
    for name in ("dolfinx_solver", "dolfinx"):
        (fake / name).mkdir(parents=True)
        (fake / name / "__init__.py").write_text(
            f"import builtins\nbuiltins.ORDER = getattr(builtins, 'ORDER', []) + [{name!r}]\n")
    script = textwrap.dedent("""\
        import builtins, sys
        import dpcollapse
        assert "dolfinx_solver" not in sys.modules and not hasattr(builtins, "ORDER")
        import dolfinx
        print(builtins.ORDER)
        """)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(fake), str(ROOT)])}
    proc = subprocess.run([sys.executable, "-S", "-c", script], env=env, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "['dolfinx_solver', 'dolfinx']"
