"""Closed-form local steps of the augmented Lagrangian (decomposition–coordination) method.

Seed 002, steps 2–3, written in the project's Frobenius norm |T| = √(T:T). With the
dissipation potential Φ(D) = η|D|² + κ|D| (so that ∂Φ/∂D = 2ηD + κ D/|D| = σ'), step 2 is
the minimiser over q of Φ(q) + (r/2)|q|² − τ:q with τ = σ' + r D(u)::

    γ̇ = [1 − κ/|τ|]_+ τ / (2η + r)                       (yield multiplier)

and for Coulomb friction with regularizing coefficient η_f ≥ 0 on the wall, with
τ_T = σ_T − r_f u_T::

    δ = −[1 − μ[−σ_n]_+ / |τ_T|]_+ τ_T / (η_f + r_f)      (slip multiplier)

Step 3 updates the multipliers: σ' ← σ' + r (D(u) − γ̇), σ_T ← σ_T − r_f (u_T − δ).
(Seed 002 writes these with ‖T‖ = √(T:T/2); the structure is the same, κ follows the norm:
κ = √2 (κ0 + μ_s [p]_+) here.) Rigid zones are where γ̇ = 0 exactly: |τ| ≤ κ.

Functions act on arrays of tensors (..., 2, 2) / vectors (..., 2), pointwise, so they apply
to the values of discontinuous (DG) fields directly.
"""

from __future__ import annotations

import numpy as np


def _norm(t: np.ndarray, axes) -> np.ndarray:
    return np.sqrt(np.sum(t * t, axis=axes))


def yield_multiplier(sigma: np.ndarray, strain_rate: np.ndarray, kappa: np.ndarray,
                     viscosity: float | np.ndarray, r: float) -> np.ndarray:
    """γ̇ = [1 − κ/|σ' + rD|]_+ (σ' + rD)/(2η + r) for tensors (..., 2, 2)."""
    tau = sigma + r * strain_rate
    size = _norm(tau, (-2, -1))
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(size > 0, np.maximum(1.0 - np.asarray(kappa) / size, 0.0), 0.0)
    return (factor / (2.0 * np.asarray(viscosity) + r))[..., None, None] * tau


def update_stress(sigma: np.ndarray, strain_rate: np.ndarray, gamma: np.ndarray, r: float) -> np.ndarray:
    """σ' ← σ' + r (D(u) − γ̇)."""
    return sigma + r * (strain_rate - gamma)


def slip_multiplier(sigma_t: np.ndarray, u_t: np.ndarray, threshold: np.ndarray,
                    eta_f: float, r_f: float) -> np.ndarray:
    """δ = −[1 − μ[−σ_n]_+/|σ_T − r_f u_T|]_+ (σ_T − r_f u_T)/(η_f + r_f), vectors (..., 2);
    ``threshold`` is μ[−σ_n]_+ (the Coulomb limit, ≥ 0)."""
    tau = sigma_t - r_f * u_t
    size = _norm(tau, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(size > 0, np.maximum(1.0 - np.asarray(threshold) / size, 0.0), 0.0)
    return -(factor / (eta_f + r_f))[..., None] * tau


def update_traction(sigma_t: np.ndarray, u_t: np.ndarray, delta: np.ndarray, r_f: float) -> np.ndarray:
    """σ_T ← σ_T − r_f (u_T − δ)."""
    return sigma_t - r_f * (u_t - delta)


def rigid(gamma: np.ndarray) -> np.ndarray:
    """Where the yield multiplier vanishes exactly (the rigid zone)."""
    return np.all(gamma == 0.0, axis=(-2, -1))
