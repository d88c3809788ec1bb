"""The exact conservative remap of c between two triangle meshes of the same box
(``models.two_phase.remap``): ∫ c conserved to 1e-12 relative, a constant stays constant,
c stays in [0, 1]; one overlap by hand; the same on DOLFINx meshes, serial and on 2 ranks."""

import numpy as np
import pytest
from mpi4py import MPI
from scipy.spatial import Delaunay

from dpcollapse import compat
from dpcollapse.models.two_phase.fraction import VolumeFraction
from dpcollapse.models.two_phase.remap import pair_overlaps, remap, triangle_areas

LENGTH, HEIGHT = 1.2, 0.7


def _jittered_mesh(rng, n: int) -> np.ndarray:
    """Delaunay triangles of a jittered n × n grid of the box (its sides kept straight)."""
    x, y = np.meshgrid(np.linspace(0, LENGTH, n), np.linspace(0, HEIGHT, n))
    points = np.c_[x.ravel(), y.ravel()]
    inside = (points[:, 0] > 0) & (points[:, 0] < LENGTH) & (points[:, 1] > 0) & (points[:, 1] < HEIGHT)
    points[inside] += (rng.random((inside.sum(), 2)) - 0.5) * 0.6 * np.array([LENGTH, HEIGHT]) / n
    return points[Delaunay(points).simplices]


def _structured_mesh(nx: int, ny: int) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(0, LENGTH, nx + 1), np.linspace(0, HEIGHT, ny + 1))
    p = np.stack([x, y], axis=-1)
    a, b, c, d = p[:-1, :-1], p[:-1, 1:], p[1:, 1:], p[1:, :-1]
    return np.concatenate([np.stack([a, b, c], axis=-2).reshape(-1, 3, 2),
                           np.stack([a, c, d], axis=-2).reshape(-1, 3, 2)])


def test_overlap_of_two_triangles_by_hand():
    """The unit right triangle and its mirror x ↔ 1 − x overlap in the triangle
    (0, 0), (1, 0), (½, ½) of area ¼; a clockwise triangle is turned round first."""
    a = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
    b = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]])
    assert pair_overlaps(a, b)[0] == pytest.approx(0.25, abs=1e-15)
    old = np.concatenate([a, b[:, ::-1]])                   # b clockwise
    assert remap(old, np.array([1.0, 0.0]), b)[0] == pytest.approx(0.5, abs=1e-15)


def test_remap_conserves_and_keeps_constants_and_bounds():
    rng = np.random.default_rng(1)
    old, new = _structured_mesh(37, 23), _jittered_mesh(rng, 50)
    centroid = old.mean(axis=1)
    # a column with a smeared edge, and zeros elsewhere (skipped by the remap)
    c = np.clip((0.3 - centroid[:, 0]) / 0.05, 0, 1) * (centroid[:, 1] < 0.5)
    mass = np.dot(c, triangle_areas(old))
    out = remap(old, c, new)
    assert np.dot(out, triangle_areas(new)) == pytest.approx(mass, rel=1e-12)
    assert out.min() >= -1e-14 and out.max() <= 1 + 1e-12
    one = remap(old, np.ones(len(old)), new)
    assert np.abs(one - 1).max() < 1e-12
    # two fields at once, and back to the first mesh
    both = remap(old, np.c_[c, 0.5 * c], new)
    np.testing.assert_allclose(both[:, 1], 0.5 * out, rtol=0, atol=1e-15)
    back = remap(new, out, old)
    assert np.dot(back, triangle_areas(old)) == pytest.approx(mass, rel=1e-12)


@pytest.mark.mpi
def test_remap_between_dolfinx_meshes_conserves_under_mpi():
    """c on one distributed box mesh remapped onto another: ∫ c (DOLFINx's assembly) kept."""
    comm = MPI.COMM_WORLD
    coarse = VolumeFraction(compat.create_rectangle(comm, (0.0, 0.0), (LENGTH, HEIGHT), (13, 7)),
                            0.4, 1.0)
    fine = VolumeFraction(compat.create_rectangle(comm, (0.0, 0.0), (LENGTH, HEIGHT), (29, 17)),
                          0.4, 1.0)
    x = coarse.S0.tabulate_dof_coordinates()
    coarse.c.x.array[:] = np.clip(np.sin(3 * x[:, 0]) + x[:, 1], 0, 1)
    mass = coarse.integral()
    fine.remap_from(*coarse.gathered())
    assert fine.integral() == pytest.approx(mass, rel=1e-12)
    lo, hi = fine.bounds()
    assert lo >= -1e-14 and hi <= 1 + 1e-12
    coarse.remap_from(*fine.gathered())
    assert coarse.integral() == pytest.approx(mass, rel=1e-12)


@pytest.mark.mpi
def test_fields_of_one_mesh_share_one_overlap_search(monkeypatch):
    """``flow.remap_fields``: c and cⁿ⁻¹ (different supports) of one old mesh are remapped in
    one candidate search and one set of overlaps — the remap's cost, paid once, not per field
    — and each equals its own remap (``remap_from``, conservative) to round-off; a field of
    another mesh gets its own search. Serial and on 2 ranks."""
    from dpcollapse.models.two_phase import remap as remap_module
    from dpcollapse.models.two_phase.flow import remap_fields
    from dpcollapse.transfer import CellwiseField

    comm = MPI.COMM_WORLD
    rect = compat.create_rectangle

    def fraction(n):
        return VolumeFraction(rect(comm, (0.0, 0.0), (LENGTH, HEIGHT), (n, n // 2 + 1)), 0.4, 1.0)

    old, other, new = fraction(13), fraction(9), fraction(29)
    expected = VolumeFraction(new.mesh, 0.4, 1.0)
    x = old.S0.tabulate_dof_coordinates()
    fields = {}
    for name, values in (("c", np.clip(0.5 - x[:, 0], 0, 1)), ("previous", np.clip(x[:, 1] - 0.2, 0, 1))):
        old.c.x.array[:] = values
        tri, v = old.gathered()
        fields[name] = CellwiseField(vertices=tri, points=tri, degree=1,
                                     values=np.repeat(v[:, None], 3, axis=1))
    other.c.x.array[:] = 0.25
    tri, v = other.gathered()
    fields["other"] = CellwiseField(vertices=tri, points=tri, degree=1,
                                    values=np.repeat(v[:, None], 3, axis=1))
    searches = []
    search = remap_module.candidate_pairs
    monkeypatch.setattr(remap_module, "candidate_pairs",
                        lambda *a: searches.append(1) or search(*a))
    remap_fields([(new.c, fields["c"]), (new.previous, fields["previous"]),
                  (new.work, fields["other"])], new.mesh)
    assert len(searches) == 2          # one for c and cⁿ⁻¹ together, one for the other mesh
    for name, target in (("c", new.c), ("previous", new.previous), ("other", new.work)):
        f = fields[name]
        expected.remap_from(f.vertices, f.values[:, 0, 0])
        np.testing.assert_allclose(target.x.array, expected.c.x.array, rtol=0, atol=1e-14)
        assert comm.allreduce(target.x.array.max(initial=0.0), op=MPI.MAX) > 0.2
