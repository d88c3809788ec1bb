"""The film trim's cut beside a bed vertex (issue 49, the a = 3 Coulomb column at L0/20):
the vertical cut x = x_δ fell 5.6 µm (1e-3 ΔX) right of a bed vertex whose removal the
resampling refused (the merged bed edge, 7.6 mm, longer than the 5 mm target), so the new
bed corner kept a 5.6 µm edge beside 3–5 mm ones; gmsh meshed it with slivers of 0.6° and the
run ended with exit 4. A vertex with an edge shorter than ``polygon.SHORT_EDGE`` × the target
is now dropped whatever the merged edge's length (a merged edge longer than 1.5 targets is
split on itself, as every long edge)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.ale.motion import quality
from dpcollapse.domain.moving import MovingDomain
from dpcollapse.geometry.mesher import BED, SURFACE, WALL, boundary_edges, mesh_polygon

H = 0.1                      # cells [m]
DELTA = 0.02                 # the trim thickness δ [m]: the wedge is δ thick at x = 1.12
X_CUT = 1.2 - 0.4 * DELTA / 0.1
GAP = 1e-3 * H               # the bed vertex this far left of the cut (the run: 5.6 µm at 5 mm)


def _wedge_toe():
    """A mass on the bed y = 0 (wall x = 0) whose top falls linearly from (0.8, 0.1) to a
    wedge toe at (1.2, 0): thickness δ at x = X_CUT, where a bed vertex stands GAP to the
    left, 1.52 H after the one before it (the two cannot merge within one target edge; every
    edge at most twice its neighbours, so the mesh keeps them as they are)."""
    bed_x = list(np.linspace(0.0, X_CUT - GAP - 1.52 * H, 6)) + [X_CUT - GAP]
    bed = [(x, 0.0) for x in bed_x]
    top = [(1.2, 0.0)] + [(1.2 - 0.4 * s, 0.1 * s) for s in np.linspace(0.125, 1.0, 8)] + [
        (0.6, 0.1), (0.4, 0.1), (0.2, 0.1), (0.0, 0.1)]
    points = np.array(bed + top + [(0.0, 0.05)], dtype=float)
    tags = np.array([BED] * len(bed) + [SURFACE] * (len(top) - 1) + [WALL] * 2)
    return points, tags


def _shortest_boundary_edge(tagged) -> float:
    edges, _ = boundary_edges(tagged)
    short = float(np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1).min()) if edges is not None else 0.0
    return tagged.mesh.comm.bcast(short, root=0)


@pytest.mark.mpi
def test_the_cut_beside_a_bed_vertex_leaves_no_sliver():
    comm = MPI.COMM_WORLD
    points, tags = _wedge_toe()
    tagged = mesh_polygon(comm, points, tags, 2 * H)   # coarse: the 1.52 H bed edge stays one
    area0 = 1.0    # only scales the vertex dropping's area budget (1e-4 of it)
    domain = MovingDomain(12.0, H, trim_thickness=DELTA, conserve_area=True, surgery=False)
    new, _ = domain.remesh(tagged, area0)          # exit 4 (MeshError) without the rule
    edges, _ = boundary_edges(new)
    on_bed = None if edges is None else edges[edges[..., 1] == 0.0]
    toe = comm.bcast(float(on_bed[:, 0].max()) if edges is not None else 0.0, root=0)
    assert toe == pytest.approx(X_CUT, abs=1e-9)    # the film was cut at x_δ (the bed corner)
    assert _shortest_boundary_edge(new) > 0.1 * H
    assert quality(new.mesh)["min_angle"] > 15.0
