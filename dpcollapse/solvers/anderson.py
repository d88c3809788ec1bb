"""Anderson acceleration (type II) of a fixed point x = G(x), distributed over MPI.

With residuals f_k = G(x_k) − x_k and the last m differences ΔF = [f_{i+1} − f_i],
ΔG = [G(x_{i+1}) − G(x_i)], the next iterate is

    x_{k+1} = G(x_k) − ΔG γ,    γ = argmin ‖f_k − ΔF γ‖_W,

a least-squares problem of size m solved through its normal equations (Tikhonov-
regularized). ``weights`` select which entries enter the norm (e.g. velocity dofs only, so
pressures in Pa do not dominate velocities in m/s); the combination is applied to all.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI


class Anderson:
    """History of the last ``depth`` iterates of a fixed point.

    The differences are kept in preallocated (depth, n) ring buffers, the residual ones
    pre-scaled by √w, so one update costs two small matrix products (BLAS), no copies of
    the history."""

    def __init__(self, comm: MPI.Comm, depth: int, owned: int, weights: np.ndarray | None = None,
                 regularization: float = 1e-12):
        self.comm, self.depth, self.owned = comm, depth, owned
        self.weights = weights
        self._scale = np.sqrt(weights) if weights is not None else None
        self.regularization = regularization
        self._dF = np.empty((depth, owned)) if depth > 0 else None   # √w (f_{i+1} − f_i)
        self._dG = np.empty((depth, owned)) if depth > 0 else None   # G(x_{i+1}) − G(x_i)
        self.reset()

    def reset(self) -> None:
        self._count = 0          # differences stored (≤ depth)
        self._next = 0           # ring position of the next difference
        self._f = None           # last scaled residual and image
        self._g = None

    def update(self, x: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Given the current iterate x_k and its image G(x_k) (owned entries), return x_{k+1}."""
        if self.depth == 0:
            return g.copy()
        f = g - x
        if self._scale is not None:
            f *= self._scale
        if self._f is None:
            self._f, self._g = f, g.copy()
            return g.copy()
        i = self._next
        np.subtract(f, self._f, out=self._dF[i])
        np.subtract(g, self._g, out=self._dG[i])
        self._f, self._g = f, g.copy()
        self._next = (i + 1) % self.depth
        self._count = min(self._count + 1, self.depth)
        F, G = self._dF[:self._count], self._dG[:self._count]
        A = self.comm.allreduce(F @ F.T, op=MPI.SUM)
        rhs = self.comm.allreduce(F @ f, op=MPI.SUM)
        scale = np.trace(A) / len(A) if np.trace(A) > 0 else 1.0
        gamma = np.linalg.solve(A + self.regularization * scale * np.eye(len(A)), rhs)
        return g - gamma @ G
