"""Time-step control: the Courant rate, adaptive growth at rest, the Courant bound in the
diagnostics, and resuming an adaptive run."""

import json

import numpy as np
import pytest

from dpcollapse.ale.quality import courant_rate
from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.simulation import FEW_ITERATIONS, STEP_GROWTH
from tests.helpers import RIGID_BDF1, ROOT, simulation


def _sim(config, overrides, run_dir, resume=False):
    """The fixed and the iteration-adaptive step (time.adaptive refuses bdf2's tolerance)."""
    return simulation(config, RIGID_BDF1 + list(overrides), run_dir, resume=resume)


def test_courant_rate_hand_values():
    """max_K max_vertex |u| / shortest edge: 2 m/s on a unit right triangle (edge 1) → 2 /s;
    the same speed on a triangle with a 0.1 m edge → 20 /s; none or u = 0 → 0."""
    tri = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                    [[2.0, 0.0], [2.1, 0.0], [2.0, 1.0]]])
    vel = np.zeros((2, 3, 2))
    vel[0, 1] = (0.0, 2.0)
    assert courant_rate(tri[:1], vel[:1]) == pytest.approx(2.0)
    vel[1, 2] = (-1.2, 1.6)
    assert courant_rate(tri, vel) == pytest.approx(20.0)
    assert courant_rate(tri, np.zeros_like(vel)) == 0.0
    assert courant_rate(tri[:0], vel[:0]) == 0.0


def test_adaptive_step_grows_at_rest(tmp_path):
    """A stable mass (creep ≪ 1 mm/s, fixed points of 1-3 iterations): Δt grows ×1.2 per step
    up to dt_max, so the at-rest test ends the run in far fewer steps than with fixed Δt."""
    over = ["geometry.mesh_size=0.02", "time.end_time=0.5", "time.adaptive=true",
            "time.dt_max=0.01", "time.rest_duration=0.1"]
    sim = _sim("stable.yaml", over, tmp_path)
    summary = sim.run()
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    dt, its = np.array(d["dt"]), np.array(d["iterations"])
    assert summary["status"] == "at_rest"
    assert dt[0] == pytest.approx(1e-3) and dt.max() == pytest.approx(0.01)
    assert np.all(dt <= 0.01 * (1 + 1e-12))
    easy = its[:-1] <= FEW_ITERATIONS
    grown = dt[1:] / dt[:-1]
    capped = np.isclose(dt[1:], 0.01)
    assert np.allclose(grown[easy & ~capped], STEP_GROWTH)
    assert len(dt) < 30   # fixed Δt = 1 ms needs 100 steps to stay at rest for 0.1 s


def test_courant_bound_in_diagnostics(tmp_path):
    """A collapse with adaptive steps: every step's Courant number Δt·max|u|/h is ≤ cfl, the
    bound is active in the fast phase, Δt ≤ dt_max, and the mass still conserves area."""
    cfl = 0.3
    over = ["geometry.mesh_size=0.03", "time.end_time=0.3", "time.adaptive=true",
            f"time.cfl={cfl}", "time.dt_max=0.01"]
    summary = _sim("rigid.yaml", over, tmp_path).run()
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    courant, dt = np.array(d["courant"]), np.array(d["dt"])
    assert summary["status"] == "end_time" and d["t"][-1] == pytest.approx(0.3)
    assert np.all(courant <= cfl * (1 + 1e-9)), courant.max()
    assert np.sum(np.isclose(courant, cfl, rtol=1e-9)) >= 5   # the bound limited those steps
    assert np.all(dt <= 0.01 * (1 + 1e-12)) and dt.max() > 2e-3
    assert d["front"][-1] > 0.297 + 0.05
    assert abs(summary["area_drift"]) < 2e-3


def test_fixed_step_reports_its_courant_number(tmp_path):
    """time.adaptive = false keeps Δt = dt; the courant column is Δt times the rate."""
    over = ["geometry.mesh_size=0.03", "time.end_time=0.05"]
    _sim("rigid.yaml", over, tmp_path).run()
    d = read_diagnostics(tmp_path / "diagnostics.csv")
    assert np.allclose(d["dt"], 1e-3)
    assert d["courant"][0] == 0.0 and 0 < d["courant"][-1] < 1


