"""Mesh-independent snapshot of P1/P2 Lagrange fields on triangles (pure numpy + scipy).

A :class:`CellwiseField` stores, cell by cell, the triangle's vertices, its Lagrange nodes
(in any order) and the nodal values. It can be evaluated at arbitrary points (used to carry
velocity and pressure onto a new mesh after remeshing), saved to / loaded from ``.npz``
(checkpoints readable on any number of MPI ranks) and concatenated (gather of per-rank
parts). No dolfinx here: the glue code extracts the arrays.

Each cell's polynomial is obtained by solving the small Vandermonde system of the monomials
(1, x, y[, x², xy, y²]) in local coordinates ``(x - centroid) / diameter`` at its nodes, so
node ordering does not matter. Points outside every cell get the value of the nearest
cell's polynomial extrapolated there; :attr:`CellwiseField.last_outside_distance` reports
how far outside the farthest such point was.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["CellwiseField", "concatenate", "monomials"]

_NODES = {1: 3, 2: 6}
#: a point this close to a cell's node (relative to the cell's diameter) is that node
NODE_MATCH = 1e-13


def monomials(xi: np.ndarray, degree: int) -> np.ndarray:
    """Monomials (1, x, y[, x², xy, y²]) of points ``xi`` (..., 2) -> (..., 3 or 6)."""
    x, y = xi[..., 0], xi[..., 1]
    one = np.ones_like(x)
    if degree == 1:
        return np.stack([one, x, y], axis=-1)
    if degree == 2:
        return np.stack([one, x, y, x * x, x * y, y * y], axis=-1)
    raise ValueError(f"degree must be 1 or 2, got {degree}")


@dataclass(eq=False)
class CellwiseField:
    """A piecewise-polynomial field on a triangle mesh stored cell by cell.

    vertices: (nc, 3, 2) the triangles' vertex coordinates;
    points:   (nc, k, 2) the cell's Lagrange nodes (k = 3 for P1, 6 for P2) in ANY order;
    values:   (nc, k, bs) the nodal values (bs = 1 for scalars, 2 for 2D vectors;
              (nc, k) is accepted for scalars);
    degree:   1 or 2.

    Coefficients and the search tree are built on first use and cached: do not modify the
    arrays in place afterwards (build a new field instead).
    """

    vertices: np.ndarray
    points: np.ndarray
    values: np.ndarray
    degree: int
    #: largest distance from a point evaluated by the last :meth:`evaluate` call to the
    #: mesh, over the points found outside every cell (0.0 if there were none)
    last_outside_distance: float = field(default=0.0, init=False)
    #: number of such outside points in the last call
    last_outside_count: int = field(default=0, init=False)
    _cache: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        self.degree = int(self.degree)
        if self.degree not in _NODES:
            raise ValueError(f"degree must be 1 or 2, got {self.degree}")
        k = _NODES[self.degree]
        self.vertices = np.asarray(self.vertices, dtype=float)
        self.points = np.asarray(self.points, dtype=float)
        values = np.asarray(self.values, dtype=float)
        if values.ndim == 2:
            values = values[..., None]
        self.values = values
        nc = len(self.vertices)
        if (self.vertices.shape != (nc, 3, 2) or self.points.shape != (nc, k, 2)
                or values.ndim != 3 or values.shape[:2] != (nc, k)):
            raise ValueError(f"degree {self.degree} needs vertices (nc, 3, 2), points "
                             f"(nc, {k}, 2) and values (nc, {k}, bs); got "
                             f"{self.vertices.shape}, {self.points.shape}, {values.shape}")

    @property
    def num_cells(self) -> int:
        return len(self.vertices)

    @property
    def block_size(self) -> int:
        return self.values.shape[2]

    # ------------------------------------------------------------------ cached geometry
    def _geometry(self) -> dict:
        c = self._cache
        if "centroid" not in c:
            v = self.vertices
            e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
            c["centroid"] = v.mean(axis=1)
            c["scale"] = np.linalg.norm(v - np.roll(v, -1, axis=1), axis=2).max(axis=1)
            det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
            if np.any(det == 0):
                raise ValueError("degenerate (zero-area) cell in CellwiseField")
            # inverse of [e1 e2] (columns): lambda_{1,2} = inv @ (x - v0)
            c["inv"] = np.stack([np.stack([e2[:, 1], -e2[:, 0]], -1),
                                 np.stack([-e1[:, 1], e1[:, 0]], -1)], 1) / det[:, None, None]
            c["tree"] = cKDTree(c["centroid"])
        return c

    def coefficients(self) -> np.ndarray:
        """(nc, k, bs) monomial coefficients of each cell's interpolant (cached)."""
        c = self._geometry()
        if "coef" not in c:
            xi = (self.points - c["centroid"][:, None]) / c["scale"][:, None, None]
            try:
                c["coef"] = np.linalg.solve(monomials(xi, self.degree), self.values)
            except np.linalg.LinAlgError as err:
                raise ValueError("a cell's Lagrange nodes are not unisolvent for degree "
                                 f"{self.degree} (repeated or collinear nodes?)") from err
        return c["coef"]

    # ------------------------------------------------------------------ evaluation
    def _barycentric(self, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Barycentric coordinates (..., 3) of points x (..., 2) in cells (...)."""
        c = self._geometry()
        d = x - self.vertices[cells, 0]
        l12 = np.einsum("...ij,...j->...i", c["inv"][cells], d)
        return np.concatenate([1.0 - l12.sum(-1, keepdims=True), l12], axis=-1)

    def _distance(self, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Distance (...) from points x (..., 2) to the closed triangles ``cells`` (...)."""
        v = self.vertices[cells]  # (..., 3, 2)
        a, b = v, np.roll(v, -1, axis=-2)
        ab, ap = b - a, x[..., None, :] - a
        t = np.clip((ap * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
        d = np.linalg.norm(ap - t[..., None] * ab, axis=-1).min(-1)
        inside = self._barycentric(x, cells).min(-1) >= 0.0
        return np.where(inside, 0.0, d)

    def locate(self, x: np.ndarray, tol: float = 1e-10, k_start: int = 8,
               k_max: int = 128) -> tuple[np.ndarray, np.ndarray]:
        """Cell of each point and its distance to that cell (0 inside).

        Candidates are the ``k`` cells with the nearest centroids, widened ×4 (up to
        ``k_max``) for points not yet found; a point is inside a cell if all barycentric
        coordinates are ≥ -``tol``. Points in no candidate get the candidate cell nearest
        to them (by true point–triangle distance) and that distance.
        """
        x = np.asarray(x, dtype=float).reshape(-1, 2)
        n, nc = len(x), self.num_cells
        if nc == 0:
            raise ValueError("cannot locate points in an empty CellwiseField")
        tree = self._geometry()["tree"]
        cells = np.full(n, -1, dtype=np.int64)
        dist = np.zeros(n)
        todo = np.arange(n)
        k = min(k_start, nc)
        while todo.size:
            _, idx = tree.query(x[todo], k=k)
            idx = idx.reshape(len(todo), k)
            lam = self._barycentric(x[todo, None, :], idx).min(-1)  # (m, k)
            j = lam.argmax(axis=1)
            rows = np.arange(len(todo))
            ok = lam[rows, j] >= -tol
            cells[todo[ok]] = idx[rows[ok], j[ok]]
            todo, idx = todo[~ok], idx[~ok]
            if not todo.size:
                break
            if k >= min(k_max, nc):  # outside every candidate: nearest candidate cell
                d = self._distance(x[todo, None, :], idx)
                j = d.argmin(axis=1)
                rows = np.arange(len(todo))
                cells[todo] = idx[rows, j]
                dist[todo] = d[rows, j]
                break
            k = min(4 * k, k_max, nc)
        return cells, dist

    def evaluate_in_cells(self, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Values (n, bs) of the polynomials of ``cells`` (n,) at points ``x`` (n, 2); a point
        on one of its cell's nodes (within NODE_MATCH × the cell's diameter) takes that
        node's stored value exactly (the polynomial's round-off, ~1e-15 relative, would
        otherwise reach a checkpoint restored on its own mesh: a resumed run must repeat
        the uninterrupted one to 1e-12)."""
        x = np.asarray(x, dtype=float).reshape(-1, 2)
        coef = self.coefficients()
        c = self._cache
        xi = (x - c["centroid"][cells]) / c["scale"][cells, None]
        out = np.einsum("nk,nkb->nb", monomials(xi, self.degree), coef[cells])
        gap = np.abs(self.points[cells] - x[:, None, :]).max(axis=-1)   # (n, k)
        node = gap.argmin(axis=1)
        rows = np.arange(len(x))
        on_node = gap[rows, node] <= NODE_MATCH * c["scale"][cells]
        out[on_node] = self.values[cells[on_node], node[on_node]]
        return out

    def evaluate(self, x: np.ndarray, tol: float = 1e-10) -> np.ndarray:
        """Field values (n, bs) at points ``x`` (n, 2).

        Points outside every cell (e.g. a new boundary lying a hair outside the old one)
        get the nearest cell's polynomial *extrapolated* at the point; the largest such
        distance is stored in :attr:`last_outside_distance` (count in
        :attr:`last_outside_count`) for the caller to log.
        """
        x = np.asarray(x, dtype=float).reshape(-1, 2)
        if len(x) == 0:
            self.last_outside_distance, self.last_outside_count = 0.0, 0
            return np.zeros((0, self.block_size))
        cells, dist = self.locate(x, tol=tol)
        self.last_outside_count = int(np.count_nonzero(dist > 0))
        self.last_outside_distance = float(dist.max())
        return self.evaluate_in_cells(x, cells)

    __call__ = evaluate

    # ------------------------------------------------------------------ (de)serialisation
    def to_arrays(self, prefix: str = "") -> dict[str, np.ndarray]:
        """Arrays for ``np.savez``: keys ``{prefix}`` + vertices, points, values, degree."""
        return {f"{prefix}vertices": self.vertices, f"{prefix}points": self.points,
                f"{prefix}values": self.values,
                f"{prefix}degree": np.array(self.degree, dtype=np.int64)}

    @classmethod
    def from_arrays(cls, d: Mapping[str, np.ndarray], prefix: str = "") -> CellwiseField:
        """Inverse of :meth:`to_arrays` (accepts a dict or an open ``np.load`` NpzFile)."""
        return cls(np.asarray(d[f"{prefix}vertices"]), np.asarray(d[f"{prefix}points"]),
                   np.asarray(d[f"{prefix}values"]), int(np.asarray(d[f"{prefix}degree"])))

    def save(self, path: str | PathLike) -> None:
        """Write the field to an ``.npz`` file."""
        np.savez(path, **self.to_arrays())

    @classmethod
    def load(cls, path: str | PathLike) -> CellwiseField:
        """Read a field written by :meth:`save`."""
        with np.load(path) as d:
            return cls.from_arrays(d)


def concatenate(fields: Sequence[CellwiseField]) -> CellwiseField:
    """One field holding all cells of ``fields`` (e.g. the gathered per-rank parts).

    All parts must share degree and block size; empty parts are fine. Cells present in
    several parts (ghosts) are kept; duplicates do not change evaluated values.
    """
    if not fields:
        raise ValueError("concatenate needs at least one field")
    deg = {f.degree for f in fields}
    bs = {f.block_size for f in fields}
    if len(deg) != 1 or len(bs) != 1:
        raise ValueError(f"cannot concatenate fields of degrees {deg} / block sizes {bs}")
    return CellwiseField(np.concatenate([f.vertices for f in fields]),
                         np.concatenate([f.points for f in fields]),
                         np.concatenate([f.values for f in fields]), deg.pop())
