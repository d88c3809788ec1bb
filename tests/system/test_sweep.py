"""dpcollapse sweep: sweep files, case names, and a tiny sweep (3 cases, one failing with
exit 3) on each executor: local processes, mpi4py.futures under mpirun -n 3, and the SLURM
array script's body run locally task by task; reruns skip finished cases; an interrupted
sweep exits 130 and resumes."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dpcollapse.cli import main
from dpcollapse.sweep.executors import case_command, child_env
from dpcollapse.sweep.naming import case_names, is_safe_name
from dpcollapse.sweep.spec import load_sweep
from tests.helpers import OVERSUBSCRIBE, ROOT, clean_env

RIGID = ROOT / "configs" / "rigid.yaml"
PY = [sys.executable, "-m", "dpcollapse.cli"]

# Three short cases (~1 s of time loop each at 4 cm); the third cannot converge in one
# fixed-point iteration and may not halve its step (dt_min = dt): a genuine exit 3. At the
# fixed 1 ms step (BDF1, tests.helpers.RIGID_BDF1): 20 steps, a step count per end time.
TINY = f"""
base: {RIGID}
set:
  geometry.mesh_size: 0.04
  time.end_time: 0.02
  time.scheme: bdf1
  time.tolerance: null
  time.dt_max: 1.5e-3
cases:
  - {{material.friction_angle: 25.5}}
  - {{material.friction_angle: 30}}
  - {{material.friction_angle: 25.5, numerics.max_iterations: 1, time.dt_min: 1.0e-3, name: fails}}
"""
NAMES = ["friction_angle=25.5", "friction_angle=30", "fails"]


def _env():
    env = clean_env()
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.update(OVERSUBSCRIBE, OPENBLAS_NUM_THREADS="1")
    return env


def _run(args, timeout=300, **kw):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, env=_env(),
                          cwd=ROOT, timeout=timeout, check=False, **kw)


def _write(tmp: Path, text: str, name: str = "tiny.yaml") -> Path:
    path = tmp / name
    path.write_text(text)
    return path


def _rows(out: Path) -> dict[str, dict]:
    with (out / "sweep.csv").open() as fh:
        return {r["case"]: r for r in csv.DictReader(fh)}


def _check_tiny(out: Path) -> None:
    rows = _rows(out)
    assert list(rows) == NAMES
    for name in NAMES[:2]:
        r = rows[name]
        assert (r["status"], r["exit_code"]) == ("end_time", "0")
        assert float(r["t_end"]) == pytest.approx(0.02) and r["steps"] == "20"
        run = json.loads((out / "runs" / name / "run.json").read_text())
        assert float(r["front"]) == run["summary"]["front"] > 0.297
        assert float(r["runout"]) == pytest.approx(run["summary"]["front"] - 0.297)
        assert float(r["wall_time"]) > 0 and float(r["process_time"]) > float(r["wall_time"])
    assert rows["friction_angle=30"]["material.friction_angle"] == "30"
    assert float(rows["friction_angle=25.5"]["runout"]) > float(rows["friction_angle=30"]["runout"])
    bad = rows["fails"]
    assert (bad["status"], bad["exit_code"]) == ("failed", "3")
    assert "did not converge" in bad["error"]
    assert (bad["numerics.max_iterations"], bad["time.dt_min"]) == ("1", "0.001")
    assert (out / "progress.txt").read_text().startswith("3 cases: 2 done, 1 failed, 0 running")


def _stamps(out: Path) -> dict[str, tuple[int, str]]:
    return {n: ((out / "runs" / n / "run.json").stat().st_mtime_ns,
                (out / "records" / f"{n}.json").read_text()) for n in NAMES}


# ----------------------------------------------------------------------------- unit
def test_grid_zip_cases_expand_to_their_product(tmp_path):
    path = _write(tmp_path, f"""
base: {RIGID}
set: {{geometry.mesh_size: 0.05}}
grid:
  geometry.bed_angle: [0, 5]
zip:
  time.dt: [1.0e-3, 5.0e-4]
  time.dt_min: [1.0e-6, 1.0e-7]
cases:
  - {{boundary.channel_width: 0.1}}
  - {{boundary.channel_width: null, name: open}}
