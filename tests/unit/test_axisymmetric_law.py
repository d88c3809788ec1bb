"""studies/benchmarks/axisymmetric/law.py (issue 52): the power fit above a ≈ 2 recovers a
known exponent and gives its standard error, the laboratory's fits as quoted, and a run
directory read into its deposit (runout at the thickness front, volume drift, CPU)."""

import json
import sys

import numpy as np
import pytest

from tests.helpers import ROOT

sys.path.insert(0, str(ROOT / "studies" / "benchmarks" / "axisymmetric"))
import law  # noqa: E402


def test_the_power_fit_recovers_the_exponent_and_its_error():
    a = np.array([2.0, 3.0, 6.0, 10.0])
    c, n, se = law.power_fit(a, 1.6 * a ** 0.5)
    assert (c, n) == pytest.approx((1.6, 0.5), rel=1e-12)
    assert se == pytest.approx(0.0, abs=1e-12)
    # a perturbed law: the exponent's standard error from the residuals
    y = 1.6 * a ** 0.5 * np.exp(np.array([0.02, -0.03, 0.01, 0.0]))
    _, n, se = law.power_fit(a, y)
    x, z = np.log(a), np.log(y)
    slope, intercept = np.polyfit(x, z, 1)
    resid = z - (slope * x + intercept)
    expected = np.sqrt(resid @ resid / 2 / np.sum((x - x.mean()) ** 2))
    assert n == pytest.approx(slope, rel=1e-12) and se == pytest.approx(expected, rel=1e-10)
    assert np.isnan(law.power_fit(a[:2], y[:2])[2])        # two points: no error


def _run_dir(tmp_path, config: str, diagnostics: str, name: str = "axi_a2_h0.01",
             status: str = "at_rest"):
    """A run directory ``name``: config.yaml, run.json (its status) and diagnostics.csv as
    given."""
    run = tmp_path / name
    run.mkdir()
    (run / "config.yaml").write_text(config)
    (run / "run.json").write_text(json.dumps({"status": status}))
    (run / "diagnostics.csv").write_text(diagnostics)
    return run


def test_the_laboratory_fits_as_quoted():
    assert law.lube([1.0, 1.7, 4.0]) == pytest.approx([1.24, 1.24 * 1.7, 3.2])
    assert law.lajeunesse([0.5, 3.0, 4.0]) == pytest.approx([0.5, 3.0, 4.0])


def test_a_run_directory_is_read_into_its_deposit(tmp_path):
    run = _run_dir(tmp_path,
                   "geometry: {shape: column, symmetry: axisymmetric, height: 0.2, base_length: 0.1, "
                   "mesh_size: 0.01}\nmaterial: {rheology: mu_i}\nboundary: {bed_condition: no_slip}\n",
                   "step,t,front,thick_front,max_height,area,remeshes,surgeries\n"
                   "0,0.0,0.1,0.1,0.2,0.0062831853,0,0\n"
                   "500,0.5,0.36,0.34,0.055,0.0062831790,40,2\n")
    (tmp_path / "axi_a2_h0.01.time").write_text("Command exited with non-zero status 1\n12.5 0.5 40.1\n")
    row = law.run_row(run)
    assert row["a"] == pytest.approx(2.0) and row["status"] == "at_rest"
    assert row["thickness_runout"] == pytest.approx(2.4) and row["mass_runout"] == pytest.approx(2.6)
    assert row["height"] == pytest.approx(0.55)
    assert row["volume_drift"] == pytest.approx((0.0062831790 - 0.0062831853) / 0.0062831853, rel=1e-9)
    assert row["cpu"] == pytest.approx(13.0) and row["surgeries"] == 2


def test_a_run_not_at_rest_is_read_where_it_settled(tmp_path):
    """A deposit still creeping at the end (status end_time) is read at its first row after
    the kinetic energy's peak below 1e-3 of it."""
    run = _run_dir(tmp_path,
                   "geometry: {height: 0.05, base_length: 0.1, mesh_size: 0.01}\n"
                   "material: {rheology: mu_i}\n",
                   "step,t,front,thick_front,max_height,area,remeshes,kinetic_energy\n"
                   "0,0.0,0.1,0.1,0.05,1.0,0,0.0\n"
                   "100,0.1,0.15,0.14,0.045,1.0,9,2.0\n"
                   "400,0.4,0.17,0.16,0.0435,1.0,29,1.9e-3\n"
                   "3000,3.0,0.158,0.151,0.046,1.0,153,3.0e-3\n",
                   name="axi_a0.5_h0.01", status="end_time")
    row = law.run_row(run)
    assert row["state"] == "settled" and row["t"] == pytest.approx(0.4)
    assert row["thickness_runout"] == pytest.approx(0.6)


