"""An erodible layer on the two-phase box (the scene's ``Container.bed_layer``, e.g. seed
000's case II): the layer's own fraction c_L, and how much of the layer the flow sets in motion.

Initial value (exact cell overlaps, ``overlap``): L = the layer's convex polygon (for the
erodible scene (0, 0) → (L, 0) → (L − h_e/tan φ_e, h_e) → (0, h_e), its right end sloped at
φ_e), c_L = χ_K = |K ∩ L| / |K|; c itself comes from the scene's whole ``fraction_region``.
c_L is advected as c is (``flow.TwoPhaseFlow.add_tracer``).

Measures (A_L = ∫ c_L dx at t = 0; the rule of ``benchmarks/erodible.py`` on the moving mesh,
the area of the layer's cells whose mean vertex speed |uⁿ| exceeds 1 mm/s, read on c_L):

    layer_area    = ∫ c_L dx                                        [m²] (conserved)
    layer_moving  = Σ_K |K| c_L,K [mean vertex |uⁿ|_K > 1 mm/s] / A_L      (fraction)
    layer_outside = Σ_K |K| max(c_L,K − χ_K, 0) / A_L                       (fraction)

layer_outside is the layer's material found in excess of the cell's initial layer content:
0 at t = 0, the part of the layer carried out of its initial region (resolved to cells).
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.models.two_phase.fraction import owned_triangles
from dpcollapse.models.two_phase.overlap import polygon_fraction

#: a layer cell counts as set in motion above this mean vertex speed [m/s] (seed 000's
#: flowing threshold, as ``benchmarks/erodible.py``)
MOVING_SPEED = 1e-3
MEASURES = ("layer_area", "layer_moving", "layer_outside")


class LayerTracer:
    """c_L on the box (a tracer of ``flow``), its initial χ and the layer measures;
    ``layer`` the layer's convex CCW polygon (m, 2)."""

    def __init__(self, flow, layer: np.ndarray):
        self.flow, self.comm = flow, flow.comm
        self.fraction = flow.add_tracer("layer_fraction")
        mesh = flow.mesh
        n = compat.num_owned_cells(mesh)
        self._cells = compat.cell_dofs(self.fraction.S0)[:n, 0]
        self._volume = self.fraction.volume[self._cells] if n else np.zeros(0)
        self.layer = layer
        self.chi = polygon_fraction(owned_triangles(mesh), layer)     # χ_K of the owned cells
        self.initial_area = self.comm.allreduce(float(np.dot(self.chi, self._volume)), op=MPI.SUM)
        self._p1 = fem.Function(compat.vector_space(mesh, 1))
        self._vertex_dofs = compat.cell_dofs(self._p1.function_space)[:n]

    def set_initial(self) -> None:
        """c_L = χ (owned cells; ghosts updated)."""
        c = self.fraction.c
        c.x.array[self._cells] = self.chi
        c.x.scatter_forward()

    def measures(self) -> dict:
        cl = self.fraction.c.x.array[self._cells]
        self._p1.interpolate(self.flow.u_old)
        speed = np.linalg.norm(self._p1.x.array.reshape(-1, 2), axis=1)
        moving = speed[self._vertex_dofs].mean(axis=1) > MOVING_SPEED if len(cl) else np.zeros(0, bool)
        local = np.array([np.dot(cl, self._volume), np.dot(cl[moving], self._volume[moving]),
                          np.dot(np.maximum(cl - self.chi, 0.0), self._volume)])
        area, moved, outside = self.comm.allreduce(local, op=MPI.SUM)
        return {"layer_area": float(area), "layer_moving": float(moved / self.initial_area),
                "layer_outside": float(outside / self.initial_area)}
