"""The boundary surgery on a mesh of two regions (``geometry.region_surgery``, issue 49): a
nose of the mass that hangs over, or dips into, the erodible layer ahead of the toe is merged
at a remesh; the pocket it encloses with the layer is kept (large) or closed (below one
cell); each region's area is put back; the interface stays conforming."""

import numpy as np
import pytest

from dpcollapse.geometry.mesher import BED, DOMAIN, INTERFACE, LAYER, SURFACE, WALL

pytest.importorskip("shapely")

H = 0.005        # cell size [m]
HE = 0.005       # layer thickness [m]


def _densify(corners, tags, h):
    pts, out = [], []
    c = np.asarray(corners, float)
    for i in range(len(c)):
        a, b = c[i], c[(i + 1) % len(c)]
        k = max(1, int(np.ceil(np.hypot(*(b - a)) / h - 1e-9)))
        pts += [a + (b - a) * s / k for s in range(k)]
        out += [tags[i]] * k
    return np.array(pts), np.array(out, dtype=np.int32)


def _nose_over_layer(tip_gap, pocket_top=0.08, flank=0.05, tip=0.13):
    """A 5 mm layer [0, 0.25] m (its end sloped) under a mass [0, flank] × [HE, 0.1] m with an
    arm at pocket_top…0.1 m reaching to x = tip + 1 cm, whose tip hangs ``tip_gap`` above
    the layer's top (negative: dips into the layer): the pocket [flank, tip] × [HE,
    pocket_top] is enclosed by the mass and the layer."""
    layer = _densify([(0, 0), (0.25, 0), (0.24, HE), (flank, HE), (0, HE)],
                     [BED, SURFACE, SURFACE, INTERFACE, WALL], H)
    mass = _densify([(0, HE), (flank, HE), (flank, pocket_top), (tip, pocket_top),
                     (tip, HE + tip_gap), (tip + 0.01, HE + tip_gap), (tip + 0.01, 0.10),
                     (0, 0.10)],
                    [INTERFACE] + [SURFACE] * 6 + [WALL], H)
    return [(*layer, LAYER), (*mass, DOMAIN)]


def _region_areas(tagged, comm):
    """{cell tag: area} of a tagged mesh (every rank)."""
    from dpcollapse.geometry.regions import gather_regions

    field = gather_regions(tagged)
    tri = field.vertices
    tags = np.rint(field.values[:, 0, 0]).astype(int)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    return {int(t): float(area[tags == t].sum()) for t in np.unique(tags)}


def _remesh(tagged, done):
    from dpcollapse.domain.region_remesh import remesh_regions

    return remesh_regions(tagged, H, None, 1e-6, conserve_area=True, surgery=True,
                          surgeries=done)[0]


@pytest.mark.mpi
def test_nose_over_the_layer_keeps_a_large_pocket(comm):
    """The tip 0.05 h above the layer: one surgery; the 8 cm × 7.5 cm pocket between the
    mass and the layer stays (a second boundary loop, free surface); the surgery's own
    change is the bridged gap (≥ 0, < 1e-3 of the mass) and lands in the mass only; after
    the remesh each region has its area of before (1e-12); a second remesh does nothing."""
    from dpcollapse.geometry.mesher import boundary_edges, mesh_regions
    from dpcollapse.geometry.polygon import chain_loops

    tagged = mesh_regions(comm, _nose_over_layer(0.05 * H), H)
    before = _region_areas(tagged, comm)
    done = []
    new = _remesh(tagged, done)
    assert len(done) == 1 and done[0].near_contacts > 0 and len(done[0].holes) == 1
    regions = done[0].regions
    mass, layer = regions["granular_mass"], regions["erodible_layer"]
    assert 0 < mass["surgery_change"] < 1e-3 * before[DOMAIN]
    assert abs(layer["surgery_change"]) < 1e-12
    after = _region_areas(new, comm)
    for tag in (DOMAIN, LAYER):
        assert after[tag] == pytest.approx(before[tag], rel=1e-12, abs=1e-15)
    edges, tags = boundary_edges(new)
    if comm.rank == 0:
        loops = chain_loops(edges, tags)
        assert len(loops) == 2 and np.all(loops[1].edge_tags == SURFACE)
        assert abs(loops[1].area) > 0.5 * 0.075 * 0.075
    again = _remesh(new, done)
    assert len(done) == 1
    for tag in (DOMAIN, LAYER):
        assert _region_areas(again, comm)[tag] == pytest.approx(before[tag], rel=1e-12)


