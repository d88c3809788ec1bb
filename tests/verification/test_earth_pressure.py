"""Savage & Hutter's earth-pressure coefficient in the depth-averaged model
(models/savage_hutter/earth_pressure.py, docs/savage_hutter.md "Earth pressure"): the
coefficients at hand values, the active/passive rule, and two exact solutions that carry K —
Savage & Hutter's parabolic cap (spreading: K_act; contracting: K_pass) and the dam break of
Mangeney et al. with c0 = √(K g h0 cosθ). Each K run is compared with the exact solution of its
own K and, to show that the test would fail if K were ignored, with the K = 1 solution. Bounds
are the measured values (docs/savage_hutter.md) with a margin."""

import math

import numpy as np
import pytest

from dpcollapse.models.savage_hutter import CoulombFriction, EarthPressure, Grid, SavageHutter, simulate
from dpcollapse.models.savage_hutter.earth_pressure import savage_hutter_coefficients
from dpcollapse.models.savage_hutter.exact import mangeney_dam_break, parabolic_cap
from studies.savage_hutter import heap_run

PHI, DELTA, THETA = 30.0, 20.0, 35.0      # the caps' internal, bed and slope angles [deg]
CAP_H, CAP_L = 0.1, 1.0                   # peak and half-length at t = 0 [m]


def test_coefficients_at_hand_values():
    # φ = 30°, δ = 20°: cos²φ sec²δ = 0.75/0.883022 = 0.849355, root 0.388131,
    # K = 2 (4/3)(1 ∓ 0.388131) − 1 = 0.631656, 2.701678
    k_act, k_pass = savage_hutter_coefficients(30.0, 20.0)
    assert k_act == pytest.approx(0.631656, abs=2e-6)
    assert k_pass == pytest.approx(2.701678, abs=2e-6)
    # δ = 0: Rankine (1 ∓ sin φ)/(1 ± sin φ) = 1/3, 3 at φ = 30°
    assert savage_hutter_coefficients(30.0, 0.0) == pytest.approx((1 / 3, 3.0), rel=1e-12)
    # δ = φ: both 2 sec²φ − 1 = 1 + 2 tan²φ = 1.455011 at 25.5° (> 1)
    k = 1 + 2 * math.tan(math.radians(25.5)) ** 2
    assert savage_hutter_coefficients(25.5, 25.5) == pytest.approx((k, k), rel=1e-12)
    with pytest.raises(ValueError, match="imaginary"):
        savage_hutter_coefficients(25.5, 26.0)


def test_active_where_stretching_or_at_rest_passive_where_compressed():
    ep = EarthPressure(0.5, 2.0)
    # ghost-extended: ghost, 5 cells, ghost; cell 3 is compressed, cell 5's right neighbour dry
    u = np.array([0.0, 0.0, 0.0, 1.0, 0.5, 2.0, 0.0])
    wet = np.array([True, True, True, True, True, True, False])
    k = ep.cell_coefficients(u, wet)
    # D = u_right − u_left: cell1 0, cell2 1, cell3 0.5, cell4 1, cell5 (dry right: itself) 1.5
    assert k.tolist() == [0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]
    u = np.array([0.0, 2.0, 1.5, 1.0, 1.0, 1.0, 0.0])
    k = ep.cell_coefficients(u, wet)    # D: 1.5, −1, −0.5, 0, 0 (one-sided)
    assert k.tolist() == [0.5, 0.5, 2.0, 2.0, 0.5, 0.5, 0.5]
    with pytest.raises(ValueError):
        EarthPressure(2.0, 0.5)


def cap_error(n, earth, k_exact, t, speed0=0.0, rate0=0.0):
    """L1(h) [m²] of an order-2 run of the cap against the exact cap of coefficient k_exact."""
    model = SavageHutter(basal=CoulombFriction(math.tan(math.radians(DELTA))), slope_deg=THETA,
                         left="open", right="open", order=2, earth_pressure=earth)
    grid = Grid(-1.5, 5.5, n)
    h0 = lambda x: np.where(np.abs(x) < CAP_L, CAP_H * (1 - (x / CAP_L) ** 2), 0.0)  # noqa: E731
    u0 = lambda x: np.where(np.abs(x) < CAP_L, speed0 + x * rate0, 0.0)              # noqa: E731
    res = simulate(model, grid, h0, [t], u_init=u0, stop_at_rest=False)
    h_ex, _ = parabolic_cap(grid.centers, t, CAP_H, CAP_L, THETA, DELTA, k_exact, speed0=speed0,
                            rate0=rate0)
    assert abs(res.mass[-1] + res.series["outflow"][-1] - res.initial_mass) < 1e-13
    assert np.all(res.h >= 0.0)
    return float(np.sum(np.abs(res.h[-1] - h_ex)) * grid.dx)


