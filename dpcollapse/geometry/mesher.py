"""Triangulate a tagged boundary polygon with gmsh and hand the mesh to DOLFINx.

Used for the initial trapezoid and for every remesh, so both share one code path. The
gmsh model is built on rank 0 only; ``model_to_mesh`` distributes the mesh. Every
polygon vertex becomes a gmsh point, so the meshed boundary contains the polygon exactly
(gmsh may add nodes *on* long edges, which changes neither the area nor the shape).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from dpcollapse import compat

#: Physical facet tags shared by the whole project.
BED, WALL, SURFACE, LEFT, RIGHT, ORIFICE = 1, 2, 3, 4, 5, 6
TAG_NAMES = {BED: "bed", WALL: "wall", SURFACE: "surface", LEFT: "left", RIGHT: "right",
             ORIFICE: "orifice"}
DOMAIN = 10
#: Cell tag of an erodible layer under the mass (same material; a second region). Interior
#: polygon edges (between two regions) carry the edge tag INTERFACE and no facet tag.
LAYER = 11
INTERFACE = 0
REGION_NAMES = {DOMAIN: "granular_mass", LAYER: "erodible_layer"}
#: Polygon edges up to this many target sizes long get their number of mesh edges from
#: ``boundary_segments``; longer ones (the initial shape's sides) are split by gmsh at h.
SINGLE_SEGMENT = 1.5
#: Largest length ratio of a boundary mesh edge to its shortest polygon neighbour.
BOUNDARY_GRADING = 2.0


@dataclass
class TaggedMesh:
    """A DOLFINx mesh with its boundary facets tagged (BED, WALL, SURFACE, LEFT, RIGHT) and
    its cells tagged by material region (DOMAIN for the granular mass: the initial mesh, a
    remesh and a landing rebuild keep them; a mesh read back from a checkpoint has None)."""

    mesh: object
    facet_tags: object
    cell_tags: object = None


@contextmanager
def gmsh_session():
    """Initialise gmsh quietly on this rank and finalise it afterwards.

    gmsh never asks: ``General.NoPopup`` answers its questions with their default (its
    "very large mesh. Do you really want to continue?" printed the question and read the
    answer from stdin, issue 47), and stdin is /dev/null while the session lasts."""
    import gmsh

    with _stdin_closed():
        gmsh.initialize(**_quiet_initialize_options(gmsh))
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.Verbosity", 0)
        gmsh.option.setNumber("General.NoPopup", 1)
        try:
            yield gmsh
        finally:
            gmsh.finalize()


def _quiet_initialize_options(gmsh) -> dict:
    """No user configuration files (their options could re-enable questions); where gmsh
    has it (>= 4.10), ``interruptible=False``: gmsh would otherwise put SIGINT back to its
    default action (killed at once, no run.json) while it runs."""
    import inspect

    names = inspect.signature(gmsh.initialize).parameters
    options = {"readConfigFiles": False} if "readConfigFiles" in names else {}
    if "interruptible" in names:
        options["interruptible"] = False
    return options


@contextmanager
def _stdin_closed():
    """File descriptor 0 reads /dev/null (end of file at once) inside the block."""
    import os

    try:
        saved = os.dup(0)
    except OSError:          # no stdin at all: nothing can be read from it
        yield
        return
    null = os.open(os.devnull, os.O_RDONLY)
    try:
        os.dup2(null, 0)
        yield
    finally:
        os.dup2(saved, 0)
        os.close(saved)
        os.close(null)


def build_polygon_model(gmsh, points: np.ndarray, edge_tags: np.ndarray,
                        size: Callable[[np.ndarray, int], float],
                        holes: list | None = None, background=None) -> None:
    """Add a plane surface bounded by ``points`` (CCW, edge i from point i to i+1), with
    ``holes`` (a list of (points, edge_tags) loops inside it; pockets kept by
    ``geometry.surgery``).

    ``size(point, tag)`` gives the target mesh size at a vertex given the tag of the
    edge leaving it (the smaller of the two adjacent edges' sizes is used).
    ``background`` (triangles (n, 3, 2), sizes (n, 3) [m], linear in each triangle: an
    ``ale.size_field.SizeField``'s arrays) sets the size inside instead of the boundary's
    (``set_background_sizes``).
    """
    gmsh.model.add("domain")
    occ = gmsh.model.geo
    loops, all_lines, all_tags = [], [], []
    for loop_points, loop_tags in [(points, edge_tags)] + list(holes or []):
        loop_points, tags = np.asarray(loop_points, dtype=float), np.asarray(loop_tags)
        n = len(loop_points)
        pts = []
        for i, (x, y) in enumerate(loop_points):
            h = min(size(loop_points[i], int(tags[i])), size(loop_points[i], int(tags[i - 1])))
            pts.append(occ.addPoint(float(x), float(y), 0.0, h))
        lines = [occ.addLine(pts[i], pts[(i + 1) % n]) for i in range(n)]
        for i, segments in enumerate(boundary_segments(loop_points, tags, size)):
            if segments:
                occ.mesh.setTransfiniteCurve(lines[i], segments + 1)
        loops.append(occ.addCurveLoop(lines))
        all_lines += lines
        all_tags += [int(t) for t in tags]
    surface = occ.addPlaneSurface(loops)
    occ.synchronize()
    lines, tags, n = all_lines, np.asarray(all_tags), len(all_lines)
    for tag in sorted(set(int(t) for t in tags)):
        group = [lines[i] for i in range(n) if tags[i] == tag]
        gmsh.model.addPhysicalGroup(1, group, tag)
        gmsh.model.setPhysicalName(1, tag, TAG_NAMES.get(tag, str(tag)))
    gmsh.model.addPhysicalGroup(2, [surface], DOMAIN)
    gmsh.model.setPhysicalName(2, DOMAIN, "granular_mass")
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    # boundary edges up to 1.5 h long (see boundary_segments) must not coarsen the inside
    sizes = [size(np.asarray(points)[i], int(edge_tags[i])) for i in range(len(points))]
    gmsh.option.setNumber("Mesh.MeshSizeMax", float(max(sizes)))
    if background is not None:
        set_background_sizes(gmsh, *background)
    gmsh.model.mesh.generate(2)


def set_background_sizes(gmsh, triangles: np.ndarray, sizes: np.ndarray) -> None:
    """The mesh size inside the surface from a triangulated size field (a gmsh list-based
    view, "PostView" background field), no longer extended from the boundary; bounded by the
    field's own range."""
    tri, h = np.asarray(triangles, dtype=float), np.asarray(sizes, dtype=float)
    data = np.concatenate([tri[:, :, 0], tri[:, :, 1], np.zeros((len(tri), 3)), h], axis=1)
    view = gmsh.view.add("mesh size")
    gmsh.view.addListData(view, "ST", len(tri), data.ravel().tolist())
    field = gmsh.model.mesh.field.add("PostView")
    gmsh.model.mesh.field.setNumber(field, "ViewTag", view)
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMin", float(h.min()))
    gmsh.option.setNumber("Mesh.MeshSizeMax", float(h.max()))


def boundary_segments(points: np.ndarray, tags: np.ndarray,
                      size: Callable[[np.ndarray, int], float]) -> list[int]:
    """Number of mesh edges for each polygon edge i (points i → i+1); 0: let gmsh choose.

    gmsh splits a line as soon as it is slightly longer than its size (⌊∫ds/h + 1.99⌋
    nodes), which halved the boundary spacing of every remeshed polygon (its edges are
    0.5–1.5 h long) and, with the size extended from the boundary, doubled the cell count.
    So an edge of length L ≤ SINGLE_SEGMENT·h gets ⌈L / (BOUNDARY_GRADING·L_min)⌉ mesh
    edges, L_min the shorter of its neighbours: one edge, unless it is more than twice as
    long as a neighbour (a short edge next to a long one, e.g. at the tip of a
    landed nose, leaves only a sliver triangle between them).
    """
    pts = np.asarray(points, dtype=float)
    n = len(pts)
    lengths = np.hypot(*(np.roll(pts, -1, axis=0) - pts).T)
    out = []
    for i in range(n):
        h = size(pts[i], int(tags[i]))
        if lengths[i] > SINGLE_SEGMENT * h:
            out.append(0)
            continue
        shortest = min(lengths[i - 1], lengths[(i + 1) % n])
        out.append(max(1, int(math.ceil(lengths[i] / (BOUNDARY_GRADING * shortest) - 1e-9))))
    return out


def size_function(mesh_size: float, surface_mesh_size: float | None):
    """Target size: ``surface_mesh_size`` on the free surface, ``mesh_size`` elsewhere."""
    hs = surface_mesh_size or mesh_size

    def size(point: np.ndarray, tag: int) -> float:
        return hs if tag == SURFACE else mesh_size

    return size


def mesh_polygon(comm: MPI.Comm, points: np.ndarray | None, edge_tags: np.ndarray | None,
                 mesh_size: float, surface_mesh_size: float | None = None,
                 size: Callable[[np.ndarray, int], float] | None = None,
                 holes: list | None = None, background=None) -> TaggedMesh:
    """Mesh the polygon given on rank 0 (other ranks may pass None), with its ``holes``
    ((points, edge tags) loops), over ``comm``; ``size`` (point, edge tag) → target size
    replaces ``size_function`` when given; ``background``: the size inside
    (``build_polygon_model``)."""
    size = size or size_function(mesh_size, surface_mesh_size)
    return _mesh_on_root(comm, lambda gmsh: build_polygon_model(
        gmsh, np.asarray(points), np.asarray(edge_tags), size, holes, background))


#: Floor of the time bound of one gmsh generation [s] (``DPCOLLAPSE_MESH_TIME_LIMIT``); the
#: bound is the larger of it and GENERATION_MARGIN times the longest generation so far.
MESH_TIME_LIMIT = 120.0
GENERATION_MARGIN = 30.0
_longest_generation = 0.0


def generation_limit() -> float:
    """Seconds one gmsh generation may take before the run is declared a mesh failure."""
    import os

    try:
        floor = float(os.environ.get("DPCOLLAPSE_MESH_TIME_LIMIT", MESH_TIME_LIMIT))
    except ValueError:
        floor = MESH_TIME_LIMIT
    return max(floor, GENERATION_MARGIN * _longest_generation)


def generate_bounded(gmsh, build: Callable) -> None:
    """``build(gmsh)`` (a gmsh model built and meshed), bounded in time: gmsh's frontal mesher
    can loop forever on a nearly degenerate boundary, or take hours on a mesh far too fine;
    past :func:`generation_limit` a watchdog thread ends the job with exit 4 (gmsh's Python
    API is ctypes, which releases the GIL, so a Python thread runs meanwhile)."""
    import time

    from dpcollapse import parallel

    global _longest_generation
    limit = generation_limit()
    t0 = time.perf_counter()
    with parallel.time_limit(limit, 4, lambda s: (
            f"meshing did not finish within {s:g} s (gmsh stuck on a nearly degenerate "
            "boundary, or asked for more cells than it makes in that time): a smaller "
            "time.dt or geometry.mesh_size, or a larger numerics.remesh_min_angle (remesh "
            "sooner), may carry a degenerating boundary further")):
        build(gmsh)
    _longest_generation = max(_longest_generation, time.perf_counter() - t0)


def _mesh_on_root(comm: MPI.Comm, build: Callable) -> TaggedMesh:
    """Build and generate the gmsh model on rank 0 (``build(gmsh)``), bounded in time
    (:func:`generate_bounded`: exit 4 instead of a hang), its failure shared with every
    rank; then distribute over ``comm``."""
    from dpcollapse import parallel

    def generate(gmsh):
        generate_bounded(gmsh, build)

    if comm.rank == 0:
        with gmsh_session() as gmsh:
            parallel.on_root(comm, lambda: generate(gmsh))
            mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, comm, 0, gdim=2)
    else:
        parallel.on_root(comm, lambda: None)
        mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(None, comm, 0, gdim=2)
    mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
    return TaggedMesh(mesh, facet_tags, cell_tags)


def build_regions_model(gmsh, regions: list[tuple[np.ndarray, np.ndarray, int]],
                        size: Callable[[np.ndarray, int], float]) -> None:
    """Add one plane surface per region ``(points, edge_tags, cell_tag)`` (each CCW, edge i
    from point i to i+1), sharing the gmsh points and lines of coincident vertices and
    edges, so that the regions' meshes are conforming along their common edges (tagged
    INTERFACE: interior, no physical line). Physical lines: the other edge tags; physical
    surfaces: the regions' cell tags. A region may carry a fourth item, its holes (a list
    of (points, edge_tags) loops: pockets a surgery kept inside it)."""
    gmsh.model.add("domain")
    geo = gmsh.model.geo
    point_ids: dict[tuple[float, float], int] = {}
    line_ids: dict[tuple[int, int], int] = {}
    groups: dict[int, list[int]] = {}
    surfaces: dict[int, list[int]] = {}
    def curve_loop(points, tags):
        points, tags = np.asarray(points, dtype=float), np.asarray(tags)
        n = len(points)
        ids = []
        for i, (x, y) in enumerate(points):
            key = (float(x), float(y))
            if key not in point_ids:
                h = min(size(points[i], int(tags[i])), size(points[i], int(tags[i - 1])))
                point_ids[key] = geo.addPoint(key[0], key[1], 0.0, h)
            ids.append(point_ids[key])
        loop = []
        segments = boundary_segments(points, tags, size)
        for i in range(n):
            a, b = ids[i], ids[(i + 1) % n]
            if (b, a) in line_ids:
                loop.append(-line_ids[(b, a)])
                continue
            line_ids[(a, b)] = line = geo.addLine(a, b)
            if segments[i]:        # short edges: as in build_polygon_model
                geo.mesh.setTransfiniteCurve(line, segments[i] + 1)
            loop.append(line)
            if int(tags[i]) != INTERFACE:
                groups.setdefault(int(tags[i]), []).append(line)
        return geo.addCurveLoop(loop)

    for points, tags, cell_tag, *holes in regions:
        loops = [curve_loop(points, tags)] + [curve_loop(*h) for h in (holes[0] if holes else [])]
        surfaces.setdefault(int(cell_tag), []).append(geo.addPlaneSurface(loops))
    geo.synchronize()
    for tag in sorted(groups):
        gmsh.model.addPhysicalGroup(1, groups[tag], tag)
        gmsh.model.setPhysicalName(1, tag, TAG_NAMES.get(tag, str(tag)))
    for tag in sorted(surfaces):
        gmsh.model.addPhysicalGroup(2, surfaces[tag], tag)
        gmsh.model.setPhysicalName(2, tag, REGION_NAMES.get(tag, str(tag)))
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    sizes = [size(p, int(t)) for points, tags, *_ in regions for p, t in zip(points, tags)]
    gmsh.option.setNumber("Mesh.MeshSizeMax", float(max(sizes)))
    gmsh.model.mesh.generate(2)


def mesh_regions(comm: MPI.Comm, regions: list | None, mesh_size: float,
                 surface_mesh_size: float | None = None) -> TaggedMesh:
    """Mesh the regions (``build_regions_model``; given on rank 0, None elsewhere) over
    ``comm``: one conforming mesh, cells tagged by region."""
    size = size_function(mesh_size, surface_mesh_size)
    return _mesh_on_root(comm, lambda gmsh: build_regions_model(gmsh, regions, size))


def write_regions_msh(path, regions: list, mesh_size: float,
                      surface_mesh_size: float | None = None) -> None:
    """Write the gmsh mesh of the regions to a ``.msh`` file (serial)."""
    with gmsh_session() as gmsh:
        build_regions_model(gmsh, regions, size_function(mesh_size, surface_mesh_size))
        gmsh.write(str(path))


def write_polygon_msh(path, points: np.ndarray, edge_tags: np.ndarray, mesh_size: float,
                      surface_mesh_size: float | None = None,
                      size: Callable[[np.ndarray, int], float] | None = None) -> None:
    """Write the gmsh mesh of a polygon to a ``.msh`` file (serial)."""
    with gmsh_session() as gmsh:
        build_polygon_model(gmsh, points, edge_tags,
                            size or size_function(mesh_size, surface_mesh_size))
        gmsh.write(str(path))


def read_msh(comm: MPI.Comm, path) -> TaggedMesh:
    """Read a gmsh ``.msh`` with physical facet groups BED=1, WALL=2, SURFACE=3.

    (DOLFINx 0.5.2's ``read_from_msh`` is broken — it returns an undefined name —
    so the file is merged into our own gmsh session on rank 0.)
    """
    from dpcollapse.errors import ConfigError

    if comm.rank == 0:
        with gmsh_session() as gmsh:
            problem = comm.bcast(_msh_problem(gmsh, path), root=0)
            if problem:
                raise ConfigError(problem)
            mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, comm, 0, gdim=2)
    else:
        problem = comm.bcast(None, root=0)
        if problem:
            raise ConfigError(problem)
        mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(None, comm, 0, gdim=2)
    mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
    return TaggedMesh(mesh, facet_tags, cell_tags)


