"""Hand-written checkpoints (this DOLFINx build has no ADIOS2).

A checkpoint holds the whole current mesh (global node coordinates, cells, their material
region tags, tagged boundary edges), the accepted state uⁿ (P2) and pⁿ (P1) cell by cell, and the
time-loop counters.
It is written by rank 0 to ``checkpoint.npz`` through a temporary file and a rename, so
the file on disk is always a complete checkpoint. Because fields are stored cell by cell
on the global mesh, a run may be resumed on a different number of MPI ranks.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

import numpy as np

from dpcollapse import compat
from dpcollapse.geometry.mesher import DOMAIN, TaggedMesh
from dpcollapse.geometry.regions import region_field, tag_cells
from dpcollapse.io.durable import fsync_path
from dpcollapse.transfer import CellwiseField

#: the loaded state's entry listing the histories the checkpoint did not carry (an older
#: version's checkpoint): the resumed steps then differ from the uninterrupted run's, and the
#: resume says so (a log line and run.json's "resume")
NOT_RESTORED = "not_restored"


def take_not_restored(extra: dict) -> list[str]:
    """The histories a checkpoint did not carry (``NOT_RESTORED``: an older version's),
    removed from the loaded state's ``extra`` and said in one warning line: the resumed
    steps then differ from an uninterrupted run's."""
    lost = extra.pop(NOT_RESTORED, [])
    if lost:
        logging.getLogger("dpcollapse").warning(
            "the checkpoint lacks %s: the resumed steps differ from an uninterrupted run's",
            "; ".join(lost))
    return lost


def note_not_restored(state: dict, what: str) -> None:
    """Record in a loaded checkpoint's ``state`` that ``what`` could not be restored."""
    state.setdefault(NOT_RESTORED, []).append(what)


def _owned_cell_tags(tagged: TaggedMesh) -> np.ndarray | None:
    """The region tag of each owned cell (None when the mesh has no cell tags)."""
    ct = tagged.cell_tags
    if ct is None:
        return None
    n = compat.num_owned_cells(tagged.mesh)
    tags = np.full(n, DOMAIN, dtype=np.int32)
    owned = ct.indices < n
    tags[ct.indices[owned]] = ct.values[owned]
    return tags


def _global_mesh(tagged: TaggedMesh):
    """(x, cells, edges, edge_tags, cell_tags or None) of the distributed mesh, on rank 0
    (None elsewhere)."""
    mesh, ft = tagged.mesh, tagged.facet_tags
    n = compat.num_owned_cells(mesh)
    tri = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n]]
    nodes = compat.entities_to_geometry(mesh, 1, ft.indices)
    edges = mesh.geometry.x[:, :2][nodes] if len(ft.indices) else np.zeros((0, 2, 2))
    parts = mesh.comm.gather((tri, edges, np.asarray(ft.values), _owned_cell_tags(tagged)), root=0)
    if mesh.comm.rank != 0:
        return None
    tri = np.concatenate([p[0] for p in parts])
    edges = np.concatenate([p[1] for p in parts])
    tags = np.concatenate([p[2] for p in parts])
    cell_tags = (None if any(p[3] is None for p in parts)
                 else np.concatenate([p[3] for p in parts]))
    x, inverse = np.unique(tri.reshape(-1, 2), axis=0, return_inverse=True)
    cells = inverse.reshape(-1, 3).astype(np.int64)
    lookup = {tuple(p): i for i, p in enumerate(x)}
    edge_nodes = np.array([[lookup[tuple(a)], lookup[tuple(b)]] for a, b in edges], dtype=np.int64)
    edge_nodes, first = np.unique(np.sort(edge_nodes, axis=1), axis=0, return_index=True)
    return x, cells, edge_nodes.reshape(-1, 2), tags[first], cell_tags


def save_checkpoint(path: Path, tagged: TaggedMesh, u: CellwiseField, p: CellwiseField,
                    state: dict, extra: dict[str, CellwiseField] | None = None) -> None:
    """Write the checkpoint (collective; rank 0 writes); ``extra``: further named fields
    (the augmented Lagrangian multipliers)."""
    mesh_data = _global_mesh(tagged)
    if tagged.mesh.comm.rank != 0:
        return
    x, cells, edges, edge_tags, cell_tags = mesh_data
    arrays = {"mesh_x": x, "mesh_cells": cells, "mesh_edges": edges, "mesh_edge_tags": edge_tags,
              "state": np.array(json.dumps(state))}
    if cell_tags is not None:
        arrays["mesh_cell_tags"] = cell_tags
    arrays.update({f"u_{k}": v for k, v in u.to_arrays().items()})
    arrays.update({f"p_{k}": v for k, v in p.to_arrays().items()})
    extra = extra or {}
    arrays["extra_fields"] = np.array(list(extra), dtype=str)
    for name, field in extra.items():
        arrays.update({f"x_{name}_{k}": v for k, v in field.to_arrays().items()})
    write_npz_atomic(path, arrays)


def save_model_checkpoint(path: Path, tagged: TaggedMesh, snapshot: dict, state: dict) -> None:
    """:func:`save_checkpoint` of a model's ``snapshot()`` (named fields with "velocity"
    and "pressure"; the others go in as extra fields)."""
    fields = dict(snapshot)
    u, p = fields.pop("velocity"), fields.pop("pressure")
    save_checkpoint(path, tagged, u, p, state, fields)


