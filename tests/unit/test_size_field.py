"""The error indicator that picks the mesh size (``ale.size_field``, ``numerics.mesh_tolerance``):
the Zienkiewicz–Zhu recovery estimate of the P2 velocity's gradient on known fields, the size
field it asks for, the mesher's background sizes, and the config keys."""

from __future__ import annotations

import numpy as np
import pytest

from dpcollapse import compat
from dpcollapse.ale.size_field import (
    INDICATOR_ORDER,
    adapted_sizes,
    recovery_indicator,
    size_field,
)
from dpcollapse.transfer import CellwiseField


def _grid_p2(n: int, u) -> CellwiseField:
    """The P2 interpolant of ``u(x, y) -> (ux, uy)`` on the unit square cut into n × n squares,
    each split into two triangles (alternating diagonals)."""
    tris = []
    h = 1.0 / n
    for i in range(n):
        for j in range(n):
            a, b = np.array([i * h, j * h]), np.array([(i + 1) * h, j * h])
            c, d = np.array([(i + 1) * h, (j + 1) * h]), np.array([i * h, (j + 1) * h])
            tris += [[a, b, c], [a, c, d]] if (i + j) % 2 == 0 else [[a, b, d], [b, c, d]]
    v = np.array(tris)
    mid = 0.5 * (v + np.roll(v, -1, axis=1))
    pts = np.concatenate([v, mid], axis=1)
    vals = np.stack(u(pts[..., 0], pts[..., 1]), axis=-1)
    return CellwiseField(v, pts, vals, 2)


def _smooth(x, y):
    return np.sin(2 * x) * np.cos(3 * y), x ** 3 * y - np.exp(x * y)


def _grad_error(u: CellwiseField, n_quad: int = 7) -> float:
    """‖∇(u − u_h)‖_{L²} of ``_smooth``'s interpolant, by a degree-5 rule per cell."""
    from dpcollapse.ale.size_field import cell_gradients

    # the cell gradient is linear: evaluate it at quadrature points by barycentric interpolation
    g = cell_gradients(u)                                     # (nc, 3, 2, 2)
    lam = np.array([[1 / 3, 1 / 3, 1 / 3], [0.0597158717, 0.4701420641, 0.4701420641],
                    [0.4701420641, 0.0597158717, 0.4701420641], [0.4701420641, 0.4701420641, 0.0597158717],
                    [0.7974269853, 0.1012865073, 0.1012865073], [0.1012865073, 0.7974269853, 0.1012865073],
                    [0.1012865073, 0.1012865073, 0.7974269853]])
    w = np.array([0.225, *[0.1323941527] * 3, *[0.1259391805] * 3])
    v = u.vertices
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    x = np.einsum("qi,nid->nqd", lam, v)
    gh = np.einsum("qi,nicd->nqcd", lam, g)
    eps = 1e-6
    exact = np.stack([(np.stack(_smooth(x[..., 0] + eps, x[..., 1]), -1)
                       - np.stack(_smooth(x[..., 0] - eps, x[..., 1]), -1)) / (2 * eps),
                      (np.stack(_smooth(x[..., 0], x[..., 1] + eps), -1)
                       - np.stack(_smooth(x[..., 0], x[..., 1] - eps), -1)) / (2 * eps)], -1)
    return float(np.sqrt(np.sum(area[:, None] * w * np.sum((exact - gh) ** 2, axis=(2, 3)))))


def test_indicator_converges_with_the_gradient_error_on_a_smooth_field():
    """Smooth u: Σ η_K² falls like h⁴ (‖∇(u − u_h)‖ ∝ h² for P2), as the true error does, and the
    estimate stays within a factor 2 of it (its effectivity)."""
    etas, errs = [], []
    for n in (8, 16, 32):
        u = _grid_p2(n, _smooth)
        etas.append(recovery_indicator(u).global_eta)
        errs.append(_grad_error(u))
    order = np.log2(np.array(etas[:-1]) / np.array(etas[1:]))
    true_order = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(true_order - 2.0) < 0.2), true_order
    assert np.all(np.abs(order - 2.0) < 0.3), order
    effectivity = np.array(etas) / np.array(errs)
    assert np.all((effectivity > 0.5) & (effectivity < 2.0)), effectivity


