"""Time series output for a moving (ALE) and occasionally remeshed mesh.

DOLFINx 0.5's ``XDMFFile`` holds one mesh per file and aborts when a function name is
written twice at the same time, so a single growing XDMF file cannot follow a mesh whose
coordinates move every step and whose cell count changes after a remesh. Instead:

* every output step ``k`` is written by DOLFINx (collectively) into its own closed pair
  ``fields/step_{k:06d}.xdmf`` / ``.h5`` under the run directory;
* rank 0 then rewrites the master ``solution.xdmf``: one temporal collection whose
  children are flattened copies of the per-step grids (geometry, topology and all point
  and cell attributes in ONE ``Uniform`` grid with ``<Time Value="t"/>``), their
  ``DataItem`` paths rewritten relative to the master (``fields/step_000012.h5:/Mesh/...``).

The master is written to ``solution.xdmf.tmp`` and moved into place with ``os.replace``,
and a step is added to it only after its H5 file is closed, so a run killed at any moment
leaves a ``solution.xdmf`` that ParaView (``Xdmf3ReaderT``) opens, covering every
completed step.

What DOLFINx 0.5 writes for ``write_mesh`` + ``write_function`` (per-step file)::

    <Domain>
      <Grid Name="mesh" GridType="Uniform">  Topology + Geometry  (step.h5:/Mesh/mesh/...)
      <Grid Name="velocity" GridType="Collection" CollectionType="Temporal">
        <Grid Name="velocity" GridType="Uniform">
          <xi:include xpointer="xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]
                                 /*[self::Topology or self::Geometry])"/>
          <Time Value="0.5"/>
          <Attribute Name="velocity" Center="Node"> step.h5:/Function/velocity/0_5
      ... one such collection per function (Center="Cell" for DG0)

The flattening resolves the xpointer by taking Topology/Geometry from the mesh grid and
gathers every ``Attribute`` of every function grid into the same grid. DOLFINx omits the
``Precision`` of its float64/int64 data (readers then assume 4 bytes: ParaView showed
float32-rounded values), so the master states ``NumberType``/``Precision`` read from the H5.
"""

from __future__ import annotations

import copy
import errno
import logging
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path

import h5py
from mpi4py import MPI

from dpcollapse import compat, parallel
from dpcollapse.errors import OutputError
from dpcollapse.io.durable import fsync_path
from dpcollapse.io.presence import DirectoryPresence, missing_files

__all__ = ["XDMFTimeSeries", "check_output_function"]

_XDMF_HEADER = '<?xml version="1.0"?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n'
log = logging.getLogger(__name__)
#: Set when an HDF5 write failed in this process: HDF5 1.14 (Debian sid) then asserts in its
#: library terminator at exit, so the command line leaves without running the terminators.
hdf5_write_failed = False
_STEP_RE = re.compile(r"^step_(\d{6,})$")
_XI_NS = "http://www.w3.org/2001/XInclude"
_NUMBER_TYPES = {"f": "Float", "i": "Int", "u": "UInt"}



def check_output_function(fn) -> None:
    """Raise ValueError unless ``fn`` lives on a P1 (vertex) or DG0 (cell) space.

    Vector and tensor versions of those are accepted; mixed spaces, higher degrees and
    DG1+ are refused (DOLFINx 0.5 would silently sample them at vertices).
    """
    info = compat.element_info(fn.function_space)
    if info.mixed:
        raise ValueError(
            f"function {fn.name!r} lives on a mixed space; collapse it and "
            "interpolate into a P1 or DG0 output space first"
        )
    family, degree = info.family, info.degree
    if (family == "P" and degree == 1) or (family == "DG" and degree == 0):
        return
    raise ValueError(
        f"function {fn.name!r} is on a {family} degree-{degree} space; XDMF output takes only "
        "P1 (vertex) or DG0 (cell) functions: interpolate into an output space first"
    )


