"""Checks of the 1D Drucker–Prager plug-flow reference (dpcollapse.reference.plug1d)."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from dpcollapse.reference.plug1d import (
    PlugFlowProblem,
    half_poiseuille,
    inviscid_solution,
    inviscid_stopping_time,
    solve_plug_flow,
    steady_half_poiseuille,
)

# the project's plug case: θ = 22°, μ_s = tan 25.5°, ρ = 1550, η = 1 Pa s, h = 5 cm, U_s = 1 m/s
PLUG = PlugFlowProblem(slope_angle=math.radians(22.0),
                       friction_coefficient=math.tan(math.radians(25.5)),
                       viscosity=1.0, density=1550.0, thickness=0.05)
US = 1.0


def plug_u0(problem=PLUG, us=US):
    return lambda Z: half_poiseuille(problem, Z, us)


def linear_series(problem, u0, t, Z, modes=400):
    """Eigen-series solution V of V_t = −S + ν V_ZZ, V(0) = 0, ν V_Z(h) = 0 (no yield at all).

    It equals the Drucker–Prager solution until the static layer appears (∂_Z U(t, 0) = 0),
    and bounds it from below afterwards (comparison principle), so V(t, h) = 0 gives a lower
    bound for the stopping time.
    """
    h, nu, S = problem.thickness, problem.kinematic_viscosity, problem.source
    kn = (np.arange(modes) + 0.5) * np.pi / h
    zq = np.linspace(0.0, h, 20001)
    wq = np.full(zq.size, zq[1])
    wq[[0, -1]] *= 0.5
    a0 = 2.0 / h * (np.sin(np.outer(kn, zq)) * u0(zq)) @ wq
    decay = np.exp(-nu * kn**2 * t)
    a = a0 * decay - 2.0 * S / (h * kn) * (1.0 - decay) / (nu * kn**2)
    return np.sin(np.outer(np.atleast_1d(Z), kn)) @ a, float(np.sum(a * kn))  # V, ∂_Z V(t, 0)


# ---------------------------------------------------------------------------------- inputs
@pytest.mark.parametrize("kwargs", [
    dict(thickness=0.0), dict(thickness=-1.0), dict(viscosity=-1e-3), dict(density=0.0),
    dict(slope_angle=math.pi / 2), dict(friction_coefficient=-0.1), dict(gravity=0.0),
    dict(viscosity=float("nan")),
])
def test_problem_rejects_nonsense(kwargs):
    base = dict(slope_angle=0.3, friction_coefficient=0.5, viscosity=1.0, density=1500.0,
                thickness=0.05)
    with pytest.raises(ValueError):
        PlugFlowProblem(**{**base, **kwargs})


@pytest.mark.parametrize("kwargs", [
    dict(t_end=0.0), dict(dt=-1e-3), dict(nz=2), dict(output_times=[0.5, 2.0]),
    dict(initial_velocity=lambda Z: np.zeros(3)),
    dict(initial_velocity=lambda Z: np.full_like(Z, np.nan)),
])
def test_solver_rejects_nonsense(kwargs):
    args = dict(initial_velocity=plug_u0(), t_end=1.0, dt=1e-3, nz=51)
    with pytest.raises(ValueError):
        solve_plug_flow(PLUG, **{**args, **kwargs})


def test_properties():
    th, mu = PLUG.slope_angle, PLUG.friction_coefficient
    assert PLUG.source == pytest.approx(9.81 * math.cos(th) * (mu - math.tan(th)), rel=1e-14)
    assert PLUG.kinematic_viscosity == pytest.approx(1.0 / 1550.0, rel=1e-14)
    Z = np.linspace(0, 0.05, 11)
    u = half_poiseuille(PLUG, Z, 2.0)
    assert u[0] == 0 and u[-1] == pytest.approx(2.0)
    assert np.allclose(steady_half_poiseuille(PLUG, Z), 0.0)  # μ_s > tanθ: steady state = rest


def test_nonconvergence_raises_with_step_and_residual():
    steep = PlugFlowProblem(math.radians(30), 0.4, 1.0, 1550.0, 0.05)
    with pytest.raises(RuntimeError, match=r"time step 1 .*residual"):
        solve_plug_flow(steep, lambda Z: 0.0 * Z, t_end=0.1, dt=1e-2, nz=51, max_iter=1)


# ------------------------------------------------------------------------- inviscid limit
def test_zero_viscosity_is_the_closed_form():
    p = PlugFlowProblem(PLUG.slope_angle, PLUG.friction_coefficient, 0.0, 1550.0, 0.05)
    u0, dt = plug_u0(p), 1e-3
    sol = solve_plug_flow(p, u0, t_end=1.7, dt=dt, nz=201, output_times=[0.2, 0.7, 1.2, 1.7])
    for t in (0.2, 0.7, 1.2, 1.7):
        assert np.max(np.abs(sol.at(t) - inviscid_solution(p, u0, t, sol.z))) < 1e-10 * US
    t_stop = inviscid_stopping_time(p, u0, sol.z)
    assert t_stop == pytest.approx(US / p.source)
    assert abs(sol.arrest_time - t_stop) <= 2 * dt
    assert abs(sol.stopping_time - (US - sol.threshold) / p.source) <= 2 * dt


def test_tiny_viscosity_approaches_the_closed_form():
    p = PlugFlowProblem(PLUG.slope_angle, PLUG.friction_coefficient, 1e-4, 1550.0, 0.05)
    u0, dt = plug_u0(p), 1e-3
    sol = solve_plug_flow(p, u0, t_end=1.6, dt=dt, nz=201, output_times=[0.3, 0.9, 1.4, 1.6])
    for t in (0.3, 0.9, 1.4):
        assert np.max(np.abs(sol.at(t) - inviscid_solution(p, u0, t, sol.z))) < 1e-3 * US
    assert abs(sol.arrest_time - inviscid_stopping_time(p, u0, sol.z)) <= 3 * dt


# -------------------------------------------------------------------- viscous, exact checks
def test_before_the_static_layer_matches_the_eigen_series():
    u0 = plug_u0()
    onset = brentq(lambda t: linear_series(PLUG, u0, t, 0.0)[1], 1e-3, 2.0)
    assert 0.5 < onset < 0.7                      # ∂_Z U(t, 0) = 0 at t ≈ 0.584 s
    times = [0.1, 0.3, 0.5, onset - 0.02, onset + 0.02]
    sol = solve_plug_flow(PLUG, u0, t_end=0.7, dt=2e-4, nz=201, output_times=times)
    for t in times[:4]:
        err = np.max(np.abs(sol.at(t) - linear_series(PLUG, u0, t, sol.z)[0]))
        assert err < 5e-5 * US, (t, err)
    assert sol.static_interface[3] == 0.0 and sol.static_interface[4] > 0.0


def test_accelerating_flow_reaches_the_half_poiseuille_profile():
    p = PlugFlowProblem(math.radians(30), 0.4, 1.0, 1550.0, 0.05)   # tanθ = 0.577 > μ_s
    assert p.source < 0
    sol = solve_plug_flow(p, lambda Z: 0.0 * Z, t_end=15.0, dt=1e-2, nz=1001,
                          output_times=[0.5, 15.0])
    steady = steady_half_poiseuille(p, sol.z)
    err = np.linalg.norm(sol.velocity[-1] - steady) / np.linalg.norm(steady)
    assert err < 1e-3
    assert np.linalg.norm(sol.velocity[0] - steady) / np.linalg.norm(steady) > 0.1
    assert math.isnan(sol.stopping_time) and math.isnan(sol.arrest_time)
    assert np.all(sol.static_interface == 0.0)


def test_time_convergence_is_first_order():
    u0, times = plug_u0(), [0.3, 0.7]
    ref = solve_plug_flow(PLUG, u0, t_end=0.7, dt=6.25e-5, nz=101, output_times=times)
    errs = []
    for dt in (4e-3, 2e-3, 1e-3):
        sol = solve_plug_flow(PLUG, u0, t_end=0.7, dt=dt, nz=101, output_times=times)
        errs.append(max(np.max(np.abs(sol.at(t) - ref.at(t))) for t in times))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders >= 0.9), (errs, orders)


def test_grid_convergence():
    u0, t = plug_u0(), 0.7
    ref = solve_plug_flow(PLUG, u0, t_end=t, dt=1e-3, nz=801, output_times=[t])
    errs = []
    for nz in (26, 51, 101):
        sol = solve_plug_flow(PLUG, u0, t_end=t, dt=1e-3, nz=nz, output_times=[t])
        errs.append(np.max(np.abs(sol.at(t) - ref.evaluate(t, sol.z))))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders >= 1.5), (errs, orders)


def test_static_layer_is_exactly_at_rest_and_grows_until_arrest():
    sol = solve_plug_flow(PLUG, plug_u0(), t_end=1.0, dt=1e-3, nz=401)
    assert len(sol.times) == 1001                 # every level stored
    for u, b in zip(sol.velocity, sol.static_interface):
        assert np.all(u[sol.z <= b] == 0.0)       # exactly zero, not just small
        assert np.all(u[sol.z > b] > 0.0)
    assert np.all(np.diff(sol.static_interface) >= 0)
    assert np.all(np.diff(sol.interface) >= 0)
    assert sol.static_interface[0] == 0.0 and sol.static_interface[-1] == PLUG.thickness
    assert 0 < sol.stopping_time <= sol.arrest_time < 1.0
    assert np.all(sol.velocity[sol.times >= sol.arrest_time] == 0.0)
    # until arrest the surface decelerates at least at the inviscid rate S (U_ZZ(h) ≤ 0)
    du = np.diff(sol.velocity[:, -1])[sol.times[1:] < sol.arrest_time]
    assert np.all(du <= -PLUG.source * 1e-3 * (1 - 1e-9))


def test_project_plug_case():
    dt = 5e-4
    sol = solve_plug_flow(PLUG, plug_u0(), t_end=1.2, dt=dt, nz=401,
                          output_times=[0.05, 0.1, 0.2, 0.6, 0.8, 1.2])
    t_inviscid = inviscid_stopping_time(PLUG, plug_u0(), sol.z)            # upper bound
    t_linear = brentq(lambda t: linear_series(PLUG, plug_u0(), t, PLUG.thickness)[0][0],
                      1e-3, 5.0)                                          # lower bound
    print(f"\nplug case: S = {PLUG.source:.5f} m/s², inviscid stop {t_inviscid:.4f} s, "
          f"no-yield-stress bound {t_linear:.4f} s, stop(1 mm/s) {sol.stopping_time:.4f} s, "
          f"arrest {sol.arrest_time:.4f} s")
    for t, b, b0 in zip(sol.times, sol.interface, sol.static_interface):
        print(f"  t = {t:.2f} s: b(1 mm/s) = {1e3 * b:.3f} mm, static top = {1e3 * b0:.3f} mm")
    assert t_linear - 2 * dt <= sol.arrest_time <= t_inviscid
    assert 0.9 < sol.arrest_time < 1.0
    assert sol.stopping_time <= sol.arrest_time


# ------------------------------------------------------------- general data, API details
@pytest.mark.parametrize("eta", [0.0, 1e-3, 1.0])
def test_non_monotone_data_obey_the_discrete_energy_inequality(eta):
    """Backward Euler: K^{n+1} − K^n ≤ Δt [g sinθ Σ m U^{n+1} − Σ Δz (ν g_i² + k_i |g_i|)]."""
    rng = np.random.default_rng(7)
    coef = rng.normal(size=6)
    p = PlugFlowProblem(PLUG.slope_angle, PLUG.friction_coefficient, eta, 1550.0, 0.05)

    def u0(Z):
        return np.sin(np.outer(Z / p.thickness, np.arange(1, 7)) * np.pi / 2) @ coef

    dt, nz = 2e-3, 301
    sol = solve_plug_flow(p, u0, t_end=0.4, dt=dt, nz=nz)
    assert len(sol.times) == 201
    dz = p.thickness / (nz - 1)
    m = np.full(nz, dz)
    m[0], m[-1] = 0.0, dz / 2
    k = p.friction_coefficient * p.gravity * math.cos(p.slope_angle) * (p.thickness - sol.z[:-1]
                                                                         - dz / 2)
    kin = 0.5 * sol.velocity**2 @ m
    g = np.diff(sol.velocity, axis=1) / dz
    work = p.gravity * math.sin(p.slope_angle) * sol.velocity @ m
    diss = dz * (p.kinematic_viscosity * g**2 + k * np.abs(g)).sum(axis=1)
    bound = dt * (work - diss)[1:]
    assert np.all(np.diff(kin) <= bound + 1e-12 * kin[0])
    assert np.any(sol.velocity[0] < 0) and sol.max_residual < 1e-10


def test_profile_interpolation():
    sol = solve_plug_flow(PLUG, plug_u0(), t_end=0.2, dt=1e-2, nz=51, output_times=[0.0, 0.1, 0.2])
    assert np.allclose(sol.at(0.05), 0.5 * (sol.velocity[0] + sol.velocity[1]))
    assert np.array_equal(sol.at(0.2), sol.velocity[-1])
    assert sol.evaluate(0.1, [0.05])[0] == pytest.approx(sol.velocity[1, -1])
    assert sol.evaluate(0.1, [0.0])[0] == 0.0
    with pytest.raises(ValueError):
        sol.at(0.3)
    with pytest.raises(ValueError):
        sol.evaluate(0.1, [0.06])
