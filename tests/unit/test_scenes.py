"""Scenes: the boundary kinds and normals they state, their initial meshes with cell tags,
and ``dpcollapse mesh`` writing the scene of the config (it wrote a trapezoid for a layer)."""

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.cli import main
from dpcollapse.config import load_config
from dpcollapse.geometry.mesher import BED, DOMAIN, LEFT, RIGHT, SURFACE, WALL, read_msh
from dpcollapse.scenes.base import Boundary, BoundaryKind
from dpcollapse.scenes.periodic_layer import LayerScene
from dpcollapse.scenes.registry import scene, scene_classes
from dpcollapse.scenes.trapezoid import TrapezoidScene
from tests.helpers import ROOT


def _area(mesh):
    return mesh.comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM)


def test_registry_finds_every_scene_module():
    classes = scene_classes()
    assert classes["trapezoid"] is TrapezoidScene and classes["layer"] is LayerScene


def test_trapezoid_boundaries():
    """Bed y = 0 with Coulomb μ_b (n = (0, −1), t = (1, 0)), wall x = 0 with μ_l
    (n = (−1, 0)), free surface; the wall becomes frictionless slip at μ_l = 0 and the bed
    no slip with bed_condition no_slip."""
    bed, wall, surface = scene(load_config(ROOT / "configs/rigid.yaml")).boundaries()
    assert (bed.tag, bed.kind, bed.normal, bed.tangent) == (
        BED,
        BoundaryKind.COULOMB,
        (0.0, -1.0),
        (1.0, 0.0),
    )
    assert bed.friction == pytest.approx(math.tan(math.radians(25.5)))
    assert (wall.tag, wall.kind, wall.normal, wall.axis) == (WALL, BoundaryKind.COULOMB, (-1.0, 0.0), 0)
    assert wall.friction == pytest.approx(math.tan(math.radians(10.2)))
    assert (surface.tag, surface.kind) == (SURFACE, BoundaryKind.FREE_SURFACE)
    cfg = load_config(ROOT / "configs/rigid.yaml", ["boundary.wall_friction_angle=0",
                                                    "boundary.bed_condition=no_slip"])
    bed, wall, _ = scene(cfg).boundaries()
    assert bed.kind == BoundaryKind.NO_SLIP and wall.kind == BoundaryKind.SLIP and not wall.has_friction


def test_layer_boundaries():
    """No-slip bed, free surface and a periodic pair: x = L is tied to x = 0 by (−L, 0)."""
    cfg = load_config(ROOT / "configs/plug.yaml")
    bounds = {b.tag: b for b in scene(cfg).boundaries()}
    assert bounds[BED].kind == BoundaryKind.NO_SLIP and bounds[SURFACE].kind == BoundaryKind.FREE_SURFACE
    assert bounds[LEFT].kind == bounds[RIGHT].kind == BoundaryKind.PERIODIC
    assert bounds[RIGHT].translation == (-cfg.geometry.base_length, 0.0) and bounds[LEFT].translation is None


def test_a_slanted_side_has_no_axis_and_gets_weak_no_penetration():
    n = (-math.sqrt(0.5), -math.sqrt(0.5))
    hopper = Boundary(7, "hopper", BoundaryKind.SLIP, n)
    assert hopper.axis is None and hopper.slanted
    assert not Boundary(7, "hopper", BoundaryKind.NO_SLIP, n).slanted    # u = 0: any angle
    assert Boundary(1, "bed", BoundaryKind.COULOMB, (0.0, -1.0), friction=0.5).axis == 1


@pytest.mark.parametrize("config, area", [("rigid.yaml", None), ("plug.yaml", 0.05 * 0.025)])
def test_initial_mesh_has_cell_and_facet_tags(config, area):
    cfg = load_config(ROOT / "configs" / config, ["geometry.mesh_size=0.005"] if area else
                      ["geometry.mesh_size=0.03"])
    tagged = scene(cfg).mesh(MPI.COMM_SELF)
    n = compat.num_owned_cells(tagged.mesh)
    ct = tagged.cell_tags
    assert len(ct.indices) == n and set(np.unique(ct.values)) == {DOMAIN}
    assert _area(tagged.mesh) == pytest.approx(area or cfg.geometry.area, rel=1e-12)


def test_mesh_command_writes_the_periodic_layer(tmp_path):
    """`dpcollapse mesh configs/plug.yaml`: the layer [0, L] × [0, h] with its bed, surface
    and periodic sides, nodes on x = 0 and x = L at the same heights (it was a trapezoid)."""
    out = tmp_path / "plug.msh"
    assert main(["mesh", str(ROOT / "configs/plug.yaml"), "--out", str(out)]) == 0
    tagged = read_msh(MPI.COMM_SELF, out)
    assert set(np.unique(tagged.facet_tags.values)) == {BED, SURFACE, LEFT, RIGHT}
    x = tagged.mesh.geometry.x
    assert x[:, 0].min() == 0.0 and x[:, 0].max() == pytest.approx(0.025, abs=1e-15)
    assert x[:, 1].min() == 0.0 and x[:, 1].max() == pytest.approx(0.05, abs=1e-15)
    assert _area(tagged.mesh) == pytest.approx(0.025 * 0.05, rel=1e-12)
    assert compat.num_owned_cells(tagged.mesh) == 2 * 5 * 10   # the divisions of layer_mesh
    left = np.sort(x[np.isclose(x[:, 0], 0.0), 1])
    right = np.sort(x[np.isclose(x[:, 0], 0.025), 1])
    np.testing.assert_allclose(left, right, atol=1e-14)


