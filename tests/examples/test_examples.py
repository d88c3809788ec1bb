"""Every file in configs/ runs, shortened to three time steps (coarser mesh for the
collapses): loads, meshes its scene, steps, writes its outputs."""

import json

import pytest
from mpi4py import MPI

from dpcollapse.config import load_config
from tests.helpers import ROOT, simulation

CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))


def test_there_are_examples():
    assert len(CONFIGS) >= 11


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_example_runs_shortened(path, tmp_path):
    cfg = load_config(path)
    over = [f"time.end_time={3 * cfg.time.dt!r}", "time.output_every=2", "time.checkpoint_every=2"]
    if cfg.geometry.shape != "layer":
        over.append(f"geometry.mesh_size={max(cfg.geometry.mesh_size, 0.03)}")
    summary = simulation(path, over, tmp_path, comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time" and summary["steps"] >= 3
    assert abs(summary["area_drift"]) < 1e-3
    for name in ("config.yaml", "diagnostics.csv", "run.json", "checkpoint.npz", "solution.xdmf"):
        assert (tmp_path / name).exists(), name
    assert json.loads((tmp_path / "run.json").read_text())["status"] == "end_time"
