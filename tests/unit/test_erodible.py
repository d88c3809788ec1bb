"""The erodible-bed scene (seed 000 case II): two conforming material regions, their tags
through remeshing and checkpoints, the surface tension on its free surface (issue 14)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.ale.remesh import remesh_domain
from dpcollapse.config import load_config
from dpcollapse.domain.region_remesh import remesh_regions
from dpcollapse.geometry.mesher import DOMAIN, LAYER, SURFACE
from dpcollapse.geometry.regions import carry_regions
from dpcollapse.io.checkpoint import load_checkpoint, save_checkpoint
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.scenes.registry import scene
from tests.helpers import ROOT

CONFIG = ROOT / "configs" / "erodible.yaml"
COARSE = ["geometry.mesh_size=0.02"]


def _region_areas(tagged):
    mesh, ct = tagged.mesh, tagged.cell_tags
    n = compat.num_owned_cells(mesh)
    tri = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n, :3]]
    d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    tags = np.zeros(n, dtype=int)
    owned = ct.indices < n
    tags[ct.indices[owned]] = ct.values[owned]
    return {t: mesh.comm.allreduce(float(area[tags == t].sum()), op=MPI.SUM) for t in (DOMAIN, LAYER)}


@pytest.fixture(scope="module")
def erodible():
    cfg = load_config(CONFIG, COARSE)
    return cfg, scene(cfg).mesh(MPI.COMM_SELF)


def test_two_regions_share_their_interface(erodible):
    """Cells tagged mass and layer with the exact areas; the interface y = h_e, x < l0 is
    interior (no boundary facet there) and each of its facets joins a mass and a layer cell."""
    cfg, tagged = erodible
    g = cfg.geometry
    areas = _region_areas(tagged)
    assert areas[LAYER] == pytest.approx(g.layer_area, rel=1e-12)
    assert areas[DOMAIN] + areas[LAYER] == pytest.approx(g.area, rel=1e-12)
    mesh = tagged.mesh
    mesh.topology.create_connectivity(1, 2)
    f2c = mesh.topology.connectivity(1, 2)
    midpoints = mesh.geometry.x[:, :2][compat.entities_to_geometry(
        mesh, 1, np.arange(mesh.topology.index_map(1).size_local, dtype=np.int32))].mean(axis=1)
    on_interface = np.flatnonzero(np.isclose(midpoints[:, 1], g.layer_thickness, atol=1e-12)
                                  & (midpoints[:, 0] < g.base_length))
    assert len(on_interface) >= g.base_length / g.mesh_size
    tags = np.zeros(len(compat.geometry_dofmap(mesh)), dtype=int)
    tags[tagged.cell_tags.indices] = tagged.cell_tags.values
    for f in on_interface:
        assert sorted(tags[f2c.links(f)]) == [DOMAIN, LAYER]
    assert not np.isin(on_interface, tagged.facet_tags.indices).any()


def test_boundaries_of_the_layer(erodible):
    cfg, tagged = erodible
    kinds = {b.tag: b.kind for b in scene(cfg).boundaries()}
    assert kinds[SURFACE] == BoundaryKind.FREE_SURFACE
    assert set(np.unique(tagged.facet_tags.values)) == set(kinds)


def test_regions_survive_a_remesh_and_a_checkpoint(erodible, tmp_path):
    """A remesh keeps the interface (``domain.region_remesh``: the layer area exactly); carried by
    centroids alone (the outer boundary remeshed) the layer, thinner than the cells, loses a
    large part of its area; a checkpoint stores the tags (the same mesh back: the same areas
    exactly); an old checkpoint without them still loads, with none."""
    from dpcollapse.transfer import CellwiseField

    cfg, tagged = erodible
    before = _region_areas(tagged)
    staircase = _region_areas(carry_regions(tagged, remesh_domain(tagged, 0.015, None, 0.0)[0]))
    assert abs(staircase[LAYER] / before[LAYER] - 1) > 0.1
    new, d_area, _ = remesh_regions(tagged, 0.015, None, 0.0)
    after = _region_areas(new)
    assert d_area == 0.0
    assert after == pytest.approx(before, rel=1e-12)
    assert compat.num_owned_cells(new.mesh) != compat.num_owned_cells(tagged.mesh)
    tri = np.zeros((1, 3, 2))
    tri[0] = [[0, 0], [1, 0], [0, 1]]
    dummy = CellwiseField(tri, tri, np.zeros((1, 3, 2)), 1)
    save_checkpoint(tmp_path / "checkpoint.npz", new, dummy, dummy, {"t": 0.0})
    loaded = load_checkpoint(tmp_path / "checkpoint.npz", MPI.COMM_SELF)[0]
    assert _region_areas(loaded) == pytest.approx(after, rel=1e-12)
    old = load_checkpoint(ROOT / "tests/data/checkpoint_d1fd579/checkpoint.npz", MPI.COMM_SELF)[0]
    assert old.cell_tags is None


@pytest.mark.mpi
def test_remesh_of_the_regions_on_all_ranks(comm):
    """The interface chained from the cells of every rank, the polygon split and meshed on
    rank 0, distributed: the regions' areas are the serial ones."""
    cfg = load_config(CONFIG, COARSE)
    tagged = scene(cfg).mesh(comm)
    new, _, nverts = remesh_regions(tagged, 0.015, None, 0.0)
    serial, _, serial_nverts = remesh_regions(scene(cfg).mesh(MPI.COMM_SELF), 0.015, None, 0.0)
    assert nverts == serial_nverts
    assert _region_areas(new) == pytest.approx(_region_areas(serial), rel=1e-12)
    assert _region_areas(new)[LAYER] == pytest.approx(cfg.geometry.layer_area, rel=1e-12)