def test_adaptive_resume_continues_the_run(tmp_path):
    """A run stopped after step 12 and resumed takes the uninterrupted run's steps (the
    checkpoint carries the adaptive target Δt)."""
    over = ["geometry.mesh_size=0.03", "time.end_time=0.08", "time.adaptive=true",
            "time.dt_max=0.004", "time.checkpoint_every=1000"]
    _sim("rigid.yaml", over, tmp_path / "full").run()
    full = read_diagnostics(tmp_path / "full" / "diagnostics.csv")
    sim = _sim("rigid.yaml", over, tmp_path / "split")
    assert sim.run(observers=[lambda s: s.state.step >= 12])["status"] == "stopped_by_observer"
    _sim("rigid.yaml", over, tmp_path / "split", resume=True).run()
    resumed = read_diagnostics(tmp_path / "split" / "diagnostics.csv")
    assert len(resumed["t"]) == len(full["t"]) > 12
    assert len(set(np.round(full["dt"], 12))) > 3   # the step did adapt
    for key in ("t", "dt", "front", "kinetic_energy"):
        np.testing.assert_allclose(resumed[key], full[key], rtol=1e-6, atol=1e-12, err_msg=key)


def test_fit_to_end_leaves_no_sliver():
    """The step toward the end time: the rest when it fits; split in two equal steps when a
    sliver under dt_min would be left; the rest in one step when it is under 2·dt_min."""
    from dpcollapse.solvers.step_control import fit_to_end

    assert fit_to_end(1e-3, 5e-4, 1e-6) == 5e-4                 # the rest fits
    assert fit_to_end(1e-3, 3e-3, 1e-6) == 1e-3                 # far from the end
    assert fit_to_end(1e-3, 1e-3 + 4e-7, 1e-6) == pytest.approx((1e-3 + 4e-7) / 2)
    assert fit_to_end(1e-6, 1.5e-6, 1e-6) == 1.5e-6             # under two smallest steps
    assert fit_to_end(0.1, 0.1 + 1e-17, 1e-6) == 0.1            # rounding: the step stands
    for step, rest in [(1e-3, 1e-3 + 9.9e-7), (2e-6, 2.5e-6), (1e-3, 1e-3)]:
        first = fit_to_end(step, rest, 1e-6)
        assert first <= max(step, rest) and (rest - first == 0 or rest - first >= 1e-6)


_SLIVER_END = 0.016307636533677877   # issue 47: a variable step landed < dt_min before it


def test_an_end_time_just_past_a_step_ends_the_run_at_it(tmp_path, capsys):
    """The issue's case (rigid collapse at 4 cm, error-controlled BDF2): it used to end with
    exit 4 "mesh degenerate" — the last sliver of time, shorter than time.dt_min, was taken
    for a mesh-motion limit. Now exit 0, status end_time, no step under dt_min; and the
    same on a resume to a new end time just past the resumed run's next step."""
    from dpcollapse.cli import main

    out = tmp_path / "run"
    args = ["run", str(ROOT / "configs" / "rigid.yaml"), "--set", "geometry.mesh_size=0.04",
            "--out", str(out), "--quiet"]
    assert main([*args, "--set", f"time.end_time={_SLIVER_END}"]) == 0, capsys.readouterr().err
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "end_time" and info["summary"]["t"] == pytest.approx(_SLIVER_END)
    d = read_diagnostics(out / "diagnostics.csv")
    assert min(d["dt"]) >= 1e-6
    end = d["t"][-1] + d["dt"][-1] + 4e-7       # one more step of that size leaves 0.4 µs
    assert main([*args, "--set", f"time.end_time={end!r}", "--resume"]) == 0, \
        capsys.readouterr().err
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "end_time" and info["summary"]["t"] == pytest.approx(end)
    assert min(read_diagnostics(out / "diagnostics.csv")["dt"]) >= 1e-6


def test_a_tolerance_out_of_reach_at_dt_min_ends_with_its_own_error(tmp_path, capsys):
    """time.tolerance = 1e-12 (issue 47: 7 002 silent steps at dt_min, then exit 4): the run
    ends with exit 3 and one line naming time.tolerance once TOLERANCE_PATIENCE steps in a
    row were taken at dt_min above it."""
    from dpcollapse.cli import main
    from dpcollapse.step_size import TOLERANCE_PATIENCE

    out = tmp_path / "run"
    code = main(["run", str(ROOT / "configs" / "rigid.yaml"), "--set", "geometry.mesh_size=0.04",
                 "--set", "time.tolerance=1e-12", "--set", "time.end_time=0.01", "--out",
                 str(out), "--quiet"])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 3 and len(lines) == 1 and "Traceback" not in err, err
    assert "time.tolerance = 1e-12 cannot be met" in lines[0] and "time.dt_min" in lines[0]
    d = read_diagnostics(out / "diagnostics.csv")
    assert TOLERANCE_PATIENCE - 1 <= sum(dt <= 1e-6 * (1 + 1e-9) for dt in d["dt"]) < 100
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "failed" and "time.tolerance" in info["summary"]["error"]