def load_model_checkpoint(path: Path, comm) -> tuple[TaggedMesh, dict, dict]:
    """(mesh, named fields for the model's ``transfer``, loop state) of a checkpoint."""
    tagged, u, p, state, extra = load_checkpoint(path, comm)
    return tagged, {"velocity": u, "pressure": p, **extra}, state


def write_npz_atomic(path: Path, arrays: dict) -> None:
    """Write ``arrays`` to ``path`` (.npz) through a temporary file and a rename, keeping
    the previous file as its ``previous_path`` (rank 0 only)."""
    path = Path(path)
    tmp = path.with_name(path.stem + ".tmp.npz")
    try:
        _write_npz(tmp, arrays)
        fsync_path(tmp)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    # The previous checkpoint stays as checkpoint.prev.npz until the new one is complete:
    # at every moment checkpoint.npz is a whole checkpoint (old or new) and the one before
    # it is kept, so a checkpoint corrupted later on disk falls back to its predecessor.
    if path.exists():
        link = previous_path(path).with_suffix(".link.tmp")
        link.unlink(missing_ok=True)
        os.link(path, link)
        os.replace(link, previous_path(path))
    os.replace(tmp, path)


def _write_npz(path: Path, arrays: dict) -> None:
    """``np.savez`` (an uncompressed zip of .npy members, which ``np.load`` reads) that
    leaves no open ZipFile behind when a write fails: numpy's would be closed again by
    its ``__del__`` later, print a second traceback on a full disk."""
    import zipfile

    with open(path, "wb") as f:
        archive = zipfile.ZipFile(f, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True)
        try:
            for name, value in arrays.items():
                with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                    np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)
            archive.close()
        except BaseException:
            archive.fp = None     # closed with the file: nothing left for __del__ to write
            raise


def previous_path(path: Path) -> Path:
    """checkpoint.npz -> checkpoint.prev.npz"""
    path = Path(path)
    return path.with_name(path.stem + ".prev" + path.suffix)


_REQUIRED = ("mesh_x", "mesh_cells", "mesh_edges", "mesh_edge_tags", "state")


def _readable(path: Path, required: tuple[str, ...] = _REQUIRED) -> str | None:
    """None if ``path`` is a complete checkpoint, else what is wrong with it."""
    try:
        with np.load(path) as data:
            missing = [k for k in required if k not in data.files]
            if missing:
                return f"no {', '.join(missing)}"
            for k in data.files:          # reads (and CRC-checks) every array
                data[k]
            json.loads(str(data["state"]))
    except FileNotFoundError:
        return "missing"
    except Exception as exc:              # zip, CRC, pickle and JSON errors alike
        return f"{type(exc).__name__}: {exc}"[:200]
    return None


def choose_checkpoint(path: Path, comm, required: tuple[str, ...] = _REQUIRED) -> Path:
    """The checkpoint to resume from: ``path`` if it is whole (holds the arrays
    ``required``), else the previous one (collective: rank 0 checks and decides).
    ConfigError if neither is usable."""
    from dpcollapse.errors import ConfigError

    path = Path(path)
    choice, problems = None, []
    if comm.rank == 0:
        for candidate in (path, previous_path(path)):
            problem = _readable(candidate, required)
            if problem is None:
                choice = str(candidate)
                break
            problems.append(f"{candidate.name}: {problem}")
    from dpcollapse import parallel

    choice, problems = parallel.bcast(comm, (choice, problems), root=0)
    if choice is None:
        raise ConfigError(f"--resume: no usable checkpoint in {path.parent} ({'; '.join(problems)})"
                          "; start the run again with --overwrite")
    if problems and comm.rank == 0:
        import logging

        logging.getLogger(__name__).warning("%s; resuming from %s instead", problems[0],
                                            Path(choice).name)
    return Path(choice)


def load_checkpoint(path: Path, comm) -> tuple[TaggedMesh, CellwiseField, CellwiseField, dict, dict]:
    """Rebuild the mesh (distributed over ``comm``) and the fields from a checkpoint:
    (mesh, u, p, state, extra fields by name). A damaged ``path`` falls back to the
    previous checkpoint (:func:`choose_checkpoint`). The cell tags are restored when the
    checkpoint has them (``mesh_cell_tags``; older checkpoints have none: no cell tags)."""
    data = np.load(choose_checkpoint(path, comm))
    names = [str(n) for n in data["extra_fields"]] if "extra_fields" in data.files else []
    extra = {name: CellwiseField.from_arrays({k[len(name) + 3:]: data[k] for k in data.files
                                              if k.startswith(f"x_{name}_")}) for name in names}
    u = CellwiseField.from_arrays({k[2:]: data[k] for k in data.files if k.startswith("u_")})
    p = CellwiseField.from_arrays({k[2:]: data[k] for k in data.files if k.startswith("p_")})
    state = json.loads(str(data["state"]))
    if comm.rank == 0:
        x, cells = data["mesh_x"], data["mesh_cells"]
        edges, edge_tags = data["mesh_edges"], data["mesh_edge_tags"]
    else:
        x, cells = np.zeros((0, 2)), np.zeros((0, 3), dtype=np.int64)
        edges, edge_tags = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int32)
    tagged = TaggedMesh(*compat.mesh_with_facet_tags(comm, cells, x, edges, edge_tags))
    has_regions = comm.bcast("mesh_cell_tags" in data.files, root=0)
    if has_regions:
        regions = (x[cells], data["mesh_cell_tags"]) if comm.rank == 0 else None
        triangles, cell_tags = comm.bcast(regions, root=0)
        tagged.cell_tags = tag_cells(tagged.mesh, region_field(triangles, cell_tags))
    return tagged, u, p, state, extra
