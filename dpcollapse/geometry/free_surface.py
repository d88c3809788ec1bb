"""The free-surface polyline of a distributed mesh and seed 000's local surface tension on it.

Every rank sends its tagged boundary edges to rank 0 (a facet shared by two ranks arrives
twice; ``polygon.chain_boundary`` merges duplicates), rank 0 chains them into the closed
counter-clockwise boundary polygon, cuts out the runs of the free-surface tags (each from
corner to corner, the mass on its left), computes γ_i = γ0_i C_i there
(``curvature.local_surface_tension_runs``) and broadcasts the nodes and γ; each rank then
sets the vertex values of its P1 function from the nodes it holds. The result does not
depend on the partition (tests/test_curvature.py: serial against 2 ranks).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from dpcollapse.errors import MeshError
from dpcollapse.geometry.curvature import local_surface_tension_runs
from dpcollapse.geometry.mesher import boundary_edges
from dpcollapse.geometry.polygon import chain_boundary, chain_loops, polygon_is_simple

#: Distance [m] under which a dof coordinate is taken to be a surface node (the same
#: floating-point vertex, up to the rounding of ``tabulate_dof_coordinates``).
NODE_TOLERANCE = 1e-10


def free_surface_runs(tagged, surface_tags) -> list[np.ndarray] | None:
    """The runs of ``surface_tags`` along the boundary polygon, as (k, 2) point arrays with
    the mass on their left (counter-clockwise around the domain), on rank 0 (None
    elsewhere); the loops of the holes a surgery kept (``geometry.surgery``) are runs too,
    clockwise. ValueError (on rank 0) when a loop crosses itself."""
    edges, tags = boundary_edges(tagged)
    if edges is None:
        return None
    loops = chain_loops(edges, tags)
    if len(loops) == 1:
        loops = [chain_boundary(edges, tags)]     # one loop: as before, simple or an error
    elif not all(polygon_is_simple(loop.points) for loop in loops):
        raise ValueError("a boundary loop intersects itself")
    wanted = {int(t) for t in surface_tags}
    runs = []
    for k, poly in enumerate(loops):
        for tag, idx in poly.segments():
            if tag in wanted:
                runs.append(poly.points[idx] if k == 0 else poly.points[idx][::-1])
    return runs


def surface_tension_nodes(tagged, surface_tags, gamma_bar: float,
                          extent: float) -> tuple[np.ndarray, np.ndarray]:
    """(points (m, 2), γ (m,)) at the free-surface nodes, on every rank [m, Pa]. MeshError
    on every rank when the free surface has folded through itself or the bed."""
    comm = tagged.mesh.comm
    data = problem = None
    try:
        runs = free_surface_runs(tagged, surface_tags)
    except ValueError as exc:
        problem = str(exc)
    if comm.rank == 0 and problem is None:
        gammas = local_surface_tension_runs(runs, gamma_bar, extent)
        data = (np.concatenate(runs) if runs else np.zeros((0, 2)),
                np.concatenate(gammas) if gammas else np.zeros(0))
    data, problem = comm.bcast((data, problem), root=0)
    if problem is not None:
        raise MeshError(f"mesh degenerate: no free-surface polyline, {problem}")
    return data


def set_nodal_values(function, points: np.ndarray, values: np.ndarray) -> None:
    """Set a P1 scalar ``function`` to ``values`` at the vertices ``points`` it holds and to
    zero elsewhere (owned and ghost dofs alike: every rank has every point)."""
    function.x.array[:] = 0.0
    if not len(points):
        return
    x = function.function_space.tabulate_dof_coordinates()[:, :2]
    distance, index = cKDTree(points).query(x, distance_upper_bound=NODE_TOLERANCE)
    hit = np.isfinite(distance)
    # a node ending one run and starting the next (a corner) has C = 0 in both
    function.x.array[hit] = values[index[hit]]
