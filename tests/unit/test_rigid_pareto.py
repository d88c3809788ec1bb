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