def _msh_problem(gmsh, path) -> str | None:
    """Merge ``path`` into the gmsh session; what makes it unusable as a scene mesh, or None:
    not a gmsh file, no physical surface (the cells) or no physical line group (the tagged
    boundary; which tags a scene needs is the scene's business)."""
    try:
        gmsh.merge(str(path))
    except Exception as exc:      # gmsh raises a bare Exception with its parser's message
        return f"geometry.mesh_file = {path}: not a gmsh mesh ({' '.join(str(exc).split())})"
    groups = gmsh.model.getPhysicalGroups()
    surfaces = [tag for dim, tag in groups if dim == 2]
    lines = sorted(tag for dim, tag in groups if dim == 1)
    if not surfaces:
        return (f"geometry.mesh_file = {path}: no physical surface group (the mass's cells "
                "must be in one)")
    if not lines:
        return (f"geometry.mesh_file = {path}: no physical line group (the boundary tags: "
                f"BED={BED}, WALL={WALL}, SURFACE={SURFACE}, LEFT={LEFT}, RIGHT={RIGHT})")
    return None


def boundary_edges(tagged: TaggedMesh) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The tagged boundary edges (m, 2, 2) and their tags (m,) of every rank, on rank 0
    (None elsewhere)."""
    mesh, ft = tagged.mesh, tagged.facet_tags
    nodes = compat.entities_to_geometry(mesh, 1, ft.indices)
    edges = mesh.geometry.x[:, :2][nodes] if len(ft.indices) else np.zeros((0, 2, 2))
    gathered = mesh.comm.gather((edges, np.asarray(ft.values)), root=0)
    if mesh.comm.rank != 0:
        return None, None
    return (np.concatenate([e for e, _ in gathered]),
            np.concatenate([t for _, t in gathered]))
