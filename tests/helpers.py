"""Helpers shared by the tests."""

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PV_SCRIPT = ROOT / "tests" / "pv_read_xdmf.py"
#: configs/rigid.yaml's time stepping before BDF2 with error control became its default: the
#: first-order fixed step (time.dt_max back at its default, for time.adaptive). For the
#: methods that refuse bdf2 (augmented Lagrangian, Savage–Hutter, time.adaptive,
#: numerics.extrapolate) and for tests of fixed-step behaviour.
RIGID_BDF1 = ["time.scheme=bdf1", "time.tolerance=null", "time.dt_max=1.5e-3"]
PV_MARK = "PV_SUMMARY_JSON:"


def clean_env():
    """The environment without the MPI launcher's variables: pvpython (built with MPI)
    must start as its own singleton, not join the mpirun job of the test."""
    prefixes = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "ORTE_", "HYDRA_", "I_MPI_")
    env = {k: v for k, v in os.environ.items() if not k.startswith(prefixes)}
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    return env


#: Let mpirun start more ranks than cores: Open MPI 4 reads the first, Open MPI 5 (PRRTE,
#: Debian 13 and later) the second.
OVERSUBSCRIBE = {"OMPI_MCA_rmaps_base_oversubscribe": "1",
                 "PRTE_MCA_rmaps_default_mapping_policy": ":oversubscribe"}


def paraview_skip_reason() -> str | None:
    """Why the ParaView read-back cannot run here: on the pip path there is no pvpython
    (ParaView has no pip package); elsewhere None (scripts/setup.sh installs it)."""
    if shutil.which("pvpython") is None:
        from dpcollapse import compat

        if compat.DOLFINX_BUILD == "wheel":
            return "pvpython: ParaView has no pip package (pip path)"
    return None


def paraview_summaries(*masters):
    """One pvpython start-up reading every master; the JSON summaries in order."""
    reason = paraview_skip_reason()
    if reason is not None:   # what ran before this call has passed
        import pytest

        pytest.skip(reason)
    pvpython = shutil.which("pvpython")
    assert pvpython is not None, "pvpython (ParaView) is not on PATH: scripts/setup.sh installs it"
    proc = subprocess.run(
        [pvpython, str(PV_SCRIPT), *map(str, masters)],
        capture_output=True,
        text=True,
        timeout=120,
        env=clean_env(),
        cwd=tempfile.gettempdir(),  # relative paths must resolve from the master, not cwd
    )
    lines = [ln[len(PV_MARK):] for ln in proc.stdout.splitlines() if ln.startswith(PV_MARK)]
    assert len(lines) == len(masters), (
        f"pvpython exit {proc.returncode}\nstdout:\n{proc.stdout[-3000:]}\n"
        f"stderr:\n{proc.stderr[-3000:]}"
    )
    summaries = [json.loads(ln) for ln in lines]
    for s in summaries:
        assert "error" not in s, f"{s}\nstderr:\n{proc.stderr[-3000:]}"
    return summaries


def dpcollapse_cmd() -> list[str]:
    exe = Path(sys.executable).parent / "dpcollapse"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "dpcollapse.cli"]


def studies_cmd() -> list[str]:
    """The studies' command line (studies/cli.py), run with ``cwd=ROOT``: not installed."""
    return [sys.executable, "-m", "studies"]


def run_cli(*args, timeout=600, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(dpcollapse_cmd() + [str(a) for a in args], capture_output=True, text=True,
                          timeout=timeout, env=clean_env(), cwd=ROOT, **kw)


def run_studies(*args, timeout=600, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(studies_cmd() + [str(a) for a in args], capture_output=True, text=True,
                          timeout=timeout, env=clean_env(), cwd=ROOT, **kw)


def pvpython() -> str | None:
    return shutil.which("pvpython")


def simulation(config, overrides=(), run_dir=None, comm=None, resume=False, events=None):
    """The one way tests build a run: a quiet Simulation of ``config`` (a file name in
    configs/ or a path) with ``--set`` style overrides, on ``comm`` (COMM_WORLD)."""
    from mpi4py import MPI

    from dpcollapse.config import load_config
    from dpcollapse.simulation import Simulation

    path = Path(config) if Path(config).is_absolute() else ROOT / "configs" / config
    cfg = load_config(path, list(overrides))
    return Simulation(cfg, run_dir, quiet=True, resume=resume, comm=comm or MPI.COMM_WORLD,
                      events=events)


def refusal_message(config, override: str, key: str, capsys) -> str:
    """Assert that ``--set override`` on ``config`` is refused in one line naming ``key``,
    by ``load_config`` (ConfigError) and by ``dpcollapse run`` (exit 2, the key on stderr);
    returns the message for further checks."""
    import pytest

    from dpcollapse.cli import main
    from dpcollapse.config import load_config
    from dpcollapse.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        load_config(config, [override])
    message = str(err.value)
    assert key in message and "\n" not in message
    assert main(["run", str(config), "--set", override, "--out", "/nonexistent/x"]) == 2
    assert key in capsys.readouterr().err
    return message


def petsc_matrix(dense):
    """A serial PETSc AIJ matrix with the nonzeros of a dense numpy array."""
    import numpy as np
    from mpi4py import MPI
    from petsc4py import PETSc

    A = PETSc.Mat().createAIJ(dense.shape, comm=MPI.COMM_SELF)
    A.setUp()
    for i, j in zip(*np.nonzero(dense)):
        A.setValue(i, j, dense[i, j])
    A.assemble()
    return A