""")
    sw = load_sweep(path, ("time.end_time=0.1",))
    assert len(sw.cases) == 8
    assert sw.varied == ["geometry.bed_angle", "time.dt", "time.dt_min", "boundary.channel_width"]
    first = sw.cases[0]
    assert first.overrides == ("geometry.mesh_size=0.05", "time.end_time=0.1",
                               "geometry.bed_angle=0", "time.dt=0.001", "time.dt_min=1.0e-06",
                               "boundary.channel_width=0.1")
    assert first.config["time"]["end_time"] == 0.1 and first.config["geometry"]["mesh_size"] == 0.05
    assert first.name == "bed_angle=0__dt=0.001__dt_min=1.0e-06__channel_width=0.1"
    assert (
        sw.cases[1].name == "bed_angle=0__dt=0.001__dt_min=1.0e-06__open"
        and sw.cases[1].config["boundary"]["channel_width"] is None
    )
    assert [c.params["geometry.bed_angle"] for c in sw.cases] == [0] * 4 + [5] * 4
    assert len({c.name for c in sw.cases}) == 8 and all(is_safe_name(c.name) for c in sw.cases)


def test_names_are_safe_and_collision_free():
    sets = [{"a.path": "x/y"}, {"a.path": "x_y"}, {"a.path": "X_Y"}, {"a.k": 1, "b.k": 2},
            {"a.long": "v" * 200}]
    names = case_names(sets)
    assert len({n.lower() for n in names}) == len(names)
    assert all(is_safe_name(n) for n in names), names
    assert names[0].startswith("path=x_y-h") and names[3] == "a.k=1__b.k=2"
    assert len(names[4]) <= 96


@pytest.mark.parametrize("text, expected", [
    ("base: {rigid}\ngrids: {{geometry.height: [0.1]}}\n",
     "grids: unknown key; allowed: base, set, grid"),
    ("base: {rigid}\ngrid: {{geometry.height: [0.1, 0.2]}}\nslurm: {{nodes: 2}}\n",
     "slurm.nodes: unknown key"),
    ("base: {rigid}\ngrid: {{height: [0.1]}}\n", "'height': must be section.key"),
    ("base: {rigid}\nzip: {{geometry.height: [0.1], time.dt: [1, 2]}}\n",
     "zip: lists must have one length"),
    ("base: {rigid}\ngrid: {{output.directory: [a, b]}}\n", "output.directory: set by the sweep"),
    ("base: nowhere.yaml\n", "base = nowhere.yaml: file not found"),
    ("base: {rigid}\nranks_per_case: 0\n", "ranks_per_case = 0"),
])
def test_bad_sweep_file_is_one_line_exit_2(tmp_path, capsys, text, expected):
    path = _write(tmp_path, text.format(rigid=RIGID), "bad.yaml")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--dry-run"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expected in err, err
    assert not (tmp_path / "out").exists()


def test_bad_override_names_the_case_and_key(tmp_path, capsys):
    path = _write(tmp_path, f"base: {RIGID}\ngrid:\n  geometry.bed_angle: [5, 95]\n"
                            "  geometry.mesh_sise: [0.05]\n", "bad.yaml")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("dpcollapse: error: case bed_angle=5__mesh_sise=0.05: "
                          "geometry.mesh_sise: unknown key; did you mean 'mesh_size'?"), err
    path.write_text(f"base: {RIGID}\ngrid:\n  geometry.bed_angle: [5, 95]\n")
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("dpcollapse: error: case bed_angle=95: geometry.bed_angle = 95: "
                   "must be in [0, 90) degrees"), err
    assert not (tmp_path / "out").exists()  # nothing ran


@pytest.mark.parametrize("section", ["grid", "zip", "cases"])
def test_a_set_of_a_key_the_sweep_varies_is_refused(tmp_path, capsys, section):
    """Issue 47: `sweep beverloo.yaml --set geometry.orifice_width=0.03` ran the five widths,
    the --set silently ignored."""
    body = {"grid": "grid:\n  geometry.bed_angle: [5, 10]\n",
            "zip": "zip:\n  geometry.bed_angle: [5, 10]\n  geometry.height: [0.2, 0.25]\n",
            "cases": "cases:\n  - {geometry.bed_angle: 5}\n  - {geometry.bed_angle: 10, name: b}\n"}
    path = _write(tmp_path, f"base: {RIGID}\n" + body[section], "varied.yaml")
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--set", "time.end_time=0.1", "--dry-run", "--out",
                 str(out)]) == 0                        # a key it does not vary: fine
    capsys.readouterr()
    for dry in (["--dry-run"], []):                     # refused before anything runs
        assert main(["sweep", str(path), "--set", "geometry.bed_angle=20", *dry, "--out",
                     str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and err.startswith(
            f"dpcollapse: error: --set geometry.bed_angle: varied by the sweep file {path} (its "
            f"{section}"), err
        assert not out.exists()


def test_the_beverloo_sweep_refuses_a_set_of_its_orifice_width(tmp_path, capsys):
    assert main(["sweep", str(ROOT / "configs" / "sweeps" / "beverloo.yaml"), "--set",
                 "geometry.orifice_width=0.03", "--dry-run", "--out", str(tmp_path / "o")]) == 2
    assert "--set geometry.orifice_width: varied by the sweep file" in capsys.readouterr().err


def test_refuses_to_run_once_per_rank(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")
    path = _write(tmp_path, TINY)
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "use 'python -m mpi4py.futures' and --executor mpi" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_case_environment_and_command(tmp_path):
    user = {"HOME": "/root", "OPENBLAS_NUM_THREADS": "8", "PYTHONPATH": "/x",
            "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1"}
    env = child_env({**user, "OMPI_COMM_WORLD_RANK": "1", "PMIX_RANK": "1", "PMI_FD": "3",
                     "OMPI_MCA_orte_hnp_uri": "x"})   # in an MPI rank: launcher's variables go
    assert not any(k.startswith(("OMPI_COMM", "PMI", "OMPI_MCA")) for k in env), env
    assert env["HOME"] == "/root" and env["OPENBLAS_NUM_THREADS"] == "1"
    assert env["OMPI_ALLOW_RUN_AS_ROOT"] == "1"
    assert child_env(user)["OMPI_MCA_rmaps_base_oversubscribe"] == "1"   # no launcher: kept
    assert env["PYTHONPATH"].split(os.pathsep) == [str(ROOT), "/x"]  # this tree's dpcollapse
    path = _write(tmp_path, f"base: {RIGID}\nranks_per_case: 2\ngrid: {{geometry.height: [0.2]}}\n")
    sw = load_sweep(path)
    cmd = case_command(sw, sw.cases[0], tmp_path / "out", resume=True)
    assert cmd[:3] == ["mpirun", "-n", "2"] and cmd[-2:] == ["--quiet", "--resume"]
    assert cmd[cmd.index("--set") + 1] == "geometry.height=0.2"
    assert case_command(sw, sw.cases[0], tmp_path, False, launcher="srun -n {ranks}")[:3] == [
        "srun", "-n", "2"]
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--executor", "slurm", "--out", str(out),
                 "--set", "time.end_time=0.01"]) == 0
    script = (out / "sweep.sbatch").read_text()
    assert "#SBATCH --ntasks=2" in script and "#SBATCH --array=0-0\n" in script
    assert "--set time.end_time=0.01 --fingerprint " in script


def test_driver_imports_no_dolfinx():
    code = ("import sys, dpcollapse.cli, dpcollapse.sweep.spec, dpcollapse.sweep.executors, "
            "dpcollapse.sweep.collect, dpcollapse.sweep.plot; "
            "print(sorted(m for m in ('dolfinx', 'petsc4py', 'ufl', 'gmsh') if m in sys.modules))")
    proc = _run([sys.executable, "-c", code])
    assert proc.returncode == 0 and proc.stdout.strip() == "[]", proc.stdout + proc.stderr


# ----------------------------------------------------------------------------- executors
@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("local")
    path = _write(tmp, TINY)
    proc = _run(PY + ["sweep", path, "--jobs", "2", "--out", tmp / "out"])
    return path, tmp / "out", proc


def test_local_executor_records_every_case_and_skips_them_again(local_sweep):
    path, out, proc = local_sweep
    assert proc.returncode == 0, proc.stderr
    _check_tiny(out)
    assert "fails: failed (exit 3)" in proc.stderr
    before = _stamps(out)
    again = _run(PY + ["sweep", path, "--jobs", "2", "--out", out])
    assert again.returncode == 0, again.stderr
    assert _stamps(out) == before   # no case ran again
    assert again.stderr.count("skipped") == 3
    _check_tiny(out)


def test_case_on_two_ranks(tmp_path):
    path = _write(tmp_path, f"base: {RIGID}\nranks_per_case: 2\n"
                            "set: {geometry.mesh_size: 0.04, time.end_time: 0.01}\n"
                            "grid: {material.friction_angle: [25.5]}\n")
    proc = _run(PY + ["sweep", path, "--out", tmp_path / "out"])
    assert proc.returncode == 0, proc.stderr
    run = json.loads((tmp_path / "out" / "runs" / "friction_angle=25.5" / "run.json").read_text())
    assert (run["status"], run["mpi_size"]) == ("end_time", 2)
    assert _rows(tmp_path / "out")["friction_angle=25.5"]["status"] == "end_time"


def test_plot_sweep(local_sweep):
    _, out, _ = local_sweep
    png = out / "front_vs_friction_angle.png"
    assert main(["plot-sweep", str(out), "--x", "friction_angle", "--y", "front"]) == 0
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    assert main(["plot-sweep", str(out), "--x", "geometry.height"]) == 2
    assert main(["plot-sweep", str(out), "--x", "friction_angle", "--y", "nothing"]) == 2


def test_mpi_futures_executor(tmp_path):
    path = _write(tmp_path, TINY)
    cmd = ["mpirun", "-n", "3", sys.executable, "-m", "mpi4py.futures", "-m", "dpcollapse.cli",
           "sweep", path, "--executor", "mpi", "--out", tmp_path / "out"]
    proc = _run(cmd)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "running 3 on 2 MPI workers" in proc.stderr
    _check_tiny(tmp_path / "out")
    hosts = {json.loads((tmp_path / "out" / "records" / f"{n}.json").read_text())["attempts"][0]
             ["command"].split()[0] for n in NAMES}
    assert hosts == {sys.executable}
    before = _stamps(tmp_path / "out")
    again = _run(cmd)
    assert again.returncode == 0 and _stamps(tmp_path / "out") == before
    # a bad override ends the whole job with exit 2 and the one line (no MPI_Abort)
    bad = _write(tmp_path, f"base: {RIGID}\ngrid: {{geometry.mesh_size: [0.04, -1]}}\n", "bad.yaml")
    proc = _run(cmd[:8] + ["sweep", bad, "--executor", "mpi", "--out", tmp_path / "bad"])
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "dpcollapse: error: case mesh_size=-1: geometry.mesh_size = -1" in proc.stderr
    assert "MPI_ABORT" not in proc.stderr


def test_slurm_array_script_run_task_by_task(tmp_path):
    path = _write(tmp_path, TINY)
    out = tmp_path / "out"
    proc = _run(PY + ["sweep", path, "--executor", "slurm", "--jobs", "2", "--out", out])
    assert proc.returncode == 0, proc.stderr
    script = (out / "sweep.sbatch").read_text()
    assert "#SBATCH --array=0-2%2" in script and "#SBATCH --ntasks=1" in script
    assert not (out / "runs").exists()  # nothing runs until the tasks do
    codes = []
    for task in range(3):
        env = dict(_env(), SLURM_ARRAY_TASK_ID=str(task))
        codes.append(subprocess.run(["bash", out / "sweep.sbatch"], env=env, cwd=tmp_path,
                                    capture_output=True, text=True, timeout=300, check=False).returncode)
    assert codes == [0, 0, 3]
    collect = subprocess.run(["bash", out / "collect.sbatch"], env=_env(), capture_output=True,
                             text=True, timeout=120, check=False)
    assert collect.returncode == 0, collect.stderr
    assert "3 cases: 2 done, 1 failed" in collect.stdout
    _check_tiny(out)
    before = _stamps(out)
    rerun = subprocess.run(["bash", out / "sweep.sbatch"], env=dict(_env(), SLURM_ARRAY_TASK_ID="0"),
                           capture_output=True, text=True, timeout=120, check=False)
    assert rerun.returncode == 0 and _stamps(out) == before
    # the script refuses to run cases that changed since it was written
    path.write_text(TINY.replace("time.end_time: 0.02", "time.end_time: 0.03"))
    stale = subprocess.run(["bash", out / "sweep.sbatch"], env=dict(_env(), SLURM_ARRAY_TASK_ID="0"),
                           capture_output=True, text=True, timeout=120, check=False)
    assert stale.returncode == 2 and "changed since the SLURM script was written" in stale.stderr


def test_interrupted_sweep_exits_130_and_resumes(tmp_path):
    path = _write(tmp_path, f"""
