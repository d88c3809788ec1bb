"""Static checks: no undefined names, unused imports or syntax errors (ruff, pyflakes rules)."""

import shutil
import subprocess
import sys
from pathlib import Path

from tests.helpers import ROOT


def test_ruff_pyflakes_rules():
    ruff = shutil.which("ruff") or str(Path(sys.executable).parent / "ruff")
    proc = subprocess.run([ruff, "check", "--select", "F,E9", "dpcollapse", "studies", "tests",
                           "scripts"],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