def test_no_branching_on_scene_model_or_method_names_outside_the_registries():
    """The library asks a scene, a model or a method what it can do (``Container``'s fields,
    ``geometry.periodic``, the registries), never ``shape == "erodible"`` and the like:
    a new scene or model is then a new file, not edits wherever a name was compared
    (config/'s tagged unions and the validation/ and studies/ drivers, which require a
    scene, may)."""
    import re

    from dpcollapse.models.registry import model_classes, model_factories
    from dpcollapse.scenes.registry import scene_classes

    names = sorted(set(scene_classes()) | set(model_factories()) | set(model_classes())
                   | {"picard", "newton"})
    quoted = "|".join(map(re.escape, names))
    pattern = re.compile(rf"""(==|!=)\s*["']({quoted})["']|["']({quoted})["']\s*(==|!=)"""
                         rf"""|\bin\s*[(\[{{]\s*["']({quoted})["']|\bshape\s*(==|!=)\s*["']""")
    offenders = []
    for path in (ROOT / "dpcollapse").rglob("*.py"):
        parts = path.relative_to(ROOT / "dpcollapse").parts
        if parts[0] in ("validation", "config"):
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if pattern.search(line):
                offenders.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()}")
    assert not offenders, "\n".join(offenders)
    # the pattern finds what it is for
    assert pattern.search('if g.shape == "erodible":') and pattern.search("m in ('two_phase', x)")
    # the loop (simulation.py, loop.py) asks no model by getattr/hasattr or by its keys either
    for name in LOOP_MODULES:
        offenders = loop_probes((ROOT / "dpcollapse" / name).read_text())
        assert not offenders, f"dpcollapse/{name}:\n" + "\n".join(offenders)


#: the modules of the time loop, which know no model (``loop`` declares what they ask)
LOOP_MODULES = ("simulation.py", "loop.py")
#: the keys the loop reads of its own dicts: the checkpoint's run identity, its state's
#: fields, its timings, the summary it wrote (``run_simulation``'s log line)
LOOP_KEYS = {"run", "run_id", "extra", "event_counts", "solve", "mesh_motion", "remesh", "output",
             "total", "summary", "status", "t", "steps", "remeshes", "area_drift", "flow_solves"}


def _model_specific_names() -> set[str]:
    """What only some models or domains have: their diagnostics columns, events, measures
    of a bin or a layer, exact rest and stop reasons."""
    import importlib
    import pkgutil

    import dpcollapse.domain
    import dpcollapse.models

    names = {"emptied", "landings", "outflow_area", "discharge_rate", "min_angle"}
    for package in (dpcollapse.models, dpcollapse.domain):
        for info in pkgutil.walk_packages(package.__path__, prefix=package.__name__ + "."):
            if info.ispkg:
                continue
            for obj in vars(importlib.import_module(info.name)).values():
                if isinstance(obj, type):
                    declared = vars(obj)
                    names.update(declared.get("extra_measures", ()), declared.get("counted_events", ()))
    from dpcollapse.models.two_phase.adapter import BIN_MEASURES
    from dpcollapse.models.two_phase.erodible_layer import MEASURES as LAYER_MEASURES

    return names | set(BIN_MEASURES) | set(LAYER_MEASURES)


def loop_probes(source: str) -> list[str]:
    """Where ``source`` asks a model by ``getattr``/``hasattr``, or reads a dict (``d[k]``,
    ``d.get(k)``, ``k in d``) by a key that is neither a shared measure (``loop.MEASURES``)
    nor the loop's own (``LOOP_KEYS``), or names anything only some models have:
    ``line: code`` of each."""
    import ast

    from dpcollapse.loop import MEASURES

    allowed, specific = set(MEASURES) | LOOP_KEYS, _model_specific_names()
    tree, lines, found = ast.parse(source), source.splitlines(), []

    def key(node):
        return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None

    for node in ast.walk(tree):
        probe = None
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in ("getattr", "hasattr")):
            probe = node.func.id
        elif (isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Load)
              and key(node.slice) not in (None, *allowed)):
            probe = key(node.slice)
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.args
              and node.func.attr in ("get", "pop", "setdefault")
              and key(node.args[0]) not in (None, *allowed)):
            probe = key(node.args[0])
        elif (isinstance(node, ast.Compare) and isinstance(node.ops[0], (ast.In, ast.NotIn))
              and not isinstance(node.comparators[0], ast.Call)    # a substring of a message
              and key(node.left) not in (None, *allowed)):
            probe = key(node.left)
        elif isinstance(node, ast.Constant) and node.value in specific:
            probe = node.value
        if probe is not None:
            found.append(f"{node.lineno}: {lines[node.lineno - 1].strip()}  ({probe})")
    return found


@pytest.mark.parametrize("snippet", [
    'scheme = getattr(disc.flow, "scheme", "bdf1")',
    'if hasattr(self.disc, "motion"):\n    pass',
    'emptied = bool(m.get("emptied", False))',
    'area = m["area"] + m["outflow_area"]',
    'if "discharge_rate" in row:\n    pass',
    'st.status = "emptied"',
    'row = {"landings": st.landings}',
])
def test_loop_probe_check_catches_an_injected_probe(snippet):
    """The check of the loop modules fails on each kind of probe put into simulation.py."""
    source = (ROOT / "dpcollapse/simulation.py").read_text()
    assert loop_probes(source) == []
    injected = source + "\n\ndef _injected(self, disc, st, m, row):\n" + "".join(
        f"    {line}\n" for line in snippet.splitlines())
    assert loop_probes(injected)
