"""The scene of a config: the class in ``dpcollapse/scenes/*.py`` whose ``shape`` is
``geometry.shape`` (a new scene is a new module here, found without editing this file)."""

from __future__ import annotations

import functools
import importlib
import pkgutil

import dpcollapse.scenes as _package

_SKIP = {"base", "registry"}


@functools.cache
def scene_classes() -> dict[str, type]:
    """shape -> scene class, from every module of the package."""
    found = {}
    for info in pkgutil.iter_modules(_package.__path__):
        if info.name in _SKIP:
            continue
        module = importlib.import_module(f"{_package.__name__}.{info.name}")
        for obj in vars(module).values():
            shape = getattr(obj, "shape", None)
            if isinstance(obj, type) and isinstance(shape, str) and obj.__module__ == module.__name__:
                found[shape] = obj
    return found


def scene(cfg):
    """The :class:`~dpcollapse.scenes.base.Scene` of ``cfg``."""
    classes = scene_classes()
    return classes[cfg.geometry.shape].from_config(cfg)


def build_mesh(cfg, comm=None):
    """The initial mesh of the config's scene (over COMM_WORLD by default)."""
    if comm is None:
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
    return scene(cfg).mesh(comm)


def write_msh(cfg, path):
    """``dpcollapse mesh``: write the initial mesh of the config's scene as a gmsh file."""
    return scene(cfg).write_msh(path)
