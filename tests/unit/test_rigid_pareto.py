"""studies/benchmarks/rigid_pareto.py (issue 51): the observed order of a three-level sequence
Q = Q0 + C h^p (equal and unequal ratios of ΔX), Richardson's extrapolation back to Q0, and
the Pareto front (no point both cheaper and more accurate)."""

import sys

import numpy as np
import pytest

from tests.helpers import ROOT

sys.path.insert(0, str(ROOT / "studies" / "benchmarks"))
import rigid_pareto  # noqa: E402


@pytest.mark.parametrize("p", [0.5, 1.0, 2.0, 3.0])
@pytest.mark.parametrize("sizes", [(0.03, 0.02, 0.014), (0.02, 0.014, 0.01), (0.04, 0.02, 0.01)])
def test_observed_order_and_extrapolation(p, sizes):
    q0 = np.array([0.66, 0.31, 0.21])
    c = np.array([0.3, -1.2, 0.05])
    runs = [
        {"name": f"h{h}", "h": h, **{k: q0 + c * h**p for k in ("front", "height", "history", "profile")}}
        for h in sizes
    ]
    for run in runs:
        run["front"] = float(run["front"][0])      # a scalar, as run.json's
    out = rigid_pareto.richardson(runs, log=lambda *_: None)
    for key in ("front", "history", "profile"):
        assert out[key]["p"] == pytest.approx(p, rel=1e-6)
    assert out["front"]["extrapolated"] == pytest.approx(q0[0], abs=1e-12)
    assert np.allclose(out["history"]["extrapolated"], q0, atol=1e-12)


def test_no_order_without_monotone_convergence():
    assert np.isnan(rigid_pareto.observed_order(1.0, 2.0, 1.0, 0.03, 0.02, 0.01))   # oscillates
    assert np.isnan(rigid_pareto.observed_order(1.0, 1.0, 1.0, 0.03, 0.02, 0.01))   # no change


def test_pareto_front():
    #          cost, error
    points = [(10, 1.0), (5, 2.0), (20, 0.5), (12, 1.5), (5, 3.0), (40, 0.5)]
    assert rigid_pareto.pareto(points) == [1, 0, 2]


@pytest.mark.parametrize("p", [0.7, 1.66, 2.5])
def test_power_fit_over_four_and_five_levels(p):
    """Q = Q0 + C h^p over 4 (unequal ratios) and 5 levels: the fit gives back Q0, C and p."""
    for sizes in ((0.02, 0.014, 0.01, 0.007), (0.03, 0.02, 0.014, 0.01, 0.005)):
        q0, c, p_fit = rigid_pareto.power_fit(sizes, [0.667 - 0.4 * h ** p for h in sizes])
        assert p_fit == pytest.approx(p, rel=1e-4)
        assert q0 == pytest.approx(0.667, abs=1e-9)
        assert c == pytest.approx(-0.4, rel=1e-3)


def test_power_fit_refuses_non_monotone_levels():
    assert np.isnan(rigid_pareto.power_fit((0.02, 0.014, 0.01, 0.007), [1.0, 0.9, 0.95, 0.94])[2])
    assert np.isnan(rigid_pareto.power_fit((0.02, 0.01), [1.0, 0.9])[2])   # two levels
    # monotone but not converging: the step 1 → 0.7 cm larger than 2 → 1.4 cm (the measured
    # deposit fronts 0.66796, 0.66732, 0.66698, 0.66481 m at 3e-5)
    assert np.isnan(rigid_pareto.power_fit((0.02, 0.014, 0.01, 0.007),
                                           [0.66796, 0.66732, 0.66698, 0.66481])[2])


def test_richardson_levels_fits_every_scalar_of_four_runs():
    p, q0 = 2.0, np.array([0.31, 0.38, 0.47, 0.56, 0.63, 0.66, 0.667, 0.667, 0.667])
    c = np.linspace(-1.0, 1.0, len(q0)) + 0.05          # no zero coefficient
    runs = [{"name": f"h{h}", "h": h, "front": 0.667 + 0.3 * h ** p, "height": 0.21 - 0.1 * h ** p,
             "history": q0 + c * h ** p, "profile": q0 + c * h ** p}
            for h in (0.02, 0.014, 0.01, 0.007)]
    out = rigid_pareto.richardson_levels(runs, log=lambda *_: None)
    assert out["fits"]["front"]["p"] == pytest.approx(p, rel=1e-4)
    assert out["fits"]["front"]["finest_error"] == pytest.approx(0.3 * 0.007 ** p, rel=1e-3)
    assert out["fits"]["x_f(0.1)"]["q0"] == pytest.approx(q0[0], abs=1e-9)
    assert out["front"]["p"] == pytest.approx(p, rel=1e-6)          # the finest triple's order


def test_done_when_against_the_default():
    """Issue 51: each error no larger than the default's, the deposit front within 2.5 mm."""
    default = {"e_hist": 1.2, "e_inf": 1.4, "e_l1": 1.3, "e_front": -1.0}
    ok = {"e_hist": 1.2, "e_inf": 1.0, "e_l1": 0.9, "e_front": 2.4}
    assert rigid_pareto.meets(ok, default)["all"]
    for key, bad in (("e_hist", 1.21), ("e_inf", 1.5), ("e_l1", 1.31), ("e_front", -2.6)):
        verdict = rigid_pareto.meets(ok | {key: bad}, default)
        assert not verdict["all"] and not verdict[key]


def test_earlier_rows_are_charted_only_against_the_same_reference(tmp_path):
    """``--rows``: the rows of an earlier CSV join the chart when its reference row is this
    reference (deposit front and steps); another reference is refused."""
    import csv

    path = tmp_path / "grid.csv"
    keys = ["name", "h", "surface", "tol", "norm", "steps", "lu", "rejected", "remeshes", "rest",
            "cpu", "total", "front", "height", "e_hist", "e_inf", "e_l1", "e_front", "e_height",
            "meets"]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        w.writerow(["h0.7_t3e-5", 0.007, 0.007, 3e-5, "max", 3977, 6113, 458, 21, 0.945, 390.0,
                    2609.0, 0.6648130358617593, 0.21, "", "", "", "", "", ""])
        w.writerow(["h3_rms8e-5", 0.03, 0.03, 8e-5, "rms", 204, 715, 10, 9, 0.941, 4.8, 30.0,
                    0.6642, 0.209, 0.83, 1.36, 5.31, -0.63, -1.0, "yes"])
        w.writerow(["h1_t3e-4", 0.01, 0.01, 3e-4, "max", 617, 1446, 80, 17, 0.935, 42.6, 290.0,
                    0.666, 0.21, 2.12, 1.79, 5.69, 1.18, 0.1, ""])
    ref = {"front": 0.6648130358617593, "steps": 3977}
    rows = rigid_pareto.earlier_rows(path, ref, skip={"h1_t3e-4"})
    assert [r["name"] for r in rows] == ["h3_rms8e-5"]
    r = rows[0]
    assert r["e_hist"] == 0.83 and r["cpu"] == 4.8 and r["steps"] == 204 and not r["graded"]
    assert r["accuracy"] is None
    with pytest.raises(SystemExit, match="is not this one"):
        rigid_pareto.earlier_rows(path, {"front": 0.66481, "steps": 3977}, skip=set())
