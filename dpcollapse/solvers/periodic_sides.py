"""The geometry both periodic constraints start from (``solvers.periodic`` with dolfinx_mpc,
``solvers.periodic_petsc`` without): the translation that maps the slave side onto the
master side, the slave facets (checked to map into the mesh) and the scalar leaf subspaces
to constrain."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat


def leaf_subspaces(V: fem.FunctionSpace) -> list[fem.FunctionSpace]:
    """The scalar (sub)spaces of V, depth first: [V] for a scalar space, [V.sub(0), V.sub(1)]
    for a 2D vector space, [W.sub(0).sub(0), W.sub(0).sub(1), W.sub(1)] for Taylor–Hood.

    Constraining scalar leaves one by one is what dolfinx_mpc 0.5 supports (its periodic
    constraint rejects value-size > 1 spaces) and lets a bc on a single velocity component
    (e.g. u_y = 0 on the bed) exempt only that component from the constraint.
    """
    if V.num_sub_spaces == 0:
        return [V]
    leaves: list[fem.FunctionSpace] = []
    for i in range(V.num_sub_spaces):
        leaves.extend(leaf_subspaces(V.sub(i)))
    return leaves


def check_images(mesh, facets, translation: np.ndarray, gdim: int) -> None:
    """The images of the slave facets' vertices under ``translation`` (3 components) must
    lie in the mesh's bounding box (a translation of the wrong sign would otherwise leave
    slaves silently unconstrained)."""
    comm = mesh.comm
    x = mesh.geometry.x[:, :gdim]
    lo = np.full(gdim, np.inf)
    hi = np.full(gdim, -np.inf)
    if len(x):
        lo[:], hi[:] = x.min(axis=0), x.max(axis=0)
    comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    tol = 1e-8 * max(float(np.max(hi - lo)), 1.0)
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, 0)
    f2v = mesh.topology.connectivity(fdim, 0)
    verts = np.unique(np.concatenate([f2v.links(f) for f in facets])) if len(facets) else \
        np.zeros(0, dtype=np.int32)
    nodes = compat.entities_to_geometry(mesh, 0, verts).ravel() if len(verts) else \
        np.zeros(0, dtype=np.int32)
    images = mesh.geometry.x[nodes, :gdim] + translation[:gdim]
    bad = int(np.sum(np.any((images < lo - tol) | (images > hi + tol), axis=1)))
    bad = comm.allreduce(bad, op=MPI.SUM)
    if bad:
        raise ValueError(
            f"{bad} slave vertices are mapped outside the mesh by translation "
            f"{tuple(translation[:gdim])}: it must map the slave side onto the master "
            "side (e.g. (-L, 0) for slave x = L, master x = 0)")


def periodic_sides(V, facet_tags, slave_tag: int, translation: Sequence[float], subspaces=None):
    """What both periodic constraints start from: the translation as a 3-vector (nonzero),
    the slave side's facets (checked to map onto the mesh under it), and the scalar leaf
    subspaces to constrain (default every leaf of V)."""
    mesh = V.mesh
    shift = np.zeros(3)
    shift[:len(translation)] = np.asarray(translation, dtype=np.float64)
    if not np.any(shift):
        raise ValueError("translation must be nonzero")
    slave_facets = facet_tags.indices[facet_tags.values == slave_tag].astype(np.int32)
    check_images(mesh, slave_facets, shift, mesh.geometry.dim)
    leaves = leaf_subspaces(V) if subspaces is None else \
        [leaf for S in subspaces for leaf in leaf_subspaces(S)]
    return shift, slave_facets, leaves