def test_indicator_points_where_the_gradient_jumps():
    """u = (|x − 0.37|, 0.2 y): linear on either side, its gradient jumps on x = 0.37. The
    indicator is zero (round-off) away from the jump, largest on the cells it crosses; the size
    field is the smallest there and the largest away from it."""
    xk = 0.37
    n = 16
    u = _grid_p2(n, lambda x, y: (np.abs(x - xk), 0.2 * y))
    ind = recovery_indicator(u)
    cx = ind.triangles[..., 0]
    crossed = (cx.min(axis=1) < xk) & (cx.max(axis=1) > xk)
    far = (np.abs(cx - xk).min(axis=1) > 1.5 / n)
    assert ind.eta[far].max() < 1e-9 * ind.eta.max()
    assert ind.eta[crossed].min() > 0.1 * ind.eta.max()
    assert np.argmax(ind.eta) in np.flatnonzero(crossed)
    field, _ = size_field(u, 1e-6, 0.01, 0.2)
    per_cell = field.sizes.max(axis=1)
    assert per_cell[crossed].max() == pytest.approx(0.01)
    farther = (np.abs(cx - xk).min(axis=1) > 3.0 / n)    # no vertex shared with a cell near it
    assert field.sizes[farther].min() == pytest.approx(0.2)


def test_adapted_sizes_reach_the_tolerance_where_the_order_holds():
    """h_new = h (τ/η)^{1/3}: on the smooth field, remeshing at the size asked for lands η on
    τ (within the factor 2 of the estimate's local variation)."""
    u = _grid_p2(16, _smooth)
    ind = recovery_indicator(u)
    tol = float(np.median(ind.eta)) / 8.0
    h_new = adapted_sizes(ind, tol, 1e-4, 1.0)
    assert np.allclose(h_new, ind.size * (tol / ind.eta) ** (1 / INDICATOR_ORDER))
    assert 0.4 < np.median(h_new / ind.size) < 0.6           # (1/8)^{1/3} = 0.5
    # a uniform mesh at the asked size: n = 32 has half the size, η_K ∝ h³ → τ
    finer = recovery_indicator(_grid_p2(32, _smooth))
    assert 0.5 < np.median(finer.eta) / tol < 2.0


def test_mesher_follows_the_background_sizes():
    """A square meshed with a background size of 2 cm on its left half and 10 cm on its right:
    the left half gets the cells (serial gmsh, no solve)."""
    from mpi4py import MPI

    from dpcollapse.geometry.mesher import BED, SURFACE, mesh_polygon

    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tags = np.array([BED, SURFACE, SURFACE, SURFACE])
    tri = np.array([[[0, 0], [0.5, 0], [0.5, 1]], [[0, 0], [0.5, 1], [0, 1]],
                    [[0.5, 0], [1, 0], [1, 1]], [[0.5, 0], [1, 1], [0.5, 1]]], dtype=float)
    sizes = np.where(tri[..., 0] < 0.5, 0.02, 0.1)
    sizes[tri[..., 0] == 0.5] = 0.02
    uniform = mesh_polygon(MPI.COMM_SELF, pts, tags, 0.1)
    graded = mesh_polygon(MPI.COMM_SELF, pts, tags, 0.1, background=(tri, sizes))

    def cells_left_right(tm):
        dofs = compat.geometry_dofmap(tm.mesh)
        x = tm.mesh.geometry.x[dofs, 0].mean(axis=1)
        return int(np.sum(x < 0.45)), int(np.sum(x > 0.55))

    ul, ur = cells_left_right(uniform)
    gl, gr = cells_left_right(graded)
    assert abs(ul - ur) < 0.3 * ul                 # without the field: both halves alike
    assert gl > 4 * gr                             # with it: the fine half holds the cells
    assert gl > 10 * ul


