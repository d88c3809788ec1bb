"""Sizes refused at check time: the cells of a run's first mesh estimated from the finest
cell size it actually uses, and its memory against the machine's (issue 47).

Triangles of side h cover √3/4 h² each, so a region of area A meshed at h has about
N = A / (√3/4 h²) cells (:func:`dpcollapse.config.models.mesh_cells`). A size that gmsh
grades linearly from h_f on a boundary piece of length ℓ to h over a distance δ adds the
cells of the half plane around the piece, h = h_f + k ρ at the distance ρ from it
(a line of length ℓ + πρ), k = (h − h_f)/δ:

    N_graded = ∫₀^δ (ℓ + πρ) dρ / (√3/4 (h_f + k ρ)²)
             = ℓ δ / (√3/4 h_f h) + π/(√3/4 k²) (ln(h/h_f) + h_f/h − 1)

(:func:`graded_cells`; measured against gmsh on the silo and the hopper, orifice cells of
2e-5 … 2.5e-3 m: 0.7 … 1.3 times the cells gmsh made, docs/benchmarks/2026-12-07-sizes.md): the orifice
of a silo (``geometry.orifice_mesh_size``), the free
surface of the moving mesh (``geometry.surface_mesh_size``). The adaptive two-phase box
(``model.min_cell`` < ``model.max_cell``) has h_min in the granular material (area A_g,
perimeter P) and in its band b = ``refine_band`` h_min, grows at the rate
g = ``refine_grading`` beyond it to h_max, and h_max elsewhere in the box (area A_b):

    N = A_g/(√3/4 h_min²) + P b/(√3/4 h_min²) + P (1/h_min − 1/h_max)/(√3/4 g) + A_b/(√3/4 h_max²)

at t = 0 (:func:`adaptive_box_cells`). :func:`first_mesh` picks the estimate of a config;
the memory is N × ``MEMORY_PER_CELL``; a run is refused (:func:`refuse_too_large`:
``ConfigError``, exit 2, one line with the estimate) when N exceeds
``MAX_GRID_CELLS`` or its memory the machine's (:func:`machine_memory`: the physical memory,
or the cgroup's limit when lower).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from dpcollapse.config.fields import _fmt
from dpcollapse.config.models import MAX_GRID_CELLS, MEMORY_PER_CELL, box_cells, mesh_cells
from dpcollapse.errors import ConfigError

#: Area of an equilateral triangle of side 1 [-].
_TRIANGLE = math.sqrt(3.0) / 4.0


def graded_cells(length: float, depth: float, fine: float, coarse: float) -> float:
    """The module's N_graded: the size grows linearly from ``fine`` (on a boundary piece of
    ``length``) to ``coarse`` over the distance ``depth`` (0 when ``fine`` >= ``coarse``)."""
    if fine >= coarse:
        return 0.0
    k = (coarse - fine) / depth
    ends = math.pi / (_TRIANGLE * k * k) * (math.log(coarse / fine) + fine / coarse - 1.0)
    return length * depth / (_TRIANGLE * fine * coarse) + ends


def adaptive_box_cells(granular_area: float, perimeter: float, box_area: float, min_cell: float,
                       max_cell: float, band: float, grading: float) -> float:
    """The module's N of the interface-adaptive box at t = 0 (``band`` in min_cell)."""
    fine = (granular_area + perimeter * band * min_cell) / (_TRIANGLE * min_cell ** 2)
    graded = perimeter * (1.0 / min_cell - 1.0 / max_cell) / (_TRIANGLE * grading)
    return fine + max(graded, 0.0) + box_area / (_TRIANGLE * max_cell ** 2)


