r"""Independent 1D reference: Drucker–Prager plug flow of a layer on an inclined plane.

Seed 000, case (a). A layer of constant thickness ``h`` on a slope ``θ`` moves parallel to the
bed with velocity ``U(t, Z)`` (``Z`` normal to the bed: 0 at the bed, ``h`` at the free
surface); no slip at the bed, stress free at the surface, hydrostatic pressure
``p = ρ g cosθ (h − Z)``. Dividing the momentum balance by ``ρ``::

    ∂_t U = g sinθ + ∂_Z σ,      σ = τ/ρ = ν ∂_Z U + k(Z) s,    ν = η/ρ,
    k(Z) = μ_s g cosθ (h − Z),   s = sign(∂_Z U) if ∂_Z U ≠ 0,  |s| ≤ 1 if ∂_Z U = 0,
    U(t, 0) = 0,                 σ(t, h) = 0.

(κ(p) = √2 μ_s p with the Frobenius norm |D| = √(D:D) gives exactly τ = μ_s p in simple shear.)
Where ∂_Z U > 0 this is model (S) of the seed, ``∂_t U + S − ν ∂_ZZ U = 0`` with
``S = g cosθ (μ_s − tanθ)``; the static/flowing interface ``b(t)`` has ``U = ν ∂_Z U = 0``.

Discretisation (no regularisation). P1 finite elements on a uniform grid ``Z_j = j Δz``
(``j = 0..N``), lumped mass ``m_j`` (``Δz``, ``Δz/2`` at the surface node), backward Euler.
Each time step is the exact minimiser of the strictly convex, non-smooth functional::

    J(U) = Σ_j m_j [(U_j − U_j^n)²/(2Δt) − g sinθ U_j] + Σ_i Δz [ν g_i²/2 + k_i |g_i|],

with ``g_i = (U_i − U_{i−1})/Δz`` on interval ``i`` and ``k_i = k(Z_{i−1/2})`` (exact for the
linear ``k``). Its optimality system, with the multiplier (plastic stress) ``λ_i = σ_i − ν g_i``::

    m_j (U_j − U_j^n)/Δt + σ_j − σ_{j+1} = m_j g sinθ      (σ_{N+1} = 0, U_0 = 0),
    σ_i = ν g_i + λ_i,     λ_i = P_{[−k_i, k_i]}(λ_i + c g_i)   (any c > 0),

is solved by a primal–dual active-set (semi-smooth Newton) iteration: interval ``i`` is *stuck*
(``g_i = 0``, ``σ_i`` unknown) where ``|λ_i + c g_i| ≤ k_i``, else *flowing* with
``σ_i = ν g_i + k_i sign(λ_i + c g_i)`` (``c = C_ACTIVE c_r``, ``c_r = ν + Δz²/Δt``). Each
iteration is one tridiagonal solve in the interleaved unknowns ``(σ_1, U_1, σ_2, U_2, ...)``.
The iteration stops when the strain-rate residual ``max_i |g_i − γ̇_i|`` with the closed-form
local projection ``γ̇_i = shrink(λ_i + c_r g_i, k_i)/c_r`` (the ``∂_Z U − γ̇`` residual of an
augmented-Lagrangian / Uzawa scheme) is below ``tol`` times a rate scale, or when the active
set reproduces itself (then the discrete problem is solved exactly; the residual is round-off).
Typically one iteration per step suffices (the previous step's set is right). Stuck intervals
get ``g_i = 0`` exactly, so the static layer is exactly at rest (``U == 0.0``). ``η = 0`` (pure
plasticity) is handled too; then, for non-decreasing ``U0``, the discrete solution is exactly
``max(U0(Z_j) − S t_n, 0)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_banded

C_ACTIVE = 1e-2
"""Active-set parameter c = C_ACTIVE (ν + Δz²/Δt). Small values decide the set mostly by dual
feasibility (|σ| > k frees a stuck interval, a sign change of g sticks a flowing one); values
≥ 1 were seen to cycle on non-monotone initial data with η ≈ 0."""
EPS = np.finfo(float).eps

__all__ = [
    "PlugFlowProblem",
    "PlugFlowSolution",
    "half_poiseuille",
    "solve_plug_flow",
    "inviscid_solution",
    "inviscid_stopping_time",
    "steady_half_poiseuille",
]


@dataclass(frozen=True)
class PlugFlowProblem:
    """Parameters of the inclined-plane layer (SI units).

    slope_angle θ [rad] (|θ| < π/2), friction_coefficient μ_s ≥ 0, viscosity η ≥ 0 [Pa s],
    density ρ > 0 [kg/m³], thickness h > 0 [m], gravity g > 0 [m/s²].
    """

    slope_angle: float
    friction_coefficient: float
    viscosity: float
    density: float
    thickness: float
    gravity: float = 9.81

    def __post_init__(self) -> None:
        for name in ("slope_angle", "friction_coefficient", "viscosity", "density",
                     "thickness", "gravity"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.number)) or not math.isfinite(value):
                raise ValueError(f"PlugFlowProblem.{name} must be a finite number, got {value!r}")
        if not abs(self.slope_angle) < math.pi / 2:
            raise ValueError(f"slope_angle must lie in (-pi/2, pi/2) rad, got {self.slope_angle}")
        if self.friction_coefficient < 0:
            raise ValueError(f"friction_coefficient must be >= 0, got {self.friction_coefficient}")
        if self.viscosity < 0:
            raise ValueError(f"viscosity must be >= 0 Pa s, got {self.viscosity}")
        if self.density <= 0:
            raise ValueError(f"density must be > 0 kg/m^3, got {self.density}")
        if self.thickness <= 0:
            raise ValueError(f"thickness must be > 0 m, got {self.thickness}")
        if self.gravity <= 0:
            raise ValueError(f"gravity must be > 0 m/s^2, got {self.gravity}")

    @property
    def source(self) -> float:
        """S = g cosθ (μ_s − tanθ) [m/s²]; S > 0: the flow decelerates and stops."""
        th = self.slope_angle
        return self.gravity * math.cos(th) * (self.friction_coefficient - math.tan(th))

    @property
    def kinematic_viscosity(self) -> float:
        """ν = η/ρ [m²/s]."""
        return self.viscosity / self.density


def _grid_values(problem: PlugFlowProblem, Z) -> np.ndarray:
    Z = np.asarray(Z, dtype=float)
    h = problem.thickness
    if not np.all(np.isfinite(Z)) or np.any(Z < -1e-12 * h) or np.any(Z > h * (1 + 1e-12)):
        raise ValueError(f"Z must lie in [0, h] = [0, {h}]")
    return Z


def half_poiseuille(problem: PlugFlowProblem, Z, surface_speed: float) -> np.ndarray:
    """U0(Z) = U_s (2 Z/h − Z²/h²): zero at the bed, U_s and ∂_Z U0 = 0 at the surface."""
    Z = _grid_values(problem, Z)
    r = Z / problem.thickness
    return float(surface_speed) * (2.0 * r - r * r)


def inviscid_solution(problem: PlugFlowProblem, initial_velocity: Callable, t, Z) -> np.ndarray:
    """η = 0 closed form U(t, Z) = max(U0(Z) − S t, 0).

    Each slice moves on its own at acceleration −S. Valid for a non-decreasing U0 ≥ 0 with
    U0(0) = 0 (then ∂_Z U ≥ 0 everywhere, so s = +1 wherever the layer moves).
    """
    Z = _grid_values(problem, Z)
    t = float(t)
    if t < 0:
        raise ValueError(f"t must be >= 0, got {t}")
    u0 = np.asarray(initial_velocity(Z), dtype=float)
    return np.maximum(u0 - problem.source * t, 0.0)


def inviscid_stopping_time(problem: PlugFlowProblem, initial_velocity: Callable, Z) -> float:
    """η = 0 stopping time max U0(Z) / S (evaluated on the points Z); inf if S ≤ 0."""
    Z = _grid_values(problem, Z)
    umax = float(np.max(np.asarray(initial_velocity(Z), dtype=float)))
    if umax <= 0:
        return 0.0
    return umax / problem.source if problem.source > 0 else math.inf


def steady_half_poiseuille(problem: PlugFlowProblem, Z) -> np.ndarray:
    """Steady state for tanθ > μ_s: U = g cosθ (tanθ − μ_s)(h Z − Z²/2)/ν (= −S(hZ − Z²/2)/ν).

    For tanθ ≤ μ_s the steady state is rest and zeros are returned; η = 0 with tanθ > μ_s has
    no steady state (ValueError).
    """
    Z = _grid_values(problem, Z)
    if problem.source >= 0:
        return np.zeros_like(Z)
    if problem.kinematic_viscosity == 0:
        raise ValueError("no steady state: tan(theta) > mu_s and zero viscosity accelerate forever")
    h = problem.thickness
    return -problem.source * (h * Z - 0.5 * Z * Z) / problem.kinematic_viscosity


@dataclass
class PlugFlowSolution:
    """Velocity profiles of :func:`solve_plug_flow`.

    times (nt,) stored times; z (nz,) grid nodes; velocity (nt, nz), velocity[:, 0] = 0.
    interface (nt,): b(t) = lowest node Z where |U| > threshold, h if none (threshold based).
    stopping_time: first backward-Euler time level t_n from which on max_Z |U| ≤ threshold at
        every later level up to t_end (checked at every level, not only at stored times), i.e.
        the level after the last one with max |U| > threshold; NaN if max |U(t_end)| > threshold,
        0 if max |U| ≤ threshold throughout. For a decelerating flow this is the first crossing.
    static_interface (nt,): top of the bed-attached layer that is exactly at rest, i.e. the
        largest Z_j with U == 0.0 at all nodes 0..j (0 if the first node above the bed moves).
    arrest_time: same with U == 0.0 exactly at every node (true discrete arrest): first level
        from which on the whole layer is exactly at rest; NaN if U(t_end) ≢ 0.
    iterations / max_step_iterations: total and largest-per-step active-set iterations;
    max_residual: largest relative strain-rate residual accepted; threshold: used [m/s].
    """

    times: np.ndarray
    z: np.ndarray
    velocity: np.ndarray
    interface: np.ndarray
    stopping_time: float
    static_interface: np.ndarray
    arrest_time: float
    problem: PlugFlowProblem
    iterations: int = 0
    max_step_iterations: int = 0
    max_residual: float = 0.0
    threshold: float = 1e-3

    def at(self, t: float) -> np.ndarray:
        """Profile U(t, z) (nz,), linear in time between stored times."""
        t = float(t)
        ts = self.times
        slack = 1e-12 * max(1.0, abs(ts[-1]))
        if not ts[0] - slack <= t <= ts[-1] + slack:
            raise ValueError(f"t = {t} outside the stored range [{ts[0]}, {ts[-1]}]")
        i = int(np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 1))
        if i == len(ts) - 1:
            return self.velocity[i].copy()
        w = (t - ts[i]) / (ts[i + 1] - ts[i])
        return (1.0 - w) * self.velocity[i] + w * self.velocity[i + 1]

    def evaluate(self, t: float, Z) -> np.ndarray:
        """U(t, Z) at points Z in [0, h]: linear in time, piecewise linear (P1) in Z."""
        Z = _grid_values(self.problem, Z)
        return np.interp(Z, self.z, self.at(t))


def _time_levels(t_end: float, dt: float, output_times):
    """Uniform levels n·Δt' with Δt' = t_end/ceil(t_end/Δt) ≤ Δt, plus the output times."""
    n = max(1, math.ceil(t_end / dt - 1e-9))
    levels = np.linspace(0.0, t_end, n + 1)
    if output_times is None:
        stride = math.ceil(n / 1000)
        store = np.zeros(n + 1, dtype=bool)
        store[::stride] = True
        store[-1] = True
        return levels, store
    out = np.unique(np.asarray(output_times, dtype=float).ravel())
    if out.size == 0 or not np.all(np.isfinite(out)) or out[0] < 0 or out[-1] > t_end * (1 + 1e-12):
        raise ValueError(f"output_times must be non-empty, finite and within [0, t_end={t_end}]")
    out = np.minimum(out, t_end)
    # drop uniform levels that nearly coincide with an output time, keep the output time itself
    near = np.min(np.abs(levels[:, None] - out[None, :]), axis=1) <= 1e-6 * levels[1]
    levels = np.union1d(levels[~near], out)
    return levels, np.isin(levels, out)


def solve_plug_flow(problem: PlugFlowProblem, initial_velocity: Callable[[np.ndarray], np.ndarray],
                    t_end: float, dt: float, nz: int, *, output_times=None,
                    threshold: float = 1e-3, tol: float = 1e-10,
                    max_iter: int = 1000) -> PlugFlowSolution:
    """Backward-Euler, exact (non-regularised) Drucker–Prager solution on ``nz`` uniform nodes.

    initial_velocity: U0(Z) on the grid (U0(0) is replaced by the no-slip value 0).
    dt: largest step; the uniform step used is t_end/ceil(t_end/dt); output_times are inserted
    as extra time levels (variable-step backward Euler) and only they are stored. Without
    output_times, every level is stored up to 1000 steps, else every ceil(n/1000)-th plus the
    last. Interface and stopping times are evaluated at every level.
    tol: relative tolerance on max_i |g_i − γ̇_i| (see module docstring), relative to
    g_ref = max(max|∂_Z U0|, max|U0|/h, (g sinθ + μ_s g cosθ) t_end/h), with an absolute
    round-off floor 100 ε (σ_ref/c_r + g_ref h/Δz), σ_ref = (g sinθ + μ_s g cosθ) h.
    RuntimeError (naming the step, time and residual) if a step needs more than max_iter
    iterations or its active sets cycle. After an exact arrest (U ≡ 0 at two successive levels)
    rest is the exact solution for any later Δt and is copied forward.
    """
    t_end, dt, threshold = float(t_end), float(dt), float(threshold)
    if not (math.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end must be > 0, got {t_end}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be > 0, got {dt}")
    if int(nz) != nz or nz < 3:
        raise ValueError(f"nz must be an integer >= 3, got {nz}")
    if not (threshold >= 0 and tol > 0 and int(max_iter) >= 1):
        raise ValueError("need threshold >= 0, tol > 0 and max_iter >= 1")
    nz, max_iter = int(nz), int(max_iter)
    h, nu = problem.thickness, problem.kinematic_viscosity
    th, grav, mu = problem.slope_angle, problem.gravity, problem.friction_coefficient
    f = grav * math.sin(th)                        # driving acceleration
    z = np.linspace(0.0, h, nz)
    N, dz = nz - 1, h / (nz - 1)
    m = np.full(N, dz)
    m[-1] = 0.5 * dz                               # lumped P1 mass of nodes 1..N
    k = mu * grav * math.cos(th) * (h - (z[:-1] + 0.5 * dz))  # yield stress/ρ at interval midpoints
    u = np.asarray(initial_velocity(z), dtype=float).copy()
    if u.shape != z.shape or not np.all(np.isfinite(u)):
        raise ValueError(f"initial_velocity must return {nz} finite values, got shape {u.shape}")
    u[0] = 0.0

    levels, store = _time_levels(t_end, dt, output_times)
    g = np.diff(u) / dz
    lam = k * np.sign(g)                           # initial multiplier guess: consistent with g
    g_ref = max(np.max(np.abs(g)), np.max(np.abs(u)) / h,
                (abs(f) + mu * grav * math.cos(th)) * t_end / h)
    sig_ref = (abs(f) + mu * grav * math.cos(th)) * h  # stress/ρ scale [m²/s²]
    ab = np.zeros((3, 2 * N))                      # tridiagonal, unknowns (σ1, U1, σ2, U2, ...)
    ab[0, 2::2] = -1.0                             # momentum j: −σ_{j+1}
    ab[2, 0::2] = 1.0                              # momentum j: +σ_j
    rhs = np.empty(2 * N)

    out_u = [u.copy()] if store[0] else []
    last_moving = 0 if np.max(np.abs(u)) > threshold else -1  # last level with max|U| > thr.
    last_nonzero = 0 if np.any(u) else -1               # last level with U ≢ 0
    total_it, max_it, worst = 0, 0, 0.0
    at_rest = False
    for n in range(1, len(levels)):
        tau = levels[n] - levels[n - 1]
        if at_rest:                                # exact rest persists (time-independent problem)
            if store[n]:
                out_u.append(u.copy())
            continue
        c_ref = nu + dz * dz / tau                 # rate ↔ stress scale of the residual [m²/s]
        c = C_ACTIVE * c_ref                       # active-set parameter (see C_ACTIVE)
        atol = tol * g_ref + 100 * EPS * (sig_ref / c_ref + g_ref * h / dz)  # round-off floor
        ab[1, 1::2] = m / tau
        rhs[1::2] = m * (u[1:] / tau + f)
        zeta = lam + c * g
        flow, s = np.abs(zeta) > k, np.sign(zeta)
        seen = {np.where(flow, s, 0.0).astype(np.int8).tobytes()}
        for it in range(1, max_iter + 1):
            # constitutive row i: a σ_i − w (U_i − U_{i−1}) = a k s  (a = 1 flowing, 0 stuck)
            w = np.where(flow, nu, c) / dz
            ab[0, 1::2] = -w
            ab[1, 0::2] = flow
            ab[2, 1:-1:2] = w[1:]
            rhs[0::2] = np.where(flow, k * s, 0.0)
            x = solve_banded((1, 1), ab, rhs, check_finite=False)
            sigma, dU = x[0::2], np.diff(x[1::2], prepend=0.0)
            dU[~flow] = 0.0                        # stuck intervals exactly rigid
            g = dU / dz
            lam = np.where(flow, k * s, sigma)     # plastic stress λ = σ − ν g (exact when flowing)
            zr = lam + c_ref * g
            res = np.max(np.abs(g - np.sign(zr) * np.maximum(np.abs(zr) - k, 0.0) / c_ref))
            zeta = lam + c * g
            flow_new, s_new = np.abs(zeta) > k, np.sign(zeta)
            if res <= atol or (np.array_equal(flow_new, flow)
                               and np.array_equal(s_new[flow], s[flow])):
                break                              # tolerance met, or the active set is exact
            key = np.where(flow_new, s_new, 0.0).astype(np.int8).tobytes()
            if key in seen:
                raise RuntimeError(f"plug flow: active-set iteration cycles at time step {n} "
                                   f"(t = {levels[n]:.6g} s, iteration {it}); relative strain-rate "
                                   f"residual {res / g_ref:.3e} > tol {tol:.1e}")
            seen.add(key)
            flow, s = flow_new, s_new
        else:
            raise RuntimeError(f"plug flow: active-set iteration did not converge at time step {n} "
                               f"(t = {levels[n]:.6g} s) after {max_iter} iterations; "
                               f"relative strain-rate residual {res / g_ref:.3e} > tol {tol:.1e}")
        max_it = max(max_it, it)
        total_it += it
        worst = max(worst, res / g_ref)
        u_new = np.concatenate(([0.0], np.cumsum(dU)))
        at_rest = not np.any(u_new) and not np.any(u)
        u = u_new
        if np.max(np.abs(u)) > threshold:
            last_moving = n
        if np.any(u):
            last_nonzero = n
        if store[n]:
            out_u.append(u.copy())

    def _after(last):                              # first level of the final at-rest stretch
        return math.nan if last == len(levels) - 1 else float(levels[last + 1])

    stop_t, arrest_t = _after(last_moving), _after(last_nonzero)
    vel = np.array(out_u)
    moving = np.abs(vel) > threshold
    interface = np.where(moving.any(axis=1), z[np.argmax(moving, axis=1)], h)
    nonzero = vel != 0.0
    first = np.where(nonzero.any(axis=1), np.argmax(nonzero, axis=1), nz)
    static = z[np.maximum(first - 1, 0)]
    return PlugFlowSolution(times=levels[store].copy(), z=z, velocity=vel, interface=interface,
                            stopping_time=float(stop_t), static_interface=static,
                            arrest_time=float(arrest_t), problem=problem, iterations=total_it,
                            max_step_iterations=max_it, max_residual=worst, threshold=threshold)
