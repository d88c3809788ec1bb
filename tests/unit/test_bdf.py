"""Variable-step BDF2 coefficients, the midpoint and predictor extrapolations, Milne's
error factor (``solvers.bdf``) and the PI step controller (``solvers.step_control``)."""

import json

import numpy as np
import pytest

from dpcollapse.models.stokes.history import TimeHistory
from dpcollapse.solvers.bdf import (
    bdf2_coefficients,
    error_constants,
    midpoint_weights,
    milne_factor,
    predictor_weights,
)
from dpcollapse.solvers.step_control import GROW, SHRINK, StepController


@pytest.mark.parametrize("dt, dt_prev", [(1.0, 1.0), (0.5, 1.0), (2.0, 0.7)])
def test_bdf2_exact_for_quadratics(dt, dt_prev):
    """(α₀y^{n+1} − α₁yⁿ + α₂y^{n−1})/Δt = y'(t^{n+1}) for y = a + bt + ct²."""
    a0, a1, a2 = bdf2_coefficients(dt, dt_prev)
    y = lambda t: 0.3 - 1.1 * t + 2.5 * t ** 2  # noqa: E731
    dy = lambda t: -1.1 + 5.0 * t  # noqa: E731
    derivative = (a0 * y(dt) - a1 * y(0.0) + a2 * y(-dt_prev)) / dt
    assert derivative == pytest.approx(dy(dt), rel=1e-12)
    assert a0 - a1 + a2 == pytest.approx(0.0, abs=1e-14)   # constants have no derivative


def test_uniform_coefficients_and_first_step():
    assert bdf2_coefficients(1e-3, 1e-3) == pytest.approx((1.5, 2.0, 0.5))
    assert bdf2_coefficients(1e-3, None) == (1.0, 1.0, 0.0)
    assert midpoint_weights(1e-3, None) == (1.0, 0.0)


@pytest.mark.parametrize("dt, dt_prev", [(1.0, 1.0), (0.4, 1.0), (1.8, 1.0)])
def test_midpoint_extrapolation_is_second_order(dt, dt_prev):
    """u* = a uⁿ + b u^{n−1} is exact at tⁿ + Δt/2 for linear u."""
    a, b = midpoint_weights(dt, dt_prev)
    u = lambda t: 2.0 - 3.0 * t  # noqa: E731
    assert a * u(0.0) + b * u(-dt_prev) == pytest.approx(u(dt / 2), rel=1e-12)


def test_predictor_exact_for_quadratics():
    w = predictor_weights(0.7, 1.0, 1.3)
    y = lambda t: 1.0 + 2.0 * t - 0.5 * t ** 2  # noqa: E731
    assert w @ np.array([y(0.0), y(-1.0), y(-2.3)]) == pytest.approx(y(0.7), rel=1e-12)


def test_uniform_error_constants():
    """Uniform steps: BDF2's local error −(2/9)h³y''', the quadratic predictor's h³y''', so
    the error is −(2/11) of the corrector–predictor difference."""
    c, c_p = error_constants(1.0, 1.0, 1.0)
    assert c == pytest.approx(-2.0 / 9.0)
    assert c_p == pytest.approx(1.0)
    assert milne_factor(1.0, 1.0, 1.0) == pytest.approx(-2.0 / 11.0)


def test_history_error_estimate_on_a_cubic():
    """For u = t³ (u''' constant) on the nodes the estimate equals BDF2's true local error."""
    h = TimeHistory(np.zeros((1, 2)))
    u = lambda t: np.array([t ** 3, 1.0 - t ** 3])  # noqa: E731
    times = [0.0, 0.1, 0.25, 0.33]
    h.push(np.zeros(2), 0.1, np.zeros((1, 2)))   # a step before t0: three solved steps
    for k in range(1, 3):   # push u at t0, t1 as the steps to t1, t2 are accepted
        h.push(u(times[k - 1]), times[k] - times[k - 1], np.zeros((1, 2)))
    dt = times[3] - times[2]
    a0, a1, a2 = h.coefficients(dt)
    du = lambda t: np.array([3 * t ** 2, -3 * t ** 2])  # noqa: E731
    computed = (dt * du(times[3]) + a1 * u(times[2]) - a2 * u(times[1])) / a0
    estimate = h.local_error(computed, u(times[2]), dt)
    assert estimate == pytest.approx(u(times[3]) - computed, rel=1e-9)
    landed = TimeHistory(np.zeros((1, 2)))
    landed.copy_from(h)    # a landing: same history, the estimate waits three steps
    assert landed.local_error(computed, u(times[2]), dt) is None


def test_history_mesh_velocity_first_and_second_order():
    """Without x^{n−1} no BDF2 mesh velocity; with it, exact for nodes moving as t²."""
    x = lambda t: np.array([[t ** 2, 2.0 * t]])  # noqa: E731
    h = TimeHistory(x(0.0))
    assert h.mesh_velocity(x(0.1), 0.1) is None
    h.push(np.zeros(2), 0.1, x(0.1))
    w = h.mesh_velocity(x(0.3), 0.2)
    assert w == pytest.approx(np.array([[0.6, 2.0]]), rel=1e-12)


def test_controller_accepts_rejects_and_bounds():
    c = StepController(tolerance=1e-3)
    assert c.accept(5e-4) and not c.accept(2e-3)
    assert c.rejected == 1
    assert c.next_step(1.0, None) == 1.0                     # no estimate: keep the step
    assert c.next_step(1.0, 1e-3 * 1e-9) == pytest.approx(GROW)
    c.forget()
    assert c.next_step(1.0, 1e3) == pytest.approx(SHRINK)
    assert SHRINK <= c.retry_step(1.0, 8e-3) < 1.0
    # on target with a steady error the step settles at SAFETY × itself
    c.forget()
    assert c.next_step(1.0, 1e-3) == pytest.approx(0.9)


def test_controller_and_history_records_restore_their_state():
    """What a checkpoint stores: a restored controller proposes the same next step and
    counts on from the same rejections; a restored history gives the same BDF2 quantities."""
    c = StepController(tolerance=1e-3)
    c.accept(2e-3)
    c.next_step(1.0, 4e-4)
    restored = StepController(tolerance=1e-3)
    restored.restore(json.loads(json.dumps(c.record())))
    assert restored.rejected == 1
    assert restored.next_step(0.5, 7e-4) == c.next_step(0.5, 7e-4)
    x = lambda t: np.array([[t ** 2, 2.0 * t]])  # noqa: E731
    h = TimeHistory(x(0.0))
    for k, t in enumerate((0.1, 0.25, 0.33)):
        h.push(np.array([k, -k], dtype=float), t - (0.0, 0.1, 0.25)[k], x(t))
    again = TimeHistory(x(0.33))
    again.restore(json.loads(json.dumps(h.record())), h.velocities, h.positions[1])
    u = np.array([3.0, 1.0])
    assert again.local_error(u, u, 0.1) == pytest.approx(h.local_error(u, u, 0.1), rel=1e-15)
    assert again.mesh_velocity(x(0.43), 0.1) == pytest.approx(h.mesh_velocity(x(0.43), 0.1), rel=1e-15)
    assert np.all(again.effective_old(u, 0.1) == h.effective_old(u, 0.1))
