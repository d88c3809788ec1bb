"""The thickness front of a deposit ending in a thin film (scenes.base.thickness_front)."""

import numpy as np
import pytest

from dpcollapse.scenes.base import film_threshold, thickness_front, vertical_thickness


def deposit():
    """A hand-made deposit, CCW from the wall foot: a heap 0.05 m high at the wall (x = 0)
    falling linearly to 0.01 m at x = 0.2, then a film 0.5 mm thick to x = 0.3."""
    return np.array([[0.0, 0.0], [0.3, 0.0], [0.3, 0.0005], [0.2, 0.0005], [0.2, 0.01],
                     [0.0, 0.05]])


def test_vertical_thickness_by_hand():
    h = vertical_thickness(deposit(), np.array([0.0, 0.1, 0.25]))
    assert h == pytest.approx([0.05, 0.03, 0.0005])
    # the step down at x = 0.2: 0.01 m on its left, 0.5 mm on its right
    assert vertical_thickness(deposit(), np.array([0.2]), -1)[0] == pytest.approx(0.01)
    assert vertical_thickness(deposit(), np.array([0.2]), +1)[0] == pytest.approx(0.0005)


def test_front_of_film_deposit():
    pts = deposit()
    assert pts[:, 0].max() == 0.3                                    # mass front: film tip
    assert thickness_front(pts, 0.005) == pytest.approx(0.2)         # the step ends the heap
    assert thickness_front(pts, 0.02) == pytest.approx(0.15)         # 0.05 - 0.2 x = 0.02
    assert thickness_front(pts, 0.0004) == pytest.approx(0.3)        # the film counts
    assert thickness_front(pts, 0.1) == -np.inf


def test_overhang_counts_material_only():
    """A nose overhanging a gap: at x = 0.25 the mass is the nose only (0.02 thick)."""
    pts = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.01], [0.3, 0.01], [0.3, 0.03],
                    [0.0, 0.03]])
    assert vertical_thickness(pts, np.array([0.25]))[0] == pytest.approx(0.02)
    assert thickness_front(pts, 0.025) == pytest.approx(0.2)


def test_film_threshold():
    assert film_threshold(1e-3, 0.01) == pytest.approx(3e-3)
    assert film_threshold(1e-4, 0.01) == pytest.approx(2.5e-3)


def test_one_front_for_every_model_and_report():
    """Issue 50: one definition (``fronts.profile_front``): the largest x where the profile
    through (x_i, h_i) reaches h_f, linear to the next point. The moving mesh's polygon
    front, the depth-averaged model's ``front_position``, the ladder's thresholds and the
    two-phase columns read the same x_f from the same profile."""
    import importlib.util

    from dpcollapse.fronts import front_thickness, profile_front
    from dpcollapse.models.savage_hutter.solver import Grid, front_position
    from tests.helpers import ROOT

    x = np.array([0.0, 0.1, 0.2, 0.3])
    h = np.array([0.05, 0.03, 0.01, 0.0])
    assert profile_front(x, h, 0.02) == pytest.approx(0.15)          # 0.03 → 0.01 across it
    assert profile_front(x, h, 0.01) == pytest.approx(0.2)           # reached: counts
    assert profile_front(x, [0.05, 0.03, 0.02, 0.02], 0.01) == 0.3   # the last point
    assert np.isnan(profile_front(x, h, 0.1))
    # the polygon's exact piecewise-linear profile, read at its vertices: the same front
    xs = np.linspace(0.0, 0.2, 5)
    for t in (0.005, 0.02, 0.04):
        assert profile_front(xs, vertical_thickness(deposit(), xs, -1), t) == \
            pytest.approx(thickness_front(deposit(), t), abs=1e-12)
    # the depth-averaged model's (and the ladder's 1 mm) front on its cell centres
    grid = Grid(0.0, 0.4, 40)
    hs = np.clip(0.05 - 0.2 * grid.centers, 0.0, None)
    for t in (1e-3, 0.02):
        assert front_position(hs, grid, t) == profile_front(grid.centers, hs, t)
        assert front_position(hs, grid, t) == pytest.approx((0.05 - t) / 0.2, abs=1e-12)
    # the ladder's table of thresholds (studies/benchmarks/two_phase/ladder_thresholds.py)
    spec = importlib.util.spec_from_file_location(
        "ladder_thresholds", ROOT / "studies" / "benchmarks" / "two_phase" / "ladder_thresholds.py")
    table = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(table)
    assert table.front(np.column_stack([grid.centers, hs]), 0.02) == front_position(hs, grid, 0.02)
    # the stated thickness: 3 grains (μ(I)) or a quarter of the cell (Drucker–Prager, d = 0)
    assert front_thickness(0.0, 0.01) == film_threshold(0.0, 0.01) == pytest.approx(2.5e-3)
    assert front_thickness(1e-3, 0.0044) == pytest.approx(3e-3)