@pytest.mark.parametrize("case", ["spreading", "contracting"])
def test_parabolic_cap_carries_k(case):
    """Spreading from rest to t = 1 s (active, K = 0.632) and contracting (ṡ0 = −2/s, u_c0 =
    3 m/s) to 0.25 s (passive, K = 2.70). Measured L1(h) at N = 350, 700: 1.38e-3, 8.2e-4 m²
    (spreading), 4.5e-4, 2.3e-4 m² (contracting); the K and K = 1 exact caps differ by 0.0217
    and 0.0279 m², and the K = 1 model is that far from the K cap (0.0212, 0.0280 m²) while it
    is 7.6e-4, 2.7e-4 m² from its own K = 1 cap."""
    ep = EarthPressure.savage_hutter(PHI, DELTA)
    k, kw = ((ep.k_active, dict(t=1.0)) if case == "spreading"
             else (ep.k_passive, dict(t=0.25, speed0=3.0, rate0=-2.0)))
    errors = [cap_error(n, ep, k, **kw) for n in (350, 700)]
    assert errors[1] < 0.7 * errors[0], errors                 # converges
    grid = Grid(-1.5, 5.5, 700)
    exact_k = parabolic_cap(grid.centers, kw["t"], CAP_H, CAP_L, THETA, DELTA, k,
                            speed0=kw.get("speed0", 0.0), rate0=kw.get("rate0", 0.0))[0]
    exact_1 = parabolic_cap(grid.centers, kw["t"], CAP_H, CAP_L, THETA, DELTA, 1.0,
                            speed0=kw.get("speed0", 0.0), rate0=kw.get("rate0", 0.0))[0]
    gap = float(np.sum(np.abs(exact_k - exact_1)) * grid.dx)
    assert errors[1] < 0.06 * gap, (errors, gap)
    # K ignored (K = 1): the error against the K cap is of the size of the gap
    assert cap_error(700, None, k, **kw) > 0.5 * gap
    # and K = 1 against its own exact cap converges like the K run
    assert cap_error(700, None, 1.0, **kw) < 0.06 * gap


def test_dam_break_carries_k():
    """Mangeney et al. on θ = 22°, δ = 21°, φ = 30° (K_act = 0.671), h0 = 1 m, t = 5 s, order 2,
    N = 800 on [−20, 40] m: the fan of c0 = √(K g h0 cosθ). Measured L1(h) 0.0416 m² (K = 1
    against its own solution: 0.0467 m²); the K and K = 1 solutions differ by 1.62 m², the K = 1
    run is 1.63 m² from the K solution."""
    ep = EarthPressure.savage_hutter(30.0, 21.0)
    grid = Grid(-20.0, 40.0, 800)

    def error(earth, k):
        model = SavageHutter(basal=CoulombFriction(math.tan(math.radians(21.0))), slope_deg=22.0,
                             left="open", right="open", order=2, earth_pressure=earth)
        res = simulate(model, grid, lambda x: np.where(x < 0, 1.0, 0.0), [5.0])
        h_ex, _ = mangeney_dam_break(grid.centers, 5.0, 1.0, 22.0, 21.0, k=k)
        return float(np.sum(np.abs(res.h[-1] - h_ex)) * grid.dx)

    h_k, _ = mangeney_dam_break(grid.centers, 5.0, 1.0, 22.0, 21.0, k=ep.k_active)
    h_1, _ = mangeney_dam_break(grid.centers, 5.0, 1.0, 22.0, 21.0)
    gap = float(np.sum(np.abs(h_k - h_1)) * grid.dx)
    with_k = error(ep, ep.k_active)
    assert with_k < 0.2 * gap, (with_k, gap)
    assert error(None, ep.k_active) > 0.5 * gap


def test_heap_at_rest_stays_at_rest_with_k():
    """The heap of test_savage_hutter (faces 0.5 and −0.3 on a 10° slope, μ = tan 30° = 0.577)
    with Savage–Hutter K at φ = 35°, δ = 30° (K_act = 1.013): K ∂x h − tanθ ∈ {0.330, −0.480},
    within μ — an exact fixed point (ū = 0, h unchanged, bit for bit), as at K = 1."""
    run = heap_run(well_balanced=True, t_end=5.0,
                   earth_pressure=EarthPressure.savage_hutter(35.0, 30.0))
    assert run["max_speed"] == 0.0 and run["max_dh"] == 0.0 and run["mass_error"] == 0.0


def test_k_one_is_the_hydrostatic_model():
    """EarthPressure(1, 1) runs the hydrostatic model (to round-off: the locking test's
    arithmetic differs)."""
    def column(earth):
        model = SavageHutter(basal=CoulombFriction(0.477), order=2, earth_pressure=earth)
        return simulate(model, Grid(0.0, 1.0, 400), lambda x: np.where(x < 0.07, 0.14, 0.0), [2.0])

    a, b = column(None), column(EarthPressure(1.0, 1.0))
    assert np.max(np.abs(a.h[-1] - b.h[-1])) < 1e-9