#: what HDF5 prints when a call fails (also when the caller does not raise: DOLFINx 0.11
#: with HDF5 2.x reports a failed flush of a full disk only on stderr)
HDF5_ERROR = "Error detected in HDF5"


class _Captured:
    text = ""
    sink = None

    def so_far(self) -> str:
        """What has been captured up to now (inside the block)."""
        fd = self.sink.fileno()
        return os.pread(fd, os.fstat(fd).st_size, 0).decode(errors="replace")

    def first_line(self, containing: str) -> str:
        """The first line of the captured text that contains ``containing``, stripped."""
        for line in self.text.splitlines():
            if containing in line:
                return " ".join(line.split())[:160]
        return ""


@contextmanager
def c_stderr_captured():
    """Route file descriptor 2 (where C libraries such as HDF5 print) into a temporary file
    for the duration of the block; the text is kept on the yielded object, and written
    back to stderr if the block succeeds (so warnings are not lost)."""
    captured = _Captured()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 2)
        captured.sink = sink
        failed = False
        try:
            yield captured
        except BaseException:
            failed = True
            raise
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            captured.text = sink.read().decode(errors="replace")
            if captured.text and not failed:
                os.write(2, captured.text.encode())


class XDMFTimeSeries:
    """Moving-mesh time series: one closed XDMF/H5 pair per output step plus a master
    temporal collection rewritten atomically after each step.

    Parameters
    ----------
    directory
        Run directory; receives ``{name}.xdmf`` and the step sub-directory.
    comm
        Communicator of the mesh; ``write`` and ``truncate_after`` are collective.
    name
        Master file stem. The per-step files go to ``fields/`` for the default name
        ``"solution"`` and to ``fields_{name}/`` otherwise, so several series can share
        a run directory.
    durable
        fsync each step's files and the master before publishing it (survives a machine
        crash, not just a killed process). Cheap for output-sized files.

    An existing master (resume) is read and continued, never clobbered. Step files that
    the master does not reference and that are numbered after its last step (left by a
    run killed between the step write and the master update) are removed.
    """

    def __init__(
        self,
        directory: Path,
        comm: MPI.Comm,
        name: str = "solution",
        durable: bool = True,
    ) -> None:
        self.comm = comm
        self.directory = Path(directory)
        self.name = name
        self.durable = durable
        self.master = self.directory / f"{name}.xdmf"
        self.fields_dir = self.directory / ("fields" if name == "solution" else f"fields_{name}")
        # Rank 0 keeps the flattened grids; every rank keeps (index, time).
        self._grids: list[ET.Element] = []
        self._steps: list[tuple[int, float]] = []
        self._next_index = 0

        def setup():
            self.fields_dir.mkdir(parents=True, exist_ok=True)
            #: the run directory and fields/ as they were taken (checked before each write)
            self._presence = [DirectoryPresence(self.directory), DirectoryPresence(self.fields_dir)]
            if self.master.exists():
                try:
                    self._grids = self._read_master(self.master)
                    self._steps = [self._grid_step(g) for g in self._grids]
                except (ET.ParseError, ValueError) as exc:
                    from dpcollapse.errors import ConfigError

                    raise ConfigError(f"{self.master} is damaged ({exc}); start the run again "
                                      "with --overwrite") from None
                self._drop_missing_steps()
            stale = Path(f"{self.master}.tmp")
            if stale.exists():
                stale.unlink()
            next_index = self._steps[-1][0] + 1 if self._steps else 0
            self._remove_orphans(next_index)
            return self._steps

        self._steps = self._on_root(setup)
        self._next_index = self._steps[-1][0] + 1 if self._steps else 0

    # ------------------------------------------------------------------ public API
    @property
    def steps(self) -> list[tuple[int, float]]:
        """(step index, time) of every step referenced by the master, in order."""
        return list(self._steps)

    def step_path(self, index: int) -> Path:
        """The per-step XDMF file of step ``index``."""
        return self.fields_dir / f"step_{index:06d}.xdmf"

    def write(self, t: float, mesh, functions: Sequence) -> Path:
        """Write ``mesh`` (current coordinates) and ``functions`` at time ``t`` as a new
        step, then publish it in the master. Collective. Returns the step XDMF path."""
        t = float(t)
        functions = list(functions)
        names = [fn.name for fn in functions]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"output functions need unique names; repeated: {duplicates}")
        for fn in functions:
            check_output_function(fn)
            if fn.function_space.mesh is not mesh:
                raise ValueError(f"function {fn.name!r} is not defined on the mesh being written")
        if self._steps and not t > self._steps[-1][1]:
            raise ValueError(
                f"output time {t!r} is not after the last written time {self._steps[-1][1]!r}; "
                "call truncate_after() when restarting from an earlier checkpoint"
            )

        index = self._next_index
        step_xdmf = self.step_path(index)
        # before DOLFINx writes: its HDF5 writer would make a removed directory again
        self._on_root(lambda: self._check_present(f"{self.fields_dir.name}/{step_xdmf.name}"))

        def write_step():
            try:
                with c_stderr_captured() as captured:   # HDF5 prints its error stack there
                    compat.write_xdmf_step(self.comm, str(step_xdmf), mesh, functions, t)
                    if HDF5_ERROR in captured.so_far():
                        raise RuntimeError("HDF5 reported an error (its stack is on stderr)")
            except RuntimeError as exc:  # HDF5 reports a full disk or a lost file this way
                global hdf5_write_failed
                hdf5_write_failed = True
                if self.comm.rank == 0:
                    for path in (step_xdmf, step_xdmf.with_suffix(".h5")):
                        path.unlink(missing_ok=True)
                    self._check_present(step_xdmf.name)   # the directory removed meanwhile?
                reason = re.search(r"error message = '([^']+)'", captured.text)
                detail = reason.group(1) if reason else str(exc)
                raise OSError(errno.EIO, f"writing {step_xdmf.name} failed ({detail})",
                              str(step_xdmf.with_suffix(".h5"))) from None

        # every rank's share of the H5 file is closed, and a failure on one is every rank's
        parallel.agree(self.comm, write_step)

        def publish():
            step_h5 = step_xdmf.with_suffix(".h5")
            # the new step and every published one are there, in the directory taken
            self._check_present(self.master.name, index)
            try:
                if self.durable:
                    fsync_path(step_h5)
                    fsync_path(step_xdmf)
                grid = self._flatten_step(step_xdmf, index, t)
            except FileNotFoundError:      # removed meanwhile: say what, if that is what
                self._check_present(self.master.name, index)
                raise
            self._grids.append(grid)
            self._write_master()
            return None

        self._on_root(publish)
        self._steps.append((index, t))
        self._next_index = index + 1
        return step_xdmf

    def truncate_after(self, t: float) -> None:
        """Drop the steps with time > t (with a 1e-12 relative tolerance, so a checkpoint
        taken at an output time keeps that output) and delete their files; numbering
        continues after the last kept step. Collective."""
        t = float(t)
        tol = 1e-12 * max(1.0, abs(t))
        keep = [i for i, (_, ti) in enumerate(self._steps) if ti <= t + tol]

        def truncate():
            self._grids = [self._grids[i] for i in keep]
            self._write_master()  # publish the shorter master before deleting files
            next_index = self._steps[keep[-1]][0] + 1 if keep else 0
            self._remove_orphans(next_index)
            return None

        self._on_root(truncate)
        self._steps = [self._steps[i] for i in keep]
        self._next_index = self._steps[-1][0] + 1 if self._steps else 0

    # ------------------------------------------------------------------ internals
    def _check_present(self, writing: str, new_index: int | None = None) -> None:
        """Rank 0: OutputError (exit 5) when the run directory or fields/ was removed or
        replaced, or a step file the master references (the published ones and
        ``new_index``) is missing: the master must never point at data that is not there."""
        for presence in self._presence:
            presence.check(writing)
        indices = [i for i, _ in self._steps] + ([new_index] if new_index is not None else [])
        gone = missing_files([self.fields_dir / f"step_{i:06d}.h5" for i in indices])
        if gone:
            raise OutputError(f"{len(gone)} step file(s) of {self.master.name} were removed "
                              f"during the run (first: {gone[0]}); writing {writing} stopped")

    def _on_root(self, fn):
        """Run ``fn`` on rank 0, share its result (or its exception) with all ranks."""
        return parallel.on_root(self.comm, fn)

    def _rel(self, path: Path) -> str:
        return Path(os.path.relpath(path, self.master.parent)).as_posix()

    def _flatten_step(self, step_xdmf: Path, index: int, t: float) -> ET.Element:
        """One Uniform grid (geometry, topology, all attributes) from a DOLFINx 0.5 file."""
        domain = ET.parse(step_xdmf).getroot().find("Domain")
        if domain is None:
            raise ValueError(f"{step_xdmf}: no <Domain>")
        top_grids = domain.findall("Grid")
        mesh_grids = [g for g in top_grids if g.get("GridType", "Uniform") == "Uniform"]
        if not mesh_grids or mesh_grids[0].find("Topology") is None:
            raise ValueError(f"{step_xdmf}: no Uniform mesh grid with a Topology")
        mesh_grid = mesh_grids[0]

        grid = ET.Element("Grid", {"Name": f"step_{index:06d}", "GridType": "Uniform"})
        for tag in ("Topology", "Geometry"):
            grid.append(copy.deepcopy(mesh_grid.find(tag)))
        ET.SubElement(grid, "Time", {"Value": repr(t)})
        seen: set[str] = set()
        for attr in mesh_grid.iter("Attribute"):
            seen.add(attr.get("Name"))
            grid.append(copy.deepcopy(attr))
        for g in top_grids:
            if g is mesh_grid:
                continue
            for attr in g.iter("Attribute"):
                if attr.get("Name") in seen:
                    raise ValueError(f"{step_xdmf}: attribute {attr.get('Name')!r} twice")
                seen.add(attr.get("Name"))
                grid.append(copy.deepcopy(attr))
        if any(el.tag == f"{{{_XI_NS}}}include" for el in grid.iter()):
            raise ValueError(f"{step_xdmf}: unresolved xi:include in the flattened grid")

        # Rewrite "step_000012.h5:/path" -> "fields/step_000012.h5:/path" (master-relative)
        # and state the stored precision: DOLFINx 0.5 omits it, and XDMF readers then take
        # float64 data as float32 and int64 as int32.
        h5_files: dict[str, h5py.File] = {}
        try:
            for item in grid.iter("DataItem"):
                if item.get("Format") != "HDF":
                    continue
                text = (item.text or "").strip()
                fname, sep, h5path = text.partition(":")
                if not sep:
                    raise ValueError(f"{step_xdmf}: HDF DataItem without ':' ({text!r})")
                h5_file = step_xdmf.parent / fname
                if "Precision" not in item.attrib:
                    if fname not in h5_files:
                        h5_files[fname] = h5py.File(h5_file, "r")
                    dtype = h5_files[fname][h5path].dtype
                    number_type = _NUMBER_TYPES.get(dtype.kind)
                    if number_type is not None:
                        item.set("NumberType", number_type)
                        item.set("Precision", str(dtype.itemsize))
                item.text = f"{self._rel(h5_file)}:{h5path}"
        finally:
            for f in h5_files.values():
                f.close()
        return grid

    @staticmethod
    def _grid_step(grid: ET.Element) -> tuple[int, float]:
        match = _STEP_RE.match(grid.get("Name", ""))
        time = grid.find("Time")
        if match is None or time is None:
            raise ValueError(f"master grid {grid.get('Name')!r} is not a dpcollapse step")
        return int(match.group(1)), float(time.get("Value"))

    def _drop_missing_steps(self) -> None:
        """Steps whose HDF5 data cannot be read (a file deleted by hand, truncated by a
        crash or a full disk, a dataset missing or of another shape than the master says)
        leave the master, which is rewritten: it must never reference data that is not there."""
        keep = []
        for grid, (index, t) in zip(self._grids, self._steps):
            problem = self._unreadable(grid)
            if problem is None:
                keep.append((grid, (index, t)))
            else:
                log.warning("%s: step %d (t = %g s): %s: dropped", self.master.name, index, t,
                            problem)
        if len(keep) != len(self._grids):
            self._grids = [g for g, _ in keep]
            self._steps = [s for _, s in keep]
            self._write_master()

    def _unreadable(self, grid: ET.Element) -> str | None:
        """What is wrong with the HDF5 data a master grid references (None: all readable,
        of the shapes its ``Dimensions`` state)."""
        files: dict[str, object] = {}
        try:
            for item in grid.iter("DataItem"):
                if item.get("Format") != "HDF":
                    continue
                fname, _, h5path = (item.text or "").strip().partition(":")
                path = self.master.parent / fname
                if fname not in files:
                    if not path.exists():
                        return f"{fname} is missing"
                    try:
                        files[fname] = h5py.File(path, "r")
                    except OSError as exc:
                        return f"{fname} cannot be read ({' '.join(str(exc).split())[:80]})"
                data = files[fname].get(h5path)
                if data is None:
                    return f"{fname} has no {h5path}"
                dims = tuple(int(d) for d in (item.get("Dimensions") or "").split())
                if dims and tuple(data.shape) != dims:
                    return f"{fname}:{h5path} has shape {tuple(data.shape)}, not {dims}"
                try:
                    if data.shape and data.shape[0]:
                        data[-1]     # the last chunk is where a truncated file ends
                except (OSError, IndexError) as exc:
                    return f"{fname}:{h5path} cannot be read ({exc})"
        finally:
            for f in files.values():
                f.close()
        return None

    def _read_master(self, path: Path) -> list[ET.Element]:
        root = ET.parse(path).getroot()
        collection = root.find("Domain/Grid")
        if collection is None or collection.get("CollectionType") != "Temporal":
            raise ValueError(f"{path}: not a temporal collection written by XDMFTimeSeries")
        return list(collection.findall("Grid"))

    def _write_master(self) -> None:
        if not self._grids:  # nothing published (truncated to before the first step)
            if self.master.exists():
                self.master.unlink()
            return
        root = ET.Element("Xdmf", {"Version": "3.0"})
        domain = ET.SubElement(root, "Domain")
        collection = ET.SubElement(
            domain,
            "Grid",
            {"Name": self.name, "GridType": "Collection", "CollectionType": "Temporal"},
        )
        collection.extend(self._grids)
        ET.indent(root, space="  ")
        tmp = Path(f"{self.master}.tmp")
        try:
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(_XDMF_HEADER)
                f.write(ET.tostring(root, encoding="unicode"))
                f.write("\n")
                f.flush()
                if self.durable:
                    os.fsync(f.fileno())
            os.replace(tmp, self.master)
        except BaseException:
            tmp.unlink(missing_ok=True)   # the published master stays as it was
            raise
        if self.durable:
            fsync_path(self.master.parent)

    def _remove_orphans(self, first_unused: int) -> None:
        """Delete step files numbered >= first_unused (not referenced by the master)."""
        referenced = {i for i, _ in (self._grid_step(g) for g in self._grids)}
        for path in self.fields_dir.glob("step_*"):
            match = _STEP_RE.match(path.name.split(".")[0])
            if match is None or path.suffix not in (".xdmf", ".h5"):
                continue
            index = int(match.group(1))
            if index >= first_unused and index not in referenced:
                path.unlink()
