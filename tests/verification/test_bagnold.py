"""`dpcollapse validate bagnold --quick`: steady μ(I) flow down a slope vs the Bagnold profile,
and the observer stop hook of Simulation.run that it relies on."""

import json

import numpy as np
import pytest

from dpcollapse.cli import main
from dpcollapse.config import load_config, with_overrides
from dpcollapse.simulation import Simulation
from dpcollapse.validation.bagnold import validate_bagnold
from tests.helpers import ROOT

CONFIG = ROOT / "configs/bagnold.yaml"


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bagnold")
    return validate_bagnold(CONFIG, out, quick=True, log=lambda m: None), out


def test_steady_profile_matches_bagnold(quick):
    """Measured: 3.7e-4 (5 cells across) and 9.3e-5 (10 cells), order 2.0. The same runs with
    a wrong law in the solver only: I0 doubled (seed 002's rate term) 1.0, μ_2 = 0.62 instead
    of 0.60 9.3e-2, μ_s = 0.33 instead of 0.32 1.2e-1, on both meshes."""
    res, _ = quick
    n5, n10 = res["cases"]
    assert (n5.cells, n10.cells) == (5, 10)
    assert n5.error < 1e-3 and n10.error < 3e-4, (n5.error, n10.error)
    assert n10.surface_error < 2e-3, n10.surface_error
    assert 1.8 < res["order"] < 2.2, res["order"]   # measured 1.99


def test_steady_state_detected_and_run_stopped_cleanly(quick):
    res, out = quick
    for c in res["cases"]:
        assert c.status == "stopped_by_observer"
        assert 4.0 < c.steady_time < 15.0 and 0.5 < c.decay_time < 1.2, (c.steady_time, c.decay_time)
        assert c.time_1pct < c.steady_time
        info = json.loads((out / f"cells_{c.cells}" / "run.json").read_text())
        assert info["status"] == "stopped_by_observer"
        assert info["summary"]["t"] == pytest.approx(c.steady_time)


def test_inertial_number_and_well_posedness(quick):
    """I is uniform (= I_θ) at the cell centroids, inside the well-posed window; only a thin
    layer under the surface (p_h → 0 with γ̇_h ≠ 0) is ill posed."""
    res, _ = quick
    I_theta, (lo, hi) = res["I_theta"], res["window"]
    assert lo < I_theta < hi
    for c in res["cases"]:
        assert c.ill_posed_cells == 0.0
        assert abs(c.I_min / I_theta - 1) < 0.05 and abs(c.I_max / I_theta - 1) < 0.05
        assert c.I_surface > hi                       # reported, not hidden
        assert 0 < c.ill_posed_depth < 0.01 * c.mesh_size


def test_outputs(quick):
    res, out = quick
    assert (out / "bagnold.png").stat().st_size > 10_000
    rows = (out / "bagnold.csv").read_text().splitlines()
    assert len(rows) == 1 + len(res["cases"]) and rows[0].startswith("label,cells,mesh_size")


def test_cli_quick(tmp_path, capsys):
    assert main(["validate", "bagnold", "--quick", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "bagnold.csv").is_file() and (tmp_path / "bagnold.png").is_file()
    assert "bagnold.csv" in capsys.readouterr().out


def test_cli_refuses_non_mu_i_config(capsys):
    assert main(["validate", "bagnold", "--config", str(ROOT / "configs/plug.yaml")]) == 2
    assert "material.rheology" in capsys.readouterr().err


def test_observer_returning_true_stops_the_run_cleanly(tmp_path):
    cfg = with_overrides(load_config(CONFIG), ["geometry.mesh_size=0.004", "time.end_time=1.0"])
    sim = Simulation(cfg, tmp_path, quiet=True)
    calls = []

    def stop_at_third(s):
        calls.append(s.state.step)
        return s.state.step == 3

    summary = sim.run(observers=[stop_at_third, lambda s: None])
    assert calls == [1, 2, 3] and summary["status"] == "stopped_by_observer" and summary["steps"] == 3
    assert json.loads((tmp_path / "run.json").read_text())["status"] == "stopped_by_observer"
    assert (tmp_path / "checkpoint.npz").is_file()
    t = np.loadtxt(tmp_path / "diagnostics.csv", delimiter=",", skiprows=1, usecols=1, ndmin=1)
    assert len(t) == 3 and t[-1] == pytest.approx(3 * cfg.time.dt)
