"""The short-wave growth G(I) of the μ(I) law and the pure helpers of
``studies.wellposed`` (growth-rate fit, classification, periodic noise)."""

import math

import numpy as np
import pytest

from dpcollapse.rheology.mu_i import MuI
from dpcollapse.rheology.wellposedness import criterion, high_wavenumber_growth

LAW = MuI(0.32, 0.60, 0.4, 0.002, 1550.0)   # configs/bagnold.yaml


def test_growth_positive_exactly_where_ill_posed():
    """G > 0 ⇔ C > 0 on a log grid of I (the two derivations agree)."""
    for I in np.logspace(-5, 3, 300):
        assert (high_wavenumber_growth(LAW, I) > 0) == (criterion(LAW, I) > 0), I


def test_growth_hand_value():
    """I = 0.004319 (θ = 17.9°): ν = Iμ'/μ = 0.009161, m = μ(1 − ν/2) = 0.32155; the bracket
    ν − m s + (1 − ν)s² over (1 − m s) is least near s = m/(2(1 − ν)): G ≈ 0.01786."""
    assert high_wavenumber_growth(LAW, 0.004319) == pytest.approx(0.01786, rel=2e-3)
    assert high_wavenumber_growth(LAW, 0.1715) < -0.1          # inside the window: decay


def test_growth_rate_fit():
    from studies.wellposed import growth_rate

    t = np.linspace(0.0, 1.0, 11)
    a = np.r_[10.0, 5.0, np.exp(3.0 * t[2:])]
    assert growth_rate(t, a, 5) == pytest.approx(3.0, rel=1e-9)
    assert math.isnan(growth_rate(t, np.r_[a[:-1], 0.0], 5))


@pytest.mark.parametrize("rates, failed, klass", [
    ([-50.0, -100.0, -300.0], False, "well_posed"),     # decays on every mesh
    ([-70.0, 40.0, 1900.0], False, "ill_posed"),        # grows faster with refinement
    ([10.0, 11.0, 11.5], False, "well_posed"),          # converged growth (stiff, not ill posed)
    ([10.0, 30.0, 20.0], False, "inconclusive"),
    ([-70.0, -100.0, 1900.0], False, "inconclusive"),   # not increasing at every refinement
    ([-1.0, 2.0], True, "failed"),
    ([float("nan"), 2.0], False, "inconclusive"),
])
def test_classify(rates, failed, klass):
    from studies.wellposed import classify

    assert classify(rates, failed) == klass


def test_periodic_noise_same_on_images():
    from studies.wellposed import periodic_noise

    pts = np.array([[0.0, 0.3], [0.1, 0.3], [0.05, 0.3], [0.1 + 1e-12, 0.3]])
    n = periodic_noise(pts, 0.1, seed=16)
    assert np.array_equal(n[0], n[1]) and np.array_equal(n[0], n[3])
    assert not np.array_equal(n[0], n[2])
    assert np.array_equal(n, periodic_noise(pts[::-1], 0.1, seed=16)[::-1])   # order-free