def test_nose_over_the_layer_closes_a_small_pocket(comm):
    """A pocket 1 cm wide and 0.8 mm high (8e-6 m², below one cell √3/4 h² = 1.1e-5 m²)
    under the nose: closed (no hole left); its area goes to the mass before the put-back;
    each region keeps its area."""
    from dpcollapse.geometry.mesher import boundary_edges, mesh_regions
    from dpcollapse.geometry.polygon import chain_loops

    tagged = mesh_regions(comm, _nose_over_layer(0.05 * H, pocket_top=HE + 0.0008,
                                                  tip=0.06), H)
    before = _region_areas(tagged, comm)
    done = []
    new = _remesh(tagged, done)
    assert len(done) == 1 and not done[0].holes and done[0].closed_pockets
    assert done[0].regions["granular_mass"]["surgery_change"] >= max(done[0].closed_pockets)
    edges, tags = boundary_edges(new)
    if comm.rank == 0:
        assert len(chain_loops(edges, tags)) == 1
    after = _region_areas(new, comm)
    for tag in (DOMAIN, LAYER):
        assert after[tag] == pytest.approx(before[tag], rel=1e-12, abs=1e-15)


def test_a_kept_pocket_below_a_cell_is_closed_later(comm):
    """The pocket kept by a first surgery, remeshed with cells so large that it is below
    one cell (h = 0.2 m: (√3/4) h² = 0.017 m² > 0.006 m²) and no contact: closed (a
    surgery event, no hole left), the mass gains the pocket before the put-back."""
    from dpcollapse.geometry.mesher import boundary_edges, mesh_regions
    from dpcollapse.geometry.region_surgery import rebuild_regions
    from dpcollapse.geometry.regions import gather_regions

    new = _remesh(mesh_regions(comm, _nose_over_layer(0.05 * H), H), [])
    field = gather_regions(new)
    edges, tags = boundary_edges(new)
    if comm.rank != 0:
        return
    cell_tags = np.rint(field.values[:, 0, 0]).astype(np.int32)
    regions, _, _, done = rebuild_regions(field.vertices, cell_tags, edges, tags, 0.2,
                                          lambda tag: H, 1e-12, True, True)
    assert done is not None and len(done.closed_pockets) == 1 and not done.holes
    pocket = done.closed_pockets[0]
    assert 0.95 * 0.08 * 0.075 < pocket < 1.01 * 0.08 * 0.075     # [0.05, 0.13] × [HE, 0.08]
    assert done.regions["granular_mass"]["surgery_change"] == pytest.approx(pocket, rel=1e-6)
    assert all(not r[3] for r in regions)


def test_nose_through_the_layer_is_counted_once(comm):
    """The tip pushed 0.3 h into the layer (the two regions' cells overlap: a crossing of
    the boundary): the overlap, 1 cm × 1.5 mm, is taken from the mass (the layer keeps its
    cells), then each region's area is put back."""
    from dpcollapse.geometry.mesher import mesh_regions
    from dpcollapse.geometry.region_surgery import rebuild_regions
    from dpcollapse.geometry.regions import gather_regions

    # mesh the two regions apart, then push the tip's nodes down into the layer
    tagged = mesh_regions(comm, _nose_over_layer(0.2 * H), H)
    x = tagged.mesh.geometry.x
    tip = (x[:, 0] >= 0.13 - 1e-12) & (x[:, 1] <= HE + 0.2 * H + 1e-12) & (x[:, 1] > HE + 1e-9)
    x[tip, 1] -= 0.5 * H
    from dpcollapse.geometry.mesher import boundary_edges

    field = gather_regions(tagged)
    edges, tags = boundary_edges(tagged)
    if comm.rank != 0:
        return
    cell_tags = np.rint(field.values[:, 0, 0]).astype(np.int32)
    regions, _, _, done = rebuild_regions(field.vertices, cell_tags, edges, tags, H,
                                          lambda tag: H, 1e-6 * 0.01, True, True)
    assert done is not None and done.crossings
    overlap = 0.01 * 0.3 * H
    change = done.regions["granular_mass"]["surgery_change"]
    assert change == pytest.approx(-overlap, rel=0.05)
    assert abs(done.regions["erodible_layer"]["surgery_change"]) < 1e-12
    for name in ("granular_mass", "erodible_layer"):
        assert abs(done.regions[name]["change"]) < 1e-12
    from shapely.geometry import Polygon

    (lp, _, _, lh), (mp, _, _, mh) = sorted(regions, key=lambda r: -r[2])
    assert Polygon(lp).intersection(Polygon(mp)).area < 1e-14


def test_surface_tension_runs_include_a_kept_hole(comm):
    """Seed 000's surface tension on a mesh with a pocket kept as a hole: the free surface
    is the outer loop's runs and the hole's loop (mass on the left: clockwise), not exit 4."""
    from dpcollapse.geometry.free_surface import free_surface_runs, surface_tension_nodes
    from dpcollapse.geometry.mesher import mesh_regions
    from dpcollapse.geometry.polygon import signed_area

    new = _remesh(mesh_regions(comm, _nose_over_layer(0.05 * H), H), [])
    runs = free_surface_runs(new, [SURFACE])
    if comm.rank == 0:
        closed = [r for r in runs if np.all(r[0] == r[-1])]
        assert len(closed) == 1 and signed_area(closed[0][:-1]) < 0
    points, gamma = surface_tension_nodes(new, [SURFACE], 1.5, 8)
    assert len(points) == len(gamma) > 0
