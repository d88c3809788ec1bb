"""Remeshing a domain of several material regions so that their interface stays conforming.

The erodible layer (5 mm) is thinner than the cells (1 cm): a remesh of the outer boundary
alone would cut its cells through the interface, and the centroid rule of
``geometry.regions.carry_regions`` would then lose a quarter of the layer's area (measured,
tests/unit/test_erodible.py). So, when the cells carry two tags that meet along one curve:

1. the interface is chained from the cells' tags (``geometry.regions.interface_chain``);
2. the boundary polygon is gathered and resampled as for a single region (``ale.remesh``),
   with the interface's two end vertices kept fixed;
3. the polygon is cut along the interface into one polygon per region
   (``geometry.regions.split_polygon``) and meshed as one conforming mesh
   (``geometry.mesher.mesh_regions``), the cells tagged by region.

With ``numerics.remesh_surgery`` or ``numerics.remesh_conserve_area`` two regions are
instead rebuilt region by region (``geometry.region_surgery``): a nose that lands on the
layer merges into it by the surgery of the column (the mass rebuilt as the union minus the
layer), pockets between the mass and the layer are kept or closed by the same rule, and the
area of each region is put back (``conserve_area``); each surgery is appended to
``surgeries`` with its per-region area changes.

Otherwise (one region, or an interface that is not one open chain between two boundary
vertices) the outer boundary is remeshed alone and each new cell takes the tag of the old
cell that contains its centroid (``carry_regions``).
"""

from __future__ import annotations

import logging

import numpy as np

from dpcollapse import parallel
from dpcollapse.ale.remesh import boundary_polygon, remesh_domain
from dpcollapse.geometry.mesher import (
    INTERFACE,
    SURFACE,
    TaggedMesh,
    boundary_edges,
    mesh_regions,
)
from dpcollapse.geometry.polygon import resample
from dpcollapse.geometry.region_surgery import rebuild_regions
from dpcollapse.geometry.regions import (
    carry_regions,
    gather_regions,
    interface_chain,
    split_polygon,
)

log = logging.getLogger(__name__)


def remesh_regions(tagged: TaggedMesh, mesh_size: float, surface_mesh_size: float | None,
                   max_area_change: float, trim_thickness: float = 0.0,
                   conserve_area: bool = False, surgery: bool = False,
                   surgeries: list | None = None,
                   axisymmetric: bool = False,
                   trim_face_slope: float | None = None,
                   background=None) -> tuple[TaggedMesh, float, int]:
    """A new mesh of the current domain with its cell tags: (mesh, polygon area change,
    number of boundary vertices); see the module docstring. With one region the front
    film trim, the surgery of contacts (``surgery``; each one done appended to
    ``surgeries``) and the area restoration of ``ale.remesh.remesh_domain`` apply; with two
    the surgery and each region's area restoration of ``geometry.region_surgery`` (no film
    trim: the layer itself is thinner than the cells; ``trim_face_slope``: the trim's cut
    face, ``remesh_domain``). ``axisymmetric``: the volume of
    the body of revolution is what is put back (``remesh_domain``). ``background``: the
    size inside from a size field, one region only (``remesh_domain``)."""
    comm = tagged.mesh.comm
    field = gather_regions(tagged)
    tags = None if field is None else np.rint(field.values[:, 0, 0]).astype(np.int32)
    if tags is None or len(np.unique(tags)) < 2:
        new, d_area, nverts = remesh_domain(tagged, mesh_size, surface_mesh_size, max_area_change,
                                            trim_thickness, conserve_area, surgery, surgeries,
                                            axisymmetric=axisymmetric,
                                            trim_face_slope=trim_face_slope, background=background)
        return (new if field is None else carry_regions(tagged, new, field)), d_area, nverts
    if (surgery or conserve_area) and not axisymmetric:
        return _rebuilt_regions(tagged, field, tags, mesh_size, surface_mesh_size,
                                max_area_change, conserve_area, surgery, surgeries)
    poly = boundary_polygon(tagged)
    regions, d_area, nverts = None, 0.0, 0
    if comm.rank == 0:
        regions, d_area, nverts = _split_regions(poly.polygon, field.vertices, tags, mesh_size,
                                                 surface_mesh_size, max_area_change)
    ok = comm.bcast(regions is not None, root=0)
    d_area, nverts = comm.bcast((d_area, nverts), root=0)
    if not ok:
        log.warning("remesh: the material regions do not meet along one interface between two "
                    "boundary vertices; their cells are re-tagged by centroid (staircase)")
        new, d_area, nverts = remesh_domain(tagged, mesh_size, surface_mesh_size, max_area_change,
                                            trim_thickness, conserve_area,
                                            axisymmetric=axisymmetric)
        return carry_regions(tagged, new, field), d_area, nverts
    return (mesh_regions(comm, regions if comm.rank == 0 else None, mesh_size, surface_mesh_size),
            d_area, nverts)


def _split_regions(poly, triangles, tags, mesh_size, surface_mesh_size, max_area_change):
    """On rank 0: (regions for ``mesh_regions`` or None, area change, #boundary vertices)."""
    chain = interface_chain(triangles, tags)
    if chain is None:
        return None, 0.0, 0
    fixed = [int(i) for end in (chain[0], chain[-1])
             for i in np.flatnonzero(np.all(poly.points == end, axis=1))]
    if len(fixed) != 2:
        return None, 0.0, 0
    hs = surface_mesh_size or mesh_size
    new, d_area = resample(poly, lambda tag: hs if tag == SURFACE else mesh_size,
                           max_area_change, fixed=fixed)
    low, high = int(tags.min()), int(tags.max())
    regions = split_polygon(new.points, new.edge_tags, chain, low, high, INTERFACE)
    return regions, d_area, len(new.points)


def _rebuilt_regions(tagged, field, tags, mesh_size, surface_mesh_size, max_area_change,
                     conserve_area, surgery, surgeries):
    """Two regions rebuilt region by region, with the surgery of contacts and each region's
    area put back (``geometry.region_surgery.rebuild_regions``)."""
    comm = tagged.mesh.comm
    edges, edge_tags = boundary_edges(tagged)
    hs = surface_mesh_size or mesh_size

    def size_of(tag: int) -> float:
        return hs if tag == SURFACE else mesh_size

    def build():
        return rebuild_regions(field.vertices, tags, edges, edge_tags, mesh_size, size_of,
                               max_area_change, conserve_area, surgery)

    regions, d_area, nverts, done = parallel.on_root(comm, build)
    if done is not None and surgeries is not None:
        surgeries.append(done)
    return (mesh_regions(comm, regions if comm.rank == 0 else None, mesh_size,
                         surface_mesh_size), d_area, nverts)
