"""Mesh quality of a P1 triangle mesh: signed areas, angles and the step that inverts.

All functions work on arrays of cell vertex coordinates (n, 3, 2), so they are pure numpy.
"""

from __future__ import annotations

import numpy as np


def signed_areas(tri: np.ndarray) -> np.ndarray:
    """Twice the signed area (det J) of each triangle (n, 3, 2) → (n,)."""
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    return e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]


def min_angles(tri: np.ndarray) -> np.ndarray:
    """Smallest interior angle of each triangle [deg]."""
    angles = []
    for i in range(3):
        a = tri[:, (i + 1) % 3] - tri[:, i]
        b = tri[:, (i + 2) % 3] - tri[:, i]
        cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.min(angles, axis=0)


def max_safe_step(tri: np.ndarray, vel: np.ndarray, shrink: float = 0.5) -> float:
    """Largest τ ≥ 0 such that moving vertices by τ·vel keeps det J ≥ shrink·det J₀.

    det J(τ) = c + bτ + aτ² for each cell, with c = det J₀; returns the smallest positive
    root of det J(τ) − shrink·c over all cells (∞ when no cell shrinks that much).
    """
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    f1, f2 = vel[:, 1] - vel[:, 0], vel[:, 2] - vel[:, 0]

    def cross(p, q):
        return p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]

    c = cross(e1, e2) * (1.0 - shrink)
    b = cross(e1, f2) + cross(f1, e2)
    a = cross(f1, f2)
    tau = np.full(len(c), np.inf)
    lin = np.abs(a) < 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        t_lin = np.where(b < 0, -c / b, np.inf)
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.where(disc >= 0, disc, 0.0))
        r1 = (-b - sq) / (2 * a)
        r2 = (-b + sq) / (2 * a)
    r1 = np.where((disc >= 0) & (r1 > 0), r1, np.inf)
    r2 = np.where((disc >= 0) & (r2 > 0), r2, np.inf)
    tau = np.where(lin, t_lin, np.minimum(r1, r2))
    return float(np.min(tau)) if len(tau) else np.inf


def courant_rate(tri: np.ndarray, vel: np.ndarray) -> float:
    """max_K max_{vertices of K} |u| / h_K [1/s], h_K the shortest edge of triangle K.

    A step Δt has Courant number Δt·rate: the largest distance a vertex velocity carries
    material in one step, in units of its cell's shortest edge (0 for no cells or u = 0).
    """
    if len(tri) == 0:
        return 0.0
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).min(axis=1)
    speed = np.linalg.norm(vel, axis=2).max(axis=1)
    return float(np.max(speed / edges))