def _deposit_checkpoint(run, step):
    """A trapezoidal deposit r ∈ [0, 0.3], top 0.05 m on r ≤ 0.1, surface falling linearly
    to the toe at r = 0.3 (h(r) = 0.05 (0.3 − r)/0.2), as the run's checkpoint at ``step``."""
    x = np.array([[0.0, 0.0], [0.3, 0.0], [0.1, 0.05], [0.0, 0.05]])
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    np.savez(run / "checkpoint.npz", mesh_x=x, mesh_edges=edges,
             mesh_edge_tags=np.array([1, 2, 2, 3]), state=np.array(json.dumps({"step": step})))


def test_the_deposit_is_read_again_at_fixed_thicknesses(tmp_path):
    """The thickness front at each of THRESHOLDS, from the checkpoint of the step the run
    stopped at (exact on the polygon: r_f = 0.3 − 4 h_f); NaN from a checkpoint of another
    step."""
    run = tmp_path / "axi_a1_h0.01"
    run.mkdir()
    _deposit_checkpoint(run, 500)
    fronts = law.deposit_fronts(run, 0.1, 500)
    assert list(fronts) == ["runout_h2.5mm", "runout_h5mm", "runout_h10mm", "runout_h20mm"]
    expected = [(0.3 - 4 * h - 0.1) / 0.1 for h in law.THRESHOLDS]
    assert list(fronts.values()) == pytest.approx(expected, rel=1e-12)
    assert all(np.isnan(v) for v in law.deposit_fronts(run, 0.1, 499).values())


def test_an_earlier_csv_is_merged_with_its_friction(tmp_path):
    """Rows of an earlier CSV (run directories gone) typed as run_row's, μ_s from the law
    report's configs, the fixed-thickness fronts NaN; a run given again replaces its row."""
    old = tmp_path / "old.csv"
    old.write_text("run,bed,rheology,a,mesh_size,status,state,t,thickness_runout,steps\n"
                   "axi_a2_h0.01,no_slip,mu_i,2,0.01,at_rest,final,0.58,2.38,635\n"
                   "axi_dp_a2_h0.01,no_slip,drucker_prager,2,0.01,at_rest,final,0.48,1.775,503\n")
    rows = law.previous_rows(old)
    assert [r["mu_s"] for r in rows] == [0.32, 0.477]
    assert rows[0]["thickness_runout"] == 2.38 and rows[0]["steps"] == 635
    assert np.isnan(rows[1]["runout_h5mm"])
    run = _run_dir(tmp_path,
                   "geometry: {height: 0.2, base_length: 0.1, mesh_size: 0.01}\n"
                   "material: {rheology: mu_i, friction_angle: 17.7447}\n",
                   "step,t,front,thick_front,max_height,area,remeshes\n"
                   "0,0.0,0.1,0.1,0.2,1.0,0\n"
                   "500,0.5,0.36,0.34,0.055,1.0,40\n")
    _deposit_checkpoint(run, 500)
    out = tmp_path / "law.csv"
    law.main([str(run), "--previous", str(old), "--csv", str(out)])
    import csv
    merged = {r["run"]: r for r in csv.DictReader(out.open())}
    assert merged["axi_a2_h0.01"]["thickness_runout"] == "2.4"     # the new run's row
    assert float(merged["axi_a2_h0.01"]["mu_s"]) == pytest.approx(0.32, rel=1e-4)
    assert float(merged["axi_a2_h0.01"]["runout_h5mm"]) == pytest.approx(1.8)
    assert merged["axi_dp_a2_h0.01"]["runout_h5mm"] == "nan"


def test_the_cone_factor_of_a_cone_is_a_third():
    """φ = V/(π R² H_f): a cone of height 0.74 r0 holding the column a = 6 (V = π r0² H0)
    has R/r0 = (3a/0.74)^{1/2} and φ = 1/3; a flat disc of the same R and H_f has φ = 1."""
    a, h = 6.0, 0.74
    runout = np.sqrt(3 * a / h) - 1
    assert law.cone_factor(a, runout, h) == pytest.approx(1 / 3, rel=1e-12)
    assert law.cone_factor(a, np.sqrt(a / h) - 1, h) == pytest.approx(1.0, rel=1e-12)


def test_the_aspect_ratio_is_one_key_per_column(tmp_path):
    """H0/r0 = 0.3/0.1 is 2.9999999999999996 in floating point: the run's a is rounded, so
    it meets an earlier CSV's row of a = 3 as the same column."""
    run = _run_dir(tmp_path,
                   "geometry: {height: 0.3, base_length: 0.1, mesh_size: 0.01}\nmaterial: {rheology: mu_i}\n",
                   "step,t,front,thick_front,max_height,area,remeshes\n"
                   "0,0.0,0.1,0.1,0.3,1.0,0\n"
                   "600,0.6,0.45,0.43,0.057,1.0,40\n", name="axi_a3_h0.01")
    assert law.run_row(run)["a"] == 3.0
