"""The geometric (PLIC) interface flux of c (``model.interface_flux: geometric``,
``models.two_phase.geometric_flux``): the closed-form placement of the interface in a
triangle, and the advection of a square and of a thin layer on the bed, sharp, conservative
and bounded, serial and on 2 ranks (the limiter's ratios and the ghost cells' c)."""

import math

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.models.two_phase.fraction import VolumeFraction, owned_triangles
from dpcollapse.models.two_phase.geometric_flux import area_fraction_below, plane_constant
from dpcollapse.models.two_phase.overlap import rectangle_fraction

N = 32                 # cells per side of the unit box
H = 1.0 / N            # their size


def test_the_interface_holds_the_cells_fraction():
    """s = plane_constant(c) puts the share c of a triangle below n·x = s, for random
    triangles, normals and fractions, on either side of the middle vertex (the knee)."""
    rng = np.random.default_rng(5)
    tri = rng.uniform(-1, 1, (400, 3, 2))
    angle = rng.uniform(0, 2 * math.pi, 400)
    normal = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    c = rng.uniform(0, 1, 400)
    p = np.einsum("nkd,nd->nk", tri, normal)
    s = plane_constant(p, c)
    assert np.abs(area_fraction_below(p, s) - c).max() < 1e-10
    # by hand: the unit right triangle cut by x = 0.5 keeps 1 − 0.25 of its area on x ≤ 0.5
    p = np.array([[0.0, 1.0, 0.0]])
    assert area_fraction_below(p, np.array([0.5]))[0] == pytest.approx(0.75, abs=1e-15)


def _box(comm):
    return compat.create_rectangle(comm, (0.0, 0.0), (1.0, 1.0), (N, N))


def _advect(mesh, flow, box, steps, dt, interface_flux="geometric", compression=0.0,
            direction="normal", reconstruct=True, **options):
    """c of the rectangle ``box`` advected by ``flow`` (a P2 interpolation) for ``steps``
    steps of ``dt``: (the VolumeFraction, ∫ c(0), bounds over the steps)."""
    vf = VolumeFraction(mesh, 0.4, compression, direction=direction, interface_flux=interface_flux,
                        **options)
    u = fem.Function(compat.vector_space(mesh, 2))
    u.interpolate(flow)
    vf.bind(u)
    if vf._geometric is not None:
        vf._geometric.reconstruct = reconstruct
    n = compat.num_owned_cells(mesh)
    vf.c.x.array[compat.cell_dofs(vf.S0)[:n, 0]] = rectangle_fraction(owned_triangles(mesh), *box)
    vf.c.x.scatter_forward()
    area0 = vf.integral()
    lo, hi = 0.0, 1.0
    for _ in range(steps):
        vf.advance(dt)
        vf.accept()
        b = vf.bounds()
        lo, hi = min(lo, b[0]), max(hi, b[1])
    return vf, area0, (lo, hi)


def _gathered(vf):
    """(centroids, areas, c) of every cell, on every rank."""
    tri, c = vf.gathered()
    d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    return tri.mean(axis=1), 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]), c


def _uniform(x):
    return np.vstack([0.6 + 0.0 * x[0], 0.3 + 0.0 * x[1]])


def _rotation(x):
    return np.vstack([-2 * math.pi * (x[1] - 0.5), 2 * math.pi * (x[0] - 0.5)])


SQUARE = ((0.3, 0.15), (0.55, 0.4))     # side 0.25: perimeter 1 m


@pytest.mark.mpi
@pytest.mark.parametrize("flow,steps", [(_uniform, 50), (_rotation, 100)], ids=["uniform", "rotation"])
def test_a_square_stays_sharp_and_its_area_is_kept(flow, steps):
    """A 0.25 m square carried 0.34 m diagonally (uniform) or once around (rotation, 1 s) on
    32 × 32 cells: ∫ c conserved to round-off, c in [0, 1], and the mixed cells (0.01 < c <
    0.99) cover at most a band two cells wide along the perimeter (the rotation crosses the
    box's sides: what a haze takes out there is counted, ``escaped_volume``), 2 H × 1 m (measured:
    0.38 of it; the compression C = 1 `normal` 2.3 / 3.6 times it, plain upwind — the
    reconstruction disabled — 3.4 / 7.2 times); after the turn the L1 distance to the
    initial square is below 0.2 of its area (measured 0.14; compression 0.48, upwind 1.13)."""
    mesh = _box(MPI.COMM_WORLD)
    vf, area0, (lo, hi) = _advect(mesh, flow, SQUARE, steps, 0.01)
    assert abs(vf.integral() + vf.escaped_volume - area0) < 1e-13 * area0
    assert lo >= -1e-14 and hi <= 1.0 + 1e-12
    x, area, c = _gathered(vf)
    mixed = area[(c > 0.01) & (c < 0.99)].sum()
    assert mixed <= 2 * H * 1.0
    if flow is _rotation:
        exact = rectangle_fraction(vf.gathered()[0], *SQUARE)
        assert (np.abs(c - exact) * area).sum() < 0.2 * area0
    vf.destroy()


def _stretching(rate):
    """u = a (x, −y): a layer on the bed y = 0 spread along it and thinned, e^{at} and e^{−at}."""
    return lambda x: np.vstack([rate * x[0], -rate * x[1]])


def _fronts(vf, thickness):
    """(profile front, mass front): the furthest x where the column integral h(x) = Σ c|K|/H
    over the cells of a column reaches ``thickness``/2 (linear between the columns' centres),
    and the furthest centroid of a cell with c > ½."""
    x, area, c = _gathered(vf)
    column = np.floor(x[:, 0] / H).astype(int)
    h = np.bincount(column, weights=c * area, minlength=N) / H
    centres = (np.arange(N) + 0.5) * H
    k = np.nonzero(h >= thickness / 2)[0].max()
    profile = centres[k] + (h[k] - thickness / 2) / (h[k] - h[k + 1]) * H
    return profile, x[c > 0.5, 0].max()