@pytest.mark.parametrize("overrides, message", [
    (["numerics.mesh_tolerance=-1"], r"^numerics.mesh_tolerance = -1: must be in \(0, 1\] m/s$"),
    (["numerics.mesh_tolerance=1e-3", "numerics.mesh_size_min=0.02", "numerics.mesh_size_max=0.01"],
     r"^numerics.mesh_size_min = 0.02 m: must be <= numerics.mesh_size_max \(0.01 m\)$"),
    (["numerics.mesh_tolerance=1e-3", "numerics.mesh_size_min=0.02"],
     r"^geometry.mesh_size = 0.01 m: with numerics.mesh_tolerance it must lie in"),
    (["numerics.mesh_size_max=0.05"], r"^numerics.mesh_size_max = 0.05: only with "
                                      r"numerics.mesh_tolerance set"),
    (["numerics.mesh_tolerance=1e-3", "numerics.ale=false"],
     r"^numerics.mesh_tolerance = 0.001: only with model.name = stokes and numerics.ale = true"),
])
def test_mesh_tolerance_keys_refused_in_one_line(overrides, message):
    from pathlib import Path

    from dpcollapse.config import load_config
    from dpcollapse.errors import ConfigError

    rigid = Path(__file__).resolve().parents[2] / "configs" / "rigid.yaml"
    with pytest.raises(ConfigError, match=message) as info:
        load_config(rigid, overrides)
    assert "\n" not in str(info.value)


def test_mesh_tolerance_bounds_default_to_a_factor_four():
    from pathlib import Path

    from dpcollapse.config import load_config

    rigid = Path(__file__).resolve().parents[2] / "configs" / "rigid.yaml"
    assert load_config(rigid).size_control is None
    cfg = load_config(rigid, ["numerics.mesh_tolerance=2e-3"])
    assert cfg.size_control == pytest.approx((2e-3, 0.0025, 0.04))


def test_moving_domain_remeshes_to_the_indicator_of_its_flow():
    """The wiring: a MovingDomain with ``size_control`` remeshes its mesh (a square, 10 cm) to
    the size field of the flow it last saw — a velocity whose gradient jumps on x = 0.5 — so the
    new mesh is fine along the jump and coarse away from it; without a flow seen, uniform."""
    from types import SimpleNamespace

    from mpi4py import MPI

    from dpcollapse.domain.moving import MovingDomain
    from dpcollapse.geometry.mesher import BED, SURFACE, mesh_polygon

    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tags = np.array([BED, SURFACE, SURFACE, SURFACE])
    tagged = mesh_polygon(MPI.COMM_SELF, pts, tags, 0.1)
    u = _grid_p2(10, lambda x, y: (np.abs(x - 0.5), 0.0 * y))
    flow = SimpleNamespace(snapshot=lambda: {"velocity": u})
    domain = MovingDomain(12.0, 0.1, size_control=(1e-4, 0.02, 0.2))

    def cells_near_far(tm):
        dofs = compat.geometry_dofmap(tm.mesh)
        x = tm.mesh.geometry.x[dofs, 0].mean(axis=1)
        return int(np.sum(np.abs(x - 0.5) < 0.1)), int(np.sum(np.abs(x - 0.5) > 0.3))

    uniform, _ = domain.remesh(tagged, 1.0)          # no flow seen: no size field
    domain._flow_of = (tagged, flow)                 # what needs_remesh records
    adapted, _ = domain.remesh(tagged, 1.0)
    un, uf = cells_near_far(uniform)
    an, af = cells_near_far(adapted)
    assert an > 4 * un                               # 2 cm along the jump against 10 cm
    assert af <= uf                                  # 10–20 cm away from it
