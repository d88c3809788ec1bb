"""Static checks: the project's ruff rule sets (pyproject.toml's [tool.ruff]: pyflakes,
pycodestyle errors and warnings with lines <= 110, isort, pyupgrade to Python 3.11) on the
whole checkout."""

import shutil
import subprocess
import sys
from pathlib import Path

from tests.helpers import ROOT


def test_ruff_rules():
    ruff = shutil.which("ruff") or str(Path(sys.executable).parent / "ruff")
    proc = subprocess.run([ruff, "check", "--no-cache", "."], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
