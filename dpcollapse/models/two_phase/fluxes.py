"""The sub-step residual of the volume fraction's fluxes (``fraction.VolumeFraction``) from
matrices assembled once per step.

Within a step the velocity is fixed and only c changes from sub-step to sub-step. The upwind
flux ``forms.two_phase.fraction_flux`` is linear in c: with c the DG0 trial function it is a
matrix A (each interior facet couples its two cells; the outflow sides the diagonal), and
its residual is A c. The interface compression ``compression_flux`` is not linear in c, but
on a facet f between cells i and j it is C w_f ψ(c_i, c_j) with w_f = ∫_f |u·n| ds, fixed
within the step, and::

    ψ_i = c_i (1 − c_j)     if c_j > c_i (or c_j = c_i and i is the facet's '−' side)
    ψ_i = −c_j (1 − c_i)    otherwise

(the flux from the emptier cell to the fuller one; at equal values the form's choice by the
facet's orientation, kept so both evaluations agree). The weights and the orientation are
the entries of ``compression_weights``. Each sub-step is then a sparse product and a sum
over the cell pairs — the same quadrature as the forms, equal to their assembly to
round-off — instead of a facet assembly (which repacked the velocity every sub-step).

Under MPI the matrices' owned rows hold every facet of the owned cells (PETSc adds the
off-process contributions at assembly), their columns are mapped to local dofs (owned, then
ghosts), and the ghost values of c are the ones the caller scatters after each sub-step.
"""

from __future__ import annotations

import numpy as np
from dolfinx.fem import petsc as fem_petsc
from scipy import sparse

from dpcollapse import compat


def _local_columns(index_map, columns: np.ndarray) -> np.ndarray:
    """Local dof numbers (owned first, then ghosts) of the global ``columns``."""
    first = index_map.local_range[0]
    n = index_map.size_local
    local = columns - first
    outside = (local < 0) | (local >= n)
    if np.any(outside):
        ghosts = np.asarray(index_map.ghosts, dtype=np.int64)
        order = np.argsort(ghosts)
        at = np.searchsorted(ghosts[order], columns[outside])
        at = np.minimum(at, len(ghosts) - 1)
        if len(ghosts) == 0 or np.any(ghosts[order][at] != columns[outside]):
            raise RuntimeError("a facet neighbour of an owned cell is not a ghost")
        local[outside] = n + order[at]
    return local


def local_csr(mat, form, index_map) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``form`` assembled into ``mat`` (zeroed first) as CSR arrays of the owned rows, the
    columns mapped to local dofs (owned, then ghosts): (indptr, columns, values)."""
    mat.zeroEntries()
    fem_petsc.assemble_matrix(mat, form)
    mat.assemble()
    indptr, columns, values = mat.getValuesCSR()
    return np.asarray(indptr), _local_columns(index_map, np.asarray(columns, np.int64)), \
        np.asarray(values)


class StepFluxes:
    """A and the compression weights for one step's velocity (``assemble``), and the
    sub-step residual ``residual(c)`` = ∫_∂K (F_upwind + F_compression) ds per owned cell."""

    def __init__(self, upwind_form, weights_form, index_map, compression: float):
        self._forms = (upwind_form, weights_form)
        self._mats = [compat.create_matrix(upwind_form), compat.create_matrix(weights_form)]
        self.index_map, self.compression = index_map, compression
        self._n = index_map.size_local
        self._n_local = self._n + index_map.num_ghosts
        self.upwind = None
        self._pairs = None

    def _csr(self, k: int):
        return local_csr(self._mats[k], self._forms[k], self.index_map)

    def assemble(self) -> None:
        """The matrices for the current velocity (once per step)."""
        indptr, columns, values = self._csr(0)
        self.upwind = sparse.csr_matrix((values, columns, indptr), shape=(self._n, self._n_local))
        if self.compression > 0:
            indptr, columns, values = self._csr(1)
            rows = np.repeat(np.arange(self._n), np.diff(indptr))
            off = (rows != columns) & (values != 0.0)
            self._pairs = (rows[off], columns[off], np.abs(values[off]), values[off] < 0.0)

    def residual(self, c: np.ndarray) -> np.ndarray:
        """∫_∂K (F_upwind + F_compression) ds of the owned cells for the local values c
        (owned and ghosts)."""
        out = self.upwind @ c
        if self.compression > 0:
            rows, columns, weight, minus = self._pairs
            ci, cj = c[rows], c[columns]
            out_of_i = (cj > ci) | ((cj == ci) & minus)
            psi = np.where(out_of_i, ci * (1.0 - cj), -cj * (1.0 - ci))
            out += self.compression * np.bincount(rows, weights=weight * psi, minlength=self._n)
        return out

    def destroy(self) -> None:
        for mat in self._mats:
            mat.destroy()
