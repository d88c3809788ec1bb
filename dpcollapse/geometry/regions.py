"""Material regions (cell tags) carried onto a new mesh of the same domain.

A scene with several regions of the same material (the erodible layer under the mass)
tags its cells; the tags are labels, not physics (one rheology everywhere). On a moving
mesh they move with the cells, i.e. with the mesh velocity w (w·n = u·n on the boundary, a
harmonic extension inside: the region boundary follows the material only as far as w ≈ u).
A remesh or a checkpoint gives a new triangulation: each new cell takes the tag of the old
cell that contains its centroid (the new interface is the staircase of old-cell boundaries
crossed; on the same triangulation, as after a checkpoint, every cell gets its own tag).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.mesher import DOMAIN, TaggedMesh
from dpcollapse.transfer import CellwiseField, concatenate


def cell_triangles(mesh, owned_only: bool = True) -> np.ndarray:
    """(n, 3, 2) vertex coordinates of the owned cells (``owned_only``) or of every local
    cell, ghosts included, in local cell order."""
    n = compat.num_owned_cells(mesh) if owned_only else len(compat.geometry_dofmap(mesh))
    return mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n, :3]]


def region_field(triangles: np.ndarray, tags: np.ndarray) -> CellwiseField:
    """The piecewise-constant field of the cell tags on triangles (n, 3, 2)."""
    values = np.repeat(np.asarray(tags, dtype=float)[:, None], 3, axis=1)
    return CellwiseField(vertices=triangles, points=triangles, values=values, degree=1)


def gather_regions(tagged: TaggedMesh) -> CellwiseField | None:
    """The cell tags of the distributed mesh as a field on every rank (None without tags)."""
    mesh, ct = tagged.mesh, tagged.cell_tags
    if mesh.comm.allreduce(ct is None, op=MPI.LOR):
        return None
    n = compat.num_owned_cells(mesh)
    tags = np.full(n, DOMAIN, dtype=np.int64)
    owned = ct.indices < n
    tags[ct.indices[owned]] = ct.values[owned]
    part = region_field(cell_triangles(mesh, True), tags)
    return concatenate(mesh.comm.allgather(part))


def tag_cells(mesh, field: CellwiseField):
    """Cell tags of every local cell of ``mesh`` (owned and ghost): the tag of the cell of
    ``field`` that contains the cell's centroid."""
    centroids = cell_triangles(mesh, False).mean(axis=1)
    cells, _ = field.locate(centroids)
    tags = np.rint(field.values[cells, 0, 0]).astype(np.int32)
    return compat.meshtags(mesh, mesh.topology.dim, np.arange(len(centroids), dtype=np.int32), tags)


def carry_regions(old: TaggedMesh, new: TaggedMesh, field: CellwiseField | None = None) -> TaggedMesh:
    """``new`` with the cell tags of ``old`` (or of ``field``, its ``gather_regions``)
    located at its cells (unchanged when ``old`` has none)."""
    field = field or gather_regions(old)
    if field is None:
        return new
    return TaggedMesh(new.mesh, new.facet_tags, tag_cells(new.mesh, field))



# ----------------------------------------------------------------------------- interface
def interface_chain(triangles: np.ndarray, tags: np.ndarray) -> np.ndarray | None:
    """The interface between two regions as one open polyline (k, 2), oriented with the
    region of the smaller tag on its left; None unless the edges shared by cells of
    different tags form exactly one open chain (two regions meeting along one curve).

    ``triangles`` (n, 3, 2) of every cell (any orientation), ``tags`` (n,)."""
    tri = np.asarray(triangles, dtype=float).reshape(-1, 3, 2) + 0.0
    tags = np.asarray(tags)
    if len(np.unique(tags)) != 2:
        return None
    verts, inv = np.unique(tri.reshape(-1, 2), axis=0, return_inverse=True)
    inv = inv.reshape(-1, 3)
    edges = {}
    for c, (i, j, k) in enumerate(inv):
        for p, q, o in ((i, j, k), (j, k, i), (k, i, j)):   # edge (p, q) opposite vertex o
            edges.setdefault((min(p, q), max(p, q)), []).append((c, o))
    low = tags.min()
    directed = {}
    for (p, q), cells in edges.items():
        if len(cells) != 2 or tags[cells[0][0]] == tags[cells[1][0]]:
            continue
        c, o = cells[0] if tags[cells[0][0]] == low else cells[1]
        ax, ay = verts[p]
        bx, by = verts[q]
        cx, cy = verts[o]
        left = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) > 0
        start, end = (p, q) if left else (q, p)
        if start in directed:
            return None               # a branch
        directed[start] = end
    if not directed:
        return None
    starts = set(directed) - set(directed.values())
    if len(starts) != 1:
        return None                   # closed loop or several pieces
    node = starts.pop()
    chain = [node]
    while node in directed:
        node = directed[node]
        chain.append(node)
    if len(chain) != len(directed) + 1:
        return None
    return verts[chain]


def split_polygon(points: np.ndarray, edge_tags: np.ndarray, chain: np.ndarray,
                  left_tag: int, right_tag: int, interface_tag: int):
    """Cut the closed CCW polygon along ``chain`` (an open polyline from one of its vertices
    to another, through its inside): [(points, edge tags, region tag)] of the region left of
    the chain (``left_tag``) and right of it; None if an end of the chain is not a vertex of
    the polygon or a part comes out with a non-positive area."""
    pts, tags = np.asarray(points), np.asarray(edge_tags)
    n, m = len(pts), len(chain) - 1
    ends = []
    for end in (chain[0], chain[-1]):
        hit = np.flatnonzero(np.all(pts == end, axis=1))
        if len(hit) != 1:
            return None
        ends.append(int(hit[0]))
    a, b = ends

    def cyclic(i, j):                 # i, i+1, …, j−1 (mod n)
        return [(i + k) % n for k in range((j - i) % n)]

    left_pts = np.concatenate([chain, pts[cyclic(b, a)[1:]].reshape(-1, 2)])
    left_tags = np.concatenate([np.full(m, interface_tag), tags[cyclic(b, a)]])
    right_pts = np.concatenate([pts[cyclic(a, b)], pts[[b]], chain[::-1][1:-1]])
    right_tags = np.concatenate([tags[cyclic(a, b)], np.full(m, interface_tag)])
    parts = [(left_pts, left_tags.astype(np.int32), left_tag),
             (right_pts, right_tags.astype(np.int32), right_tag)]
    for p, t, _ in parts:
        if len(p) != len(t) or len(p) < 3 or _signed_area(p) <= 0:
            return None
    return parts


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
