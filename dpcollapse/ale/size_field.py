"""An a-posteriori error indicator of the velocity and the mesh size field it asks for
(``numerics.mesh_tolerance``; docs/model.md, "The mesh size from an error indicator").

Zienkiewicz–Zhu recovery on the P2 velocity u_h: its gradient ∇u_h is linear and
discontinuous from cell to cell; the recovered gradient G* is the continuous piecewise-linear
field whose value at each vertex is the area-weighted mean of the adjacent cells' ∇u_h there.
The indicator of a cell K is

    η_K = ‖G* − ∇u_h‖_{L²(K)} = ( |K|/12 Σ_c [ Σ_i d_{c,i}² + (Σ_i d_{c,i})² ] )^{1/2}   [m/s]

(d_{c,i}: component c of G* − ∇u_h at the cell's vertex i; exact for the linear difference),
an estimate of ‖∇(u − u_h)‖_{L²(K)}, ≈ the velocity error on the cell. For a smooth u it
falls like h_K^{k+1} = h_K³ (P2: k = 2; the gradient error h², the cell's measure h); so the
size that brings η_K to the tolerance τ is

    h_K,new = clip( h_K (τ / η_K)^{1/3}, h_min, h_max ),

h_K the edge of the equilateral triangle of K's area. With the order 3, one step lands on the
size where u is smooth, and at a jump of the gradient (η_K ∝ h_K there) the sizes shrink
monotonically from remesh to remesh (h ← h^{2/3} τ^{1/3} …); a lower order would overshoot
and oscillate in the smooth part. The size at a vertex is the smallest of its cells'
(``SizeField``), linear in each old cell: the background mesh of the next remesh
(``geometry.mesher``).

Pure NumPy on the gathered ``transfer.CellwiseField`` of the velocity (every rank computes
the same field).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpcollapse.transfer import CellwiseField

#: The indicator's order in the cell size where the velocity is smooth (P2: ‖∇e‖_{L²(K)} ∝ h³).
INDICATOR_ORDER = 3.0
#: Relative rounding of vertex coordinates when cells are matched at shared vertices.
_VERTEX_DIGITS = 12


@dataclass
class Indicator:
    """The recovery indicator per cell: ``eta`` [m/s], ``size`` h_K [m] (equilateral edge of
    the cell's area), ``triangles`` (nc, 3, 2) the cells' vertices, ``vertex`` (nc, 3) the index
    of each cell vertex among the distinct vertices."""

    eta: np.ndarray
    size: np.ndarray
    triangles: np.ndarray
    vertex: np.ndarray

    @property
    def global_eta(self) -> float:
        """(Σ_K η_K²)^{1/2}: the estimate of ‖∇(u − u_h)‖_{L²(Ω)} [m/s]."""
        return float(np.sqrt(np.sum(self.eta ** 2)))


@dataclass
class SizeField:
    """Target mesh size [m] at the vertices of each cell of a triangulation: ``triangles``
    (nc, 3, 2), ``sizes`` (nc, 3); linear in each cell."""

    triangles: np.ndarray
    sizes: np.ndarray

    def at(self, points: np.ndarray) -> np.ndarray:
        """The size at ``points`` (n, 2) [m] (outside the triangulation: the nearest cell's
        linear extension, clipped to the field's range)."""
        field = CellwiseField(self.triangles, self.triangles, self.sizes[..., None], 1)
        values = field.evaluate(np.asarray(points, dtype=float).reshape(-1, 2))[:, 0]
        return np.clip(values, self.sizes.min(), self.sizes.max())


def _distinct_cells(u: CellwiseField) -> np.ndarray:
    """Indices of the cells of ``u`` counted once (the gathered parts repeat ghost cells)."""
    c = u.vertices.mean(axis=1)
    scale = max(float(np.abs(u.vertices).max()), 1e-300)
    key = np.round(c / scale, _VERTEX_DIGITS)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)


def cell_gradients(u: CellwiseField) -> np.ndarray:
    """∇u_h at each cell's three vertices: (nc, 3, bs, 2) [1/s] (the cell's own polynomial)."""
    coef = u.coefficients()                              # (nc, k, bs), monomials of ξ
    centroid = u.vertices.mean(axis=1)
    scale = np.linalg.norm(u.vertices - np.roll(u.vertices, -1, axis=1), axis=2).max(axis=1)
    xi = (u.vertices - centroid[:, None]) / scale[:, None, None]   # (nc, 3, 2)
    ones = np.ones(xi.shape[:2])
    if u.degree == 1:
        dx = np.stack([0 * ones, ones, 0 * ones], -1)
        dy = np.stack([0 * ones, 0 * ones, ones], -1)
    else:                                                 # (1, ξ, η, ξ², ξη, η²)
        x, y = xi[..., 0], xi[..., 1]
        zero = 0 * ones
        dx = np.stack([zero, ones, zero, 2 * x, y, zero], -1)
        dy = np.stack([zero, zero, ones, zero, x, 2 * y], -1)
    gx = np.einsum("nvk,nkb->nvb", dx, coef) / scale[:, None, None]
    gy = np.einsum("nvk,nkb->nvb", dy, coef) / scale[:, None, None]
    return np.stack([gx, gy], axis=-1)


def recovery_indicator(u: CellwiseField) -> Indicator:
    """The Zienkiewicz–Zhu indicator η_K of the velocity ``u`` (module docstring)."""
    keep = _distinct_cells(u)
    u = CellwiseField(u.vertices[keep], u.points[keep], u.values[keep], u.degree)
    tri = u.vertices
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    scale = max(float(np.abs(tri).max()), 1e-300)
    _, vertex = np.unique(np.round(tri.reshape(-1, 2) / scale, _VERTEX_DIGITS), axis=0,
                          return_inverse=True)
    vertex = vertex.reshape(-1, 3)
    grad = cell_gradients(u)                              # (nc, 3, bs, 2)
    nv = int(vertex.max()) + 1
    flat = grad.reshape(len(tri), 3, -1)                  # (nc, 3, 2 bs)
    weight = np.zeros(nv)
    total = np.zeros((nv, flat.shape[2]))
    np.add.at(weight, vertex.ravel(), np.repeat(area, 3))
    np.add.at(total, vertex.ravel(), (flat * area[:, None, None]).reshape(-1, flat.shape[2]))
    recovered = total / weight[:, None]                   # G* at the vertices
    d = recovered[vertex] - flat                          # (nc, 3, 2 bs)
    eta2 = area / 12.0 * np.sum(np.sum(d ** 2, axis=1) + np.sum(d, axis=1) ** 2, axis=1)
    size = np.sqrt(4.0 * area / np.sqrt(3.0))
    return Indicator(np.sqrt(eta2), size, tri, vertex)


def adapted_sizes(ind: Indicator, tolerance: float, size_min: float, size_max: float,
                  order: float = INDICATOR_ORDER) -> np.ndarray:
    """h_K (τ/η_K)^{1/order} per cell, clipped to [size_min, size_max] [m]."""
    with np.errstate(divide="ignore"):
        ratio = np.where(ind.eta > 0, tolerance / np.maximum(ind.eta, 1e-300), np.inf)
    return np.clip(ind.size * ratio ** (1.0 / order), size_min, size_max)


def size_field(u: CellwiseField, tolerance: float, size_min: float,
               size_max: float) -> tuple[SizeField, Indicator]:
    """The size field asked for by the velocity ``u`` at ``tolerance`` [m/s] (each vertex: the
    smallest adapted size of its cells), with the indicator it came from."""
    ind = recovery_indicator(u)
    h_cell = adapted_sizes(ind, tolerance, size_min, size_max)
    nv = int(ind.vertex.max()) + 1
    h_vertex = np.full(nv, np.inf)
    np.minimum.at(h_vertex, ind.vertex.ravel(), np.repeat(h_cell, 3))
    return SizeField(ind.triangles, h_vertex[ind.vertex]), ind


#: A mesh is re-adapted when some cell's η_K exceeds this many tolerances while it is still
#: coarser than this many minimum sizes (a cell at the minimum cannot be refined further).
REFINE_TRIGGER = 2.0
REFINE_SIZE_MARGIN = 1.25


def under_resolved(ind: Indicator, tolerance: float, size_min: float) -> int:
    """The number of cells with η_K > REFINE_TRIGGER τ that could still be refined."""
    return int(np.count_nonzero((ind.eta > REFINE_TRIGGER * tolerance)
                                & (ind.size > REFINE_SIZE_MARGIN * size_min)))
