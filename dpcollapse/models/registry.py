"""The model of a config, found without editing this file:

- ``model_factory(cfg)``: what the time loop drives (``loop.ModelFactory``) — the class
  whose ``model_name`` is ``model.name``, in a module under ``dpcollapse/models/`` (a new
  model is a new package here) or in ``dpcollapse.discretization`` (the 2D model's, which
  uses the mesh motion of ``ale/`` above this package); it provides ``from_config(cfg)``;
- ``model_class(method)``: the 2D flow class whose ``method`` is ``numerics.method``; it
  provides ``from_config(tagged, cfg, params)``."""

from __future__ import annotations

import functools
import importlib
import pkgutil

import dpcollapse.models as _package

_SKIP = {"base", "registry"}


def _package_modules() -> list[str]:
    """Every module of the package and its packages, but ``base`` and ``registry``."""
    return [info.name for info in pkgutil.walk_packages(_package.__path__, prefix=f"{_package.__name__}.")
            if not info.ispkg and info.name.rsplit(".", 1)[-1] not in _SKIP]


def _classes_by(attribute: str, modules) -> dict[str, type]:
    """value of ``attribute`` (a str) -> the class defining it (with ``from_config``) in
    ``modules``."""
    found = {}
    for name in modules:
        module = importlib.import_module(name)
        for obj in vars(module).values():
            key = getattr(obj, attribute, None)
            if (isinstance(obj, type) and isinstance(key, str) and hasattr(obj, "from_config")
                    and obj.__module__ == module.__name__):
                found[key] = obj
    return found


@functools.cache
def model_classes() -> dict[str, type]:
    """numerics.method -> model class, from every module of the package and its packages."""
    return _classes_by("method", _package_modules())


#: Modules outside the package that hold a model factory (imported when asked for).
FACTORY_MODULES = ("dpcollapse.discretization",)


@functools.cache
def model_factories() -> dict[str, type]:
    """model.name -> factory class (``model_name`` and ``from_config``)."""
    return _classes_by("model_name", [*_package_modules(), *FACTORY_MODULES])


def model_factory(cfg):
    """The factory of ``model.name`` built from the config."""
    return model_factories()[cfg.model.name].from_config(cfg)


def model_class(method: str) -> type:
    """The model class of ``numerics.method``."""
    return model_classes()[method]
