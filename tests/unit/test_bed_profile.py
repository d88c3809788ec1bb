"""The rigid bed as a profile y = b(x) (``Scene.bed_height``, ``ale.motion``): facets of the
moving mesh on it are bed, a bed facet with a node above it (slid past the end of a higher
bed, a step's edge) becomes free surface; the flat bed b = 0 of every other scene is
unchanged."""

import numpy as np
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.ale.motion import flat_bed, retag_bed
from dpcollapse.config import load_config
from dpcollapse.geometry.mesher import BED, SURFACE
from dpcollapse.geometry.rectangle import structured_rectangle
from dpcollapse.scenes.registry import scene
from tests.helpers import ROOT


def _tag_midpoints(tagged, tag):
    ft = tagged.facet_tags
    nodes = compat.entities_to_geometry(tagged.mesh, 1, ft.indices[ft.values == tag])
    return tagged.mesh.geometry.x[nodes][:, :, :2].mean(axis=1)


def test_bed_facets_past_a_step_edge_become_free_surface_and_landed_ones_bed():
    """The rectangle [0, 0.3] × [0, 0.1] (6 × 2 squares) on the bed y = 0 up to x_e = 0.15:
    with b = −0.05 beyond x_e (a step down) its bed facets beyond x_e have left the bed (free
    surface), those before it stay bed; with b = 0.1 beyond x_e (a step up to its top), the top
    facets beyond x_e lie on the bed (bed)."""
    tagged = structured_rectangle(MPI.COMM_SELF, 0.3, 0.1, 6, 2)
    bed_before = _tag_midpoints(tagged, BED)
    assert len(bed_before) == 6

    down = retag_bed(tagged, lambda x: np.where(np.asarray(x) <= 0.15, 0.0, -0.05))
    bed = _tag_midpoints(down, BED)
    assert len(bed) == 3 and np.all(bed[:, 0] < 0.15)
    freed = _tag_midpoints(down, SURFACE)
    freed_bed = freed[np.isclose(freed[:, 1], 0.0)]
    assert len(freed_bed) == 3 and np.all(freed_bed[:, 0] > 0.15)

    up = retag_bed(tagged, lambda x: np.where(np.asarray(x) < 0.15, 0.0, 0.1))
    bed = _tag_midpoints(up, BED)
    on_top = bed[np.isclose(bed[:, 1], 0.1)]
    assert len(on_top) == 3 and np.all(on_top[:, 0] > 0.15)

    flat = retag_bed(tagged, flat_bed)         # b = 0: nothing changes
    assert np.array_equal(flat.facet_tags.values, tagged.facet_tags.values)


def test_a_flat_scene_bed_is_y_0():
    """``SceneSections.bed_height``: b(x) = 0 (the trapezoid of configs/rigid.yaml)."""
    x = np.array([0.0, 0.1, 0.12, 0.1201, 0.5])
    cfg = load_config(ROOT / "configs" / "rigid.yaml")
    assert np.array_equal(scene(cfg).bed_height(x), np.zeros(5))
