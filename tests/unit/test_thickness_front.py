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