@pytest.mark.mpi
def test_a_thin_layer_spread_along_the_bed_is_neither_thinned_nor_shortened():
    """A layer two cells thick on the bed, x ∈ [0, 0.3], spread along the bed by u = a (x, −y)
    to 2.5 times its length and 0.8 of a cell's thickness in 0.5 s (the front of a collapsing
    column thins so): its profile front (where h = ∫ c dy reaches half the exact thickness)
    and its mass front (c > ½) within one cell of the exact 0.75 m, its thickness at mid-length
    within 10 %. Measured (cells): geometric −0.22 / −0.67, thickness −0.2 %; the compression
    across every facet (`facet`, the default before 2026-12-05) −1.9 / −2.3, +29 %; upwind
    (the reconstruction disabled) +0.10 / −3.3; the compression `normal` (today's) +0.01 / −0.67,
    +7 %."""
    mesh = _box(MPI.COMM_WORLD)
    stretch, t_end, thick0 = 2.5, 0.5, 2 * H
    vf, area0, (lo, hi) = _advect(mesh, _stretching(math.log(stretch) / t_end),
                                  ((0.0, 0.0), (0.3, thick0)), 50, t_end / 50)
    assert abs(vf.integral() + vf.escaped_volume - area0) < 1e-13 * area0
    assert lo >= -1e-14 and hi <= 1.0 + 1e-12
    thick, exact = thick0 / stretch, 0.3 * stretch
    profile, mass = _fronts(vf, thick)
    assert abs(profile - exact) <= H and abs(mass - exact) <= H
    x, area, c = _gathered(vf)
    middle = np.floor(x[:, 0] / H).astype(int) == int(exact / 2 / H)
    assert (c[middle] * area[middle]).sum() / H == pytest.approx(thick, rel=0.1)
    vf.destroy()


@pytest.mark.mpi
def test_a_thin_layer_sheared_along_the_bed_keeps_its_front():
    """A layer 1.5 cells thick on the bed, x ∈ [0.1, 0.4], sheared by u = (γ y, 0) so its top
    runs 2.7 cells ahead of its foot in 0.5 s: the front where h reaches half the thickness is
    the exact x₁ + γ d/2 t within one cell, and its mass front (c > ½) too (measured: geometric
    +0.02 / +0.93 cells). A guard: the compression (`normal` +0.25 / +0.27, `facet` −0.01 /
    −0.07) and upwind (−0.09 / −0.73) pass it too — a shear along the bed's rows of cells
    moves c across the triangles' diagonals only."""
    mesh = _box(MPI.COMM_WORLD)
    thick, t_end = 1.5 * H, 0.5
    rate = 0.2 / thick
    vf, area0, (lo, hi) = _advect(mesh, lambda x: np.vstack([rate * x[1], 0.0 * x[1]]),
                                  ((0.1, 0.0), (0.4, thick)), 50, t_end / 50)
    assert abs(vf.integral() + vf.escaped_volume - area0) < 1e-13 * area0
    assert lo >= -1e-14 and hi <= 1.0 + 1e-12
    exact = 0.4 + rate * thick / 2 * t_end
    profile, mass = _fronts(vf, thick)
    assert abs(profile - exact) <= H and abs(mass - exact) <= H
    vf.destroy()


def test_a_bad_interface_flux_is_one_line(capsys):
    """``model.interface_flux`` other than compression or geometric: one line naming the key,
    exit 2."""
    from tests.helpers import ROOT, refusal_message

    message = refusal_message(ROOT / "configs" / "column_eulerian_a0.5.yaml",
                              "model.interface_flux=plic", "model.interface_flux", capsys)
    assert "geometric" in message


@pytest.mark.mpi
def test_a_tongue_thinner_than_a_cell_stays_a_layer_with_the_height_function_normal():
    """A layer 0.4 of a cell thick on the bed, x ∈ [0.1, 0.4], carried 0.4 m along it by a
    uniform flow: with the height function's normal in thin layers (``interface_normal:
    height_function``) every column inside the exact layer [0.5, 0.8] keeps h within 50 % of
    the thickness (measured 0.63–1.09 of it over [0.5, 0.78]) and its front is within a cell.
    With ∇c̄'s normal (``gradient``) the layer breaks into blobs (the normal along the layer,
    each blob's grains put at its back): columns with h = 0 and 2.09 d between them."""
    mesh = _box(MPI.COMM_WORLD)
    thick, t_end = 0.4 * H, 0.4
    vf, area0, (lo, hi) = _advect(mesh, lambda x: np.vstack([1.0 + 0.0 * x[0], 0.0 * x[1]]),
                                  ((0.1, 0.0), (0.4, thick)), 40, t_end / 40,
                                  interface_normal="height_function", strips=(H, N))
    assert abs(vf.integral() + vf.escaped_volume - area0) < 1e-13 * area0
    assert lo >= -1e-14 and hi <= 1.0 + 1e-12
    x, area, c = _gathered(vf)
    h = np.bincount(np.floor(x[:, 0] / H).astype(int), weights=c * area, minlength=N) / H
    inside = h[int(0.5 / H) + 1:int(0.8 / H) - 1]
    assert inside.min() >= 0.5 * thick and inside.max() <= 1.5 * thick
    profile, _ = _fronts(vf, thick)
    assert abs(profile - (0.4 + t_end)) <= H
    vf.destroy()