base: {RIGID}
set: {{geometry.mesh_size: 0.04, time.end_time: 0.25, time.checkpoint_every: 5}}
grid: {{material.friction_angle: [30]}}
""")
    out = tmp_path / "out"
    run_dir = out / "runs" / "friction_angle=30"
    driver = subprocess.Popen([*PY, "sweep", str(path), "--out", str(out)], env=_env(), cwd=ROOT,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (run_dir / "checkpoint.npz").exists() and driver.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.2)
    driver.send_signal(signal.SIGINT)
    _, err = driver.communicate(timeout=150)
    assert driver.returncode == 130, err
    assert err.strip().splitlines()[-1].startswith("dpcollapse: error: sweep interrupted: 1 cases")
    assert _rows(out)["friction_angle=30"]["status"] == "interrupted"
    t_stop = json.loads((run_dir / "run.json").read_text())["summary"]["t"]
    assert 0 < t_stop < 0.25
    proc = _run(PY + ["sweep", path, "--out", out])
    assert proc.returncode == 0, proc.stderr
    record = json.loads((out / "records" / "friction_angle=30.json").read_text())
    assert [a["action"] for a in record["attempts"]] == ["fresh", "resume"]
    assert [a["exit_code"] for a in record["attempts"]] == [130, 0]
    row = _rows(out)["friction_angle=30"]
    assert row["status"] == "end_time" and float(row["t_end"]) == pytest.approx(0.25)


def test_changed_config_runs_the_case_again_from_scratch(local_sweep, tmp_path):
    _, out, _ = local_sweep
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    path = _write(tmp_path, TINY.replace("time.end_time: 0.02", "time.end_time: 0.01"))
    proc = _run(PY + ["sweep", path, "--out", copy, "--dry-run"])
    assert proc.returncode == 0, proc.stderr
    assert "   0 friction_angle=25.5: stale (end_time)" in proc.stdout
    proc = _run(PY + ["sweep", path, "--out", copy, "--jobs", "2"])
    assert proc.returncode == 0, proc.stderr
    rows = _rows(copy)
    assert [rows[n]["status"] for n in NAMES] == ["end_time", "end_time", "failed"]
    assert float(rows["friction_angle=30"]["t_end"]) == pytest.approx(0.01)
    record = json.loads((copy / "records" / "friction_angle=30.json").read_text())
    assert [a["action"] for a in record["attempts"]] == ["fresh"]
    diag = (copy / "runs" / "friction_angle=30" / "diagnostics.csv").read_text().splitlines()
    assert len(diag) == 1 + 10   # one run only: header and 10 steps, nothing of the old run


def test_slope_study_is_the_twelve_slope_configs():
    from dpcollapse.config import config_to_dict, load_config

    sw = load_sweep(ROOT / "configs" / "sweeps" / "slopes.yaml")
    assert len(sw.cases) == 12
    for case in sw.cases:
        slope = case.params["geometry.bed_angle"]
        rh = {"mu_i": "mui", "drucker_prager": "dp"}[case.params["material.rheology"]]
        width = case.params["boundary.channel_width"]
        cfg = config_to_dict(load_config(ROOT / "configs" / f"slope{slope}_{rh}.yaml",
                                          [f"boundary.channel_width={width}".replace("None", "null")]))
        cfg["output"] = case.config["output"]
        assert case.config == json.loads(json.dumps(cfg)), case.name


def test_case_that_cannot_start_is_recorded(tmp_path, capsys):
    path = _write(tmp_path, f"base: {RIGID}\nranks_per_case: 2\nlauncher: no-such-launcher "
                            "-n {ranks}\ngrid: {material.friction_angle: [25.5, 30]}\n")
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out)]) == 0
    rows = _rows(out)
    assert [(r["status"], r["exit_code"]) for r in rows.values()] == [("failed", "127")] * 2
    assert "No such file or directory: 'no-such-launcher'" in rows["friction_angle=30"]["error"]
    log = out / "logs" / "friction_angle=30.log"
    assert main(["sweep", str(path), "--out", str(out)]) == 0  # kept as failed
    assert log.read_text().count(" fresh: ") == 1
    assert main(["sweep", str(path), "--out", str(out), "--retry-failed"]) == 0
    assert log.read_text().count(" fresh: ") == 2   # tried again, from scratch
    record = json.loads((out / "records" / "friction_angle=30.json").read_text())
    assert [a["exit_code"] for a in record["attempts"]] == [127]
    assert "2 cases: 0 done, 2 failed" in capsys.readouterr().out


def test_longer_end_time_continues_the_finished_cases(local_sweep, tmp_path):
    _, out, _ = local_sweep
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    path = _write(tmp_path, TINY.replace("time.end_time: 0.02", "time.end_time: 0.03"))
    proc = _run(PY + ["sweep", path, "--out", copy, "--dry-run"])
    assert "   0 friction_angle=25.5: stale (end_time) -> resume" in proc.stdout, proc.stdout
    assert "   2 fails: stale (failed) -> fresh" in proc.stdout, proc.stdout
    proc = _run(PY + ["sweep", path, "--out", copy, "--jobs", "2"])
    assert proc.returncode == 0, proc.stderr
    rows = _rows(copy)
    assert [rows[n]["status"] for n in NAMES] == ["end_time", "end_time", "failed"]
    assert float(rows["friction_angle=30"]["t_end"]) == pytest.approx(0.03)
    record = json.loads((copy / "records" / "friction_angle=30.json").read_text())
    assert [a["action"] for a in record["attempts"]] == ["fresh", "resume"]
    diag = (copy / "runs" / "friction_angle=30" / "diagnostics.csv").read_text().splitlines()
    assert len(diag) == 1 + 30   # 20 steps of the first run, 10 of the resumed one


def test_the_documented_sweep_file_is_valid(tmp_path):
    import re

    doc = (ROOT / "docs" / "sweeps.md").read_text()
    text = re.search(r"## The sweep file.*?```yaml\n(.*?)```", doc, re.DOTALL).group(1)
    text = text.replace("../slope19_mui.yaml", str(ROOT / "configs" / "slope19_mui.yaml"))
    sw = load_sweep(_write(tmp_path, text, "doc.yaml"))
    assert len(sw.cases) == 3 * 2 * 2 * 2
    assert sw.cases[1].name == ("bed_angle=10__rheology=mu_i__dt=0.001__dt_min=1.0e-06"
                                "__no_walls")
    assert sw.spec.slurm.time == "01:00:00" and sw.spec.collect == ["area_drift", "remeshes"]


def test_column_runout_example_is_valid():
    """configs/sweeps/column_runout.yaml: eight aspect ratios (0.5 to 10) of the column
    scene × two bed conditions × two mesh sizes, all valid."""
    sw = load_sweep(ROOT / "configs" / "sweeps" / "column_runout.yaml")
    heights = sorted({c.config["geometry"]["height"] for c in sw.cases})
    assert heights == [0.05, 0.08, 0.142, 0.2, 0.3, 0.45, 0.626, 1.0]
    assert len(sw.cases) == 32


def test_a_key_added_since_the_run_keeps_the_case_done(local_sweep, tmp_path):
    """A finished run written before the program gained a config key (absent from its
    run.json; here ``time.rest_energy_fraction`` stands in for it, a key the sweep's config
    leaves at its default) ran with that key's default: the case stays done; the same key at
    a value other than its default would make it stale."""
    path, out, _ = local_sweep
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    run_json = copy / "runs" / "friction_angle=30" / "run.json"
    run = json.loads(run_json.read_text())
    assert run["config"]["time"].pop("rest_energy_fraction") == 0.0
    run_json.write_text(json.dumps(run))
    proc = _run(PY + ["sweep", path, "--out", copy, "--dry-run"])
    assert proc.returncode == 0, proc.stderr
    assert "friction_angle=30: done" in proc.stdout, proc.stdout
    for change in (
        {"rest_energy_fraction": 0.1},
        {"a_key_since_removed": 1},
    ):  # the latter: compared as written
        run["config"]["time"] = {**run["config"]["time"], **change}
        run_json.write_text(json.dumps(run))
        proc = _run(PY + ["sweep", path, "--out", copy, "--dry-run"])
        assert "friction_angle=30: stale" in proc.stdout, proc.stdout
