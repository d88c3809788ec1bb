r"""Linear well-posedness of the incompressible μ(I) rheology (Barker, Schaeffer, Bohórquez &
Gray 2015, J. Fluid Mech. 779).

With ν(I) = I μ'(I)/μ(I), the 2D equations are well posed (at high wavenumber) where::

    C(I) = 4 ν² − 4 ν + μ² (1 − ν/2)² < 0.

For μ(I) = μ_s + (μ_2 − μ_s) I/(I0 + I), ν → 0 as I → 0 and as I → ∞, so C → μ_s² > 0 and
μ_2² > 0: the law is ill posed at both ends and (when at all) well posed in one window
I_min < I < I_max. Only numpy/scipy; the law is any object with ``friction(I)`` and
``friction_derivative(I)`` (e.g. :class:`dpcollapse.rheology.mu_i.MuI`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

__all__ = ["criterion", "well_posed_window", "fraction_ill_posed", "high_wavenumber_growth"]

_I_LO, _I_HI, _N_GRID = 1e-10, 1e6, 4001


def criterion(law, I):
    """C(I) = 4(Iμ'/μ)² − 4(Iμ'/μ) + μ²(1 − Iμ'/(2μ))²; well posed where C < 0.

    I ≥ 0, scalar or array; returns a float for a scalar."""
    I = np.asarray(I, dtype=float)
    mu = np.asarray(law.friction(I), dtype=float)
    nu = I * np.asarray(law.friction_derivative(I), dtype=float) / mu
    C = 4.0 * nu**2 - 4.0 * nu + mu**2 * (1.0 - 0.5 * nu) ** 2
    return float(C) if C.ndim == 0 else C


def well_posed_window(law, I_range=(_I_LO, _I_HI), n_grid=_N_GRID):
    """(I_min, I_max) with C < 0 in between, or (nan, nan) if C ≥ 0 on the whole grid.

    C is sampled on a log grid over ``I_range``; the sign changes are refined with brentq
    (xtol relative 1e-12). I_min is the first change + → −, I_max the last change − → +
    (for the Jop law the well-posed set is a single interval). If C < 0 at an end of the range,
    that end is returned."""
    lo, hi = I_range
    if not (0 < lo < hi):
        raise ValueError(f"I_range must satisfy 0 < lo < hi, got {I_range}")
    grid = np.logspace(math.log10(lo), math.log10(hi), int(n_grid))
    C = criterion(law, grid)
    neg = C < 0
    if not np.any(neg):
        return (math.nan, math.nan)
    f = lambda x: criterion(law, x)  # noqa: E731
    first, last = np.flatnonzero(neg)[[0, -1]]
    I_min = grid[0] if first == 0 else brentq(f, grid[first - 1], grid[first], xtol=1e-14, rtol=1e-12)
    I_max = (
        grid[-1] if last == len(grid) - 1 else brentq(f, grid[last], grid[last + 1], xtol=1e-14, rtol=1e-12)
    )
    return (float(I_min), float(I_max))


def fraction_ill_posed(law, I_values, weights=None):
    """Fraction (weighted, e.g. by cell area) of the samples where C(I) ≥ 0 (ill posed).

    I_values ≥ 0 (I = 0, a static zone, counts as ill posed); weights ≥ 0 of the same shape,
    uniform if None. Raises ValueError on empty input, NaN, or a zero total weight."""
    I = np.asarray(I_values, dtype=float).ravel()
    if I.size == 0:
        raise ValueError("I_values is empty")
    if not np.all(np.isfinite(I)):
        raise ValueError("I_values must be finite")
    w = np.ones_like(I) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != I.shape:
        raise ValueError(f"weights shape {w.shape} != I_values shape {I.shape}")
    if np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValueError("weights must be finite and >= 0")
    total = w.sum()
    if total <= 0:
        raise ValueError("total weight must be > 0")
    ill = criterion(law, I) >= 0
    return float(np.sum(w * ill) / total)


def high_wavenumber_growth(law, I, n_grid: int = 20001) -> float:
    r"""G(I): the largest growth rate of a short wave, in units of k² η/ρ (η = μ p/γ̇).

    Frozen-coefficient linearization about simple shear (γ̇, p) at wavenumber k → ∞, wave
    vector at angle φ to the shear direction, s = sin 2φ, m = μ(1 − ν/2), ν = Iμ'/μ
    (incompressible, so δu ⊥ k and δp = n·δσ'·n)::

        σ(k, φ) = −(k² η/ρ) [ν − m s + (1 − ν) s²] / (1 − m s),

    G = max over s ∈ [−1, 1] of −[ν − m s + (1 − ν)s²]/(1 − m s). The bracket is negative for
    some s iff 4ν(1 − ν) < m², i.e. C(I) > 0: G > 0 exactly where the law is ill posed
    (then σ grows as k², without bound), G < 0 where every short wave decays at least at
    |G| k² η/ρ. Needs m < 1 (μ < 1). I > 0 scalar."""
    I = float(I)
    mu = float(law.friction(I))
    nu = I * float(law.friction_derivative(I)) / mu
    m = mu * (1.0 - 0.5 * nu)
    if not (I > 0 and m < 1.0):
        raise ValueError(f"needs I > 0 and mu(1 - nu/2) < 1, got I = {I}, m = {m}")
    s = np.linspace(-1.0, 1.0, int(n_grid))
    g = -(nu - m * s + (1.0 - nu) * s**2) / (1.0 - m * s)
    return float(g.max())
