"""The interface normal of a thin layer on the bed from its height function (issue 50), for
the interface compression's facet alignment (``model.compression_direction: layer_normal``).

The box's strips S_j = [j Δ, (j + 1) Δ] × ℝ (Δ the fine cell size, the strips of the measures'
h(x)) carry the layer's thickness (the height function)::

    h_j  = (1/Δ) Σ_K c_K |K ∩ S_j|
    h'_j = (h_{j+1} − h_{j−1}) / (2Δ)        (one-sided at the box's ends)
    n_j  = (−h'_j, 1) / √(1 + h'_j²)          the normal of the layer's top y = h(x)
    thin_j = 1 if h_j < k Δ else 0            (k = ``model.thin_layer_cells``, 2 by default)

A cell takes the values of the strip of its centroid. Why: the normal n̂ = ∇c̄/|∇c̄| of c
averaged to the vertices (``normal``) is the layer's only where the layer is at least two
cells thick (the vertex average spans a cell on either side). In a layer of thickness h < Δ,
one row of cells with c = h/Δ, the vertical gradient is about c/(2Δ) = h/(2Δ²) and the
gradient along the layer h'/Δ, so n̂ tilts along the layer by 2Δ h'/h instead of h': at the
tip of a tongue (h → 0) it points along the flow, and the compression (from the emptier cell
to the fuller one) pulls the tongue back into the body at the flow's speed. The height
function gives the layer's own normal, across it: the compression then acts across the
layer and along it only by the layer's slope h'.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.regions import cell_triangles
from dpcollapse.models.two_phase.remap import strip_overlaps

#: a layer thinner than this many cells takes the height function's normal: the vertex
#: average of c spans one cell on either side of a vertex
THIN_LAYER_CELLS = 2.0


def layer_normals(h: np.ndarray, width: float, cells: float = THIN_LAYER_CELLS
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(n_j (count, 2), thin_j (count,)) of the strips' thicknesses h_j [m] (module docstring),
    thin below ``cells`` strip widths."""
    slope = np.gradient(h, width) if len(h) > 1 else np.zeros_like(h)
    norm = np.sqrt(1.0 + slope ** 2)
    normal = np.stack([-slope / norm, 1.0 / norm], axis=1)
    return normal, (h < cells * width).astype(float)


class LayerNormal:
    """The DG0 fields ``normal`` (n_j of the cell's strip) and ``thin`` (thin_j) of the DG0
    fraction ``fraction`` on strips of ``width`` × ``count`` from x = 0; ``update()`` refreshes
    them from the fraction's current values (every rank's owned cells, summed over ranks)."""

    def __init__(self, fraction, width: float, count: int, cells: float = THIN_LAYER_CELLS):
        mesh = fraction.function_space.mesh
        self.fraction, self.width, self.count, self.cells = fraction, width, count, cells
        self.comm = mesh.comm
        n_owned = compat.num_owned_cells(mesh)
        S0 = fraction.function_space
        self._owned = compat.cell_dofs(S0)[:n_owned, 0]
        self._cell, self._strip, self._area = strip_overlaps(cell_triangles(mesh, owned_only=True),
                                                             width, count)
        every = cell_triangles(mesh, owned_only=False)      # owned and ghost cells
        centre = every[:, :, 0].mean(axis=1) if len(every) else np.zeros(0)
        self._strip_of = np.clip(np.floor(centre / width).astype(int), 0, count - 1)
        V = compat.vector_space(mesh, 0, "DG")
        self.normal = fem.Function(V)
        self.thin = fem.Function(S0)
        self._vector_dofs = compat.cell_dofs(V)[:len(every), 0]
        self._scalar_dofs = compat.cell_dofs(S0)[:len(every), 0]

    def thickness(self) -> np.ndarray:
        """h_j [m] of every strip, on every rank."""
        own = self.fraction.x.array[self._owned]
        local = np.bincount(self._strip, weights=own[self._cell] * self._area,
                            minlength=self.count)
        return self.comm.allreduce(local, op=MPI.SUM) / self.width

    def update(self) -> None:
        normal, thin = layer_normals(self.thickness(), self.width, self.cells)
        self.normal.x.array.reshape(-1, 2)[self._vector_dofs] = normal[self._strip_of]
        self.thin.x.array[self._scalar_dofs] = thin[self._strip_of]
