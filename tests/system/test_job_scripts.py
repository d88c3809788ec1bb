"""Job scripts built safely (issue 30): every value a sweep file or the command line puts
into ``sweep.sbatch``/``collect.sbatch`` is validated (no newline or control character,
SLURM option values one word) and quoted; paths with spaces survive in the ``#SBATCH``
lines and in the printed submit hint; a launcher's unknown ``{placeholder}`` is bad input."""

from __future__ import annotations

import shlex
import subprocess

import pytest

from dpcollapse.cli import main
from tests.helpers import ROOT

RIGID = ROOT / "configs" / "rigid.yaml"


def _sweep(folder, slurm: str = "", launcher: str = "") -> str:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "my sweep.yaml"
    path.write_text(f"base: {RIGID}\nset: {{geometry.mesh_size: 0.04}}\n"
                    "grid: {material.friction_angle: [25, 30]}\n" + slurm + launcher)
    return str(path)


def _one_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_generated_scripts_parse_and_quote_paths_with_spaces(tmp_path, capsys):
    folder = tmp_path / "a dir"
    path = _sweep(folder, 'slurm: {partition: debug, time: "01:00:00", sbatch: ["--qos=short"]}\n')
    out = folder / "out dir"
    assert main(["sweep", path, "--executor", "slurm", "--out", str(out)]) == 0
    hint = capsys.readouterr().out.splitlines()[-1]
    for name in ("sweep.sbatch", "collect.sbatch"):
        script = out / name
        check = subprocess.run(["bash", "-n", str(script)], capture_output=True, text=True)
        assert check.returncode == 0, check.stderr
        directives = [ln for ln in script.read_text().splitlines() if ln.startswith("#SBATCH")]
        for line in directives:          # sbatch splits them as a shell would: one option each
            assert len(shlex.split(line)) == 2, line
    text = (out / "sweep.sbatch").read_text()
    assert '#SBATCH --job-name="sweep-my sweep"' in text
    assert f'#SBATCH --output="{out.resolve()}/logs/slurm-%A_%a.out"' in text
    assert "#SBATCH --partition=debug" in text and "#SBATCH --qos=short" in text
    hint = hint.removeprefix("submit: ")
    assert subprocess.run(["bash", "-n", "-c", hint]).returncode == 0
    for name in ("sweep.sbatch", "collect.sbatch"):
        assert shlex.quote(str((out / name).resolve())) in hint


@pytest.mark.parametrize("slurm, key", [
    ('slurm: {partition: "debug\\necho INJECTED"}\n', "slurm.partition"),
    ('slurm: {account: "a b"}\n', "slurm.account"),
    ('slurm: {sbatch: ["--qos=short; rm -rf ~"]}\n', "slurm.sbatch"),
    ('slurm: {setup: ["module load x\\necho INJECTED"]}\n', "slurm.setup"),
    ('slurm: {launcher: "srun -n {rank}"}\n', "slurm.launcher"),
])
def test_values_a_job_script_cannot_hold_are_refused(tmp_path, capsys, slurm, key):
    path = _sweep(tmp_path, slurm)
    out = tmp_path / "out"
    assert main(["sweep", path, "--executor", "slurm", "--out", str(out)]) == 2
    assert key in _one_line(capsys.readouterr().err)
    assert not (out / "sweep.sbatch").exists()


def test_unknown_launcher_placeholder_is_bad_input(tmp_path, capsys):
    path = _sweep(tmp_path, "ranks_per_case: 2\n", "launcher: mpirun -np {nprocs}\n")
    assert main(["sweep", path, "--dry-run", "--out", str(tmp_path / "out")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "launcher" in line and "{nprocs}" in line


def test_an_out_path_with_a_newline_is_refused(tmp_path, capsys):
    path = _sweep(tmp_path)
    out = tmp_path / "out\nx"
    assert main(["sweep", path, "--executor", "slurm", "--out", str(out)]) == 2
    assert "--out" in _one_line(capsys.readouterr().err)
