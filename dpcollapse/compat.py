"""Every DOLFINx call whose API changed after 0.5, in one place.

Porting dpcollapse to a newer DOLFINx is meant to be a change to this file only:
element and space creation (``ufl.VectorElement`` → ``basix.ufl``), gmsh import
(``gmshio.model_to_mesh`` → ``gmsh.model_to_mesh``), XDMF writing, interpolation points
(method → property), PETSc vector access (``u.vector`` → ``u.x.petsc_vec``), geometry
dofmaps (AdjacencyList → 2D array) and bounding-box trees.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, geometry
from dolfinx import mesh as dmesh
from dolfinx.io import XDMFFile, gmshio
from mpi4py import MPI
from petsc4py import PETSc

ScalarType = PETSc.ScalarType


# --------------------------------------------------------------------------- spaces
def taylor_hood_space(mesh) -> fem.FunctionSpace:
    """Mixed P2 (vector velocity) / P1 (pressure) Taylor–Hood space."""
    cell = mesh.ufl_cell()
    p2 = ufl.VectorElement("Lagrange", cell, 2)
    p1 = ufl.FiniteElement("Lagrange", cell, 1)
    return fem.FunctionSpace(mesh, ufl.MixedElement([p2, p1]))


def vector_space(mesh, degree: int, family: str = "Lagrange") -> fem.FunctionSpace:
    """Vector-valued space with mesh.geometry.dim components."""
    return fem.VectorFunctionSpace(mesh, (family, degree))


def scalar_space(mesh, degree: int, family: str = "Lagrange") -> fem.FunctionSpace:
    """Scalar space (``family`` "Lagrange" or "DG")."""
    return fem.FunctionSpace(mesh, (family, degree))


def tensor_space(mesh, degree: int, family: str = "DG") -> fem.FunctionSpace:
    """Tensor-valued space (2x2 in 2D), discontinuous by default."""
    return fem.TensorFunctionSpace(mesh, (family, degree))


def interpolation_points(V: fem.FunctionSpace) -> np.ndarray:
    """Reference points at which V's element interpolates."""
    return V.element.interpolation_points()


def expression(expr, V: fem.FunctionSpace) -> fem.Expression:
    """A compiled UFL expression evaluated at V's interpolation points."""
    return fem.Expression(expr, interpolation_points(V))


def petsc_vec(u: fem.Function) -> PETSc.Vec:
    """The PETSc vector wrapping a Function's degrees of freedom."""
    return u.vector


# --------------------------------------------------------------------------- mesh
def geometry_dofmap(mesh) -> np.ndarray:
    """(num_cells_local_incl_ghosts, nodes_per_cell) array of geometry node indices."""
    dm = mesh.geometry.dofmap
    num_cells = dm.num_nodes
    return dm.array.reshape(num_cells, -1)


def num_owned_cells(mesh) -> int:
    return mesh.topology.index_map(mesh.topology.dim).size_local


def gmsh_model_to_mesh(model, comm: MPI.Comm, rank: int = 0, gdim: int = 2):
    """(mesh, cell_tags, facet_tags) from a gmsh model that lives on ``rank``."""
    return gmshio.model_to_mesh(model, comm, rank, gdim=gdim)


def create_mesh(comm: MPI.Comm, cells: np.ndarray, x: np.ndarray):
    """A P1 triangle mesh from global cells and coordinates (given on every rank, or on
    rank 0 with empty arrays elsewhere)."""
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.triangle, 1))
    return dmesh.create_mesh(comm, cells, x, domain)


def meshtags(mesh, dim: int, indices: np.ndarray, values: np.ndarray):
    order = np.argsort(indices)
    return dmesh.meshtags(mesh, dim, indices[order].astype(np.int32), values[order].astype(np.int32))


def bounding_box_tree(mesh):
    return geometry.BoundingBoxTree(mesh, mesh.topology.dim)


def colliding_cells(mesh, tree, points: np.ndarray) -> np.ndarray:
    """For each (n, 3) point, one local cell containing it, or -1."""
    candidates = geometry.compute_collisions(tree, points)
    colliding = geometry.compute_colliding_cells(mesh, candidates, points)
    out = np.full(points.shape[0], -1, dtype=np.int32)
    for i in range(points.shape[0]):
        links = colliding.links(i)
        if len(links) > 0:
            out[i] = links[0]
    return out


# --------------------------------------------------------------------------- I/O
def write_xdmf_step(comm: MPI.Comm, filename: str, mesh, functions, t: float) -> None:
    """Write one mesh and the given functions at time t into a new XDMF/HDF5 pair.

    The functions must live on spaces DOLFINx 0.5 writes faithfully (P1 or DG0): a P2
    function would be silently sampled at vertices.
    """
    with XDMFFile(comm, filename, "w") as f:
        f.write_mesh(mesh)
        for fn in functions:
            f.write_function(fn, t)


def entities_to_geometry(mesh, dim: int, entities: np.ndarray) -> np.ndarray:
    """Geometry node indices of each entity, (len(entities), nodes_per_entity)."""
    from dolfinx.cpp.mesh import entities_to_geometry as _e2g

    return _e2g(mesh._mesh, dim, np.asarray(entities, dtype=np.int32), False)


def cell_dofs(V: fem.FunctionSpace) -> np.ndarray:
    """(num_local_cells, dofs_per_cell) array of V's (unblocked) dof indices."""
    dm = V.dofmap.list
    return dm.array.reshape(dm.num_nodes, -1)


def mesh_with_facet_tags(comm: MPI.Comm, cells: np.ndarray, x: np.ndarray,
                         edges: np.ndarray, edge_tags: np.ndarray):
    """A distributed P1 triangle mesh and its facet tags from global arrays on rank 0
    (empty arrays on other ranks); ``edges`` are pairs of node indices into ``x``."""
    from dolfinx.cpp.io import distribute_entity_data
    from dolfinx.cpp.graph import AdjacencyList_int32

    from dpcollapse.geometry.mesher import TaggedMesh

    mesh = create_mesh(comm, np.asarray(cells, dtype=np.int64), np.asarray(x, dtype=np.float64))
    mesh.topology.create_connectivity(1, 2)
    entities, values = distribute_entity_data(mesh._mesh, 1, np.asarray(edges, dtype=np.int64),
                                              np.asarray(edge_tags, dtype=np.int32))
    mesh.topology.create_connectivity(1, 0)
    ft = dmesh.meshtags_from_entities(mesh, 1, AdjacencyList_int32(entities),
                                      values.astype(np.int32))
    return TaggedMesh(mesh, ft)
