"""The interface-adaptive mesh of the two-phase box (``domain.adaptive_box``): the size
field by hand, the gmsh box (sides tagged, fine cells over the granular region, coarse ones far
away), the uniform box kept for absent keys, and the config's one-line errors."""

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import load_config
from dpcollapse.domain.adaptive_box import SizeField, adaptive_box, equivalent_size
from dpcollapse.errors import ConfigError
from dpcollapse.geometry.mesher import BED, LEFT, RIGHT, SURFACE
from dpcollapse.models.two_phase.adapter import TwoPhaseFactory, is_adaptive
from dpcollapse.models.two_phase.fraction import owned_triangles
from tests.helpers import ROOT

CONFIG = ROOT / "configs" / "column_eulerian_a0.5.yaml"


def test_size_field_by_hand():
    """h_min inside the band b, h_min + g (d − b) beyond, h_max far away and with no grains."""
    size = SizeField(0.01, 0.05, band=0.04, grading=0.5)
    points = np.array([[0.0, 0.03], [0.0, 0.08], [0.0, 1.0]])
    np.testing.assert_allclose(size(points, np.zeros((1, 2))), [0.01, 0.03, 0.05])
    np.testing.assert_allclose(size(points, np.zeros((0, 2))), [0.05] * 3)


def test_size_field_on_the_background_grid_equals_the_formula_at_every_vertex():
    """The size field reads each distinct point once (the background grid repeats its vertices:
    they are compared as pairs): at every vertex of the grid, repeated or not, in any memory
    layout (a transposed view, integers), h equals the formula with d by brute force."""
    from dpcollapse.domain.adaptive_box import background_grid

    size = SizeField(0.01, 0.05, band=0.02, grading=0.3)
    rng = np.random.default_rng(0)
    grains = rng.random((40, 2)) * [0.1, 0.05]
    points = background_grid(0.4, 0.2, 0.02).reshape(-1, 2)
    d = np.linalg.norm(points[:, None] - grains[None], axis=2).min(axis=1)
    expected = np.minimum(0.05, 0.01 + 0.3 * np.maximum(d - 0.02, 0.0))
    np.testing.assert_allclose(size(points, grains), expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(size(np.asfortranarray(points), grains), expected, rtol=0, atol=1e-15)
    whole = np.array([[0, 0], [1, 0], [0, 0], [0, 1]])   # integers [m], one repeated
    d = np.linalg.norm(whole[:, None] - grains[None], axis=2).min(axis=1)
    np.testing.assert_allclose(size(whole, grains), rtol=0, atol=1e-15, desired=
                                  np.minimum(0.05, 0.01 + 0.3 * np.maximum(d - 0.02, 0.0)))


@pytest.mark.mpi
def test_adaptive_box_is_fine_over_the_grains_and_coarse_far_away():
    comm = MPI.COMM_WORLD
    size = SizeField(0.01, 0.05, band=0.02, grading=0.3)
    x, y = np.meshgrid(np.linspace(0.005, 0.095, 10), np.linspace(0.005, 0.045, 5))
    tagged = adaptive_box(comm, 0.4, 0.2, size, np.c_[x.ravel(), y.ravel()])
    tri = owned_triangles(tagged.mesh)
    h, mid = equivalent_size(tri), tri.mean(axis=1)
    grains = (mid[:, 0] < 0.1) & (mid[:, 1] < 0.05)
    far = mid[:, 0] > 0.3
    assert comm.allreduce(float(h[grains].max()) if grains.any() else 0.0, op=MPI.MAX) < 1.5 * 0.01
    assert comm.allreduce(float(h[far].min()) if far.any() else np.inf, op=MPI.MIN) > 2 * 0.01
    area = comm.allreduce(float(np.sum(0.25 * np.sqrt(3) * h**2)), op=MPI.SUM)
    assert area == pytest.approx(0.4 * 0.2, rel=1e-12)
    tags = set(comm.allreduce(set(np.unique(tagged.facet_tags.values).tolist()), op=MPI.BOR))
    assert tags == {BED, LEFT, RIGHT, SURFACE}


def test_absent_keys_and_equal_sizes_give_the_uniform_box():
    """No model.min_cell: today's structured box of geometry.mesh_size; min_cell = max_cell:
    the same box (the same cells); only min_cell < max_cell is adaptive."""
    comm = MPI.COMM_SELF
    today = TwoPhaseFactory(load_config(CONFIG, ["geometry.mesh_size=0.02"]))
    same = TwoPhaseFactory(load_config(CONFIG, ["geometry.mesh_size=0.04", "model.min_cell=0.02",
                                                "model.max_cell=0.02"]))
    assert not is_adaptive(today.cfg) and not is_adaptive(same.cfg)
    a, b = today.start(comm), same.start(comm)
    np.testing.assert_array_equal(owned_triangles(a.mesh), owned_triangles(b.mesh))
    np.testing.assert_array_equal(a.fraction.c.x.array, b.fraction.c.x.array)
    assert compat.num_owned_cells(a.mesh) == 15 * 5 * 2
    a.destroy(), b.destroy()
    assert is_adaptive(load_config(CONFIG, ["model.min_cell=0.002"]))


def test_min_cell_above_max_cell_is_one_line():
    with pytest.raises(ConfigError, match="model.min_cell = 0.03: must be <= model.max_cell"):
        load_config(CONFIG, ["model.min_cell=0.03", "model.max_cell=0.02"])


def test_a_box_mesher_that_never_returns_is_a_mesh_failure(tmp_path):
    """The adaptive box's gmsh generation has the same time bound as every other
    (``mesher.generate_bounded``, issue 47: it had none): exit 4 and one line once
    DPCOLLAPSE_MESH_TIME_LIMIT has passed. The hang is injected in a child process (the
    bound ends the process)."""
    import subprocess
    import sys
    import textwrap
    import time

    from tests.helpers import ROOT, clean_env

    script = textwrap.dedent("""
        import time
        import numpy as np
        from mpi4py import MPI
        from dpcollapse.domain import adaptive_box as adaptive
        adaptive._build_box_model = lambda *args, **kwargs: time.sleep(3600)
        size = adaptive.SizeField(0.01, 0.05, band=0.04, grading=0.5)
        adaptive.adaptive_box(MPI.COMM_WORLD, 0.4, 0.2, size, np.array([[0.1, 0.05]]))
    """)
    env = {**clean_env(), "DPCOLLAPSE_MESH_TIME_LIMIT": "2"}
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 4, done.stderr[-2000:]
    assert time.monotonic() - t0 < 60
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "meshing did not finish within 2 s" in lines[0], done.stderr


def test_the_thickness_front_is_every_model_s_front():
    """Issue 50: the two-phase ``thick_front`` is ``fronts.profile_front`` through the
    columns' centres at the stated thickness (the one definition of the depth-averaged
    model, the ladder and the reports), not the right edge of the last thick column. The
    initial a = 0.5 column (L0 = 0.1 m, H0 = 0.05 m) on 2 cm cells: h = 0.05 m in the column
    [0.08, 0.1], 0 in [0.1, 0.12], h_f = max(3 d, ΔX/4) = 5 mm: x_f = 0.09 + 0.02 · 0.045/0.05
    = 0.108 m (the column's edge 0.1 m was the former reading)."""
    from dpcollapse.fronts import profile_front

    disc = TwoPhaseFactory(load_config(CONFIG, ["geometry.mesh_size=0.02"])).start(MPI.COMM_SELF)
    h = disc.thickness()
    assert disc.thick_floor == pytest.approx(5e-3, rel=1e-5)     # 3 d, d = 1.66667 mm
    got = disc.measures()["thick_front"]
    assert got == profile_front((np.arange(disc.nx) + 0.5) * disc.dx_bin, h, disc.thick_floor)
    assert got == pytest.approx(0.108, abs=1e-8)
    disc.destroy()


def _column_and_tongue(spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of [0, 0.4] × [0, 0.2] (structured, ``spacing``) and c = 1 in a column
    [0, 0.1] × [0, 0.1] and a tongue [0.1, 0.3] × [0, 4 mm] on the bed (by centroid)."""
    from dpcollapse.domain.adaptive_box import background_grid

    tri = background_grid(0.4, 0.2, spacing)
    x, y = tri.mean(axis=1).T
    c = (((x < 0.1) & (y < 0.1)) | ((x < 0.3) & (y < 0.004))).astype(float)
    return tri, c


def test_layer_cell_refines_the_thin_layer_and_not_the_thick_column():
    """Issue 50, ``model.layer_cell``: on strips of h_min the column (h = 0.1 m) is thick and
    the tongue (h ≈ 5 mm < 2 h_min) thin; the box meshed with the second level has cells of
    about h_l = 2.5 mm in the tongue and keeps h_min = 1 cm in the column's body; without it
    (``layer_cell`` None) the tongue has cells of h_min."""
    from dpcollapse.domain.adaptive_box import thin_layer_cells

    h_min, h_l = 0.01, 0.0025
    tri, c = _column_and_tongue(h_min)
    thin = thin_layer_cells(tri, c, 0.01, h_min, 2 * h_min)
    x, y = tri.mean(axis=1).T
    assert thin[(x > 0.12) & (x < 0.28) & (c > 0)].all()
    assert not thin[x < 0.09].any()          # the column's strips
    granular, seeds = tri[c > 0.01].mean(axis=1), tri[thin].mean(axis=1)
    sizes = {}
    for layer in (h_l, None):
        size = SizeField(h_min, 0.05, band=4 * h_min, grading=0.3, layer_cell=layer)
        mesh = adaptive_box(MPI.COMM_SELF, 0.4, 0.2, size, granular, seeds).mesh
        new = owned_triangles(mesh)
        h, (mx, my) = equivalent_size(new), new.mean(axis=1).T
        tongue = (mx > 0.15) & (mx < 0.25) & (my < 0.004)
        body = (mx > 0.02) & (mx < 0.06) & (my > 0.03) & (my < 0.07)
        far = (mx > 0.35) & (my > 0.1)
        sizes[layer] = (float(h[tongue].max()), float(np.median(h[body])), float(h[far].min()))
    assert sizes[h_l][0] < 1.5 * h_l                 # the tongue: the second level
    assert sizes[h_l][1] > 0.8 * h_min               # the column's body: h_min, not h_l
    assert sizes[h_l][2] > 2 * h_min                 # far from both: still coarse
    assert sizes[None][0] > 3 * h_l                  # off: the tongue in cells of h_min
    assert sizes[None][1] == pytest.approx(sizes[h_l][1], rel=0.1)


@pytest.mark.parametrize("over, message", [
    (["model.min_cell=0.004", "model.layer_cell=0.004"], "model.layer_cell = 0.004: must be in"),
    (["model.min_cell=0.004", "model.layer_cell=0.0002"], "model.layer_cell = 0.0002: must be in"),
    (["model.layer_cell=0.001"], "model.layer_cell = 0.001: needs the adaptive box"),
])
def test_layer_cell_out_of_range_is_one_line(over, message):
    with pytest.raises(ConfigError, match=message):
        load_config(CONFIG, over)


@pytest.mark.mpi
def test_thin_layer_columns_are_summed_over_the_ranks():
    """The strips' columns of ``thin_layer_cells`` are those of the whole box when each rank
    holds a share of the cells (drawn at random): the same mask as on one rank. Thin below
    7 cm: the column (0.1 m) is thick, each rank's half of it (5 cm) would not be."""
    from dpcollapse.domain.adaptive_box import thin_layer_cells

    comm = MPI.COMM_WORLD
    tri, c = _column_and_tongue(0.01)
    whole = thin_layer_cells(tri, c, 0.01, 0.01, 0.07)
    x = tri.mean(axis=1)[:, 0]
    assert whole[(x > 0.12) & (c > 0)].all() and not whole[x < 0.09].any()
    mine = np.random.default_rng(5).integers(comm.size, size=len(tri)) == comm.rank
    np.testing.assert_array_equal(thin_layer_cells(tri[mine], c[mine], 0.01, 0.01, 0.07, comm),
                                  whole[mine])
