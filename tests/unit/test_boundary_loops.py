"""The reused chaining of a moving mesh's boundary (``geometry.boundary_loops``): the same
loops as ``polygon.chain_loops`` (bitwise) and so the same contacts
(``surgery.surgery_needed``), on the surgery tests' polygons and on random ones, with the
chaining recorded on other coordinates of the same edges."""

import numpy as np
import pytest

from dpcollapse.geometry.boundary_loops import BoundaryLoops
from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.geometry.polygon import chain_loops, polygon_is_simple
from dpcollapse.geometry.surgery import surgery_needed

pytest.importorskip("shapely")

from tests.unit.test_surgery import _densify, _hook, _nose


def _edges(loops, rng):
    """The loops' edges (m, 2, 2) as a mesh gathers them: shuffled, some reversed, some
    twice (a facet on two ranks); returns (edges, tags, slots) with slots (m, 2) the loop
    vertex (index into the stacked points) at each end."""
    pts = np.concatenate([p for p, _ in loops])
    slots, tags, base = [], [], 0
    for p, t in loops:
        n = len(p)
        for i in range(n):
            slots.append((base + i, base + (i + 1) % n))
            tags.append(t[i])
        base += n
    slots, tags = np.array(slots), np.array(tags)
    order = rng.permutation(len(slots))
    twice = rng.choice(len(slots), size=len(slots) // 10, replace=False)
    order = np.concatenate([order, twice])
    slots, tags = slots[order], tags[order]
    flip = rng.random(len(slots)) < 0.5
    slots[flip] = slots[flip][:, ::-1]
    return pts, slots, tags


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert np.array_equal(x.points, y.points) and np.array_equal(x.edge_tags, y.edge_tags)


def _check(loops_now, loops_before, mesh_size, seed=0):
    """Record the chaining on ``loops_before`` (same vertex counts), then compare on
    ``loops_now``: the loops and the contacts of the plain chaining."""
    rng = np.random.default_rng(seed)
    before, slots, tags = _edges(loops_before, rng)
    now = np.concatenate([p for p, _ in loops_now])
    key = (object(),)
    chained = BoundaryLoops()
    chained.loops(before[slots], tags, key)
    fast = chained.loops(now[slots], tags, key)
    plain = chain_loops(now[slots], tags)
    assert chained.chained == 1            # the recorded order was reused
    _same(fast, plain)
    assert (surgery_needed(fast[0], mesh_size, fast[1:])
            == surgery_needed(plain[0], mesh_size, plain[1:]))
    return surgery_needed(fast[0], mesh_size, fast[1:])


def _jitter(poly, scale, rng):
    return (poly.points + scale * rng.standard_normal(poly.points.shape), poly.edge_tags)


def _moved_hook(tip_y, h=0.1):
    """The open hook (tip 2 h above the block) with its tip moved down to ``tip_y`` (same
    vertices): every vertex with x ≥ 1.8 below the arm is lowered by the same amount."""
    poly = _hook(0.5, h=h)
    pts = poly.points.copy()
    tip = (pts[:, 0] >= 1.8 - 1e-12) & (pts[:, 1] < 0.8 - 1e-12) & (pts[:, 1] > 0.3 + 1e-12)
    pts[tip, 1] -= 0.5 - tip_y
    return pts, poly.edge_tags


@pytest.mark.parametrize("tip_y, kinds", [(0.5, None), (0.3 + 0.005, "self-contact"),
                                          (0.3 - 0.002, "crossing, self-contact")])
def test_same_contacts_on_the_hook(tip_y, kinds):
    """The hook open, at a near contact and pushed through the block: found as by the
    plain chaining (recorded on the open hook)."""
    assert _check([_moved_hook(tip_y)], [_moved_hook(0.5)], 0.1) == kinds


@pytest.mark.parametrize("tip_y, kinds", [(0.005, None), (0.0, None)])
def test_same_contacts_on_the_nose(tip_y, kinds):
    """A nose above the bed and landed (its large pocket kept: no surgery asked for)."""
    h = 0.05
    poly = _nose(tip_y)
    rng = np.random.default_rng(1)
    assert _check([(poly.points, poly.edge_tags)], [_jitter(poly, 0.01 * h, rng)], h) == kinds


def test_same_contacts_on_a_small_landed_pocket():
    h = 0.05
    corners = [(0, 0), (1.55, 0), (1.575, 0.02), (1.6, 0.0), (1.7, 0.1), (1.3, 0.5), (0, 0.5)]
    poly = _densify(corners, [BED, SURFACE, SURFACE, SURFACE, SURFACE, SURFACE, WALL], h)
    rng = np.random.default_rng(2)
    loops = [(poly.points, poly.edge_tags)]
    assert _check(loops, [_jitter(poly, 0.01 * h, rng)], h) == "bed contact"


def _star(rng, n, center, radius, wobble):
    angles = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = radius * (1 + wobble * rng.uniform(-1, 1, n))
    pts = center + np.column_stack([r * np.cos(angles), r * np.sin(angles)])
    tags = rng.choice([BED, WALL, SURFACE], size=n, p=[0.2, 0.1, 0.7])
    return pts, tags


@pytest.mark.parametrize("seed", range(40))
def test_same_loops_on_random_polygons(seed):
    """Random star polygons (some folded by the move), with a hole for odd seeds, moved
    from random other coordinates: the same loops and contacts as the plain chaining."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(8, 120))
    outer = _star(rng, n, np.zeros(2), 1.0, 0.5 if seed % 4 else 0.95)
    loops = [outer]
    if seed % 2:
        hole_pts, _ = _star(rng, int(rng.integers(3, 20)), np.zeros(2), 0.2, 0.1)
        loops.append((hole_pts, np.full(len(hole_pts), SURFACE)))
    before = [(p + 0.05 * rng.standard_normal(p.shape), t) for p, t in loops]
    _check(loops, before, mesh_size=float(rng.uniform(0.02, 0.3)), seed=seed)


def test_rechained_when_the_mesh_or_its_tags_change():
    rng = np.random.default_rng(3)
    pts, tags = _star(rng, 30, np.zeros(2), 1.0, 0.3)
    _, slots, etags = _edges([(pts, tags)], rng)
    edges = pts[slots]
    chained, key = BoundaryLoops(), (object(),)
    chained.loops(edges, etags, key)
    chained.loops(edges, etags, key)
    assert chained.chained == 1
    chained.loops(edges, etags, (object(),))                 # a new mesh
    assert chained.chained == 2
    other = etags.copy()
    other[0] = WALL if other[0] != WALL else BED
    _same(chained.loops(edges, other, chained._key), chain_loops(edges, other))   # retagged
    assert chained.chained == 3


def test_coinciding_vertices_fail_as_the_plain_chaining():
    """A move that puts a vertex onto another (which the plain chaining merges): the fast
    path is not used, the same error as ``chain_loops``."""
    rng = np.random.default_rng(4)
    pts, tags = _star(rng, 30, np.zeros(2), 1.0, 0.3)
    _, slots, etags = _edges([(pts, tags)], rng)
    chained, key = BoundaryLoops(), (object(),)
    chained.loops(pts[slots], etags, key)
    moved = pts.copy()
    moved[10] = moved[20]
    with pytest.raises(ValueError) as plain:
        chain_loops(moved[slots], etags)
    with pytest.raises(ValueError) as fast:
        chained.loops(moved[slots], etags, key)
    assert str(fast.value) == str(plain.value)


def test_folded_hook_is_not_simple():
    """(The crossing case above really crosses.)"""
    assert not polygon_is_simple(_moved_hook(0.298)[0])


def test_orientation_and_order_follow_the_move():
    """A move that mirrors the loops (their orientation flips) and makes the second one the
    larger: still the plain chaining's CCW loops, largest first."""
    rng = np.random.default_rng(5)
    a_pts, a_tags = _star(rng, 25, np.zeros(2), 1.0, 0.3)
    b_pts, b_tags = _star(rng, 15, np.array([5.0, 0.0]), 0.3, 0.3)
    mirror = np.array([-1.0, 1.0])
    before = [(a_pts * mirror, a_tags), (b_pts * mirror, b_tags)]
    now = [(0.2 * a_pts, a_tags), (np.array([5.0, 0.0]) + 5 * (b_pts - [5.0, 0.0]), b_tags)]
    _check(now, before, mesh_size=0.1)