def machine_memory() -> float | None:
    """The memory this process may use [bytes]: physical memory, or the cgroup v2/v1 limit
    when lower; None when unknown."""
    sizes = []
    try:
        sizes.append(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        pass
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(path).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 1 << 60:
            sizes.append(int(text))
    return float(min(sizes)) if sizes else None


@dataclass(frozen=True)
class MeshEstimate:
    """The cells of a run's first mesh, what they cover and the keys that set their size."""

    cells: float
    keys: str          # e.g. "geometry.mesh_size = 1e-05"
    what: str          # e.g. "the half vessel 0.1 x 0.22 m"
    finest: float      # the finest cell size [m] the estimate used

    @property
    def memory(self) -> float:
        """[bytes]: cells × MEMORY_PER_CELL."""
        return self.cells * MEMORY_PER_CELL


def refuse_too_large(estimate: MeshEstimate) -> None:
    """ConfigError naming the estimate's keys when its cells exceed MAX_GRID_CELLS or their
    memory the machine's; the estimate is in the line."""
    cells, memory, available = estimate.cells, estimate.memory, machine_memory()
    too_many = not cells <= MAX_GRID_CELLS          # also nan/inf
    too_big = available is not None and not memory <= available
    if not (too_many or too_big):
        return
    limit = (f"more than {MAX_GRID_CELLS} cells" if too_many
             else f"more than this machine's {available / 1e9:.3g} GB")
    raise ConfigError(f"{estimate.keys}: about {cells:.3g} cells of {estimate.finest:.3g} m and "
                      f"coarser for {estimate.what} (about {memory / 1e9:.3g} GB), {limit}; must "
                      "be a coarser mesh or a smaller domain")


def first_mesh(cfg) -> MeshEstimate:
    """The estimate for ``cfg``'s first mesh: the moving mesh of the mass (model.name
    stokes), the two-phase box (uniform or adaptive) or a scene's own vessel (the silo)."""
    g = cfg.geometry
    if cfg.model.name != "two_phase":
        fine = g.surface_mesh_size if getattr(g, "surface_mesh_size", None) is not None else g.mesh_size
        fine = min(fine, g.mesh_size)
        key = "surface_mesh_size" if fine < g.mesh_size else "mesh_size"
        return MeshEstimate(moving_mesh_cells(g), f"geometry.{key} = {_fmt(fine)}",
                            f"the {g.area:.4g} m^2 of the mass", fine)
    if getattr(g, "own_vessel", False):
        return _vessel(g)
    return _box(g, cfg.model)


def _box(g, m) -> MeshEstimate:
    """The two-phase box: uniform at its finest size (``model.min_cell`` = ``max_cell`` when
    set, else ``geometry.mesh_size``), or adaptive (``model.min_cell`` < ``max_cell``)."""
    box = f"the {m.box_length:g} x {m.box_height:g} m box"
    coarse = m.max_cell if m.max_cell is not None else g.mesh_size
    if m.min_cell is not None and m.min_cell < coarse:
        length, height = g.footprint          # the material's sides in the fluid
        cells = adaptive_box_cells(g.area, length + height, m.box_length * m.box_height,
                                   m.min_cell, coarse, m.refine_band, m.refine_grading)
        return MeshEstimate(cells, f"model.min_cell = {_fmt(m.min_cell)}",
                            f"{box} refined around the material", m.min_cell)
    key, h = (("model.min_cell", m.min_cell) if m.min_cell is not None
              else ("geometry.mesh_size", g.mesh_size))
    return MeshEstimate(box_cells(m.box_length, m.box_height, h),
                        f"model.box_length = {_fmt(m.box_length)}, model.box_height = "
                        f"{_fmt(m.box_height)}, {key} = {_fmt(h)}", box, h)


def _vessel(g) -> MeshEstimate:
    """A scene's own vessel (the silo, the hopper): the orifice's keys when its cells are
    most of them."""
    cells = silo_cells(g)
    what = f"the half vessel {0.5 * g.width:g} x {g.bin_height:g} m"
    if g.orifice_mesh_size is not None and cells > 2.0 * silo_cells(g, orifice=False):
        return MeshEstimate(cells, f"geometry.orifice_mesh_size = {_fmt(g.orifice_mesh_size)}",
                            what, g.orifice_mesh_size)
    return MeshEstimate(cells, f"geometry.mesh_size = {_fmt(g.mesh_size)} (geometry.width = "
                        f"{_fmt(g.width)}, geometry.bin_height = {_fmt(g.bin_height)})", what,
                        min(g.mesh_size, g.orifice_mesh_size or g.mesh_size))


def moving_mesh_cells(g) -> float:
    """The moving (ALE) mesh of the mass at t = 0: ``geometry.mesh_size`` over its area, and
    the free surface's strip of ``geometry.surface_mesh_size`` (length: at most the
    footprint's length + height; depth: the smaller of the two)."""
    cells = mesh_cells(g.area, g.mesh_size)
    fine = getattr(g, "surface_mesh_size", None)
    if fine is not None:
        length, height = g.footprint
        cells += graded_cells(length + height, min(length, height), fine, g.mesh_size)
    return cells


def silo_cells(g, orifice: bool = True) -> float:
    """The half vessel of a silo/hopper: ``geometry.mesh_size`` over its area, and the cells
    graded from ``geometry.orifice_mesh_size`` on the half orifice to ``mesh_size`` at the
    nearer of the bottom's corner and the open top."""
    r, d = 0.5 * g.width, 0.5 * g.orifice_width
    vessel = r * g.bin_height - 0.5 * (r - d) * min(g.hopper_top, g.bin_height)
    cells = mesh_cells(vessel, g.mesh_size)
    if orifice and g.orifice_mesh_size is not None:
        cells += graded_cells(d, min(r - d, g.bin_height), g.orifice_mesh_size, g.mesh_size)
    return cells
