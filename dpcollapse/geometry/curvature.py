"""Discrete curvature of the free surface and seed 000's local surface tension profile.

Seed 000 (erodible bed, case b_e) cures a free surface that folds up by a *local* surface
tension: P·N = γN on Γ_f with γ = γ0·C, C = dθ/ds the curvature, applied only around the
surface node of largest curvature. On the polyline of free-surface nodes N_0 … N_m, with
R_i = N_{i−1}N_i the edge arriving at node i and δθ_i the angle it turns through there,

    C_i = δθ_i / ((|R_{i+1}| + |R_i|)/2),            i = 1 … m−1,

    γ0_i = γ̄0 (max{0, 1 − ((i − i_c)/δ)²})²,        i_c = argmax_i |C_i|,

and γ̄0 = o(h) (it must vanish with the mesh size h).

Sign convention (the seed's figure is lost; this is the one the Laplace law fixes): the
polyline runs with the granular mass on its left (counter-clockwise around the domain),
so δθ_i > 0 where the surface is convex (bulging out) and < 0 where it is concave (a
re-entrant fold). Surface tension pulls a convex bulge in and pushes a concave fold out:
the traction is σ·N = −γ0_i C_i N. It is the seed's γ = γ0·C with C measured the other
way round (mass on the right), which is what makes it a tension and not an anti-tension.
"""

from __future__ import annotations

import numpy as np


def turning_angles(points: np.ndarray) -> np.ndarray:
    """Signed turning angle δθ_i ∈ (−π, π] at the interior nodes of an open polyline
    (counter-clockwise turns positive); shape (m − 1,) for m + 1 points."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return np.zeros(0)
    a = p[1:-1] - p[:-2]          # R_i
    b = p[2:] - p[1:-1]           # R_{i+1}
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.einsum("ij,ij->i", a, b)
    return np.arctan2(cross, dot)


def discrete_curvature(points: np.ndarray) -> np.ndarray:
    """C_i = δθ_i / ((|R_{i+1}| + |R_i|)/2) at every node of an open polyline, 0 at its
    two end nodes (corners with the bed or a wall) [1/m]; shape (m + 1,)."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    curvature = np.zeros(len(p))
    if len(p) < 3:
        return curvature
    lengths = np.linalg.norm(np.diff(p, axis=0), axis=1)
    mean_length = 0.5 * (lengths[:-1] + lengths[1:])
    curvature[1:-1] = turning_angles(p) / mean_length
    return curvature


def bump_weights(count: int, centre: int, extent: float) -> np.ndarray:
    """(max{0, 1 − ((i − i_c)/δ)²})² for i = 0 … count−1: 1 at i_c, 0 from |i − i_c| ≥ δ."""
    if extent <= 0:
        raise ValueError(f"extent δ = {extent}: must be > 0 (in nodes)")
    i = np.arange(count, dtype=float)
    return np.maximum(0.0, 1.0 - ((i - centre) / extent) ** 2) ** 2


def local_surface_tension(points: np.ndarray, gamma_bar: float, extent: float) -> np.ndarray:
    """The normal traction coefficient at each node of the free-surface polyline, such that
    σ·N = −γ_i N there [Pa]: γ_i = γ0_i C_i, with γ0_i the bump of height γ̄0 [N/m] and
    extent δ [nodes] around the node of largest |C| (seed 000). Zero everywhere when γ̄0 = 0
    or the surface is straight."""
    curvature = discrete_curvature(points)
    if gamma_bar == 0.0 or not np.any(curvature):
        return np.zeros_like(curvature)
    centre = int(np.argmax(np.abs(curvature)))
    return gamma_bar * bump_weights(len(curvature), centre, extent) * curvature


def local_surface_tension_runs(runs: list[np.ndarray], gamma_bar: float,
                               extent: float) -> list[np.ndarray]:
    """``local_surface_tension`` over a free surface made of several open polylines (runs of
    one boundary tag between corners): C_i on each run (0 at its end nodes), one node i_c of
    largest |C| over all runs, the bump of height γ̄0 and extent δ on the run that holds it
    (counted along that run), zero on the others [Pa], one array per run."""
    curvatures = [discrete_curvature(run) for run in runs]
    out = [np.zeros_like(c) for c in curvatures]
    if gamma_bar == 0.0 or not any(np.any(c) for c in curvatures):
        return out
    peaks = [float(np.abs(c).max()) if len(c) else 0.0 for c in curvatures]
    k = int(np.argmax(peaks))
    c = curvatures[k]
    centre = int(np.argmax(np.abs(c)))
    out[k] = gamma_bar * bump_weights(len(c), centre, extent) * c
    return out
