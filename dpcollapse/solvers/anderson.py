"""Anderson acceleration (type II) of a fixed point x = G(x), distributed over MPI.

With residuals f_k = G(x_k) − x_k and the last m differences ΔF = [f_{i+1} − f_i],
ΔG = [G(x_{i+1}) − G(x_i)], the next iterate is

    x_{k+1} = G(x_k) − ΔG γ,    γ = argmin ‖f_k − ΔF γ‖_W,

a least-squares problem of size m solved through its normal equations (Tikhonov-
regularized). ``weights`` select which entries enter the norm (e.g. velocity dofs only, so
pressures in Pa do not dominate velocities in m/s); the combination is applied to all.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from mpi4py import MPI


class Anderson:
    """History of the last ``depth`` iterates of a fixed point."""

    def __init__(self, comm: MPI.Comm, depth: int, owned: int, weights: np.ndarray | None = None,
                 regularization: float = 1e-12):
        self.comm, self.depth, self.owned = comm, depth, owned
        self.weights = weights
        self.regularization = regularization
        self._f: deque = deque(maxlen=depth + 1)
        self._g: deque = deque(maxlen=depth + 1)

    def reset(self) -> None:
        self._f.clear()
        self._g.clear()

    def _dot(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        w = self.weights
        local = (a * w) @ b.T if w is not None else a @ b.T
        return self.comm.allreduce(local, op=MPI.SUM)

    def update(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Given the current iterate x_k and its image G(x_k) (owned entries), return x_{k+1}."""
        f = g - x
        self._f.append(f.copy())
        self._g.append(g.copy())
        if self.depth == 0 or len(self._f) < 2:
            return g.copy()
        F = np.diff(np.array(self._f), axis=0)          # (m, n)
        G = np.diff(np.array(self._g), axis=0)
        A = self._dot(F, F)
        rhs = self._dot(F, f[None, :])[:, 0]
        scale = np.trace(A) / len(A) if np.trace(A) > 0 else 1.0
        gamma = np.linalg.solve(A + self.regularization * scale * np.eye(len(A)), rhs)
        return g - gamma @ G
