"""`dpcollapse validate plug --quick`: the 2D solver against the 1D non-smooth reference."""

import numpy as np
import pytest

from dpcollapse.cli import main
from dpcollapse.validation.plug import validate_plug
from tests.helpers import ROOT


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("plug")
    return validate_plug(ROOT / "configs/plug.yaml", out, quick=True, log=lambda m: None), out


def test_error_bounds_at_eps_1e6(quick):
    res, _ = quick
    fine = next(r for r in res["results"]["epsilon"] if r.epsilon == 1e-6)
    bounds = {0.2: 1e-3, 0.4: 2e-3, 0.6: 5e-3, 0.8: 1.5e-2}
    for t, bound in bounds.items():
        assert fine.errors[t] < bound, (t, fine.errors[t])


def test_regularization_error_dominates_at_eps_1e2(quick):
    """ε = 1e-2 is visibly worse once the static layer grows, and never stops (creep)."""
    res, _ = quick
    by_eps = {r.epsilon: r for r in res["results"]["epsilon"]}
    assert by_eps[1e-2].errors[0.8] > 1.3 * by_eps[1e-6].errors[0.8]
    assert np.isnan(by_eps[1e-2].stopping_time)


def test_stopping_time_and_interface_match_reference(quick):
    res, _ = quick
    ref = res["reference"]
    fine = next(r for r in res["results"]["epsilon"] if r.epsilon == 1e-6)
    assert abs(fine.stopping_time - ref.stopping_time) < 0.01
    t2d, b2d = np.array(fine.interface).T
    for t in (0.7, 0.8, 0.9):
        i = np.argmin(np.abs(t2d - t))
        b1d = np.interp(t2d[i], ref.times, ref.interface)
        assert abs(b2d[i] - b1d) < 0.0025, (t, b2d[i], b1d)  # half a cell of the 5 mm mesh


def test_time_order_and_outputs(quick):
    res, out = quick
    assert res["orders"]["time"] >= 0.9
    assert (out / "plug.png").stat().st_size > 10_000
    assert len((out / "plug.csv").read_text().splitlines()) == 1 + 2 + 3 + 3


def test_cli_rejects_missing_config(tmp_path, capsys):
    assert main(["validate", "plug", "--config", str(tmp_path / "nope.yaml")]) == 2
    assert "--config" in capsys.readouterr().err


def test_space_order(quick):
    """Coarse meshes (20, 10, 5 mm), where the spatial error dominates at t = 0.8 s."""
    res, _ = quick
    assert res["orders"]["space"] >= 0.9
